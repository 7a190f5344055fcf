"""``tmaplan plan P [--objective …] [--horizon SEC] [--out DIR] --json``: optimal headings."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.planning.belief import Belief
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.objectives import OBJECTIVE_NAMES, ObjectiveEvaluator
from tmaplan.plotting import plot_plan
from tmaplan.scenario import load

HELP = "optimal observer heading plan (casadi/IPOPT) compared with baseline manoeuvres"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``plan``."""
    parser.add_argument("problem", help="built-in problem name or path to a .toml file")
    parser.add_argument("--objective", choices=OBJECTIVE_NAMES, default=None,
                        help="objective (default: the problem's planning.objective)")
    parser.add_argument("--horizon", type=float, default=None, metavar="SEC",
                        help="planning horizon [s] (default: the problem's)")
    parser.add_argument("--control-interval", type=float, default=None, metavar="SEC",
                        help="duration of a piecewise-constant turn rate [s]")
    parser.add_argument("--transcription", choices=("direct", "bang-bang"), default="direct")
    parser.add_argument("--starts", type=int, default=4, help="multi-start initial guesses")
    parser.add_argument("--out", default="out", help="directory for the figure (default out/)")
    parser.add_argument("--no-plot", action="store_true", help="do not write the figure")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Plan, evaluate the baselines, write ``<out>/<problem>_plan.png``; return the payload."""
    scenario = load(args.problem)
    planner = HeadingPlanner(scenario, objective=args.objective, horizon=args.horizon,
                             control_interval=args.control_interval,
                             transcription=args.transcription, n_starts=args.starts)
    belief = Belief.from_prior(scenario)
    plan = planner.solve(belief)
    ev = ObjectiveEvaluator(scenario, planner.objective, n_steps=planner.K, belief=belief)
    base = evaluate_baselines(scenario, planner.objective, belief=belief, n_steps=planner.K,
                              evaluator=ev)
    payload: dict[str, Any] = {
        "problem": scenario.name, "objective_name": planner.objective.name,
        "times": plan.times, "heading": plan.heading, "turn_rate": plan.turn_rate,
        "switch_times": plan.switch_times, "objective": plan.objective,
        "range_bound": plan.range_bound, "range_bound_times": plan.observer.times,
        "baselines": {k: v[0].objective for k, v in base.items()},
        "baseline_params": {k: v[0].params for k, v in base.items()},
        "solver": {"status": plan.status, "seconds": plan.seconds,
                   "iterations": plan.iterations, "transcription": plan.transcription},
    }
    if args.json != "-":
        print(f"{scenario.name}: {planner.objective.name} = {plan.objective:.4g} "
              f"({plan.status}, {plan.seconds:.2f} s)")
        for k, v in payload["baselines"].items():
            print(f"  baseline {k:<12} {v:.4g}")
    if not args.no_plot:
        path = Path(args.out) / f"{scenario.name}_plan.png"
        plot_plan(plan, base, belief, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
