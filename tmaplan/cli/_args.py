"""Argument types, limits and up-front checks shared by every ``tmaplan`` verb.

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
import sys
from collections.abc import Callable
from typing import Any, NoReturn

from tmaplan.cli._paths import _fail, check_json_path, check_out_dir, check_outputs
from tmaplan.display import seconds_text
from tmaplan.errors import (
    ArgumentError,
    PlanningError,
    ScenarioError,
    UnitError,
    is_whole_count,
    warn_field,
    whole_steps_text,
)
from tmaplan.estimators.applicability import MLE_DRIFT_RATIO_MAX
from tmaplan.planning.heading import BUILT_IN_STARTS
from tmaplan.simulate import check_truth_source
from tmaplan.units import to_si

__all__ = [
    "MAX_DURATION",
    "MAX_PARTICLES",
    "MAX_PLAN_STEPS",
    "MAX_RUNS",
    "MAX_SAMPLES",
    "MAX_STARTS",
    "MAX_WORKERS",
    "MLE_DRIFT_RATIO_MAX",
    "PLAN_STARTS",
    "OneLineParser",
    "UsageError",
    "add_figure_arguments",
    "add_problem_argument",
    "add_seed_argument",
    "duration",
    "frequency_lines",
    "integer",
    "json_path",
    "open_fraction",
    "out_dir",
    "preflight",
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
                _fail(f"an integer >= {minimum}", repr(text))
            value = int(number)
        if value < minimum:
            _fail(f">= {minimum}", value)
        if maximum is not None and value > maximum:
            _fail(f"<= {maximum} (documented limit)", value)
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
        _fail("a number in (0, 1) or a percentage like '10 %'", repr(text))
    if not 0.0 < value < 1.0:
        _fail("in (0, 1)", value)
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
            _fail(f"a duration {lower} s (seconds, or with a unit like '30 min')", repr(text))
        if value < 0 or (value == 0 and not allow_zero):
            _fail(f"a duration {lower} s", repr(text))
        if value > maximum:
            _fail(f"at most {seconds_text(maximum)} (documented limit)",
                  f"{text!r} = {seconds_text(value)}")
        return value

    parse.__name__ = "duration"
    return parse


def step_list(text: str) -> list[int]:
    """Type of ``--ping-steps``: comma-separated grid steps >= 0 (``"14,27,40"``)."""
    try:
        steps = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        _fail("comma-separated integers like '14,27,40'", repr(text))
    if not steps:
        _fail("at least one step", repr(text))
    if min(steps) < 0:
        _fail("steps >= 0", min(steps))
    twice = repeated(steps)
    if twice is not None:
        _fail(f"distinct steps, each once ({twice} is repeated)", repr(text))
    return steps


def out_dir(text: str) -> str:
    """Type of ``--out``: a directory (created when needed), not an existing file nor a path
    under one (:func:`tmaplan.cli._paths.check_out_dir`)."""
    return check_out_dir(text)


def json_path(text: str) -> str:
    """Type of ``--json``: ``-`` (stdout) or a file path, not an existing directory nor a path
    under an existing file (:func:`tmaplan.cli._paths.check_json_path`)."""
    return check_json_path(text)


# --------------------------------------------------------------------------------------------
# Shared argument definitions
# --------------------------------------------------------------------------------------------


def command_line(verb: str, fallback: str) -> str:
    """The ``tmaplan VERB ...`` command line of this process, for a report.

    The words after ``verb`` on ``sys.argv`` when run as ``tmaplan`` (top-level flags such as
    ``--debug`` before the verb are left out), else ``fallback``.
    """
    import shlex

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


# --------------------------------------------------------------------------------------------
# Up-front checks that need the scenario
# --------------------------------------------------------------------------------------------


def _flag_error(flag: str, constraint: str, received: Any, scenario: Any) -> ArgumentError:
    return ArgumentError(flag, constraint, received, source=scenario.name)


def _scenario_error(field: str, constraint: str, received: Any, scenario: Any) -> ScenarioError:
    return ScenarioError(field, constraint, received, source=scenario.name)


def _check_starts(args: argparse.Namespace, scenario: Any) -> None:
    """``plan --starts`` only where the planner's built-in initial guesses are solved: the
    bang-bang transcription, or the first heading solve of a joint plan (``--pings``); the
    direct plan without pings is multi-started from the manoeuvres it must beat
    (:func:`tmaplan.policies.plan_starts.plan_from_prior`), whatever ``--starts``."""
    starts = getattr(args, "starts", None)
    if starts is None:
        return
    tr = getattr(args, "transcription", "direct")
    if tr == "direct" and getattr(args, "pings", 0) == 0:
        raise _flag_error("--starts", "only with --transcription bang-bang (at most "
                          f"{PLAN_STARTS['bang-bang']}) or --pings K (at most "
                          f"{PLAN_STARTS['direct']} with the direct transcription): the direct "
                          "plan without pings starts from straight, the tactics, the best "
                          "single turns and 4 fixed guesses, whatever --starts", starts,
                          scenario)
    if starts > PLAN_STARTS[tr]:
        raise _flag_error("--starts", f"at most {PLAN_STARTS[tr]} with --transcription {tr} "
                          "(the planner's built-in initial guesses)", starts, scenario)


def _check_plan(args: argparse.Namespace, scenario: Any) -> None:
    _check_starts(args, scenario)
    dt = float(scenario.time.dt)
    pl = scenario.planning
    tc = args.control_interval if getattr(args, "control_interval", None) is not None else (
        pl.control_interval if pl is not None and pl.control_interval else dt)
    if getattr(args, "control_interval", None) is not None:
        m = tc / dt
        if not is_whole_count(m):
            raise _flag_error("--control-interval", whole_steps_text(dt), seconds_text(tc),
                              scenario)
    joint, stride = getattr(args, "joint", None), getattr(args, "ping_stride", None)
    if getattr(args, "pings", 0) == 0 and (joint is not None or stride is not None):
        flag = "--joint" if joint is not None else "--ping-stride"
        raise _flag_error(flag, "only with --pings K (K >= 1): a heading-only plan has no "
                          "pings", joint if joint is not None else stride, scenario)
    if joint == "alternating" and stride is not None:
        raise _flag_error("--ping-stride", "only with --joint ocp (the alternating blocks "
                          "search every step)", stride, scenario)
    if getattr(args, "pings", 0) > 0:
        from tmaplan.planning.joint import JOINT_OBJECTIVES

        objective = args.objective or (pl.objective if pl is not None else "range-bound")
        if objective not in JOINT_OBJECTIVES:
            given = "" if args.objective else " (the problem's planning.objective)"
            raise _flag_error("--objective", f"with --pings, one of {', '.join(JOINT_OBJECTIVES)}",
                              f"{objective}{given}", scenario)
        if args.pings > scenario.n_steps:
            raise _flag_error("--pings", f"at most the {scenario.n_steps} steps of the horizon",
                              args.pings, scenario)
    if args.horizon is None:
        h = pl.horizon if pl is not None and pl.horizon else float(scenario.time.horizon)
        if round(h / dt) > scenario.n_steps:  # a receding horizon may; an offline plan not
            raise _scenario_error(
                "planning.horizon", "at most the problem's horizon of "
                f"{seconds_text(float(scenario.time.horizon))} for an offline plan (or give "
                "--horizon)", seconds_text(h), scenario)
        if getattr(args, "control_interval", None) is not None:  # else rounded silently
            n = h / tc
            if not is_whole_count(n):
                raise _flag_error("--control-interval", "a whole number (>= 1) of intervals in "
                                  f"the planning horizon of {seconds_text(h)} (or give "
                                  "--horizon)", seconds_text(tc), scenario)
        return
    k = round(args.horizon / dt)
    if k > MAX_PLAN_STEPS:
        raise _flag_error("--horizon", f"at most {MAX_PLAN_STEPS} steps of dt = {dt:g} s "
                          f"({seconds_text(MAX_PLAN_STEPS * dt)}, documented limit)",
                          f"{seconds_text(args.horizon)} = {k} steps", scenario)
    h = float(scenario.time.horizon)
    if k > scenario.n_steps:  # a plan past the problem's end: beyond its measurements
        raise _flag_error("--horizon", f"at most the problem's horizon of {seconds_text(h)}",
                          seconds_text(args.horizon), scenario)
    n = args.horizon / tc
    if not is_whole_count(n):
        raise _flag_error("--horizon", f"a whole number (>= 1) of control intervals of "
                          f"{seconds_text(tc)}", seconds_text(args.horizon), scenario)


def _check_bound(args: argparse.Namespace, scenario: Any) -> None:
    if scenario.prior is None:
        raise _scenario_error("prior", "a [prior] table: the PCRB starts from the prior "
                              "information (J₀ = P₀⁻¹); add one or use `tmaplan crlb "
                              f"{scenario.name}` for the batch CRLB of a deterministic track",
                              None, scenario)
    if args.ping_every is not None and args.ping_every < scenario.time.dt:
        raise _flag_error("--ping-every", f">= dt = {scenario.time.dt:g} s",
                          seconds_text(args.ping_every), scenario)
    if args.ping_steps is not None and max(args.ping_steps) > scenario.n_steps:
        raise _flag_error("--ping-steps", f"steps within 0..{scenario.n_steps}",
                          max(args.ping_steps), scenario)


def _check_frequencies(args: argparse.Namespace, scenario: Any) -> None:
    available = max((len(s.f0) for s in scenario.sensors_of("frequency")), default=0)
    if (getattr(args, "frequencies", 0) or 0) > available:
        raise _flag_error("--frequencies", f"0..{available} (lines of {scenario.name})",
                          args.frequencies, scenario)


def _check_schedule(args: argparse.Namespace, scenario: Any) -> None:
    if args.budget is not None and args.budget > scenario.n_steps:
        raise _flag_error("--budget", f"at most the {scenario.n_steps} steps of the horizon",
                          args.budget, scenario)
    from tmaplan.cli.schedule import check_options, check_spacing, read_observer_plan

    check_options(args, scenario)
    track = None
    if args.observer_plan is not None:
        track = read_observer_plan(args.observer_plan, scenario)
    check_spacing(args, scenario, track)


def _check_track(args: argparse.Namespace, scenario: Any) -> None:
    from tmaplan.estimators.applicability import check_applicable

    # the flags' own constraints first, then whether the estimator applies at all
    turn = getattr(args, "turn_direction", "auto")
    if turn != "auto" and args.estimator != "mle":
        raise _flag_error("--turn-direction", "only with --estimator mle", turn, scenario)
    model = scenario.target.model
    if turn in ("clockwise", "anticlockwise") and model != "constant-turn":
        raise _flag_error("--turn-direction", "'auto' or 'either' unless the target model is "
                          f"'constant-turn' ({scenario.name}'s is '{model}')", turn, scenario)
    _check_frequencies(args, scenario)
    check_applicable(args.estimator, scenario, bound=args.bound, cli=True)


def repeated(values: list[Any]) -> Any:
    """The first value given twice in ``values``, else None: the one test behind the list
    flags' "each once" rule (``--policies``, ``--plans``, ``--ping-steps``)."""
    seen: set[Any] = set()
    for v in values:
        if v in seen:
            return v
        seen.add(v)
    return None


