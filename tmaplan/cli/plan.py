"""``tmaplan plan P [--objective ...] [--horizon T] [--out DIR] --json``: optimal headings.

The JSON carries the planned observer track on the scenario's grid (``observer``: ``times``,
``position``, ``velocity``, ``mean_velocity``, ``heading``, ``speed``, SI), so that
``tmaplan schedule P --observer-plan PLAN.json`` schedules pings along exactly this track.
Every time in it is on the scenario clock (``t0`` included), the single-turn baseline's
``baseline_params.time`` too (the library's :class:`~tmaplan.planning.baselines.Baseline`
counts it from ``t0``); durations (``leg_duration``) are durations.

Several contacts (docs/several-contacts.md): one joint own-ship plan for all of them
(:class:`tmaplan.planning.contacts.ContactsPlanner`, ``--objective`` one of
:data:`tmaplan.planning.multi_objectives.CONTACTS_OBJECTIVE_NAMES`), set against each
contact's own plan: the JSON adds ``contacts: {name: {...}}`` and ``alone_plans``. With
``--pings K``, the headings and K pings shared by the contacts planned together
(:func:`tmaplan.planning.joint_contacts.plan_contacts_joint`, ``--objective`` one of
:data:`tmaplan.planning.joint.JOINT_OBJECTIVES`, the contacts' weighted mean): the JSON adds
``pings`` with one contact's keys and ``pings.contacts``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Any, cast

import numpy as np

from tmaplan.cli.args import (
    MAX_STARTS,
    PLAN_STARTS,
    add_figure_arguments,
    add_problem_argument,
    duration,
    integer,
)
from tmaplan.cli.contacts import preflight_per_contact, require_priors
from tmaplan.cli.simulate import DEFAULT_ORIGIN, DEFAULT_START, parse_start
from tmaplan.display import minute_list, objective_label
from tmaplan.errors import ArgumentError
from tmaplan.io import LocalFrame
from tmaplan.io.plans import Leg, legs_from_track, legs_json, write_plan
from tmaplan.models.leg_table import NavigatorLegs, track_navigator_legs
from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import (
    ContactSet,
    ContactsPlan,
    ContactsPlanner,
    warn_if_saturated,
)
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner
from tmaplan.planning.joint import JOINT_OBJECTIVES, plan_joint
from tmaplan.planning.joint_contacts import plan_contacts_joint
from tmaplan.planning.joint_ocp import plan_joint_ocp
from tmaplan.planning.multi_objectives import (
    CONTACTS_OBJECTIVE_NAMES,
    DEFAULT_CONTACTS_OBJECTIVE,
    contacts_bound_objective,
)
from tmaplan.planning.objectives import OBJECTIVE_NAMES, ObjectiveEvaluator
from tmaplan.planning.pings import schedule_pings
from tmaplan.policies.plan_starts import plan_from_prior
from tmaplan.scenario import Scenario, load

HELP = "optimal observer heading plan (casadi/IPOPT) compared with baseline manoeuvres"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("objective",)

#: Several contacts: one joint plan for all of them (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "joint"


#: ``--pings K`` with several contacts and no ``--objective``, unless the problem's
#: ``planning.objective`` is one of :data:`JOINT_OBJECTIVES`.
SEVERAL_PINGS_OBJECTIVE = "mean-range-bound"

#: Defaults of ``--transcription`` and ``--starts`` (a figure's name omits them).
TRANSCRIPTION = "direct"
STARTS = 4


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``plan``."""
    add_problem_argument(parser)
    parser.add_argument("--objective", choices=OBJECTIVE_NAMES + CONTACTS_OBJECTIVE_NAMES,
                        default=None,
                        help="objective (default: the problem's planning.objective); with "
                             f"several contacts one of {', '.join(CONTACTS_OBJECTIVE_NAMES)} "
                             f"(default {DEFAULT_CONTACTS_OBJECTIVE}), with several contacts "
                             f"and --pings one of {', '.join(JOINT_OBJECTIVES)}, the "
                             "contacts' weighted mean (default the problem's "
                             f"planning.objective if one of these, else "
                             f"{SEVERAL_PINGS_OBJECTIVE})")
    parser.add_argument("--horizon", type=duration(), default=None, metavar="T",
                        help="planning horizon, seconds or with a unit ('30 min'; default: "
                             "the problem's; at most its time.horizon)")
    parser.add_argument("--control-interval", type=duration(), default=None, metavar="T",
                        help="duration of a piecewise-constant turn rate, seconds or with a "
                             "unit ('1 min')")
    parser.add_argument("--transcription", choices=("direct", "bang-bang"),
                        default=TRANSCRIPTION,
                        help=f"heading OCP: direct (a turn rate per control interval; default "
                             f"{TRANSCRIPTION}) or bang-bang (the durations of arcs at full "
                             "and zero turn rate)")
    parser.add_argument("--starts", type=integer(1, MAX_STARTS), default=None,
                        help=f"built-in initial guesses of the heading solve (default {STARTS}): "
                             f"with --transcription bang-bang (at most "
                             f"{PLAN_STARTS['bang-bang']}) or --pings K (direct: at most "
                             f"{PLAN_STARTS['direct']}); refused with the direct transcription "
                             "without pings, which starts from straight, the tactics, the best "
                             "single turns and 4 fixed guesses")
    parser.add_argument("--pings", type=integer(0), default=0, metavar="K",
                        help="plan K range pings with the headings (default 0: headings "
                             "only); with several contacts K pings shared by all, each "
                             "informing the contacts within the range sensor's max_range")
    parser.add_argument("--joint", choices=("ocp", "alternating"), default=None,
                        help="with --pings: one OCP (relaxed, rounded, polished, certified on "
                             "its pings) or alternating heading/ping blocks (default ocp; "
                             "several contacts: alternating only)")
    parser.add_argument("--ping-stride", type=integer(1), default=None, metavar="N",
                        help="--joint ocp: candidate ping steps every N steps (default 1)")
    add_figure_arguments(parser)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Plan, evaluate the baselines, write the figure (:func:`figure_name`); return the
    payload."""
    scenario = load(args.problem)
    if len(scenario.contacts) > 1:
        return _run_several(args, scenario)
    planner = HeadingPlanner(scenario, objective=args.objective, horizon=args.horizon,
                             control_interval=args.control_interval,
                             transcription=args.transcription, n_starts=_starts(args))
    belief = Belief.from_prior(scenario)
    pings = _joint(args, scenario, belief) if args.pings > 0 else None
    if pings is not None:
        plan = pings[0]
    elif args.transcription == "direct":
        plan = plan_from_prior(scenario, planner=planner)
    else:
        plan = planner.solve(belief)
    ev = planner.evaluator(belief)  # the objective the planner minimised, settings and all
    base = evaluate_baselines(scenario, planner.objective, belief=belief, n_steps=planner.K,
                              evaluator=ev)
    payload: dict[str, Any] = {
        "problem": scenario.name, "objective_name": planner.objective.name,
        "times": plan.times, "heading": plan.heading, "turn_rate": plan.turn_rate,
        "switch_times": plan.switch_times, "objective": plan.objective,
        "range_bound": plan.range_bound, "range_bound_times": plan.observer.times,
        "baselines": {k: v[0].objective for k, v in base.items()},
        "baseline_params": {k: _on_clock(v[0].params, scenario.time.t0)
                            for k, v in base.items()},
        "solver": {"status": plan.status, "seconds": plan.seconds, "message": plan.message,
                   "iterations": plan.iterations, "transcription": plan.transcription},
        "observer": {"times": plan.observer.times, "position": plan.observer.position,
                     "velocity": plan.observer.velocity,
                     "mean_velocity": plan.observer.mean_velocity,
                     "heading": plan.observer.heading, "speed": plan.observer.speed},
    }
    if pings is not None:
        payload["pings"] = pings[1]
    if args.json != "-":
        if pings is not None:
            pj = pings[1]
            print(f"{scenario.name}: {args.pings} ping(s) at {minute_list(pj['ping_times'])} "
                  f"({args.joint or 'ocp'}): objective {pj['objective']:.4g} m, lower bound "
                  f"{pj['lower_bound']:.4g} m, gap {100 * pj['gap']:.2f} %")
        print(f"{scenario.name}: {objective_label(planner.objective.name)} = "
              f"{plan.objective:.4g} over "
              f"{minute_list(plan.times[-1] - plan.times[0], 0)} ({plan.status}, solved in "
              f"{plan.seconds:.2f} s)")
        for k, v in payload["baselines"].items():
            print(f"  baseline {k:<12} {v:.4g}" + (" (no pings)" if pings else ""))
    payload.update(_navigator_plan(plan, scenario, Path(args.out),
                                   _figure(args, scenario, planner.objective.name)[:-4],
                                   quiet=args.json == "-"))
    if not args.no_figure:
        path = Path(args.out) / _figure(args, scenario, planner.objective.name)
        from tmaplan.plotting import plot_plan  # deferred: matplotlib

        plot_plan(plan, base, belief, path, objective=planner.objective.name)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload


def _figure(args: argparse.Namespace, scenario: Scenario, objective: str) -> str:
    """The figure's name of this plan (:func:`figure_name`; its stem names the exports)."""
    return figure_name(scenario.name, objective, args.pings, horizon=args.horizon,
                       control_interval=args.control_interval,
                       transcription=args.transcription, starts=_starts(args),
                       joint=args.joint, ping_stride=args.ping_stride)


