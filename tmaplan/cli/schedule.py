"""``tmaplan schedule P --budget K [--method ...] [--objective ...] --json``: ping times.

Pings are scheduled along the problem's scripted observer track, or along a planned track
saved by ``tmaplan plan P --json PLAN.json`` (``--observer-plan PLAN.json``).

Several contacts (docs/several-contacts.md): one set of ping times under one budget for all
of them, a ping ranging every contact within the range sensor's ``max_range``
(:func:`tmaplan.planning.ping_contacts.schedule_contact_pings`); the objective is the
contacts' weighted mean, certified as for one contact; the JSON adds ``contacts: {name:
{...}}``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli.args import (
    MAX_WORKERS,
    add_figure_arguments,
    add_problem_argument,
    duration,
    integer,
)
from tmaplan.cli.contacts import preflight_per_contact, require_priors
from tmaplan.display import minute_list, seconds_text
from tmaplan.errors import ArgumentError, ScenarioError, warn_field
from tmaplan.geometry import course_speed
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.sensors import default_ping_budget
from tmaplan.models.target import initial_velocity
from tmaplan.planning import max_pings, ping_candidates
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import ContactSet
from tmaplan.planning.ping_contacts import ping_max_range, schedule_contact_pings
from tmaplan.planning.pings import PING_OBJECTIVES, schedule_pings
from tmaplan.scenario import RangeSensor, Scenario, load, measurement_steps

HELP = "schedule active range pings under a budget (closed-form PCRB)"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("objective",)

#: Several contacts: one shared schedule for all of them (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "joint"

#: Defaults of ``--method``, ``--objective`` and ``--time-limit`` [s].
METHOD = "relaxed"
OBJECTIVE = "mean-range-bound"
TIME_LIMIT = 600.0

#: Options read by some methods only: flag -> (Namespace name, where it applies, whether the
#: method and objective read it). Given where it is not read it would be silently ignored, so
#: it is refused (:func:`check_options`).
_METHOD_OPTIONS: dict[str, tuple[str, str, Any]] = {
    "--time-limit": ("time_limit", "only with --method exact (the enumeration's limit)",
                     lambda method, objective: method == "exact"),
    "--workers": ("workers", "only with --method exact and --objective mean-range-bound or "
                  "terminal-range-bound (the processes of the tree search)",
                  lambda method, objective: method == "exact"
                  and objective != "mean-position-bound"),
}

_TRACK_KEYS = ("times", "position", "velocity", "mean_velocity", "heading", "speed")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``schedule``."""
    add_problem_argument(parser)
    parser.add_argument("--budget", type=integer(0), default=None,
                        help="maximum number of pings (default: planning.ping_budget)")
    parser.add_argument("--method", choices=("exact", "relaxed", "greedy"), default=METHOD,
                        help=f"exact (enumeration), relaxed (convex relaxation, rounded and "
                             f"polished) or greedy (default {METHOD})")
    parser.add_argument("--objective", choices=PING_OBJECTIVES, default=OBJECTIVE,
                        help=f"what the pings minimise (default {OBJECTIVE})")
    parser.add_argument("--min-spacing", type=duration(allow_zero=True), default=None,
                        metavar="T", help="minimum time between pings, seconds or with a unit "
                                          "('2 min'; default: the problem's)")
    parser.add_argument("--time-limit", type=duration(), default=None, metavar="T",
                        help="enumeration time limit for --method exact, seconds or with a "
                             f"unit (default {TIME_LIMIT:g} s; the certified gap is reported "
                             "when hit); refused with another method")
    parser.add_argument("--workers", type=integer(1, MAX_WORKERS), default=None,
                        help="processes for --method exact with a range objective (default: "
                             "the cores, at most 2); refused where unused")
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
    _check_start(track, scenario, err)
    return track


#: Tolerances of a saved plan's initial own-ship state against the scenario's: position
#: [m], course [rad] (0.06°), speed [m/s] (the plan starts exactly there, to round-off).
START_TOLERANCE = {"position": 1.0, "course": 1e-3, "speed": 1e-3}