def _check_compare(args: argparse.Namespace, scenario: Any) -> None:
    from tmaplan.policies.combine import check_policy

    names = [p.strip() for p in args.policies.split(",") if p.strip()]
    if not names:
        raise _flag_error("--policies", "one or more distinct MANOEUVRE[+PING], comma-separated",
                          args.policies, scenario)
    twice = repeated(names)
    if twice is not None:
        raise _flag_error("--policies", f"one or more distinct MANOEUVRE[+PING], each once "
                          f"({twice} is repeated)", args.policies, scenario)
    for name in names:
        try:
            check_policy(name, scenario)
        except ArgumentError as exc:  # the policy's rule, on the flag that named it
            raise _flag_error("--policies", exc.expected, exc.received, scenario) from None
        except PlanningError:  # an unknown name
            from tmaplan.policies.combine import MANOEUVRES, PINGS

            raise _flag_error("--policies", f"names MANOEUVRE[+PING] with MANOEUVRE in "
                              f"{', '.join(sorted(MANOEUVRES))} and PING in "
                              f"{', '.join(sorted(PINGS))}", name, scenario) from None
    if scenario.prior is None:
        raise _scenario_error("prior", "a [prior] table: every policy is flown against the "
                              "particle filter, which starts from the prior (and --truth prior "
                              "draws the truths from it); add one (see the example of "
                              "docs/scenario-files.md)",
                              None, scenario)
    check_truth_source(scenario, getattr(args, "truth", "prior") == "prior")
    turning = [p.strip() for p in args.policies.split(",")
               if p.strip() and p.strip().split("+")[0] != "straight"]
    if turning and scenario.observer.turn_rate_max is None:
        raise _scenario_error("observer.turn_rate_max", "a turn-rate limit of the own ship "
                              "(e.g. turn_rate_max = \"0.5 deg/s\" in [observer]) for the "
                              f"turning policies {', '.join(turning)}, or --policies "
                              "straight[+PING] only", None, scenario)