def several_ping_objective(args: argparse.Namespace, scenario: Scenario) -> str:
    """The objective of ``plan --pings K`` on a several-contact problem: ``--objective`` (one
    of :data:`JOINT_OBJECTIVES`, else :class:`ArgumentError` naming it), default the
    problem's ``planning.objective`` if it is one of them, else
    :data:`SEVERAL_PINGS_OBJECTIVE`."""
    if args.objective is None:
        pl = scenario.planning
        own = pl.objective if pl is not None else None
        return own if own in JOINT_OBJECTIVES else SEVERAL_PINGS_OBJECTIVE
    if args.objective not in JOINT_OBJECTIVES:
        raise ArgumentError("--objective", f"with --pings and several contacts one of "
                            f"{', '.join(JOINT_OBJECTIVES)} (the contacts' weighted mean; "
                            f"default {SEVERAL_PINGS_OBJECTIVE})", args.objective,
                            source=scenario.name)
    return str(args.objective)


def preflight_several(args: argparse.Namespace, scenario: Scenario,
                      preflight: Any) -> None:
    """``plan``'s checks on a several-contact problem: ``--objective`` one of
    :data:`CONTACTS_OBJECTIVE_NAMES` (a one-contact objective is refused, not mapped); with
    ``--pings K`` one of :data:`JOINT_OBJECTIVES` instead (:func:`several_ping_objective`),
    ``--joint`` alternating (the default) and no ``--ping-stride``; then the one-contact
    checks on each contact's view (:func:`tmaplan.cli.contacts.preflight_per_contact`: the
    horizon, the control interval, ``--starts``, the keep-out range from each contact's
    prior)."""
    objective = None
    if args.pings:
        objective = several_ping_objective(args, scenario)
        if args.joint == "ocp":
            raise ArgumentError("--joint", "alternating with --pings and several contacts "
                                "(heading and shared-ping blocks; the one OCP plans one "
                                "contact)", args.joint, source=scenario.name)
        if args.ping_stride is not None:
            raise ArgumentError("--ping-stride", "only with --joint ocp, which plans one "
                                "contact (the alternating blocks search every step)",
                                args.ping_stride, source=scenario.name)
    elif args.objective is not None and args.objective not in CONTACTS_OBJECTIVE_NAMES:
        raise ArgumentError("--objective", f"with several contacts one of "
                            f"{', '.join(CONTACTS_OBJECTIVE_NAMES)} (default "
                            f"{DEFAULT_CONTACTS_OBJECTIVE}; {', '.join(scenario.contact_names)})",
                            args.objective, source=scenario.name)
    require_priors(scenario, "the joint plan starts from every contact's prior")
    preflight_per_contact(argparse.Namespace(**{**vars(args), "objective": objective}),
                          scenario, preflight)


