"""``tmaplan schedule P --budget K [--method …] [--objective …] --json``: ping times."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tmaplan.models.observer import observer_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.pings import PING_OBJECTIVES, schedule_pings
from tmaplan.plotting import plot_schedule
from tmaplan.scenario import load

HELP = "schedule active range pings under a budget (closed-form PCRB)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``schedule``."""
    parser.add_argument("problem", help="built-in problem name or path to a .toml file")
    parser.add_argument("--budget", type=int, default=None,
                        help="maximum number of pings (default: planning.ping_budget)")
    parser.add_argument("--method", choices=("exact", "relaxed", "greedy"), default="relaxed")
    parser.add_argument("--objective", choices=PING_OBJECTIVES, default="mean-range-bound")
    parser.add_argument("--min-spacing", type=float, default=None, metavar="SEC",
                        help="minimum time between pings [s] (default: the problem's)")
    parser.add_argument("--time-limit", type=float, default=600.0, metavar="SEC",
                        help="enumeration time limit for --method exact [s] (the certified "
                             "gap is reported when it is hit)")
    parser.add_argument("--workers", type=int, default=None,
                        help="processes for --method exact (default: the cores, at most 2)")
    parser.add_argument("--out", default="out", help="directory for the figure (default out/)")
    parser.add_argument("--no-plot", action="store_true", help="do not write the figure")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Schedule, write ``<out>/<problem>_schedule.png`` and return the payload."""
    scenario = load(args.problem)
    budget = args.budget
    if budget is None:
        budget = scenario.planning.ping_budget if scenario.planning is not None else 0
    belief = Belief.from_prior(scenario)
    obs = observer_track(scenario.observer, scenario.time)
    res = schedule_pings(scenario, budget=budget, method=args.method,
                         objective=args.objective, observer=obs, belief=belief,
                         min_spacing=args.min_spacing, time_limit=args.time_limit,
                         workers=args.workers)
    payload: dict[str, Any] = {
        "problem": scenario.name, "budget": budget, "objective_name": res.objective_name,
        "ping_times": res.times, "ping_steps": res.steps, "objective": res.objective,
        "no_ping_objective": res.no_ping_objective, "uniform_objective": res.uniform_objective,
        "lower_bound": res.lower_bound, "gap": res.gap, "gap_reference": res.gap_reference,
        "times": obs.times, "bound": res.bound,
        "solver": {"status": res.status, "seconds": res.seconds, "method": res.method,
                   "bound_seconds": res.bound_seconds},
    }
    if args.json != "-":
        print(f"{scenario.name}: {res.objective_name} = {res.objective:.4g} m with pings at "
              f"{', '.join(f'{t:.0f}' for t in res.times)} s ({res.method}, {res.status}, "
              f"lower bound {res.lower_bound:.4g} m, gap {100 * res.gap:.2f} %); "
              f"no pings {res.no_ping_objective:.4g} m, uniform {res.uniform_objective:.4g} m")
    if not args.no_plot:
        path = Path(args.out) / f"{scenario.name}_schedule.png"
        plot_schedule(scenario, obs, belief, res, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
