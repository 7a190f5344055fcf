"""The advice for several contacts at once: ONE own-ship manoeuvre and ONE ping schedule.

**Now.** The latest of the contacts' last grid times (their last bearings); a contact whose
last bearing is earlier has its posterior moved to now at constant velocity (each sample's
target position advanced by its velocity, the own ship's displacement and velocity change
from the navigation subtracted; no process noise added over that gap), so that every belief
is at one time and relative to one own-ship state (:class:`tmaplan.planning.ContactBeliefs`).

**Manoeuvre.** The several-contact planner (:class:`tmaplan.planning.ContactsPlanner`,
objective ``all-contacts-time-to-accuracy``: the expected time until *every* contact is
localised to :data:`~tmaplan.advice.recommend.ACCURACY`, multi-started from each contact's
own plan and the straight course) from every contact's current posterior
(:func:`~tmaplan.advice.recommend.contact_belief`) and the own ship's current position,
course and speed, with the platform's turn-rate limit and keep-out range (from every
contact's estimate). The plan and *holding course* are both scored by that objective without
the turn penalty [s from now]; the recommendation is the plan only when it converged and is
no worse than holding course (else "hold course", and the advice says why). Each contact's
own expected time to accuracy is reported on both tracks.

**Pings** (``--budget K``): one schedule for all contacts along the recommended track
(:func:`tmaplan.planning.schedule_contact_pings`, ``relaxed``, objective the contacts' mean
``mean-range-bound``) with its convex-relaxation certificate (lower bound, gap, status).

The views share one bearing sensor: its standard deviation is the median over every
contact's bearings (the planner's :class:`tmaplan.planning.ContactSet` holds one own ship and
one sensor suite).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from tmaplan.advice.problem import Platform
from tmaplan.advice.recommend import (
    ACCURACY,
    PLAN_STEP,
    contact_belief,
    planning_scenario,
)
from tmaplan.advice.solution import ContactSolution
from tmaplan.display import short_repr
from tmaplan.errors import TmaplanError
from tmaplan.io.plans import Leg, legs_from_track
from tmaplan.models.observer import ObserverTrack, turn_rate_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.planning.multi_objectives import ContactBeliefs, contacts_objective
from tmaplan.planning.objectives import ObjectiveEvaluator, expected_time_to_accuracy
from tmaplan.planning.ping_contacts import ContactsPingSchedule, schedule_contact_pings
from tmaplan.scenario import Contact
from tmaplan.scenario.names import DEFAULT_CONTACT

__all__ = ["JOINT_OBJECTIVE", "JointAdvice", "advise_contacts", "belief_at"]

#: The objective of the joint advice (DESIGN.md §6's default for N > 1).
JOINT_OBJECTIVE = "all-contacts-time-to-accuracy"


@dataclasses.dataclass(frozen=True, kw_only=True)
class JointAdvice:
    """The advice for several contacts at once (module doc).

    Attributes
    ----------
    names : tuple of str
        The contacts, in the recording's order.
    objective : str
        :data:`JOINT_OBJECTIVE`.
    recommendation : str
        "plan" or "hold course".
    note : str
        Why (one line).
    legs : tuple of Leg
        Of the recommended track (starts relative to now; the exact per-control-interval
        table).
    track, hold_track : ObserverTrack
        The recommended track and holding course [s since the recording's origin, m].
    expected_time_to_accuracy, hold_course_time_to_accuracy : float
        The objective without the turn penalty on the recommended track and holding course
        [s from now]: the expected time until every contact is localised.
    plan_time_to_accuracy : float
        The planner's plan's [s] (NaN when it failed).
    contacts : dict of str to dict of str to float
        Per contact: ``expected_time_to_accuracy`` and ``hold_course_time_to_accuracy`` [s]
        (its own, recommended track and holding course), ``alone_expected_time_to_accuracy``
        [s] (its own plan alone; NaN when that plan failed).
    range_bounds, hold_range_bounds : dict of str to ndarray, shape (K + 1,)
        Each contact's closed-form PCRB range bound [m] along the recommended track and
        holding course.
    pings : ContactsPingSchedule or None
        With a budget: the shared schedule and its certificate (``pings.schedule``).
    solver : dict
        The joint planner's ``status``, ``success``, ``seconds`` and ``start`` (the start of
        the kept solution).
    """

    __repr__ = short_repr

    names: tuple[str, ...]
    objective: str
    recommendation: str
    note: str
    legs: tuple[Leg, ...]
    track: ObserverTrack
    hold_track: ObserverTrack
    expected_time_to_accuracy: float
    hold_course_time_to_accuracy: float
    plan_time_to_accuracy: float
    contacts: dict[str, dict[str, float]]
    range_bounds: dict[str, np.ndarray]
    hold_range_bounds: dict[str, np.ndarray]
    pings: ContactsPingSchedule | None
    solver: dict[str, Any]


def belief_at(belief: Belief, now: float, own_then: np.ndarray, own_now: np.ndarray) -> Belief:
    """A relative-state belief moved from its time to ``now`` at constant target velocity.

    Parameters
    ----------
    belief : Belief
        Relative state ``target − own ship`` at ``belief.t`` [m, m, m/s, m/s].
    now : float
        [s], >= ``belief.t``.
    own_then, own_now : ndarray, shape (4,)
        The own ship's position and velocity at ``belief.t`` and at ``now`` [m, m/s].

    Returns
    -------
    Belief
        At ``now``, relative to ``own_now``, assimilated as ``belief`` (no process noise
        added over the gap).
    """
    tau = float(now) - float(belief.t)
    M = np.eye(4)
    M[0, 2] = M[1, 3] = tau
    shift = np.asarray(own_then, float) @ M.T - np.asarray(own_now, float)
    if belief.samples is not None:
        X = np.asarray(belief.samples, float) @ M.T + shift
        return Belief.from_samples(X, belief.weights, t=now, assimilated=belief.assimilated)
    return Belief.from_moments(M @ belief.mean + shift, M @ belief.cov @ M.T, t=now,
                               assimilated=belief.assimilated)


def _own_state(sol: ContactSolution) -> np.ndarray:
    """The own ship's position and (mean) velocity at the contact's last grid time (4,)."""
    obs = sol.problem.observer
    return np.concatenate([obs.position[-1], obs.mean_velocity[-1]])


def advise_contacts(solutions: Sequence[ContactSolution], platform: Platform, *,
                    horizon: float = 1200.0, budget: int = 0) -> JointAdvice:
    """The one advice for several solved contacts (module doc).

    Parameters
    ----------
    solutions : sequence of ContactSolution
        At least one; their own-ship tracks are the recording's navigation.
    platform : Platform
    horizon : float
        [s], rounded to whole minutes.
    budget : int
        Pings shared by the contacts (0: none).

    Returns
    -------
    JointAdvice
    """
    sols = list(solutions)
    names = tuple(s.name for s in sols)
    base = max(sols, key=lambda s: float(s.problem.observer.times[-1]))
    now = float(base.problem.observer.times[-1])
    sigma = float(np.median(np.concatenate([
        np.atleast_1d([float(m.sigma) for m in s.problem.measurements]) for s in sols])))
    sc, h0, s0, p0 = planning_scenario(base.problem, platform, horizon, budget, sigma=sigma)
    views = tuple(dataclasses.replace(
        sc, name=s.name, description=f"advice for contact '{s.name}' among {len(sols)}",
        contacts=(Contact(name=DEFAULT_CONTACT, target=s.problem.scenario.target),))
        for s in sols)
    cs = ContactSet(views=views, names=names, required_accuracies=(ACCURACY,) * len(sols))
    own_now = _own_state(base)
    beliefs = ContactBeliefs(beliefs=tuple(
        belief_at(contact_belief(s, float(s.problem.observer.times[-1])), now, _own_state(s),
                  own_now) for s in sols), names=names)
    planner = ContactsPlanner(cs, objective=JOINT_OBJECTIVE,
                              turn_rate_max=platform.turn_rate_max,
                              keep_out_range=platform.keep_out_range)
    j = planner.joint
    K = j.K
    hold = turn_rate_track(p0, h0, s0, np.zeros(K), PLAN_STEP, now)
    score = ObjectiveEvaluator(views[0], contacts_objective(
        JOINT_OBJECTIVE, q=[v.target.q for v in views], accuracies=cs.required_accuracies,
        turn_weight=0.0), n_steps=K, belief=beliefs,  # type: ignore[arg-type]
        turn_rate_max=platform.turn_rate_max)
    each = [ObjectiveEvaluator(v, expected_time_to_accuracy(ACCURACY, turn_weight=0.0),
                               n_steps=K, belief=b, turn_rate_max=platform.turn_rate_max)
            for v, b in zip(views, beliefs.beliefs, strict=True)]
    t_hold = float(score(hold)[0])
    hold_each = [ev(hold) for ev in each]
    solver: dict[str, Any] = {"status": "not run", "success": False, "seconds": 0.0,
                              "start": None}
    t_plan, plan, alone = np.nan, None, {}
    try:
        cp = planner.solve(beliefs, heading0=h0, position0=p0, speed0=s0,
                           raise_on_failure=False)
        plan, alone = cp.plan, cp.alone_times
        solver = {"status": plan.status, "success": bool(plan.success),
                  "seconds": float(cp.seconds), "start": cp.start}
        if plan.success:
            t_plan = float(score(plan.observer)[0])
    except TmaplanError as exc:  # infeasible (keep-out), solver errors: hold course, told
        solver["status"] = f"failed: {exc}"
    if plan is not None and plan.success and t_plan <= t_hold:
        rec, track, t_rec = "plan", plan.observer, t_plan
        note = (f"turn as planned: expected time until every "
                f"contact is within {ACCURACY:.0%} range accuracy {t_plan / 60:.1f} min "
                f"against {t_hold / 60:.1f} min holding course")
        legs = legs_from_track(plan.times - now, plan.heading, turn_rates=plan.turn_rate)
    else:
        rec, track, t_rec = "hold course", hold, t_hold
        why = (f"the joint plan is no better ({t_plan / 60:.1f} min against "
               f"{t_hold / 60:.1f} min until every contact is localised)"
               if np.isfinite(t_plan) else
               f"the joint planner did not give a plan ({solver['status']})")
        note = f"hold course: {why}"
        legs = legs_from_track(hold.times - now, hold.heading)
    rec_each = hold_each if track is hold else [ev(track) for ev in each]
    per = {n: {"expected_time_to_accuracy": float(r[0]),
               "hold_course_time_to_accuracy": float(h[0]),
               "alone_expected_time_to_accuracy": float(alone.get(n, np.nan))}
           for n, r, h in zip(names, rec_each, hold_each, strict=True)}
    pings = None
    if budget > 0:
        pings = schedule_contact_pings(cs, budget=budget, method="relaxed", observer=track,
                                       beliefs=beliefs)
    return JointAdvice(
        names=names, objective=JOINT_OBJECTIVE, recommendation=rec, note=note, legs=legs,
        track=track, hold_track=hold, expected_time_to_accuracy=float(t_rec),
        hold_course_time_to_accuracy=t_hold, plan_time_to_accuracy=float(t_plan),
        contacts=per,
        range_bounds={n: np.asarray(r[1]) for n, r in zip(names, rec_each, strict=True)},
        hold_range_bounds={n: np.asarray(h[1]) for n, h in zip(names, hold_each,
                                                                strict=True)},
        pings=pings, solver=solver)