def _run_several(args: argparse.Namespace, scenario: Scenario) -> dict[str, Any]:
    """The joint plan of several contacts, each contact's own plan, their per-contact values
    (console table, JSON ``contacts`` and ``alone_plans``), baselines and figure."""
    cs = ContactSet.from_scenario(scenario)
    if args.pings > 0:
        return _run_several_pings(args, scenario, cs)
    kw: dict[str, Any] = {"horizon": args.horizon, "control_interval": args.control_interval,
                          "transcription": args.transcription}
    if args.starts is not None:
        kw["n_starts"] = int(args.starts)
    planner = ContactsPlanner(cs, objective=args.objective, **kw)
    bel = cs.beliefs()
    res = planner.solve(bel)  # a joint NLP that converged from no start raises
    plans: dict[str, HeadingPlan] = {"joint": res.plan,
                                     **{f"alone:{n}": p for n, p in res.alone.items()}}
    each = dict(zip(plans, planner.per_contact(bel, [p.observer for p in plans.values()]),
                    strict=True))
    warn_if_saturated(res.objective_name, {n: t for n, (t, _) in each["joint"].items()},
                      float(res.plan.times[-1] - res.plan.times[0]))
    ev = planner.joint.evaluator(cast(Any, bel))  # the joint objective, settings and all
    base = evaluate_baselines(cs.views[0], evaluator=ev)
    plan = res.plan
    payload: dict[str, Any] = {
        **_several_json(scenario, res.objective_name, plan, plan.objective, base,
                        res.seconds, res.start),
        "contacts": _contacts_json(cs, res, each),
        "alone_plans": {n: {"objective": ev(p.observer)[0], "own_objective": p.objective,
                            "status": p.status, "heading": p.heading,
                            "turn_rate": p.turn_rate, "times": p.times,
                            "contacts": {c: {"expected_time_to_accuracy": t,
                                             "final_range_bound": float(b[-1])}
                                         for c, (t, b) in each[f"alone:{n}"].items()}}
                        for n, p in res.alone.items()},
    }
    quiet = args.json == "-"
    if not quiet:
        print(f"{scenario.name}: {len(cs)} contacts, {objective_label(res.objective_name)} = "
              f"{plan.objective:.4g} over {minute_list(plan.times[-1] - plan.times[0], 0)} "
              f"({plan.status}, solved in {res.seconds:.2f} s, kept the start {res.start})")
        for k, v in payload["baselines"].items():
            print(f"  baseline {k:<12} {v:.4g}")
    stem = _figure(args, scenario, res.objective_name)
    payload.update(_navigator_plan(plan, scenario, Path(args.out), stem[:-4], quiet=quiet))
    if not quiet:
        for line in _contacts_table(cs.names, payload):
            print(line)
    if not args.no_figure:
        path = Path(args.out) / stem
        from tmaplan.report_contacts import plan_figure  # deferred: matplotlib

        plan_figure(cs.views, cs.names, plans,
                    {k: {c: b for c, (_, b) in v.items()} for k, v in each.items()}, path,
                    title=f"{scenario.name}: {res.objective_name} = {plan.objective:.4g} s")
        payload["figure"] = str(path)
        if not quiet:
            print(f"wrote {path}")
    return payload