#: Verbs whose results depend on the prior (the others do not read it).
_PRIOR_VERBS = frozenset({"bound", "track", "plan", "schedule", "compare", "demo"})


def _truth_note(verb: str, scenario: Any) -> None:
    if verb not in _PRIOR_VERBS:
        return
    p = scenario.prior
    fields = p.truth_fields if p is not None else ()
    if fields:
        print(f"tmaplan {verb}: warning: {scenario.name}: the prior is centred on the target's "
              f"true initial state ({', '.join('prior.' + f for f in fields)} from the truth)",
              file=sys.stderr)


def _reach_note(args: argparse.Namespace, scenario: Any) -> None:
    """``bound``/``track``: a one-line warning when a range sensor with a ``max_range`` gives
    range readings, which the PCRB counts as if each reached the contact (the simulation and
    the batch CRLB apply the reach)."""
    from tmaplan.scenario import measurement_steps

    if args.verb not in ("bound", "track"):
        return
    flagged = getattr(args, "ping_every", None) or getattr(args, "ping_steps", None)
    for i, s in enumerate(scenario.sensors):
        if getattr(s, "max_range", None) is not None and (
                flagged or measurement_steps(s, scenario.time).size):
            warn_field(f"sensors[{i}].max_range", "not applied by the PCRB yet: it counts every "
                       "range reading as if it reached the contact (the simulation, the filters "
                       "and the batch CRLB apply the reach), so the bound may be optimistic",
                       source=scenario.name)


