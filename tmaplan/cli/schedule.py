"""``tmaplan schedule P --budget K [--method ...] [--objective ...] --json``: ping times.

Pings are scheduled along the problem's scripted observer track, or along a planned track
saved by ``tmaplan plan P --json PLAN.json`` (``--observer-plan PLAN.json``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli._args import (
    add_figure_arguments,
    add_problem_argument,
    duration,
    integer,
)
from tmaplan.display import minute_list
from tmaplan.errors import ArgumentError
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.pings import PING_OBJECTIVES, schedule_pings
from tmaplan.plotting import plot_schedule
from tmaplan.scenario import Scenario, load

HELP = "schedule active range pings under a budget (closed-form PCRB)"

#: Results that must be numbers (:mod:`tmaplan.cli._finite`).
FINITE = ("objective",)

_TRACK_KEYS = ("times", "position", "velocity", "mean_velocity", "heading", "speed")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``schedule``."""
    add_problem_argument(parser)
    parser.add_argument("--budget", type=integer(0), default=None,
                        help="maximum number of pings (default: planning.ping_budget)")
    parser.add_argument("--method", choices=("exact", "relaxed", "greedy"), default="relaxed")
    parser.add_argument("--objective", choices=PING_OBJECTIVES, default="mean-range-bound")
    parser.add_argument("--min-spacing", type=duration(allow_zero=True), default=None,
                        metavar="T", help="minimum time between pings, seconds or with a unit "
                                          "('2 min'; default: the problem's)")
    parser.add_argument("--time-limit", type=duration(), default=600.0, metavar="T",
                        help="enumeration time limit for --method exact, seconds or with a "
                             "unit (default 600 s; the certified gap is reported when hit)")
    parser.add_argument("--workers", type=integer(1, 256), default=None,
                        help="processes for --method exact (default: the cores, at most 2)")
    parser.add_argument("--observer-plan", metavar="PLAN.json", default=None,
                        help="schedule along the planned track saved by `tmaplan plan P "
                             "--json PLAN.json` (default: the problem's scripted observer)")
    add_figure_arguments(parser)


def read_observer_plan(path: str | Path, scenario: Scenario) -> ObserverTrack:
    """The planned observer track in a ``tmaplan plan --json`` file, checked against the
    scenario it is used with.

    Raises
    ------
    ArgumentError
        Naming ``--observer-plan`` and the file: unreadable or not JSON, no ``observer``
        track, a plan of another problem, a null or non-finite value in the track, or a track
        not on the scenario's time grid.
    """
    def err(expected: str, received: Any) -> ArgumentError:
        return ArgumentError("--observer-plan", expected, received, source=str(path))

    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise err("an existing file written by `tmaplan plan P --json PLAN.json`",
                  "no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise err("a JSON file written by `tmaplan plan P --json PLAN.json`",
                  f"{type(exc).__name__}: {exc}") from None
    obs = data.get("observer") if isinstance(data, dict) else None
    if not isinstance(obs, dict) or any(k not in obs for k in _TRACK_KEYS):
        raise err(f"a plan with an 'observer' track ({', '.join(_TRACK_KEYS)})",
                  sorted(obs) if isinstance(obs, dict) else type(obs).__name__)
    if data.get("problem") != scenario.name:
        raise err(f"a plan of problem {scenario.name!r}", data.get("problem"))
    try:
        track = ObserverTrack(**{k: np.asarray(obs[k], dtype=float) for k in _TRACK_KEYS})
    except (TypeError, ValueError) as exc:
        raise err("numeric arrays in the 'observer' track", str(exc)) from None
    t = track.times
    n = t.shape[0]
    shapes_ok = (t.ndim == 1 and n >= 2 and track.position.shape == (n, 2)
                 and track.velocity.shape == (n, 2) and track.mean_velocity.shape == (n, 2)
                 and track.heading.shape == (n,) and track.speed.shape == (n,))
    if not shapes_ok:
        raise err("per-step arrays of one length: times (n,), position/velocity (n, 2)",
                  f"times {t.shape}, position {track.position.shape}")
    bad = [k for k in _TRACK_KEYS if not np.all(np.isfinite(getattr(track, k)))]
    if bad:
        raise err("finite numbers in the 'observer' track", f"null or non-finite values in "
                  f"{', '.join(bad)}")
    grid = scenario.time
    if abs(t[0] - grid.t0) > 1e-6 or np.max(np.abs(np.diff(t) - grid.dt)) > 1e-6 \
            or n - 1 > grid.n_steps:
        raise err(f"a track on the problem's grid (t0 = {grid.t0:g} s, dt = {grid.dt:g} s, "
                  f"at most {grid.n_steps} steps)",
                  f"t0 = {t[0]:g} s, {n - 1} steps of {np.diff(t).mean():g} s")
    return track


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Schedule, write ``<out>/<problem>_schedule.png`` and return the payload."""
    scenario = load(args.problem)
    budget = args.budget
    if budget is None:
        budget = scenario.planning.ping_budget if scenario.planning is not None else 0
    belief = Belief.from_prior(scenario)
    if args.observer_plan is not None:
        obs = read_observer_plan(args.observer_plan, scenario)
    else:
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
        "observer_plan": args.observer_plan,
        "solver": {"status": res.status, "seconds": res.seconds, "method": res.method,
                   "bound_seconds": res.bound_seconds},
    }
    if args.json != "-":
        along = f"along {args.observer_plan}" if args.observer_plan else "along the scripted track"
        print(f"{scenario.name}: {res.objective_name} = {res.objective:.4g} m with pings at "
              f"{minute_list(res.times)} {along} ({res.method}, {res.status}, "
              f"lower bound {res.lower_bound:.4g} m, gap {100 * res.gap:.2f} %); "
              f"no pings {res.no_ping_objective:.4g} m, uniform {res.uniform_objective:.4g} m")
    if not args.no_figure:
        path = Path(args.out) / f"{scenario.name}_schedule.png"
        plot_schedule(scenario, obs, belief, res, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