def _run_several_pings(args: argparse.Namespace, scenario: Scenario,
                       cs: ContactSet) -> dict[str, Any]:
    """``--pings K`` with several contacts: headings and K shared pings planned together
    (:func:`tmaplan.planning.joint_contacts.plan_contacts_joint`), certified on its pings;
    the several-contact JSON (``contacts``: each contact's values with the pings, ``alone_plans``
    empty) with ``pings`` as for one contact plus ``pings.contacts``."""
    objective = several_ping_objective(args, scenario)
    bel = cs.beliefs()
    r = plan_contacts_joint(cs, budget=args.pings, objective=objective, beliefs=bel,
                            horizon=args.horizon, control_interval=args.control_interval,
                            transcription=args.transcription, n_starts=_starts(args))
    plan, sched = r.heading, r.pings.schedule
    ev = ObjectiveEvaluator(cs.views[0], contacts_bound_objective(
        r.objective_name, q=[v.target.q for v in cs.views], weights=cs.weights),
        n_steps=plan.observer.times.size - 1, belief=cast(Any, bel))  # without pings
    base = evaluate_baselines(cs.views[0], evaluator=ev)
    pings = {"method": "alternating", "objective": r.objective,
             "lower_bound": sched.lower_bound, "gap": sched.gap,
             "ping_steps": sched.steps, "ping_times": sched.times, "budget": args.pings,
             "no_ping_objective": sched.no_ping_objective,
             "start_objective": r.start_objective,
             "solver": {"status": r.status, "seconds": r.seconds, "rounds": r.rounds,
                        "gap_reference": sched.gap_reference},
             "contacts": {n: {"pings_in_reach": r.pings.pings_in_reach[n],
                              "ping_steps_in_reach": sched.steps[r.pings.reach[n][sched.steps]]}
                          for n in cs.names}}
    payload: dict[str, Any] = {
        **_several_json(scenario, r.objective_name, plan, r.objective, base, r.seconds,
                        "built-in"),
        "contacts": {n: {"weight": w, "required_accuracy": a, **values} for (n, values), w, a
                     in zip(r.pings.contacts_json().items(), cs.weights,
                            cs.required_accuracies, strict=True)},
        "alone_plans": {},
        "pings": pings,
    }
    quiet = args.json == "-"
    if not quiet:
        reach = ", ".join(f"{n} {k}" for n, k in r.pings.pings_in_reach.items())
        print(f"{scenario.name}: {len(cs)} contacts, {sched.steps.size} shared ping(s) at "
              f"{minute_list(sched.times)} (alternating, in reach: {reach}): objective "
              f"{r.objective:.4g} m (the plan without pings {r.start_objective:.4g} m), lower "
              f"bound {sched.lower_bound:.4g} m, gap {100 * sched.gap:.2f} %")
        print(f"{scenario.name}: {objective_label(r.objective_name)} (the contacts' weighted "
              f"mean) = {r.objective:.4g} over {minute_list(plan.times[-1] - plan.times[0], 0)} "
              f"({plan.status}, {r.rounds} heading block(s), {r.seconds:.2f} s)")
        for k, v in payload["baselines"].items():
            print(f"  baseline {k:<12} {v:.4g} (no pings)")
    stem = _figure(args, scenario, r.objective_name)
    payload.update(_navigator_plan(plan, scenario, Path(args.out), stem[:-4], quiet=quiet))
    if not args.no_figure:
        path = Path(args.out) / stem
        from tmaplan.report_contacts import plan_figure  # deferred: matplotlib

        what = "position" if r.objective_name == "mean-position-bound" else "range"
        plan_figure(cs.views, cs.names, {"joint": plan}, {"joint": r.pings.bounds}, path,
                    title=f"{scenario.name}: {r.objective_name} = {r.objective:.4g} m with "
                          f"{sched.steps.size} shared ping(s)", ping_times=sched.times,
                    bound_label=f"closed-form PCRB {what} bound with the pings [m]")
        payload["figure"] = str(path)
        if not quiet:
            print(f"wrote {path}")
    return payload


