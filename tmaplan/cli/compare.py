"""``tmaplan compare P --policies a,b,.. --runs N``: Monte Carlo policy comparison.

The report and its figures go to ``<out>/P_compare/`` (``tmaplan demo`` writes to
``<out>/demo/``, another problem to its own directory: no report overwrites another's); the
runs are stored in ``<out>/campaign-<key>/`` and reloaded by the same campaign.

The closed loop as a navigator sees it: the own-ship track each policy flew on run 0 (the
report's example run) as a leg table, printed (merged, :mod:`tmaplan.models.leg_table`) and
written to ``<out>/P_compare/<policy>_run0_legs.csv`` (exact) and ``_navigator_legs.csv``
(merged), with its track as GPX and CSV (``_track.gpx``, ``_track.csv``; the own ship at
``simulate --export``'s default origin and start), JSON ``flown: {policy: {legs,
navigator_legs, exports}}``.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli.args import (
    MAX_RUNS,
    accuracy_of,
    add_accuracy_argument,
    add_figure_arguments,
    add_particles_argument,
    add_problem_argument,
    add_seed_argument,
    add_workers_arguments,
    command_line,
    integer,
    repeated,
)
from tmaplan.cli.contacts import preflight_per_contact
from tmaplan.cli.finite import require_finite
from tmaplan.cli.plan import navigator_exports
from tmaplan.errors import ArgumentError, PlanningError
from tmaplan.evaluation.replans import replan_cell
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.geometry import course_speed
from tmaplan.io.plans import legs_from_track
from tmaplan.models.leg_table import flown_turn_rates, navigator_legs
from tmaplan.models.target import initial_velocity
from tmaplan.policies.combine import MANOEUVRES, PINGS
from tmaplan.policies.contacts import CONTACTS_MANOEUVRES, CONTACTS_PINGS
from tmaplan.policies.parse import check_policy
from tmaplan.report_tables import censored_lines
from tmaplan.scenario import Scenario, load

HELP = "compare manoeuvre/ping policies by Monte Carlo (paired runs), with figures and a report"

#: Several contacts: the campaign flies all of them at once (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "joint"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("policies.*.rmse_position[-1]", "policies.*.final_range_rmse")


#: Default of ``--policies``.
POLICIES = "straight,single-turn,zigzag"
#: Default of ``--policies`` on a several-contact problem (zig-zag flies for one contact).
CONTACTS_POLICIES = "straight,single-turn,nearest-contact,planned"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``compare``."""
    add_problem_argument(parser)
    parser.add_argument("--policies", default=POLICIES,
                        help=f"comma-separated MANOEUVRE[+PING], each once (default {POLICIES}; "
                             f"with several contacts {CONTACTS_POLICIES}; "
                             f"manoeuvres: {', '.join(MANOEUVRES)}; pings: {', '.join(PINGS)}, "
                             "a ping policy only with a range sensor; several contacts: "
                             f"{', '.join(CONTACTS_MANOEUVRES)}, planned:NAME, pings "
                             f"{', '.join(CONTACTS_PINGS)})")
    parser.add_argument("--runs", type=integer(1, MAX_RUNS), default=50,
                        help="Monte Carlo runs (default 50)")
    add_seed_argument(parser, help="root seed (default 0)")
    add_particles_argument(parser)
    add_accuracy_argument(parser)
    parser.add_argument("--truth", choices=("prior", "scenario"), default="prior",
                        help="draw each run's target from the prior (default) or use the "
                             "scenario's")
    add_workers_arguments(parser)
    add_figure_arguments(parser, report=True)


