"""Manoeuvre policies: straight, single turn, zig-zag, offline plan (the receding horizon
is :mod:`tmaplan.policies.receding`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from concurrent.futures import Executor
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.errors import (
    ArgumentError,
    PlanningError,
    as_real,
    finite_real,
)
from tmaplan.models.observer import ObserverTrack
from tmaplan.planning.baselines import single_turn_track, straight_track, zigzag_track
from tmaplan.policies.base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    CourseKeeper,
    initial_course,
    turn_limits,
)
from tmaplan.policies.plan_starts import plan_from_prior

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["Planned", "SingleTurn", "Straight", "TurnRatePlayback", "Zigzag", "offline_plan",
           "remember_offline_plan"]


# --------------------------------------------------------------------------------------------
# manoeuvre policies
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class Straight:
    """Hold the initial course."""

    name: str = "straight"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller that never turns."""
        return _Const()

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown (used to schedule pings offline)."""
        return straight_track(scenario)


class _Const:
    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=0.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SingleTurn:
    """One course change of ``angle`` [rad] (positive = starboard) starting at ``time`` [s],
    at the maximum turn rate.

    Attributes
    ----------
    angle : float
        Course change [rad], in [−π, π]; the sign gives the side, also for ±π (a −180° turn
        goes to port, in closed loop as in the nominal track).
    time : float
        Start of the turn [s], in [t0, t0 + horizon).
    """

    angle: float
    time: float
    name: str = "single-turn"

    @classmethod
    def from_baseline(cls, params: Mapping[str, float], scenario: Scenario) -> SingleTurn:
        """The turn of a baseline grid's single turn (its ``params``: ``angle`` [rad],
        ``time`` [s] from the start; :func:`tmaplan.planning.baselines.evaluate_baselines`)."""
        return cls(angle=float(params["angle"]), time=scenario.time.t0 + float(params["time"]))

    def _checked(self, scenario: Scenario) -> tuple[float, float]:
        """(angle [rad], time [s]), or ArgumentError naming the field."""
        a, t = as_real(self.angle), as_real(self.time)
        if not (math.isfinite(a) and abs(a) <= math.pi):
            raise ArgumentError("single-turn.angle", "an angle in [−π, π] rad", self.angle)
        t0, end = scenario.time.t0, scenario.time.t0 + scenario.time.horizon
        if not (math.isfinite(t) and t0 <= t < end):
            raise ArgumentError("single-turn.time", f"a time in [t0, t0 + horizon) = "
                                f"[{t0:g}, {end:g}) s", self.time)
        return a, t

    def controller(self, scenario: Scenario) -> Controller:
        """A controller steering to the new course after ``time``."""
        angle, t = self._checked(scenario)
        u_max, dt = turn_limits(scenario)
        c0 = initial_course(scenario)
        return CourseSchedule([(scenario.time.t0, c0), (t, c0 + angle)], u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown (used to schedule pings offline)."""
        angle, t = self._checked(scenario)
        return single_turn_track(scenario, angle, t - scenario.time.t0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Zigzag:
    """Legs of ``leg_duration`` [s] alternately ``+angle`` and ``−angle`` [rad] about the
    initial course, turning at the maximum rate; the first leg starts at ``start`` [s] (at t0
    by default).

    Attributes
    ----------
    leg_duration : float
        [s], finite and at least one time step.
    angle : float
        Course of the first leg from the initial course [rad], in [−π, π] (negative: the
        first leg to port); each later turn is ``2·angle`` the other way.
    start : float, optional
        Start of the first leg [s] on the scenario clock (absolute, like ``t0``), in
        [t0, t0 + horizon); None (default): t0, whatever t0 is. :meth:`nominal_track` needs
        the start at t0.
    """

    leg_duration: float
    angle: float
    start: float | None = None
    name: str = "zigzag"

    @classmethod
    def from_baseline(cls, params: Mapping[str, float], scenario: Scenario) -> Zigzag:
        """The zig-zag of a baseline grid's (its ``params``: ``leg_duration`` [s] and
        ``angle`` [rad], the *whole* swing between the legs' courses, so the first leg flies
        half of it; :func:`tmaplan.planning.baselines.evaluate_baselines`), from t0."""
        return cls(leg_duration=float(params["leg_duration"]),
                   angle=0.5 * float(params["angle"]), start=scenario.time.t0)

    def _check(self, scenario: Scenario) -> float:
        """The start [s] of the first leg, or ArgumentError naming the first invalid field."""
        dt = scenario.time.dt  # a shorter leg cannot be flown (1e-9 s hung building legs)
        finite_real("zigzag.leg_duration", self.leg_duration, f">= one step (dt = {dt:g} s)",
                    lower=dt)
        if not (math.isfinite(a := as_real(self.angle)) and abs(a) <= math.pi):
            raise ArgumentError("zigzag.angle", "an angle in [−π, π] rad", self.angle)
        t0, end = scenario.time.t0, scenario.time.t0 + scenario.time.horizon
        if self.start is None:
            return float(t0)
        if not (math.isfinite(t := as_real(self.start)) and t0 <= t < end):
            raise ArgumentError("zigzag.start", f"a time in [t0, t0 + horizon) = "
                                f"[{t0:g}, {end:g}) s (None: t0)", self.start)
        return t

    def controller(self, scenario: Scenario) -> Controller:
        """A controller following the zig-zag course schedule."""
        t = self._check(scenario)
        u_max, dt = turn_limits(scenario)
        c0 = initial_course(scenario)
        end = scenario.time.t0 + scenario.time.horizon
        sched = [(scenario.time.t0, c0)]
        sign = 1.0
        while t < end:
            sched.append((t, c0 + sign * float(self.angle)))
            t += float(self.leg_duration)
            sign = -sign
        return CourseSchedule(sched, u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown (used to schedule pings offline)."""
        if self._check(scenario) != scenario.time.t0:
            raise PlanningError("zigzag.nominal_track: only zig-zags starting at t0")
        return zigzag_track(scenario, float(self.leg_duration), 2.0 * float(self.angle))


class CourseSchedule(CourseKeeper):
    """Course ``c`` [rad, unwrapped, the first one the initial course] from time ``t`` [s],
    for the ``(t, c)`` of ``schedule``."""

    def __init__(self, schedule: list[tuple[float, float]], u_max: float, dt: float) -> None:
        super().__init__(schedule[0][1], u_max, dt)
        self.times = np.array([s[0] for s in schedule])
        self.courses = np.array([s[1] for s in schedule])

    def act(self, belief: BeliefView, t: float) -> Action:
        i = int(np.searchsorted(self.times, t + 1e-9, side="right") - 1)
        return Action(turn_rate=self.steer(belief, float(self.courses[max(i, 0)])))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Planned:
    """Fly the offline heading plan computed from the prior (``tmaplan.planning``).

    Attributes
    ----------
    objective : str
        Planning objective (default :data:`CLOSED_LOOP_OBJECTIVE`).
    plan : object, optional
        A precomputed ``HeadingPlan``; computed once per scenario otherwise (and cached).
    """

    objective: str | None = CLOSED_LOOP_OBJECTIVE
    plan: Any = None
    name: str = "planned"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller replaying the plan's turn rates."""
        plan = self.plan if self.plan is not None else offline_plan(scenario, self.objective)
        return TurnRatePlayback(plan, scenario)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The planned own-ship track (used to schedule pings offline)."""
        plan = self.plan if self.plan is not None else offline_plan(scenario, self.objective)
        return plan.observer


#: Offline plans by (scenario, objective), the 32 most recently used (:mod:`tmaplan.caching`).
_PLAN_CACHE: LRUCache[tuple[Scenario, str | None], Any] = LRUCache(32)


def offline_plan(scenario: Scenario, objective: str | None, *, workers: int = 1,
                 pool: Executor | None = None) -> Any:
    """The heading plan from the prior, multi-started from straight, the tactics and the best
    single turns (:func:`tmaplan.policies.plan_starts.plan_from_prior`, its starts solved on
    ``workers`` processes or on ``pool``), cached per scenario and objective."""
    key = (scenario, objective)
    if key not in _PLAN_CACHE:
        _PLAN_CACHE[key] = plan_from_prior(scenario, objective, workers=workers, pool=pool)
    return _PLAN_CACHE[key]


def remember_offline_plan(scenario: Scenario, objective: str | None, plan: Any) -> None:
    """Keep ``plan`` as this process's :func:`offline_plan` of ``(scenario, objective)`` (a
    worker given the plan its parent computed, so that it is not solved again)."""
    _PLAN_CACHE[(scenario, objective)] = plan


class TurnRatePlayback:
    """The controller that flies a heading plan's turn rates (``planned``, and the receding
    policy between re-plans).

    Parameters
    ----------
    plan : HeadingPlan
        Its ``times`` (control nodes [s]) and ``turn_rate`` per interval [rad/s].
    scenario : Scenario
        Gives the turn-rate limit the rates are clipped to.
    """

    def __init__(self, plan: Any, scenario: Scenario) -> None:
        self.times = np.asarray(plan.times, float)
        self.rates = np.asarray(plan.turn_rate, float)
        u_max, _ = turn_limits(scenario)
        self.u_max = u_max

    def rate_at(self, t: float) -> float:
        """The plan's turn rate [rad/s] at time ``t`` [s] (0 outside the plan)."""
        i = int(np.searchsorted(self.times, t + 1e-9, side="right") - 1)
        if i < 0 or i >= len(self.rates):
            return 0.0
        return float(np.clip(self.rates[i], -self.u_max, self.u_max))

    def act(self, belief: BeliefView, t: float) -> Action:
        """Turn at :meth:`rate_at` ``t``."""
        return Action(turn_rate=self.rate_at(t))