def _check_start(track: ObserverTrack, scenario: Scenario, err: Any) -> None:
    """A plan's track must start from the scenario's own-ship state (``observer.position``,
    its initial course and speed): a plan of another scenario of the same name and grid
    starts elsewhere."""
    obs = scenario.observer
    p0 = np.asarray(obs.position, float)
    course0, speed0 = (float(v) for v in course_speed(initial_velocity(obs)))
    tol = START_TOLERANCE
    d = float(np.hypot(*(track.position[0] - p0)))
    if d > tol["position"]:
        raise err(f"a plan starting at the problem's observer.position ({p0[0]:g}, {p0[1]:g}) "
                  f"m (within {tol['position']:g} m)", f"observer.position[0] = "
                  f"({track.position[0][0]:g}, {track.position[0][1]:g}) m in the plan")
    dc = abs((float(track.heading[0]) - course0 + np.pi) % (2 * np.pi) - np.pi)
    if dc > tol["course"]:
        raise err(f"a plan starting on the problem's initial observer course "
                  f"{np.degrees(course0):.4g}° (within {np.degrees(tol['course']):.2g}°)",
                  f"observer.heading[0] = {np.degrees(float(track.heading[0])):.4g}° in "
                  "the plan")
    if abs(float(track.speed[0]) - speed0) > tol["speed"]:
        raise err(f"a plan starting at the problem's initial observer speed {speed0:.6g} m/s "
                  f"(within {tol['speed']:g} m/s)",
                  f"observer.speed[0] = {float(track.speed[0]):.6g} m/s in the plan")


def check_options(args: argparse.Namespace, scenario: Scenario) -> None:
    """Refuse ``--time-limit`` / ``--workers`` where the method and objective do not read
    them (:data:`_METHOD_OPTIONS`)."""
    for flag, (name, where, applies) in _METHOD_OPTIONS.items():
        value = getattr(args, name, None)
        if value is not None and not applies(args.method, args.objective):
            shown = seconds_text(value) if flag == "--time-limit" else value
            raise ArgumentError(flag, f"{where}; it is not used by --method {args.method} "
                                f"--objective {args.objective}", shown, source=scenario.name)


def check_spacing(args: argparse.Namespace, scenario: Scenario,
                  track: ObserverTrack | None) -> None:
    """The ping budget must fit in the candidate steps of the track (``--observer-plan``'s, or
    the scenario's grid) with the minimum spacing, before any work: the error names
    ``--min-spacing`` or ``planning.ping_min_spacing`` (a spacing that lets too few pings
    fit), else ``--budget`` / ``planning.ping_budget`` (too few steps outside
    ``planning.ping_forbidden``)."""
    budget = args.budget if args.budget is not None else default_ping_budget(scenario)
    if budget == 0:
        return
    times = track.times if track is not None else np.asarray(scenario.time.times, float)
    cand, gap, spacing = ping_candidates(scenario, times, min_spacing=args.min_spacing)
    fit = max_pings(cand, gap)
    if budget <= fit:
        return
    budget_name = "--budget" if args.budget is not None else "planning.ping_budget"
    if fit < min(budget, cand.size):  # the spacing is what leaves too few
        field = "--min-spacing" if args.min_spacing is not None else \
            "planning.ping_min_spacing"
        error_type = ArgumentError if field.startswith("-") else ScenarioError
        raise error_type(field, f"a spacing at which the {budget} pings of {budget_name} fit "
                         f"in the {len(times) - 1} steps (at most {fit} fit with this one; or "
                         f"a smaller {budget_name})", seconds_text(spacing),
                         source=scenario.name)
    error_type = ArgumentError if args.budget is not None else ScenarioError
    raise error_type(budget_name, f"at most the {cand.size} candidate ping steps (steps "
                     "outside planning.ping_forbidden)", budget, source=scenario.name)


def preflight_several(args: argparse.Namespace, scenario: Scenario, preflight: Any) -> None:
    """``schedule``'s checks on a several-contact problem: no ``--workers`` (the shared
    schedule's search runs in one process), then the one-contact checks on each contact's
    view (:func:`tmaplan.cli.contacts.preflight_per_contact`: the budget, the spacing,
    ``--observer-plan``, the options of the method, each contact's prior)."""
    if args.workers is not None:
        raise ArgumentError("--workers", "only with one contact (the search of a schedule "
                            "shared by several contacts runs in one process)", args.workers,
                            source=scenario.name)
    require_priors(scenario, "the shared schedule minimises every contact's bound from its "
                   "prior")
    if args.observer_plan is not None:  # the own ship's: its error names no contact
        read_observer_plan(args.observer_plan, scenario)
    preflight_per_contact(args, scenario, preflight)