def _several_json(scenario: Scenario, name: str, plan: HeadingPlan, objective: float,
                  base: dict[str, Any], seconds: float, start: str) -> dict[str, Any]:
    """The one-contact keys of a several-contact plan's JSON (no top-level
    ``range_bound``): the plan, its ``objective`` (``name``), the ``baselines`` (from
    :func:`evaluate_baselines`), ``solver`` (``seconds`` [s], the ``start`` kept) and
    ``observer``."""
    return {
        "problem": scenario.name, "objective_name": name,
        "times": plan.times, "heading": plan.heading, "turn_rate": plan.turn_rate,
        "switch_times": plan.switch_times, "objective": objective,
        "range_bound_times": plan.observer.times,
        "baselines": {k: v[0].objective for k, v in base.items()},
        "baseline_params": {k: _on_clock(v[0].params, scenario.time.t0)
                            for k, v in base.items()},
        "solver": {"status": plan.status, "seconds": seconds, "message": plan.message,
                   "iterations": plan.iterations, "transcription": plan.transcription,
                   "start": start},
        "observer": _observer_json(plan)}


def _observer_json(plan: HeadingPlan) -> dict[str, Any]:
    """A plan's own-ship track for ``schedule --observer-plan`` (SI, the scenario clock)."""
    obs = plan.observer
    return {"times": obs.times, "position": obs.position, "velocity": obs.velocity,
            "mean_velocity": obs.mean_velocity, "heading": obs.heading, "speed": obs.speed}


