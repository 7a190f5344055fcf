"""``tmaplan plan P [--objective ...] [--horizon T] [--out DIR] --json``: optimal headings.

The JSON carries the planned observer track on the scenario's grid (``observer``: ``times``,
``position``, ``velocity``, ``mean_velocity``, ``heading``, ``speed``, SI), so that
``tmaplan schedule P --observer-plan PLAN.json`` schedules pings along exactly this track.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tmaplan.cli._args import (
    MAX_STARTS,
    add_figure_arguments,
    add_problem_argument,
    duration,
    integer,
    minutes,
)
from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.planning.belief import Belief
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.objectives import OBJECTIVE_NAMES, ObjectiveEvaluator
from tmaplan.plotting import plot_plan
from tmaplan.policies.plan_starts import plan_from_prior
from tmaplan.scenario import load

HELP = "optimal observer heading plan (casadi/IPOPT) compared with baseline manoeuvres"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``plan``."""
    add_problem_argument(parser)
    parser.add_argument("--objective", choices=OBJECTIVE_NAMES, default=None,
                        help="objective (default: the problem's planning.objective)")
    parser.add_argument("--horizon", type=duration(), default=None, metavar="T",
                        help="planning horizon, seconds or with a unit ('30 min'; default: "
                             "the problem's)")
    parser.add_argument("--control-interval", type=duration(), default=None, metavar="T",
                        help="duration of a piecewise-constant turn rate, seconds or with a "
                             "unit ('1 min')")
    parser.add_argument("--transcription", choices=("direct", "bang-bang"), default="direct")
    parser.add_argument("--starts", type=integer(1, MAX_STARTS), default=4,
                        help="built-in initial guesses of the bang-bang transcription "
                             "(default 4); the direct one starts from straight, the tactics "
                             "and the best single turns as well")
    add_figure_arguments(parser)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Plan, evaluate the baselines, write ``<out>/<problem>_plan.png``; return the payload."""
    scenario = load(args.problem)
    planner = HeadingPlanner(scenario, objective=args.objective, horizon=args.horizon,
                             control_interval=args.control_interval,
                             transcription=args.transcription, n_starts=args.starts)
    belief = Belief.from_prior(scenario)
    plan = (plan_from_prior(scenario, planner=planner) if args.transcription == "direct"
            else planner.solve(belief))
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
        "solver": {"status": plan.status, "seconds": plan.seconds, "message": plan.message,
                   "iterations": plan.iterations, "transcription": plan.transcription},
        "observer": {"times": plan.observer.times, "position": plan.observer.position,
                     "velocity": plan.observer.velocity,
                     "mean_velocity": plan.observer.mean_velocity,
                     "heading": plan.observer.heading, "speed": plan.observer.speed},
    }
    if args.json != "-":
        print(f"{scenario.name}: {planner.objective.name} = {plan.objective:.4g} over "
              f"{minutes(plan.times[-1] - plan.times[0], 0)} ({plan.status}, solved in "
              f"{plan.seconds:.2f} s)")
        for k, v in payload["baselines"].items():
            print(f"  baseline {k:<12} {v:.4g}")
    if not args.no_figure:
        path = Path(args.out) / f"{scenario.name}_plan.png"
        plot_plan(plan, base, belief, path, objective=planner.objective.name)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
