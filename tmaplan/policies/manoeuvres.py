"""Manoeuvre policies: straight, single turn, zig-zag, offline plan, receding horizon."""

from __future__ import annotations

import dataclasses
import math
import time
from concurrent.futures import BrokenExecutor, CancelledError, Executor, Future
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.errors import (
    ArgumentError,
    PlanningError,
    ScenarioError,
    as_real,
    finite_real,
    is_integer,
    is_whole_count,
)
from tmaplan.policies._base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    _CourseKeeper,
    _initial_course,
    _turn_limits,
    log,
)

if TYPE_CHECKING:
    from tmaplan.models.observer import ObserverTrack
    from tmaplan.scenario import Scenario

__all__ = ["Planned", "Receding", "SingleTurn", "Straight", "Zigzag", "offline_plan",
           "prefetch_receding_model"]


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
        from tmaplan.planning.baselines import straight_track

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
        u_max, dt = _turn_limits(scenario)
        c0 = _initial_course(scenario)
        return _CourseSchedule([(scenario.time.t0, c0), (t, c0 + angle)], u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown (used to schedule pings offline)."""
        from tmaplan.planning.baselines import single_turn_track

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
        u_max, dt = _turn_limits(scenario)
        c0 = _initial_course(scenario)
        end = scenario.time.t0 + scenario.time.horizon
        sched = [(scenario.time.t0, c0)]
        sign = 1.0
        while t < end:
            sched.append((t, c0 + sign * float(self.angle)))
            t += float(self.leg_duration)
            sign = -sign
        return _CourseSchedule(sched, u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown (used to schedule pings offline)."""
        from tmaplan.planning.baselines import zigzag_track

        if self._check(scenario) != scenario.time.t0:
            raise PlanningError("zigzag.nominal_track: only zig-zags starting at t0")
        return zigzag_track(scenario, float(self.leg_duration), 2.0 * float(self.angle))


class _CourseSchedule(_CourseKeeper):
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
        return _TurnRatePlayback(plan, scenario)

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
        from tmaplan.policies.plan_starts import plan_from_prior

        _PLAN_CACHE[key] = plan_from_prior(scenario, objective, workers=workers, pool=pool)
    return _PLAN_CACHE[key]


class _TurnRatePlayback:
    def __init__(self, plan: Any, scenario: Scenario) -> None:
        self.times = np.asarray(plan.times, float)
        self.rates = np.asarray(plan.turn_rate, float)
        u_max, _ = _turn_limits(scenario)
        self.u_max = u_max

    def rate_at(self, t: float) -> float:
        i = int(np.searchsorted(self.times, t + 1e-9, side="right") - 1)
        if i < 0 or i >= len(self.rates):
            return 0.0
        return float(np.clip(self.rates[i], -self.u_max, self.u_max))

    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=self.rate_at(t))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Receding:
    """Receding-horizon re-planning on the particle filter's posterior.

    Every ``replan_interval`` [s] the heading OCP is re-solved from the current own-ship state
    over ``horizon`` [s] with the filter's particles as the belief, warm-started from the last
    plan; its first segment is flown until the next re-plan. If a re-plan fails, the previous
    plan is kept (and the failure logged in the controller's ``log``).

    Attributes
    ----------
    replan_interval : float, optional
        [s], a whole number (>= 1) of steps of dt; default (None):
        ``scenario.planning.replan_interval``.
    horizon : float, optional
        Look-ahead [s], finite and > 0; default: the planner's.
    objective : str
        Planning objective (default :data:`CLOSED_LOOP_OBJECTIVE`).
    max_particles : int
        Particles passed to the planner as belief samples (>= 5): a systematic subsample
        when the filter has more, else all of them with their weights
        (:meth:`tmaplan.planning.Belief.from_particles`).
    real_time : bool
        Re-plan by one warm-started SQP step (:class:`tmaplan.planning.rti.RealTimeIteration`,
        milliseconds) from the previous plan, the first one from the offline plan from the
        prior, with a full IPOPT solve as the fallback; False: a full IPOPT solve at every
        re-plan (the first one cold, from the filter's belief).
    qpsol : str
        QP solver of the real-time iteration (:data:`tmaplan.planning.rti.QP_SOLVERS`).
    rti_steps : int
        SQP steps per re-plan of the real-time iteration, >= 1.
    full_solves : tuple of int
        With ``real_time``: re-plans (0 = the first) always solved by a full IPOPT solve
        warm-started from the previous plan (default none).
    full_above : float
        With ``real_time``: when a real-time iteration step lowers the objective by more than
        this fraction of its value at the shifted previous plan, the optimum has moved far and
        a full IPOPT solve warm-started from the previous plan replaces the step; ``inf``:
        never (``receding-rti``). On ``default`` (tuning seeds 1000, 28 re-plans of 3 runs,
        ``benchmarks/closed_loop.py --gaps``) the start was 100–320 objective units (10–30 %)
        from the IPOPT optimum at 5 re-plans, where the step lowered the objective by
        1.2–15 %, and at most 10 units at the others, where it lowered it by at most 0.4 %:
        the default 1 % separates them.
    full_tol : float, optional
        With ``real_time``: IPOPT's tolerance for those full solves (``tol`` of
        :meth:`tmaplan.planning.HeadingPlanner.solve`; None: the planner's 1e-7). Default
        1e-4: on ``default`` (runs 0–23 of seed 0, the two settings interleaved in one
        process) a full solve took 1.00 s instead of 1.24 s, and over 100 paired runs the
        closed loop did not change (time to accuracy +1.4 s [−64.3, +67.0], final range error
        +5.6 m [−38.6, +49.8] against 1e-7; docs/findings.md).
    until_end : bool
        Count only the plan steps up to the scenario's end (``HeadingPlanner(until_end=True)``):
        a re-plan at time t optimises the time the mission has left instead of a full
        horizon that runs past the end, where the metrics stop counting. Off by default: on
        ``bow-closing`` (30 min, 400 paired runs, seed 6) it changed the mean time to
        accuracy by +0.6 s [−13.2, +14.4] against the default (README).
    multi_start : tuple of int
        With ``real_time``: re-plans (0 = the first) solved by IPOPT from the shifted previous
        plan *and* from its mirror image, straight and the planner's turn-early guesses,
        keeping the best (the log's ``start`` names it): a warm-started solve
        stays on the side the previous plan turned to, while the posterior may favour the
        other. Default none: with ``(1, 2, 3)`` a start other than the warm one won 232 of
        the 300 multi-start re-plans on ``bow-closing`` (100 runs, development seed 3000),
        yet the time to accuracy changed by −0.08 [−0.96, +0.79] min against the default
        there and by −0.65 [−1.86, +0.56] min on ``default``, at 6–10 times the planning
        time (README).
    rti : RTIModel, optional
        The offline plan and the Hessian model of the real-time iteration
        (:func:`tmaplan.planning.rti.reference_model`); computed once per scenario if not given
        (:meth:`resolve` computes it once per campaign, so that workers receive it).
    replan_on_alarm : bool
        Re-plan at once from the (recovered) posterior when the consistency monitor raised an
        alarm since the last step (:attr:`BeliefView.alarms`), not only every
        ``replan_interval``; a run without alarms is unchanged.
    """

    replan_interval: float | None = None
    horizon: float | None = None
    objective: str | None = CLOSED_LOOP_OBJECTIVE
    max_particles: int = 2000
    real_time: bool = True
    qpsol: str = "daqp"
    rti_steps: int = 1
    full_solves: tuple[int, ...] = ()
    full_above: float = 0.01
    full_tol: float | None = 1e-4
    until_end: bool = False
    multi_start: tuple[int, ...] = ()
    rti: Any = dataclasses.field(default=None, compare=False, repr=False)
    replan_on_alarm: bool = True
    name: str = "receding"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller owning a planner built once for the whole run."""
        return _RecedingController(self, scenario)

    def resolve(self, scenario: Scenario) -> Receding:
        """The same policy with the real-time iteration's model computed (once per campaign)."""
        _check_receding(self, scenario)
        if not self.real_time or self.rti is not None:
            return self
        return dataclasses.replace(self, rti=_rti_model(scenario, self.objective, self.horizon,
                                                        self.until_end))

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The offline plan from the prior: the receding controller's first plan."""
        return offline_plan(scenario, self.objective).observer