def preflight(args: argparse.Namespace, scenario: Any) -> None:
    """Checks of the arguments that need the scenario, before any work starts.

    Raises :class:`tmaplan.errors.ArgumentError` naming the flag for: ``plan --horizon`` /
    ``--control-interval`` not whole (``--control-interval`` alone: in the problem's planning
    horizon) or over :data:`MAX_PLAN_STEPS`, ``plan --horizon`` past the problem's
    ``time.horizon`` (the plan's track would leave the problem's grid, which
    ``schedule --observer-plan`` refuses), ``plan --pings`` with an
    objective that has no joint form or more pings than steps; ``schedule --budget`` over the
    number of steps; ``crlb`` / ``track --frequencies`` over the problem's lines;
    ``compare --policies`` empty or repeated; ``bound --ping-every``
    below dt or ``--ping-steps`` beyond the horizon; ``schedule --observer-plan`` not a plan
    of this problem on its grid; ``compare`` turning policies without
    ``observer.turn_rate_max``; ``track`` estimator/bound combinations
    that cannot give a number (``--bound prior`` (no range bound; with ``mle``: not used),
    ``range-only`` without ranges, ``mle`` on a target whose process noise drifts more than
    :data:`MLE_DRIFT_RATIO_MAX` times the finest measurement noise over the horizon, the
    drift being the NCV position std ``sqrt(q T³/3)``). Then prints a one-line warning on
    stderr when the scenario's prior takes values from the truth (``prior.centred_on_truth``
    or ``course_mode = "true"``): every run of a verb that uses the prior says so.
    Output paths first (:func:`tmaplan.cli._paths.check_outputs`): ``--json PATH`` naming an
    input of the verb (the problem file, ``--observer-plan``) or an existing file that is not
    a JSON document is refused (the output would overwrite it), as is a ``--json`` or
    ``--out`` where no file can be created.
    """
    check_outputs(args, scenario.name)
    from tmaplan.cli._feasible import check_feasible, check_memory

    check_memory(args, scenario)  # first: the verbs' checks below may allocate per step
    check = {"plan": _check_plan, "bound": _check_bound, "track": _check_track,
             "schedule": _check_schedule, "compare": _check_compare,
             "rank-costs": lambda a, s: check_truth_source(s, True),
             "crlb": _check_frequencies}.get(args.verb)
    if check is not None:
        check(args, scenario)
    check_feasible(args, scenario, prior_verb=args.verb in _PRIOR_VERBS)
    _truth_note(args.verb, scenario)
    _reach_note(args, scenario)