def _contacts_json(cs: ContactSet, res: ContactsPlan,
                   each: dict[str, dict[str, tuple[float, np.ndarray]]]) -> dict[str, Any]:
    """``contacts: {name: {...}}`` of a joint plan: the contact's weight, required accuracy,
    expected time to accuracy [s] and range bound [m] (per step, final) on the joint plan
    and on its own plan (``alone_*``)."""
    out: dict[str, Any] = {}
    for (name, values), w, a in zip(res.contacts_json().items(), cs.weights,
                                    cs.required_accuracies, strict=True):
        bound = each["joint"][name][1]
        d: dict[str, Any] = {"weight": w, "required_accuracy": a, **values,
                             "final_range_bound": float(bound[-1]), "range_bound": bound}
        if f"alone:{name}" in each:
            d["alone_final_range_bound"] = float(each[f"alone:{name}"][name][1][-1])
        out[name] = d
    return out


def _contacts_table(names: tuple[str, ...], payload: dict[str, Any]) -> list[str]:
    """The console's per-contact table: each contact's expected time to accuracy and final
    range bound on the joint plan and on each contact's own plan (the trade-off)."""
    def cell(t: float, b: float) -> str:
        return f"{t / 60:6.1f} min / {b:7.0f} m"

    rows = [("joint plan", payload["objective"],
             [cell(payload["contacts"][n]["expected_time_to_accuracy"],
                   payload["contacts"][n]["final_range_bound"]) for n in names])]
    rows += [(f"{own}'s own plan", a["objective"],
              [cell(a["contacts"][n]["expected_time_to_accuracy"],
                    a["contacts"][n]["final_range_bound"]) for n in names])
             for own, a in payload["alone_plans"].items()]
    width = max(24, *(len(n) + 2 for n in names))
    lines = ["expected time to accuracy / final range bound of each contact, on each plan:",
             f"  {'plan':<22} {'joint objective':>15}  " + "".join(
                 f"{n:<{width}}" for n in names)]
    lines += [f"  {label:<22} {value:>13.4g} s  " + "".join(f"{c:<{width}}" for c in cells)
              for label, value, cells in rows]
    return [line.rstrip() for line in lines]


def _navigator_plan(plan: HeadingPlan, scenario: Any, out: Path, stem: str, *,
                    quiet: bool) -> dict[str, Any]:
    """The plan as a navigator uses it (:func:`navigator_exports`)."""
    legs = legs_from_track(plan.times - plan.times[0], plan.heading,
                           turn_rates=plan.turn_rate)
    obs = plan.observer
    return navigator_exports(legs, track_navigator_legs(legs, obs), obs.times, obs.position,
                             scenario, out, stem, quiet=quiet)


def navigator_exports(legs: Sequence[Leg], nav: NavigatorLegs, times: np.ndarray,
                      position: np.ndarray, scenario: Any, out: Path, stem: str, *,
                      quiet: bool) -> dict[str, Any]:
    """A scenario's own-ship track as a navigator uses it (docs/recordings.md): its leg
    table printed (``nav``, the merged one) and written (``<stem>_legs.csv``, exact;
    ``<stem>_navigator_legs.csv``, merged), and its track as GPX and CSV, the own ship
    starting at ``simulate --export``'s default origin and time (the scenario's plane shifted
    there). Returns the JSON keys ``legs``, ``navigator_legs``, ``exports``."""
    p0 = np.asarray(scenario.observer.position, float)
    t0 = float(scenario.time.t0)
    files = write_plan(out, stem, legs, np.asarray(times) - t0, position[:, 0] - p0[0],
                       position[:, 1] - p0[1], start=parse_start(DEFAULT_START),
                       frame=LocalFrame(lat0=DEFAULT_ORIGIN[0], lon0=DEFAULT_ORIGIN[1]),
                       navigator=nav.legs)
    if not quiet:
        print(nav.text())
        print(f"wrote {', '.join(files.values())}")
    return {"legs": legs_json(legs), "navigator_legs": nav.to_json(), "exports": files}