#: Heading planners (casadi problems built once) by (scenario, objective, horizon, until_end),
#: the 16 most recently used.
_PLANNER_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool], Any] = LRUCache(16)


def _planner(scenario: Scenario, objective: str | None, horizon: float | None,
             until_end: bool = False) -> Any:
    key = (scenario, objective, horizon, until_end)
    if key not in _PLANNER_CACHE:
        from tmaplan.planning import HeadingPlanner

        kw: dict[str, Any] = {"until_end": until_end}
        if objective is not None:
            kw["objective"] = objective
        if horizon is not None:
            kw["horizon"] = horizon
        _PLANNER_CACHE[key] = HeadingPlanner(scenario, **kw)
    return _PLANNER_CACHE[key]


#: Real-time-iteration models (or their pending futures), keyed as the planners.
_RTI_MODEL_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool], Any] = LRUCache(16)
#: Real-time iterations (each holds its planner and QP), the 16 most recently used.
_RTI_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool, str, int], Any] = (
    LRUCache(16))


def _rti_model(scenario: Scenario, objective: str | None, horizon: float | None,
               until_end: bool = False) -> Any:
    """The real-time iteration's model at the offline plan from the prior (cached)."""
    key = (scenario, objective, horizon, until_end)
    if key not in _RTI_MODEL_CACHE:
        from tmaplan.planning import Belief
        from tmaplan.planning.rti import reference_model

        planner = _planner(scenario, objective, horizon, until_end)
        prior = Belief.from_prior(scenario)
        plan = offline_plan(scenario, objective) if horizon is None else planner.solve(prior)
        _RTI_MODEL_CACHE[key] = reference_model(planner, plan, prior)
    model = _RTI_MODEL_CACHE[key]
    if isinstance(model, Future):  # computed on a worker (prefetch_receding_model)
        try:
            model = model.result()
        except (CancelledError, BrokenExecutor):  # the pool went away first: compute here
            del _RTI_MODEL_CACHE[key]
            return _rti_model(scenario, objective, horizon, until_end)
        except BaseException:
            del _RTI_MODEL_CACHE[key]  # reported, and not kept: a later call tries again
            raise
        _RTI_MODEL_CACHE[key] = model
    return model


