"""``tmaplan rank-costs P [--candidates N] [--runs R] [--workers W | --scheduler ADDR]``: how
well each cost functional predicts closed-loop performance.

Several contacts: the ranking runs per contact (:func:`tmaplan.cli.contacts.run_per_contact`),
on each contact's one-contact view with the same seeds: the cost functionals are one-contact
functionals, so each is ranked against the closed loop of the contact it scores; figures and
reports are named ``<problem>-<contact>_...``."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

from tmaplan.cli.args import (
    MAX_RUNS,
    MAX_SAMPLES,
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
from tmaplan.cli.contacts import scenario_of
from tmaplan.errors import ArgumentError
from tmaplan.experiments import rank_costs
from tmaplan.planning.objectives import OBJECTIVE_NAMES

HELP = ("rank every cost functional against closed-loop Monte Carlo over a family of candidate "
        "manoeuvres (Spearman/Kendall with bootstrap intervals)")
#: Largest ``--candidates`` (the grid of single turns and zig-zags plus tactics and plans).
MAX_CANDIDATES = 500

#: Several contacts: each contact's view is ranked in turn (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "per-contact"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``rank-costs``."""
    add_problem_argument(parser)
    parser.add_argument("--candidates", type=integer(3, MAX_CANDIDATES), default=40,
                        help="number of candidate manoeuvres (default 40): straight, the "
                             "tactics, the plan of each objective, then single turns and "
                             "zig-zags spread over their grids")
    parser.add_argument("--runs", type=integer(1, MAX_RUNS), default=50,
                        help="paired Monte Carlo runs per candidate (default 50)")
    add_seed_argument(parser, help="root seed (default 0)")
    add_particles_argument(parser)
    add_accuracy_argument(parser)
    parser.add_argument("--plans", default="all", metavar="all|none|OBJ,OBJ,..",
                        help="objectives whose offline plans are candidates (default all)")
    parser.add_argument("--cost-samples", type=integer(20, MAX_SAMPLES), default=1000,
                        help="prior draws behind the Monte Carlo bounds (default 1000)")
    parser.add_argument("--resamples", type=integer(0, 100_000), default=999,
                        help="bootstrap resamples of the intervals (default 999)")
    add_workers_arguments(parser)
    add_figure_arguments(parser)


def _plans(text: str) -> tuple[str, ...] | None:
    t = text.strip()
    if t == "all":
        return None
    if t == "none":
        return ()
    names = tuple(x.strip() for x in t.split(",") if x.strip())
    bad = [n for n in names if n not in OBJECTIVE_NAMES]
    if bad or not names:
        raise ArgumentError("--plans", f"'all', 'none' or names of {', '.join(OBJECTIVE_NAMES)}",
                            text)
    twice = repeated(list(names))
    if twice is not None:
        raise ArgumentError("--plans", f"'all', 'none' or distinct objective names, each once "
                            f"({twice} is repeated)", text)
    return names


def check_arguments(args: argparse.Namespace) -> None:
    """The flags' own rules (no scenario needed): run before any contact's block."""
    _plans(args.plans)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run (or resume) the ranking; write the figure and ``<problem>_rank-costs.html``."""
    scenario = scenario_of(args)
    quiet = args.json == "-"
    accuracy = accuracy_of(args, scenario)
    res = rank_costs(scenario, candidates=args.candidates, runs=args.runs, seed=args.seed,
                     n_particles=args.particles, accuracy=accuracy,
                     plan_objectives=_plans(args.plans), cost_samples=args.cost_samples,
                     n_resamples=args.resamples, workers=args.workers,
                     scheduler=args.scheduler, out_dir=args.out,
                     progress=(not quiet) and sys.stderr.isatty())
    payload = res.to_json()
    # the report's figures need matplotlib (~0.8 s), not the checks before the runs
    from tmaplan import ranking_report  # deferred: matplotlib

    plot_cost_ranking = ranking_report.plot_cost_ranking
    write_ranking_report = ranking_report.write_ranking_report

    fig = None
    if not args.no_figure:
        fig = plot_cost_ranking(res, f"{args.out}/{scenario.name}_rank_costs.png")
        payload["figure"] = f"{args.out}/{scenario.name}_rank_costs.png"
        del fig
    cmd = command_line("rank-costs", f"tmaplan rank-costs {shlex.quote(args.problem)} "
                       f"--candidates {args.candidates} --runs {args.runs} --seed {args.seed} "
                       f"--particles {args.particles} --accuracy {accuracy} --plans "
                       f"{shlex.quote(args.plans)} --cost-samples {args.cost_samples} "
                       f"--resamples {args.resamples}")
    report = write_ranking_report(res, args.out, command=cmd, figure=None if args.no_figure
                                  else Path(payload["figure"]))
    payload["report"] = str(report)
    if not quiet:
        print(f"{scenario.name}: {len(res.candidates)} candidates, {args.runs} runs; default "
              f"objective {res.default_objective}")
        print(f"{'cost':<28} {'Spearman ρ':>10} {'95 % CI':>17} {'Kendall τ':>10} "
              f"{'ρ (RMSE)':>9}")
        for c in res.costs:
            ci = "–" if c.spearman_ci[0] != c.spearman_ci[0] else \
                f"[{c.spearman_ci[0]:+.2f}, {c.spearman_ci[1]:+.2f}]"
            print(f"{c.name:<28} {c.spearman:>+10.2f} {ci:>17} {c.kendall:>+10.2f} "
                  f"{c.spearman_rmse:>+9.2f}")
        print(f"wrote {report} ({len(res.campaign.computed_runs)} runs computed, "
              f"{len(res.campaign.loaded_runs)} loaded)")
    return payload