def figure_name(problem: str, objective: str, pings: int = 0, *,
                horizon: float | None = None, control_interval: float | None = None,
                transcription: str = TRANSCRIPTION, starts: int = STARTS,
                joint: str | None = None,
                ping_stride: int | None = None) -> str:
    """``<problem>_plan_<objective>[_<K>pings][_<setting>...].png``, one suffix per plan
    setting given away from its default (``h30min``, ``ci1min``, ``bang-bang``,
    ``2starts``, ``alternating``, ``stride2``; times [s] in minutes or seconds): plans of
    other objectives, ping budgets or settings into the same ``--out`` do not overwrite each
    other's figure, and the default plan keeps its short name."""
    def span(t: float) -> str:
        return f"{t / 60:g}min" if t >= 60 and float(t / 60).is_integer() else f"{t:g}s"

    parts = [f"{problem}_plan_{objective}"]
    parts += [f"{pings}pings"] if pings > 0 else []
    parts += [f"h{span(horizon)}"] if horizon is not None else []
    parts += [f"ci{span(control_interval)}"] if control_interval is not None else []
    parts += [transcription] if transcription != TRANSCRIPTION else []
    parts += [f"{starts}starts"] if starts != STARTS else []
    parts += ["alternating"] if pings > 0 and joint == "alternating" else []
    parts += [f"stride{ping_stride}"] if pings > 0 and ping_stride not in (None, 1) else []
    return "_".join(parts) + ".png"


def _starts(args: argparse.Namespace) -> int:
    """``--starts`` (default :data:`STARTS`); the preflight refused it where it has no effect
    (:func:`tmaplan.cli.preflight.preflight`), so a figure named ``_<N>starts`` was started from
    N guesses."""
    return STARTS if args.starts is None else int(args.starts)


def _on_clock(params: dict[str, float], t0: float) -> dict[str, float]:
    """Baseline parameters with the turn ``time`` [s after t0] on the scenario clock [s]."""
    return {k: v + t0 if k == "time" else v for k, v in params.items()}


def _joint(args: argparse.Namespace, scenario: Any,
           belief: Belief) -> tuple[HeadingPlan, dict[str, Any]]:
    """``--pings K``: the joint plan (``--joint``) and its JSON (``objective``,
    ``lower_bound``, ``gap``, ``solver``)."""
    pl = scenario.planning
    objective = args.objective or (pl.objective if pl is not None else "range-bound")
    kw = {"horizon": args.horizon, "control_interval": args.control_interval,
          "transcription": args.transcription, "n_starts": _starts(args)}
    if args.joint in (None, "ocp"):
        r = plan_joint_ocp(scenario, budget=args.pings,
                           objective=objective,  # type: ignore[arg-type]
                           ping_stride=args.ping_stride or 1, belief=belief, **kw)
        return r.heading, {"method": "ocp", **r.payload()}
    j = plan_joint(scenario, budget=args.pings, objective=objective,  # type: ignore[arg-type]
                   belief=belief, **kw)
    # the certificate of the alternating plan's pings along its track
    cert = schedule_pings(scenario, budget=args.pings,
                          objective=j.pings.objective_name,  # type: ignore[arg-type]
                          observer=j.heading.observer, belief=belief)
    lb = min(cert.lower_bound, j.objective)
    return j.heading, {"method": "alternating", "objective": j.objective,
                       "lower_bound": lb, "gap": (j.objective - lb) / j.objective,
                       "ping_steps": j.pings.steps, "ping_times": j.pings.times,
                       "budget": args.pings,
                       "solver": {"status": j.pings.status, "seconds": j.seconds,
                                  "rounds": j.iterations}}