def prefetch_receding_model(scenario: Scenario, objective: str | None, pool: Executor) -> None:
    """Start computing the real-time iteration's model of ``Receding(objective=objective)``
    (the Hessian at the offline plan, about 5 s on ``default``) on a worker of ``pool``, so
    that the main process can meanwhile do other work (``tmaplan demo``: the ping schedule);
    :meth:`Receding.resolve` then waits for it. The same model, bit for bit, as computed in
    this process. Needs the offline plan (:func:`offline_plan`), which the worker receives."""
    key = (scenario, objective, None, False)
    if key not in _RTI_MODEL_CACHE:
        _RTI_MODEL_CACHE[key] = pool.submit(_rti_model_on_worker, scenario, objective,
                                            offline_plan(scenario, objective))


def _rti_model_on_worker(scenario: Scenario, objective: str | None, plan: Any) -> Any:
    _PLAN_CACHE[(scenario, objective)] = plan
    return _rti_model(scenario, objective, None)


def _rti(policy: Receding, scenario: Scenario) -> Any:
    """The policy's real-time iteration (casadi functions built once per process)."""
    from tmaplan.planning.rti import RealTimeIteration

    model = policy.rti if policy.rti is not None else _rti_model(
        scenario, policy.objective, policy.horizon, policy.until_end)
    key = (scenario, policy.objective, policy.horizon, policy.until_end, policy.qpsol,
           policy.rti_steps)
    if key not in _RTI_CACHE:
        planner = _planner(scenario, policy.objective, policy.horizon, policy.until_end)
        _RTI_CACHE[key] = RealTimeIteration(planner, model, qpsol=policy.qpsol,
                                            steps=policy.rti_steps)
    return _RTI_CACHE[key].with_model(model)