def preflight_several(args: argparse.Namespace, scenario: Scenario,
                      preflight: Callable[[argparse.Namespace, Any], None]) -> None:
    """``compare``'s checks on a several-contact problem: ``--policies`` against the whole
    scenario (its policies, :mod:`tmaplan.policies.contacts`), then the other checks on each
    contact's view (:func:`tmaplan.cli.contacts.preflight_per_contact`: its prior, its truth
    source, the turn-rate limit), with a one-contact stand-in for the policies. The
    one-contact default of ``--policies`` becomes :data:`CONTACTS_POLICIES`."""
    if args.policies == POLICIES:  # the one-contact default: the several-contact one
        args.policies = CONTACTS_POLICIES
    names = [p.strip() for p in args.policies.split(",") if p.strip()]
    if not names or repeated(names) is not None:
        raise ArgumentError("--policies", "one or more distinct MANOEUVRE[+PING], each once",
                            args.policies, source=scenario.name)
    for name in names:
        try:
            check_policy(name, scenario)
        except ArgumentError as exc:  # the policy's rule, on the flag that named it
            raise ArgumentError("--policies", exc.expected, exc.received,
                                source=scenario.name) from None
        except PlanningError as exc:  # an unknown name
            raise ArgumentError("--policies", f"names MANOEUVRE[+PING] with MANOEUVRE in "
                                f"{', '.join(CONTACTS_MANOEUVRES)} or planned:NAME and PING "
                                f"in {', '.join(CONTACTS_PINGS)} (several contacts)", name,
                                source=scenario.name) from exc
    turning = any(n.split("+")[0] != "straight" for n in names)
    stand_in = argparse.Namespace(**{**vars(args),
                                     "policies": "single-turn" if turning else "straight"})
    preflight_per_contact(stand_in, scenario, preflight)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run or resume the campaign, write figures and ``<out>/<problem>_compare/report.html``."""
    scenario = load(args.problem)
    policies = tuple(p.strip() for p in args.policies.split(",") if p.strip())
    accuracy = accuracy_of(args, scenario)
    spec = CampaignSpec(scenario=scenario, policies=policies, runs=args.runs,
                        seed=args.seed, n_particles=args.particles, truth=args.truth,
                        accuracy=accuracy)
    quiet = args.json == "-"
    result = run_campaign(spec, out_dir=args.out, workers=args.workers,
                          scheduler=args.scheduler,
                          progress=(not quiet) and sys.stderr.isatty())
    cmd = command_line("compare", f"tmaplan compare {shlex.quote(args.problem)} --policies "
                       f"{shlex.quote(args.policies)} --runs {args.runs} --seed {args.seed} "
                       f"--particles {args.particles} --accuracy {accuracy} "
                       f"--truth {args.truth}")
    # the report's figures need matplotlib (~0.8 s), not the checks before the runs
    from tmaplan import report_contacts  # deferred: matplotlib
    from tmaplan.report import efficiency, write_report  # deferred: matplotlib

    console_lines = report_contacts.console_lines

    out_dir = Path(args.out) / f"{scenario.name}_compare"
    several = len(scenario.contacts) > 1  # per-contact tables and figure (report_contacts)
    figures = ({"contacts": report_contacts.contacts_figure(result, out_dir)}
               if several and not getattr(args, "no_figure", False) else None)
    report = write_report(result, out_dir, command=cmd,
                          title=f"tmaplan compare: {scenario.name}",
                          extra_html=report_contacts.contacts_html(result) if several else "",
                          figures=figures)
    payload = result.to_json()
    for name, e in efficiency(result).items():
        payload["policies"][name]["efficiency"] = e
    payload["report"] = str(report)
    payload["directory"] = str(result.directory)
    require_finite(payload, FINITE, source=scenario.name,
                   why=f"report written to {report}, runs kept in {result.directory}")
    if not quiet:
        for name in result.policies:
            s = result.summary[name]
            tta = s["time_to_accuracy"]
            tta_s = "never" if tta == float("inf") else f"{tta / 60:6.1f} min"
            print(f"{name:<28} time to accuracy {tta_s}  localised "
                  f"{s['reached_fraction']:4.0%}  final range RMSE "
                  f"{s['final_range_rmse']:8.0f} m  pings {s['pings_used']:.1f}  "
                  f"recoveries {s['recoveries']:.2f}{replan_cell(s['replans'])}")
        for line in console_lines(result) if several else []:
            print(line)
        for line in censored_lines(result):  # a zero difference there is no tie
            print(line)
        print(f"wrote {report} ({len(result.computed_runs)} runs computed, "
              f"{len(result.loaded_runs)} loaded from {Path(str(result.directory))})")
    payload["flown"] = flown_legs(result, scenario, out_dir, quiet=quiet)
    return payload


def flown_legs(result: Any, scenario: Scenario, out_dir: Path, *,
               quiet: bool) -> dict[str, Any]:
    """Each policy's own-ship track on run 0 as a navigator's plan (module doc): its turn
    rates recovered from the flown positions (:func:`tmaplan.models.leg_table.flown_turn_rates`,
    exact for the closed loop's constant rate over each step)."""
    times = result.times
    dt = float(times[1] - times[0])
    heading0 = float(course_speed(initial_velocity(scenario.observer))[0])
    out: dict[str, Any] = {}
    stems: set[str] = set()
    for name in result.policies:
        pos = np.asarray(result.examples[name].observer, float)
        rates, courses, speed = flown_turn_rates(pos, heading0, dt)
        legs = legs_from_track(times - times[0], courses, turn_rates=rates)
        nav = navigator_legs(legs, pos, speed=speed, dt=dt)
        base = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)
        # two names may read alike in a file name ("planned:a b", "planned:a_b"): number the
        # later ones, never overwrite an earlier policy's files
        stem, k = base, 1
        while stem in stems:
            k += 1
            stem = f"{base}-{k}"
        stems.add(stem)
        stem += "_run0"
        if not quiet:
            print(f"{name}, flown on run 0:")
        out[name] = navigator_exports(legs, nav, times, pos, scenario, out_dir, stem,
                                      quiet=quiet)
    return out
