"""The advice for one contact: the own ship's recommended manoeuvre over the next horizon
and the recommended ping times.

**Manoeuvre.** The heading planner (:class:`tmaplan.planning.HeadingPlanner`, objective
``expected-time-to-accuracy``) starts from the contact's current posterior (the particle
filter's particles, :meth:`tmaplan.planning.Belief.from_particles`; the batch estimate's
moments when the filter failed) and from the own ship's current position, course and speed
(the navigation's), with the platform's turn-rate limit and keep-out range, at constant speed.
Its plan and *holding course* are both scored by the expected time to 10 % range accuracy
without the turn penalty (:func:`tmaplan.planning.objectives.expected_time_to_accuracy`,
``turn_weight=0``; [s] from now, the horizon plus one step when never reached): the
recommendation is the plan only when it is no worse than holding course (a failed or worse
plan: "hold course", and the advice says why).

**Pings** (``--budget K``): at most K active pings along the recommended track
(:func:`tmaplan.planning.pings.schedule_pings`, ``relaxed`` with its convex-relaxation
certificate: the lower bound and the gap).

**Grid**: steps of :data:`PLAN_STEP` (15 s), turn rate constant over a minute
(:data:`CONTROL_INTERVAL`), the horizon rounded to whole minutes.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tmaplan.advice.problem import ContactProblem, Platform
from tmaplan.advice.solution import ContactSolution
from tmaplan.display import short_repr
from tmaplan.errors import TmaplanError
from tmaplan.geometry import course_speed
from tmaplan.io.plans import Leg, legs_from_track
from tmaplan.models.observer import ObserverTrack, turn_rate_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.objectives import ObjectiveEvaluator, expected_time_to_accuracy
from tmaplan.planning.pings import PingSchedule, schedule_pings
from tmaplan.scenario import (
    BearingSensor,
    Contact,
    Observer,
    Planning,
    RangeSensor,
    Scenario,
    TimeGrid,
)
from tmaplan.scenario.names import DEFAULT_CONTACT

__all__ = ["ACCURACY", "CONTROL_INTERVAL", "PLAN_STEP", "Advice", "advise_contact",
           "contact_belief", "planning_scenario"]

#: Step of the planning grid [s].
PLAN_STEP = 15.0
#: Turn rate held constant over this [s].
CONTROL_INTERVAL = 60.0
#: Relative range accuracy of the time to accuracy.
ACCURACY = 0.1


@dataclasses.dataclass(frozen=True, kw_only=True)
class Advice:
    """The advice for one contact (module doc).

    Attributes
    ----------
    name : str
        The contact.
    recommendation : str
        "plan" or "hold course".
    note : str
        Why (one line).
    legs : tuple of Leg
        Of the recommended track (starts relative to now).
    track : ObserverTrack
        The recommended track [s since the recording's origin, m].
    hold_track : ObserverTrack
        Holding course and speed.
    expected_time_to_accuracy, hold_course_time_to_accuracy : float
        [s] from now (module doc).
    plan_time_to_accuracy : float
        The planner's plan's [s] (NaN when it failed).
    range_bound, hold_range_bound : ndarray, shape (K + 1,)
        Closed-form PCRB range bound [m] along the recommended track and holding course.
    pings : PingSchedule or None
        With a budget.
    solver : dict
        The planner's ``status``, ``success`` and ``seconds``.
    """

    __repr__ = short_repr

    name: str
    recommendation: str
    note: str
    legs: tuple[Leg, ...]
    track: ObserverTrack
    hold_track: ObserverTrack
    expected_time_to_accuracy: float
    hold_course_time_to_accuracy: float
    plan_time_to_accuracy: float
    range_bound: np.ndarray
    hold_range_bound: np.ndarray
    pings: PingSchedule | None
    solver: dict[str, Any]


def planning_scenario(problem: ContactProblem, platform: Platform, horizon: float,
                      budget: int, *, sigma: float | None = None
                      ) -> tuple[Scenario, float, float, np.ndarray]:
    """The scenario the planner sees from now: the own ship's current state and limits, the
    contact's bearing noise (``sigma`` [rad] when given, else the median of its bearings'), a
    ping sensor, ``horizon`` rounded to whole control intervals.

    Returns
    -------
    scenario : Scenario
    heading0, speed0 : float
        The own ship's current course [rad] and speed [m/s].
    position0 : ndarray, shape (2,)
    """
    obs = problem.observer
    now = float(obs.times[-1])
    H = CONTROL_INTERVAL * max(1, round(horizon / CONTROL_INTERVAL))
    course, speed = course_speed(obs.mean_velocity[-1])
    heading0, speed0 = float(course), float(speed)
    p0 = obs.position[-1]
    if sigma is None:
        sigma = float(np.median([float(m.sigma) for m in problem.measurements]))
    est = problem.scenario.target
    sc = Scenario(
        name=problem.name, description=f"advice for contact '{problem.name}'",
        time=TimeGrid(dt=PLAN_STEP, horizon=H, t0=now),
        contacts=(Contact(name=DEFAULT_CONTACT, target=est),),
        observer=Observer(position=(float(p0[0]), float(p0[1])), course=heading0,
                          speed=speed0, speed_min=speed0, speed_max=max(speed0, 1e-3),
                          turn_rate_max=platform.turn_rate_max),
        sensors=(BearingSensor(sigma=sigma), RangeSensor(sigma=platform.ping_sigma, steps=())),
        planning=Planning(horizon=H, objective="expected-time-to-accuracy",
                          keep_out_range=platform.keep_out_range,
                          control_interval=CONTROL_INTERVAL, ping_budget=budget,
                          ping_min_spacing=platform.ping_min_spacing))
    return sc, heading0, speed0, np.asarray(p0, float)


def contact_belief(sol: ContactSolution, now: float) -> Belief:
    """The contact's current posterior, relative to the own ship (module doc).

    Parameters
    ----------
    sol : ContactSolution
    now : float
        The time of its last grid step [s].

    Returns
    -------
    Belief
        Assimilated (it holds the bearings at ``now``).
    """
    st = getattr(sol.pf_track, "details", None)
    if st is not None and getattr(st, "particles", None) is not None:
        w = np.exp(np.asarray(st.log_weights, float))
        return Belief.from_particles(np.asarray(st.particles, float), w, t=now,
                                     assimilated=True)
    tr = sol.mle_track
    if tr is None:
        raise TmaplanError(f"contact '{sol.name}': no estimate to plan from")
    return Belief.from_moments(tr.estimates[-1], tr.covariances[-1], t=now, assimilated=True)


def advise_contact(sol: ContactSolution, platform: Platform, *, horizon: float = 1200.0,
                   budget: int = 0) -> Advice:
    """The advice for one solved contact (module doc).

    Parameters
    ----------
    sol : ContactSolution
    platform : Platform
    horizon : float
        [s], rounded to whole minutes.
    budget : int
        Pings (0: none).

    Returns
    -------
    Advice
    """

    problem = sol.problem
    now = float(problem.observer.times[-1])
    sc, h0, s0, p0 = planning_scenario(problem, platform, horizon, budget)
    belief = contact_belief(sol, now)
    planner = HeadingPlanner(sc, objective="expected-time-to-accuracy",
                             turn_rate_max=platform.turn_rate_max,
                             keep_out_range=platform.keep_out_range)
    K = planner.K
    hold = turn_rate_track(p0, h0, s0, np.zeros(K), PLAN_STEP, now)
    score = ObjectiveEvaluator(sc, expected_time_to_accuracy(ACCURACY, turn_weight=0.0),
                               n_steps=K, belief=belief, turn_rate_max=platform.turn_rate_max)
    t_hold, rb_hold = score(hold)
    solver: dict[str, Any] = {"status": "not run", "success": False, "seconds": 0.0}
    try:
        plan = planner.solve(belief, heading0=h0, position0=p0, speed0=s0,
                             raise_on_failure=False)
        solver = {"status": plan.status, "success": bool(plan.success),
                  "seconds": float(plan.seconds)}
        t_plan, rb_plan = score(plan.observer) if plan.success else (np.nan, rb_hold)
    except TmaplanError as exc:  # infeasible (keep-out), solver errors: hold course, told
        plan, t_plan, rb_plan = None, np.nan, rb_hold
        solver["status"] = f"failed: {exc}"
    if plan is not None and plan.success and t_plan <= t_hold:
        rec, track, t_rec, rb = "plan", plan.observer, t_plan, rb_plan
        note = (f"turn as planned: expected time to {ACCURACY:.0%} range accuracy "
                f"{t_plan / 60:.1f} min against {t_hold / 60:.1f} min holding course")
        legs = legs_from_track(plan.times - now, plan.heading, turn_rates=plan.turn_rate)
    else:
        rec, track, t_rec, rb = "hold course", hold, t_hold, rb_hold
        why = (f"the planner's plan is no better ({t_plan / 60:.1f} min against "
               f"{t_hold / 60:.1f} min)" if np.isfinite(t_plan) else
               f"the planner did not give a plan ({solver['status']})")
        note = f"hold course: {why}"
        legs = legs_from_track(hold.times - now, hold.heading)
    pings = None
    if budget > 0:
        pings = schedule_pings(sc, budget=budget, method="relaxed", observer=track,
                               belief=belief)
    return Advice(name=sol.name, recommendation=rec, note=note, legs=legs, track=track,
                  hold_track=hold, expected_time_to_accuracy=float(t_rec),
                  hold_course_time_to_accuracy=float(t_hold),
                  plan_time_to_accuracy=float(t_plan), range_bound=np.asarray(rb),
                  hold_range_bound=np.asarray(rb_hold), pings=pings, solver=solver)