def warn_scripted_ranges(scenario: Scenario) -> None:
    """Warn, one line per range sensor with scripted readings (``steps``, ``period``,
    ``every``; active or passive), that the schedule leaves them out: its closed-form bound
    counts the bearings and the scheduled pings only, so every objective it prints (no
    pings, uniform, the schedule's) lacks them, where ``tmaplan bound`` counts them."""
    for i, sen in enumerate(scenario.sensors):
        if not isinstance(sen, RangeSensor):
            continue
        n = measurement_steps(sen, scenario.time).size
        if n:
            what = "pings" if sen.active else "passive range readings (active = false)"
            warn_field(f"sensors[{i}].steps", "no scripted range readings: the schedule's "
                       "bound counts the bearings and the scheduled pings only, so its "
                       f"objectives (no pings, uniform, the schedule's) leave out these {what}"
                       f" (tmaplan bound counts them), received {n} scripted step(s)",
                       source=scenario.name)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Schedule, write ``<out>/<problem>_schedule.png`` and return the payload."""
    scenario = load(args.problem)
    warn_scripted_ranges(scenario)
    budget = args.budget if args.budget is not None else default_ping_budget(scenario)
    if args.observer_plan is not None:
        obs = read_observer_plan(args.observer_plan, scenario)
    else:
        obs = observer_track(scenario.observer, scenario.time)
    if len(scenario.contacts) > 1:
        return _run_several(args, scenario, budget, obs)
    belief = Belief.from_prior(scenario)
    res = schedule_pings(scenario, budget=budget, method=args.method,
                         objective=args.objective, observer=obs, belief=belief,
                         min_spacing=args.min_spacing,
                         time_limit=TIME_LIMIT if args.time_limit is None else args.time_limit,
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
        print(f"{scenario.name}: {res.objective_name} = {res.objective:.4g} m with "
              f"{_pings_at(res.times)} {along} ({res.method}, {res.status}, "
              f"lower bound {res.lower_bound:.4g} m, gap {100 * res.gap:.2f} %); "
              f"no pings {res.no_ping_objective:.4g} m, uniform {res.uniform_objective:.4g} m")
    if not args.no_figure:
        from tmaplan.plotting import plot_schedule  # deferred: matplotlib is slow to import

        path = Path(args.out) / f"{scenario.name}_schedule.png"
        plot_schedule(scenario, obs, belief, res, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload


def _run_several(args: argparse.Namespace, scenario: Scenario, budget: int,
                 obs: ObserverTrack) -> dict[str, Any]:
    """One ping schedule shared by the contacts (their weighted mean objective), its
    certificate and each contact's values; figure ``<out>/<problem>_schedule.png``."""
    cs = ContactSet.from_scenario(scenario)
    both = schedule_contact_pings(cs, budget=budget, method=args.method,
                                  objective=args.objective, observer=obs,
                                  min_spacing=args.min_spacing,
                                  time_limit=TIME_LIMIT if args.time_limit is None
                                  else args.time_limit)
    res = both.schedule
    contacts = both.contacts_json()
    for c, w, a in zip(cs.names, cs.weights, cs.required_accuracies, strict=True):
        contacts[c] = {"weight": w, "required_accuracy": a, **contacts[c]}
    payload: dict[str, Any] = {
        "problem": scenario.name, "budget": budget, "objective_name": res.objective_name,
        "ping_times": res.times, "ping_steps": res.steps, "objective": res.objective,
        "no_ping_objective": res.no_ping_objective, "uniform_objective": res.uniform_objective,
        "lower_bound": res.lower_bound, "gap": res.gap, "gap_reference": res.gap_reference,
        "times": obs.times, "bound": res.bound, "observer_plan": args.observer_plan,
        "max_range": ping_max_range(scenario),
        "solver": {"status": res.status, "seconds": res.seconds, "method": res.method,
                   "bound_seconds": res.bound_seconds},
        "contacts": contacts,
    }
    quiet = args.json == "-"
    if not quiet:
        along = f"along {args.observer_plan}" if args.observer_plan else "along the scripted track"
        print(f"{scenario.name}: {len(cs)} contacts, weighted mean of their "
              f"{res.objective_name} = {res.objective:.4g} m with "
              f"{_pings_at(res.times)} {along} ({res.method}, {res.status}, lower bound "
              f"{res.lower_bound:.4g} m, gap {100 * res.gap:.2f} %); no pings "
              f"{res.no_ping_objective:.4g} m, uniform {res.uniform_objective:.4g} m")
        for c in cs.names:
            d = contacts[c]
            print(f"  {c:<16} weight {d['weight']:g}: {d['objective']:.4g} m with the pings "
                  f"(no pings {d['no_ping_objective']:.4g} m), {d['pings_in_reach']} of "
                  f"{len(res.steps)} ping(s) in reach")
    if not args.no_figure:
        path = Path(args.out) / f"{scenario.name}_schedule.png"
        from tmaplan.report_contacts import schedule_figure  # deferred: matplotlib

        schedule_figure(both, obs.times, path, title=f"{scenario.name}: {budget} pings shared "
                        f"by {len(cs)} contacts, {res.status} (gap {100 * res.gap:.2f} %)")
        payload["figure"] = str(path)
        if not quiet:
            print(f"wrote {path}")
    return payload


def _pings_at(times: Any) -> str:
    """``"pings at 3.0, 9.0 min"``, or ``"no pings"`` for an empty schedule."""
    return f"pings at {minute_list(times)}" if len(times) else "no pings"
