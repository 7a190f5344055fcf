"""Argument types and limits shared by every ``tmaplan`` verb (the up-front checks that need
the scenario: :mod:`tmaplan.cli.preflight`).

One place defines how a number on the command line is read and checked, so that every verb
answers a bad value with the same one-line error (``tmaplan plan: error: --horizon must be a
duration > 0 s ..., received '0'``) before any work starts, and every time-valued flag takes
the unit strings of the scenario files (``--horizon "30 min"``, ``--min-spacing "2 min"``,
``--ping-every "80 s"``; a bare number is seconds), parsed by :func:`tmaplan.units.to_si`.

Documented limits (beyond them a run would take hours or exhaust memory on a workstation;
each is refused with its value in the message):

=====================  ==========================================================
``--runs``             1 .. :data:`MAX_RUNS`
``--particles``        2 .. :data:`MAX_PARTICLES`
``--samples``          2 .. :data:`MAX_SAMPLES`
``--workers``          1 .. :data:`MAX_WORKERS`
``--starts``           1 .. :data:`MAX_STARTS` (``plan``: 1 .. 4 with ``--transcription
                       bang-bang``; only where the built-in guesses are solved,
                       :data:`PLAN_STARTS`)
``--budget``           >= 0 (and at most the number of steps, checked by the scheduler)
``--accuracy``         in (0, 1)
``--seed``             an integer >= 0 (``numpy.random.SeedSequence``)
time flags             > 0 (``--min-spacing`` >= 0), at most :data:`MAX_DURATION`
``plan --horizon``     at most the problem's ``time.horizon`` and :data:`MAX_PLAN_STEPS`
                       grid steps (the heading OCP grows with the number of steps;
                       ``plan default --starts 1`` took 3 s for 180 steps, 12 s for 720 and
                       21 s for 1440 on 2 cores, ×4 with 4 starts)
=====================  ==========================================================
"""

from __future__ import annotations

import argparse
import math
import re
import shlex
import sys
from collections.abc import Callable
from typing import Any, NoReturn

from tmaplan.cli.paths import check_json_path, check_out_dir, fail
from tmaplan.display import seconds_text
from tmaplan.errors import (
    UnitError,
)
from tmaplan.planning.heading import BUILT_IN_STARTS
from tmaplan.units import to_si

__all__ = [
    "MAX_DURATION",
    "MAX_PARTICLES",
    "MAX_PLAN_STEPS",
    "MAX_RUNS",
    "MAX_SAMPLES",
    "MAX_STARTS",
    "MAX_WORKERS",
    "PLAN_STARTS",
    "OneLineParser",
    "UsageError",
    "accuracy_of",
    "add_accuracy_argument",
    "add_figure_arguments",
    "add_problem_argument",
    "add_seed_argument",
    "duration",
    "frequency_lines",
    "integer",
    "json_path",
    "open_fraction",
    "out_dir",
    "repeated",
    "seconds_text",
    "seed",
    "step_list",
]

MAX_RUNS = 100_000
"""Largest ``--runs``."""
MAX_PARTICLES = 1_000_000
"""Largest ``--particles`` (a million particles already need ~100 MB per filter step)."""
MAX_SAMPLES = 1_000_000
"""Largest ``--samples`` of a Monte Carlo bound."""
MAX_WORKERS = 256
"""Largest ``--workers``."""
#: The policies ``tmaplan demo`` compares (here, not in the verb's module, so that the up-front
#: checks of every verb read them without loading the demo's plotting).
DEMO_POLICIES = ("straight", "single-turn", "zigzag", "planned", "receding",
                 "planned+uniform", "planned+scheduled", "planned+scheduled-terminal",
                 "receding+scheduled")
PLAN_STARTS = BUILT_IN_STARTS
"""``plan --starts``: the heading planner's built-in initial guesses by transcription
(:class:`tmaplan.planning.HeadingPlanner`), the most that a value can start from."""
MAX_STARTS = max(PLAN_STARTS.values())
"""Largest ``--starts`` (built-in initial guesses of the heading OCP, :data:`PLAN_STARTS`)."""
MAX_DURATION = 7 * 86400.0
"""Largest value of a time flag [s] (one week)."""
MAX_PLAN_STEPS = 1440
"""Largest planning horizon of ``tmaplan plan`` in grid steps (6 h at dt = 15 s)."""


# --------------------------------------------------------------------------------------------
# Parser: every usage error is one line
# --------------------------------------------------------------------------------------------


class UsageError(Exception):
    """A command-line argument is invalid; the message is one line."""


class OneLineParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` whose errors raise :class:`UsageError`.

    ``tmaplan.cli.main`` prints them as one line (``tmaplan VERB: error: ...``) and exits 1,
    the same as any other error, instead of argparse's usage block and exit status 2.
    """

    def error(self, message: str) -> NoReturn:
        # "argument --runs: must be >= 1, received 0" -> "--runs must be >= 1, received 0"
        m = re.match(r"argument ([^:]+): (must be .*)$", message)
        if m:
            message = f"{m[1].split('/')[0]} {m[2]}"
        raise UsageError(f"{self.prog}: error: {message} (see '{self.prog} --help')")


# --------------------------------------------------------------------------------------------
# Types (callables for ``type=``): raise ArgumentTypeError("must be ..., received ...")
# --------------------------------------------------------------------------------------------


def integer(minimum: int, maximum: int | None = None) -> Callable[[str], int]:
    """Type of an integer flag in ``[minimum, maximum]``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            try:  # "1e4" is an integer too
                number = float(text)
            except ValueError:
                number = math.nan
            if not (math.isfinite(number) and number.is_integer()):
                fail(f"an integer >= {minimum}", repr(text))
            value = int(number)
        if value < minimum:
            fail(f">= {minimum}", value)
        if maximum is not None and value > maximum:
            fail(f"<= {maximum} (documented limit)", value)
        return value

    parse.__name__ = "integer"
    return parse


def frequency_lines(text: str) -> int | None:
    """Type of ``crlb`` / ``track --frequencies``: a number of lines >= 0, or ``all`` (None:
    every line of the problem, the default of :func:`tmaplan.bounds.crlb.crlb`)."""
    return None if text.strip().lower() == "all" else integer(0)(text)


def seed(text: str) -> int:
    """Type of ``--seed``: an integer >= 0 (the root of a ``numpy.random.SeedSequence``)."""
    return integer(0)(text)


def open_fraction(text: str) -> float:
    """Type of a fraction in (0, 1): ``0.1`` or ``"10 %"``."""
    t = text.strip()
    try:
        value = float(t[:-1]) / 100.0 if t.endswith("%") else float(t)
    except ValueError:
        fail("a number in (0, 1) or a percentage like '10 %'", repr(text))
    if not 0.0 < value < 1.0:
        fail("in (0, 1)", value)
    return value


def duration(*, allow_zero: bool = False,
             maximum: float = MAX_DURATION) -> Callable[[str], float]:
    """Type of a time flag: seconds, or a string with a unit (``"30 min"``, ``"80 s"``).

    Returns the value in seconds. Zero is accepted only with ``allow_zero``.
    """
    lower = ">= 0" if allow_zero else "> 0"

    def parse(text: str) -> float:
        try:
            value = to_si(text, "time", "value")
        except UnitError:
            fail(f"a duration {lower} s (seconds, or with a unit like '30 min')", repr(text))
        if value < 0 or (value == 0 and not allow_zero):
            fail(f"a duration {lower} s", repr(text))
        if value > maximum:
            fail(f"at most {seconds_text(maximum)} (documented limit)",
                  f"{text!r} = {seconds_text(value)}")
        return value

    parse.__name__ = "duration"
    return parse


def step_list(text: str) -> list[int]:
    """Type of ``--ping-steps``: comma-separated grid steps >= 0 (``"14,27,40"``)."""
    try:
        steps = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        fail("comma-separated integers like '14,27,40'", repr(text))
    if not steps:
        fail("at least one step", repr(text))
    if min(steps) < 0:
        fail("steps >= 0", min(steps))
    twice = repeated(steps)
    if twice is not None:
        fail(f"distinct steps, each once ({twice} is repeated)", repr(text))
    return steps


def out_dir(text: str) -> str:
    """Type of ``--out``: a directory (created when needed), not an existing file nor a path
    under one (:func:`tmaplan.cli.paths.check_out_dir`)."""
    return check_out_dir(text)


def json_path(text: str) -> str:
    """Type of ``--json``: ``-`` (stdout) or a file path, not an existing directory nor a path
    under an existing file (:func:`tmaplan.cli.paths.check_json_path`)."""
    return check_json_path(text)


# --------------------------------------------------------------------------------------------
# Shared argument definitions
# --------------------------------------------------------------------------------------------


def command_line(verb: str, fallback: str) -> str:
    """The ``tmaplan VERB ...`` command line of this process, for a report.

    The words after ``verb`` on ``sys.argv`` when run as ``tmaplan`` (top-level flags such as
    ``--debug`` before the verb are left out), else ``fallback``.
    """
    argv = list(sys.argv)
    if not argv or not argv[0].endswith("tmaplan") or verb not in argv[1:]:
        return fallback
    rest = argv[argv.index(verb, 1) + 1:]
    return " ".join(["tmaplan", verb, *(shlex.quote(a) for a in rest)])


def add_problem_argument(parser: argparse.ArgumentParser) -> None:
    """The positional ``P``: a built-in problem name or a path to a .toml file."""
    parser.add_argument("problem", help="built-in problem name or path to a .toml file")


def add_seed_argument(parser: argparse.ArgumentParser, help: str = "random seed (default 0)"
                      ) -> None:
    """``--seed S`` (an integer >= 0, default 0)."""
    parser.add_argument("--seed", type=seed, default=0, help=help)


def add_particles_argument(parser: argparse.ArgumentParser) -> None:
    """``--particles N``: the particle-filter size (2 .. :data:`MAX_PARTICLES`, default 3000).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The verb's parser.
    """
    parser.add_argument("--particles", type=integer(2, MAX_PARTICLES), default=3000,
                        help="particle-filter size (default 3000)")


def add_workers_arguments(parser: argparse.ArgumentParser) -> None:
    """``--workers W`` (local worker processes, 1 .. :data:`MAX_WORKERS`, default 1) or
    ``--scheduler ADDR`` (the address of a Dask scheduler, default None), not both.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The verb's parser; the two options form one mutually exclusive group.
    """
    g = parser.add_mutually_exclusive_group()
    g.add_argument("--workers", type=integer(1, MAX_WORKERS), default=1,
                   help="local worker processes (default 1)")
    g.add_argument("--scheduler", default=None, help="address of a Dask scheduler")


def add_accuracy_argument(parser: argparse.ArgumentParser) -> None:
    """``--accuracy A``: the relative range error that counts as localised (default None:
    the problem's, :func:`accuracy_of`)."""
    parser.add_argument("--accuracy", type=open_fraction, default=None,
                        help="relative range error that counts as localised (default: the "
                             "contact's required_accuracy, else planning.required_accuracy, "
                             "else 0.1)")


def accuracy_of(args: argparse.Namespace, scenario: Any) -> float:
    """The ``--accuracy`` a verb runs with: the flag if given, else the scenario's
    :attr:`~tmaplan.scenario.Scenario.required_accuracy` (its one contact's own, else
    ``planning.required_accuracy``, else 0.1: a file that sets none runs as it always did).
    A contact's own ``required_accuracy`` is kept over the flag (the several-contact
    campaigns, :func:`tmaplan.evaluation.contacts_campaign.contact_accuracy`; a contact's view
    under :func:`tmaplan.cli.contacts.run_per_contact`, ``args.contact``)."""
    own = getattr(getattr(args, "contact", None), "required_accuracy", None)
    if own is not None:
        return float(own)
    if len(scenario.contacts) == 1 and scenario.contacts[0].required_accuracy is not None:
        return float(scenario.contacts[0].required_accuracy)
    flag = getattr(args, "accuracy", None)
    return float(scenario.required_accuracy if flag is None else flag)


class _DeprecatedNoPlot(argparse.Action):
    """``--no-plot``: the old name of ``--no-figure``; sets it and prints a one-line note."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        print(f"{parser.prog}: note: --no-plot is deprecated, use --no-figure",
              file=sys.stderr)
        namespace.no_figure = True


def add_figure_arguments(parser: argparse.ArgumentParser, *, report: bool = False) -> None:
    """``--out DIR`` and ``--no-figure`` (every verb that draws); ``--no-plot`` is a hidden,
    deprecated alias of ``--no-figure``. ``report``: the verb writes a report, whose figures
    are part of it, so only ``--out`` is added."""
    parser.add_argument("--out", type=out_dir, default="out", metavar="DIR",
                        help="output directory (default out/)")
    if report:
        return
    parser.add_argument("--no-figure", action="store_true", help="do not write figures")
    parser.add_argument("--no-plot", action=_DeprecatedNoPlot, nargs=0, dest="no_figure",
                        help=argparse.SUPPRESS)


def repeated(values: list[Any]) -> Any:
    """The first value given twice in ``values``, else None: the one test behind the list
    flags' "each once" rule (``--policies``, ``--plans``, ``--ping-steps``)."""
    seen: set[Any] = set()
    for v in values:
        if v in seen:
            return v
        seen.add(v)
    return None
