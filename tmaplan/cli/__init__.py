"""Command line interface ``tmaplan`` (docs/cli.md).

Each verb lives in its own module ``tmaplan.cli.<verb>`` defining ``HELP`` (one line),
``add_arguments(parser)``, ``run(args) -> dict | None``, optionally ``FINITE`` (payload
quantities that must not be NaN, :mod:`tmaplan.cli.finite`: a NaN there is an error, never exit
0) and, for a verb without a problem argument that works on a fixed problem, ``PROBLEM`` (its
name); the returned dict is written as JSON
to ``--json PATH`` (``-`` for stdout); a dict payload always carries the ``problem`` key.
Argument types, limits and the up-front checks that need the scenario live in
:mod:`tmaplan.cli.args`, shared by every verb. Every error, a bad flag value included, exits 1
with one line on stderr (a traceback only with ``--debug``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import shlex
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli.args import OneLineParser, UsageError, json_path
from tmaplan.cli.contacts import (
    per_contact,
    preflight_per_contact,
    refuse_several,
    run_per_contact,
    takes_several,
)
from tmaplan.cli.finite import require_finite
from tmaplan.cli.paths import check_outputs
from tmaplan.cli.preflight import preflight
from tmaplan.errors import ArgumentError
from tmaplan.interrupts import Interrupted, as_interrupt, checkpoint, signals_interrupt
from tmaplan.models.checks import check_scenario
from tmaplan.scenario import load, load_problem
from tmaplan.version import __version__

__all__ = ["VERBS", "main", "write_json"]

#: Verb name -> module name, in help order. Modules that do not exist yet are skipped.
VERBS: dict[str, str] = {
    "problems": "problems",
    "simulate": "simulate",
    "crlb": "crlb",
    "bound": "bound",
    "track": "track",
    "plan": "plan",
    "schedule": "schedule",
    "compare": "compare",
    "rank-costs": "rank_costs",
    "demo": "demo",
    "advise": "advise",
}


def _default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def write_json(payload: Any, path: str) -> None:
    """Write ``payload`` as JSON to ``path`` (``-`` = stdout). NaN/inf become null."""

    def clean(x: Any) -> Any:
        if isinstance(x, float) and not np.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list | tuple):
            return [clean(v) for v in x]
        if isinstance(x, np.ndarray):
            return clean(x.tolist())
        if isinstance(x, np.generic):
            return clean(x.item())
        return x

    text = json.dumps(clean(payload), default=_default, indent=1, allow_nan=False)
    if path == "-":
        sys.stdout.write(text + "\n")
    else:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(text + "\n", encoding="utf-8")


def _chosen_verb(argv: Sequence[str]) -> str | None:
    """The verb ``argv`` names (its first word that is not an option), if it is one of
    :data:`VERBS`; ``None`` otherwise (no verb, ``--help``, a misspelt verb)."""
    for word in argv:
        if word in ("-h", "--help", "--version"):
            return None
        if not word.startswith("-"):
            return word if word in VERBS else None
    return None


def _build_parser(verb: str | None = None) -> tuple[
        argparse.ArgumentParser, dict[str, Any], dict[str, argparse.ArgumentParser]]:
    """The ``tmaplan`` parser with every verb's sub-parser, or only ``verb``'s: a verb's
    module imports what it computes with (casadi, scipy, matplotlib), which a command that
    names its verb need not load for the others (an impossible input is refused in a second,
    not after every verb's imports)."""
    parser = OneLineParser(
        prog="tmaplan",
        description="Observer-trajectory planning and sensor management for TMA.",
    )
    parser.add_argument("--version", action="version", version=f"tmaplan {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = parser.add_subparsers(dest="verb", metavar="VERB")
    modules: dict[str, Any] = {}
    parsers: dict[str, argparse.ArgumentParser] = {}
    for name, modname in VERBS.items():
        if verb is not None and name != verb:
            continue
        try:
            mod = importlib.import_module(f"tmaplan.cli.{modname}")
        except ModuleNotFoundError as exc:
            if exc.name == f"tmaplan.cli.{modname}":
                continue
            raise
        p = sub.add_parser(name, help=mod.HELP, description=mod.HELP)
        p.add_argument("--json", metavar="PATH", default=None, type=json_path,
                       help="write machine-readable output to PATH ('-' for stdout)")
        # SUPPRESS: no default of its own, so `tmaplan --debug VERB` keeps the top-level value
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                       help="show tracebacks on errors")
        mod.add_arguments(p)
        modules[name] = mod
        parsers[name] = p
    return parser, modules, parsers


def _names_problem(text: str, problem: str) -> bool:
    """Whether an error message already names ``problem`` as its source: in front
    (``"<problem>: ..."``) or in parentheses (``"... (<problem>)"``), not merely as a word of
    the message (a problem named ``x`` in ``"unknown parameters (x, y, vx, vy)"``)."""
    return text.startswith(f"{problem}: ") or f"({problem})" in text


def _one_line_warning(verb: str) -> Any:
    """A :func:`warnings.showwarning` that prints ``tmaplan VERB: warning: Category: text``,
    each distinct line once (the verb loads its scenario again after the preflight, whose
    warnings would repeat)."""
    shown: set[str] = set()

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: Any = None, line: str | None = None) -> None:
        text = str(message).replace("\n", " ")
        out = f"tmaplan {verb}: warning: {category.__name__}: {text}"
        if out not in shown:
            shown.add(out)
            print(out, file=sys.stderr)
    return show