def _check_receding(policy: Receding, scenario: Scenario) -> None:
    """ArgumentError naming the first invalid time or step count of ``policy``."""
    for field in ("replan_interval", "horizon"):
        v = getattr(policy, field)
        if v is not None:
            finite_real(f"receding.{field}", v, "> 0 s", lower=0.0, strict=True)
    v, dt = policy.replan_interval, scenario.time.dt
    if v is not None and not is_whole_count(float(v) / dt):
        # the controller acts on the grid: another interval would silently be rounded up
        raise ArgumentError("receding.replan_interval", f"a whole number of steps of dt = "
                            f"{dt:g} s", v)
    n = policy.rti_steps
    if not is_integer(n, 1):
        raise ArgumentError("receding.rti_steps", "an integer >= 1", n)


class _RecedingController:
    def __init__(self, policy: Receding, scenario: Scenario) -> None:
        _check_receding(policy, scenario)
        pl = scenario.planning
        interval = policy.replan_interval if policy.replan_interval is not None else (
            pl.replan_interval if pl else None)
        if interval is None:
            raise ScenarioError("planning.replan_interval", "a re-planning interval for the "
                                "receding policy", None, source=scenario.name)
        self.interval = float(interval)
        for field in ("full_solves", "multi_start"):
            idx = getattr(policy, field)
            if not all(is_integer(i, 0) for i in idx):
                raise ArgumentError(f"receding.{field}", "re-plan indices >= 0", idx)
        mp = policy.max_particles
        if not is_integer(mp, 5):
            raise ArgumentError("receding.max_particles", "an integer >= 5", mp)
        if not as_real(policy.full_above) > 0:  # (NaN, a bool or a string fail)
            raise ArgumentError("receding.full_above", "> 0 (inf: never)", policy.full_above)
        from tmaplan.planning import HeadingPlanner

        HeadingPlanner.check_tolerance(policy.full_tol, "receding.full_tol")
        self.policy = policy
        self.scenario = scenario
        self.planner = _planner(scenario, policy.objective, policy.horizon, policy.until_end)
        self.rti = _rti(policy, scenario) if policy.real_time else None
        self.u_max, self.dt = _turn_limits(scenario)
        self.plan: Any = None
        self.playback: _TurnRatePlayback | None = None
        self.next_replan = scenario.time.t0
        self.log: list[dict[str, Any]] = []
        self.alarms = 0

    def act(self, belief: BeliefView, t: float) -> Action:
        alarmed = self.policy.replan_on_alarm and belief.alarms > self.alarms
        self.alarms = belief.alarms
        if alarmed or t + 1e-9 >= self.next_replan:
            self._replan(belief, t)
            self.next_replan = t + self.interval
        rate = self.playback.rate_at(t) if self.playback is not None else 0.0
        return Action(turn_rate=rate)

    def _replan(self, belief: BeliefView, t: float) -> None:
        from tmaplan.planning import Belief

        t0 = time.perf_counter()
        # the filter's posterior at step k has assimilated the measurements at k (it predicts
        # and updates to k before the controller acts at k; at step 0 it has updated with the
        # measurements of step 0, if any): the plan counts the sensors from the next step
        b = Belief.from_particles(belief.particles, belief.weights, t=t,
                                  max_samples=self.policy.max_particles, assimilated=True)
        entry: dict[str, Any] = {"t": t}
        try:
            if self.rti is not None and len(self.log) in self.policy.multi_start:
                plan = self.multi_start(b, heading0=belief.heading,
                                        position0=belief.position)
                entry["start"] = plan.message
            elif self.rti is not None and len(self.log) in self.policy.full_solves:
                plan = self.planner.solve(b, heading0=belief.heading, position0=belief.position,
                                          warm_start=self.plan or self.rti.model.plan,
                                          tol=self.policy.full_tol)
            elif self.rti is not None:
                plan = self.rti.solve(b, previous=self.plan, heading0=belief.heading,
                                      position0=belief.position)
                start = (plan.warm or {}).get("start_objective")
                if start is not None and (start - plan.objective > self.policy.full_above
                                          * abs(start)):
                    plan = self.planner.solve(b, heading0=belief.heading,
                                              position0=belief.position,
                                              warm_start=self.plan or self.rti.model.plan,
                                              tol=self.policy.full_tol)
            else:
                plan = self.planner.solve(b, heading0=belief.heading,
                                          position0=belief.position, warm_start=self.plan)
            entry.update(status=plan.status, success=True, solver=plan.solver)
            self.plan = plan
            self.playback = _TurnRatePlayback(plan, self.scenario)
        except PlanningError as exc:  # keep flying the previous plan
            entry.update(status=str(exc), success=False)
            log.info("re-plan at t=%.0f s failed (%s); keeping the previous plan", t, exc)
        entry["seconds"] = time.perf_counter() - t0
        self.log.append(entry)

    def multi_start(self, b: Any, *, heading0: float | None,
                    position0: np.ndarray | None) -> Any:
        """Full IPOPT re-plan from several starts, the best kept (its ``message`` names the
        start): the previous plan shifted to ``b.t`` (warm), its mirror image (the same
        manoeuvre to the other side), straight and the turn-early guesses to both sides.

        Parameters
        ----------
        b : Belief
            The belief to plan against, at ``b.t`` [s].
        heading0 : float, optional
            Own-ship heading [rad] (None: the scenario's initial course).
        position0 : ndarray, shape (2,), optional
            Own-ship position [m].

        Returns
        -------
        HeadingPlan
            The best of the converged solves.

        Raises
        ------
        PlanningError
            If no start converged.
        """
        prev = self.plan
        if prev is None:
            if self.rti is None:
                raise PlanningError("multi-start re-plan: no previous plan to start from")
            prev = self.rti.model.plan
        pl = self.planner
        kw = {"heading0": heading0, "position0": position0,
              "tol": self.policy.full_tol, "raise_on_failure": False}
        k = max(round((b.t - float(prev.times[0])) / pl.Tc), 0)
        u = np.clip(prev.turn_rate / max(pl.u_max, 1e-12), -1.0, 1.0)
        u = np.concatenate([u[k:], np.full(min(k, pl.n), u[-1] if u.size else 0.0)])
        u = np.resize(u, pl.n) if u.size != pl.n else u
        j = np.arange(pl.n)
        starts = {"mirrored": -u, "straight": np.zeros(pl.n),
                  "early-port": np.where(j < pl.n / 4, -1.0, 0.0),
                  "early-starboard": np.where(j < pl.n / 4, 1.0, 0.0)}
        plans = {"warm": pl.solve(b, warm_start=prev, **kw)}
        for name, s in starts.items():
            plans[name] = pl.solve(b, starts=[s], **kw)
        ok = {n: p for n, p in plans.items() if p.success and np.isfinite(p.objective)}
        if not ok:
            raise PlanningError(f"multi-start re-plan at t={b.t:.0f} s: no start converged")
        name = min(ok, key=lambda n: ok[n].objective)
        return dataclasses.replace(ok[name], message=f"multi-start: {name}")