def _interrupted(verb: str, exc: KeyboardInterrupt, argv: Sequence[str]) -> str:
    """The one line of an interrupted verb: the signal, what was kept (a campaign's stored
    runs) and, then, the command that resumes it (the same one)."""
    if not isinstance(exc, Interrupted):
        return f"tmaplan {verb}: interrupted by SIGINT"
    text = f"tmaplan {verb}: {exc}"
    if exc.resumable:
        text += f"; to resume, run the same command: {shlex.join(['tmaplan', *argv])}"
    return text.replace("\n", " ")


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``tmaplan`` command. Returns the exit status.

    0 on success, 1 on any error (one line on stderr), 2 without a verb (help), 130 when
    interrupted by SIGINT or SIGTERM, with one line on stderr
    (for a campaign: the runs kept and the command that resumes it).
    """
    parser, modules, parsers = _build_parser(
        _chosen_verb(sys.argv[1:] if argv is None else argv))
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:  # reported by the verb's parser, whose --help lists what it takes
            parsers.get(args.verb, parser).error(f"unrecognized arguments: {' '.join(extra)}")
    except UsageError as exc:
        print(str(exc).replace("\n", " "), file=sys.stderr)
        return 1
    if not args.verb:
        parser.print_help()
        return 2
    problem = None
    try:
        with signals_interrupt(), warnings.catch_warnings():  # SIGTERM stops a verb as
            # Ctrl-C does, inside a solve too; warnings are one line, as errors are (--debug:
            # Python's, with the source)
            if not args.debug:
                warnings.showwarning = _one_line_warning(args.verb)
            # the verb's problem: its positional P, or a fixed one (``PROBLEM``, e.g. demo's)
            fixed = getattr(modules[args.verb], "PROBLEM", None)
            given = getattr(args, "problem", None)  # (demo's P is optional: else PROBLEM)
            if given is not None or fixed is not None:
                scenario = load(given) if given is not None else load_problem(str(fixed))
                problem = scenario.name
                # the rules that need the motion model (tmaplan.scenario is below the models)
                check_scenario(scenario, source=given)
                # a verb that cannot handle several contacts says so (tmaplan.cli.contacts)
                if len(scenario.contacts) > 1 and not takes_several(modules[args.verb]):
                    modules = {**_build_parser()[1], **modules}  # to name the verbs that do
                refuse_several(args.verb, modules[args.verb], scenario, modules)
                several = len(scenario.contacts) > 1 and per_contact(modules[args.verb])
                if len(scenario.contacts) > 1:  # a verb's own checks for them, or per contact
                    getattr(modules[args.verb], "preflight_several", preflight_per_contact)(
                        args, scenario, preflight)
                else:
                    preflight(args, scenario)
            else:  # (preflight checks them with the problem)
                several = False
                check_outputs(args)
            finite = tuple(getattr(modules[args.verb], "FINITE", ()))
            if several:  # each contact's view through the one-contact verb
                payload = run_per_contact(modules[args.verb], args, scenario)
                finite = tuple(f"contacts.*.{p}" for p in finite)
            else:
                payload = modules[args.verb].run(args)
            checkpoint()  # an interrupt that Python ignored on the way is still one
            require_finite(payload, finite, source=problem)
            if isinstance(payload, dict) and problem is not None:
                payload.setdefault("problem", problem)
            if args.json is not None and payload is not None:
                write_json(payload, args.json)
    except BaseException as exc:
        interrupt = as_interrupt(exc)  # (a SystemError reporting one is one)
        if interrupt is not None:
            print(_interrupted(args.verb, interrupt, sys.argv[1:] if argv is None else argv),
                  file=sys.stderr)
            return interrupt.exit_status if isinstance(interrupt, Interrupted) else 130
        if args.debug or not isinstance(exc, Exception):
            raise
        text = str(exc)
        # every error but a flag's says which problem it is about: a field error with its
        # source names it already (the file or problem it came from); a failure of the
        # computation, or a field error without a source, gets the problem's name in front
        named = isinstance(exc, ArgumentError) and (exc.source is not None
                                                    or exc.field.startswith("-"))
        if problem is not None and not named and not _names_problem(text, problem):
            text = f"{problem}: {text}"
        print(f"tmaplan {args.verb}: error: {text}".replace("\n", " "), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
