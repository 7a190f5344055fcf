"""Tactical policies behind one interface: ``act(belief, t) -> Action``.

A policy is a frozen dataclass (its parameters). For one closed-loop run it makes a
:class:`Controller` (``policy.controller(scenario)``), the only place where per-run state lives
(the current plan, pings used, the last re-plan time). Manoeuvre policies command a turn rate
over the next step; ping policies decide whether to ping at the next step; :class:`Combined`
joins one of each.

Manoeuvre policies: :class:`Straight`, :class:`SingleTurn`, :class:`Zigzag`, :class:`Planned`
(offline heading plan from the prior), :class:`Receding` (re-plans on the particle filter's
posterior every ``replan_interval``). Ping policies: :class:`NoPing`, :class:`UniformPings`,
:class:`ScheduledPings` (offline schedule), :class:`AdaptivePings` (ping when the filter's
relative range uncertainty calls for it).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from tmaplan.errors import PlanningError, ScenarioError
from tmaplan.geometry import wrap_angle

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "CLOSED_LOOP_OBJECTIVE",
    "Action",
    "AdaptivePings",
    "BeliefView",
    "Combined",
    "Controller",
    "NoPing",
    "Planned",
    "Receding",
    "ScheduledPings",
    "SingleTurn",
    "Straight",
    "UniformPings",
    "Zigzag",
    "best_single_turn",
    "best_zigzag",
    "parse_policy",
]

log = logging.getLogger(__name__)

#: Planning objective of the closed-loop policies (``planned``, ``receding``) and of the choice
#: of the best single turn / zig-zag. Scale-free and smooth in time, it tracks the time to a
#: *relative* range accuracy that the comparison measures; the absolute range bound of
#: DESIGN §4 (the scenario's default ``planning.objective``) rewards closing on the contact
#: for its own sake and localised more slowly in Monte Carlo trials (see the README).
CLOSED_LOOP_OBJECTIVE = "mean-relative-range-crlb"


@dataclasses.dataclass(frozen=True, kw_only=True)
class Action:
    """What a controller decides at step k.

    Attributes
    ----------
    turn_rate : float
        Turn rate over (t_k, t_{k+1}] [rad/s], positive = starboard (clockwise).
    ping : bool
        Emit an active range ping at step k + 1.
    """

    turn_rate: float = 0.0
    ping: bool = False


@dataclasses.dataclass(frozen=True, kw_only=True)
class BeliefView:
    """What a controller may look at (never the truth).

    Attributes
    ----------
    step : int
        Current grid step k.
    t : float
        Current time [s].
    heading : float
        Own-ship heading [rad].
    position : ndarray, shape (2,)
        Own-ship position [m].
    particles : ndarray, shape (N, 4)
        Particle filter's relative-state particles [m, m/s].
    weights : ndarray, shape (N,)
        Normalised weights.
    pings_used : int
        Pings emitted so far.
    """

    step: int
    t: float
    heading: float
    position: np.ndarray
    particles: np.ndarray
    weights: np.ndarray
    pings_used: int

    @property
    def mean(self) -> np.ndarray:
        """Posterior mean of the relative state, shape (4,)."""
        return self.weights @ self.particles

    @property
    def cov(self) -> np.ndarray:
        """Posterior covariance, shape (4, 4)."""
        d = self.particles - self.mean
        return (d * self.weights[:, None]).T @ d

    def range_stats(self) -> tuple[float, float]:
        """Posterior mean and std of the range [m]."""
        r = np.hypot(self.particles[:, 0], self.particles[:, 1])
        m = float(self.weights @ r)
        return m, float(np.sqrt(max(self.weights @ (r - m) ** 2, 0.0)))


class Controller(Protocol):
    """Per-run decision maker made by a policy."""

    def act(self, belief: BeliefView, t: float) -> Action:
        """Decide the action at time ``t`` [s] from the belief."""
        ...  # pragma: no cover


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def _turn_limits(scenario: Scenario) -> tuple[float, float]:
    o = scenario.observer
    if o.turn_rate_max is None:
        raise ScenarioError("observer.turn_rate_max", "a turn-rate limit for manoeuvre policies",
                            None, source=scenario.name)
    return float(o.turn_rate_max), float(scenario.time.dt)


def _steer(heading: float, course: float, u_max: float, dt: float) -> float:
    """Turn rate that reaches ``course`` as fast as the limit allows (shortest way)."""
    delta = float(wrap_angle(course - heading))
    return float(np.clip(delta / dt, -u_max, u_max))


def _initial_course(scenario: Scenario) -> float:
    from tmaplan.models.target import initial_velocity

    v = initial_velocity(scenario.observer)
    return float(np.arctan2(v[0], v[1]))


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

    def nominal_track(self, scenario: Scenario) -> Any:
        """The own-ship track flown (used to schedule pings offline)."""
        from tmaplan.planning.baselines import straight_track

        return straight_track(scenario)


class _Const:
    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=0.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class SingleTurn:
    """One course change of ``angle`` [rad] (positive = starboard) starting at ``time`` [s],
    at the maximum turn rate."""

    angle: float
    time: float
    name: str = "single-turn"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller steering to the new course after ``time``."""
        u_max, dt = _turn_limits(scenario)
        c0 = _initial_course(scenario)
        return _CourseSchedule([(scenario.time.t0, c0), (self.time, c0 + self.angle)], u_max, dt)

    def nominal_track(self, scenario: Scenario) -> Any:
        """The own-ship track flown (used to schedule pings offline)."""
        from tmaplan.planning.baselines import single_turn_track

        return single_turn_track(scenario, self.angle, self.time - scenario.time.t0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Zigzag:
    """Legs of ``leg_duration`` [s] alternately ``+angle`` and ``−angle`` [rad] about the
    initial course, turning at the maximum rate; the first leg starts at ``start`` [s]."""

    leg_duration: float
    angle: float
    start: float = 0.0
    name: str = "zigzag"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller following the zig-zag course schedule."""
        if not self.leg_duration > 0:
            raise ScenarioError("zigzag.leg_duration", "> 0 s", self.leg_duration)
        u_max, dt = _turn_limits(scenario)
        c0 = _initial_course(scenario)
        end = scenario.time.t0 + scenario.time.horizon
        sched = [(scenario.time.t0, c0)]
        t, sign = self.start, 1.0
        while t < end:
            sched.append((t, c0 + sign * self.angle))
            t += self.leg_duration
            sign = -sign
        return _CourseSchedule(sched, u_max, dt)

    def nominal_track(self, scenario: Scenario) -> Any:
        """The own-ship track flown (used to schedule pings offline)."""
        from tmaplan.planning.baselines import zigzag_track

        if self.start != scenario.time.t0:
            raise PlanningError("zigzag.nominal_track: only zig-zags starting at t0")
        return zigzag_track(scenario, self.leg_duration, 2.0 * self.angle)


class _CourseSchedule:
    def __init__(self, schedule: list[tuple[float, float]], u_max: float, dt: float) -> None:
        self.times = np.array([s[0] for s in schedule])
        self.courses = np.array([s[1] for s in schedule])
        self.u_max, self.dt = u_max, dt

    def act(self, belief: BeliefView, t: float) -> Action:
        i = int(np.searchsorted(self.times, t + 1e-9, side="right") - 1)
        course = self.courses[max(i, 0)]
        return Action(turn_rate=_steer(belief.heading, course, self.u_max, self.dt))


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
        plan = self.plan if self.plan is not None else _offline_plan(scenario, self.objective)
        return _TurnRatePlayback(plan, scenario)

    def nominal_track(self, scenario: Scenario) -> Any:
        """The planned own-ship track (used to schedule pings offline)."""
        plan = self.plan if self.plan is not None else _offline_plan(scenario, self.objective)
        return plan.observer


_PLAN_CACHE: dict[tuple[str, str | None], Any] = {}


def _offline_plan(scenario: Scenario, objective: str | None) -> Any:
    from tmaplan.scenario import dump

    key = (dump(scenario), objective)
    if key not in _PLAN_CACHE:
        from tmaplan.planning import plan_heading

        kw = {} if objective is None else {"objective": objective}
        _PLAN_CACHE[key] = plan_heading(scenario, **kw)
    return _PLAN_CACHE[key]


class _TurnRatePlayback:
    def __init__(self, plan: Any, scenario: Scenario, t_start: float | None = None) -> None:
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
        [s]; default: ``scenario.planning.replan_interval``.
    horizon : float, optional
        Look-ahead [s]; default: the planner's.
    objective : str
        Planning objective (default :data:`CLOSED_LOOP_OBJECTIVE`).
    max_particles : int
        Particles passed to the planner as belief samples (a systematic subsample).
    """

    replan_interval: float | None = None
    horizon: float | None = None
    objective: str | None = CLOSED_LOOP_OBJECTIVE
    max_particles: int = 2000
    name: str = "receding"

    def controller(self, scenario: Scenario) -> Controller:
        """A controller owning a planner built once for the whole run."""
        return _RecedingController(self, scenario)

    def nominal_track(self, scenario: Scenario) -> Any:
        """The offline plan from the prior: the receding controller's first plan."""
        return _offline_plan(scenario, self.objective).observer


_PLANNER_CACHE: dict[tuple[str, str | None, float | None], Any] = {}


def _planner(scenario: Scenario, objective: str | None, horizon: float | None) -> Any:
    from tmaplan.scenario import dump

    key = (dump(scenario), objective, horizon)
    if key not in _PLANNER_CACHE:
        from tmaplan.planning import HeadingPlanner

        kw: dict[str, Any] = {}
        if objective is not None:
            kw["objective"] = objective
        if horizon is not None:
            kw["horizon"] = horizon
        _PLANNER_CACHE[key] = HeadingPlanner(scenario, **kw)
    return _PLANNER_CACHE[key]


class _RecedingController:
    def __init__(self, policy: Receding, scenario: Scenario) -> None:
        pl = scenario.planning
        interval = policy.replan_interval or (pl.replan_interval if pl else None)
        if interval is None:
            raise ScenarioError("planning.replan_interval", "a re-planning interval for the "
                                "receding policy", None, source=scenario.name)
        self.interval = float(interval)
        self.policy = policy
        self.scenario = scenario
        self.planner = _planner(scenario, policy.objective, policy.horizon)
        self.u_max, self.dt = _turn_limits(scenario)
        self.plan: Any = None
        self.playback: _TurnRatePlayback | None = None
        self.next_replan = scenario.time.t0
        self.log: list[dict[str, Any]] = []

    def act(self, belief: BeliefView, t: float) -> Action:
        if t + 1e-9 >= self.next_replan:
            self._replan(belief, t)
            self.next_replan = t + self.interval
        rate = self.playback.rate_at(t) if self.playback is not None else 0.0
        return Action(turn_rate=rate)

    def _replan(self, belief: BeliefView, t: float) -> None:
        from tmaplan.planning import Belief

        t0 = time.perf_counter()
        idx = _subsample(belief.weights, self.policy.max_particles)
        b = Belief.from_samples(belief.particles[idx], t=t)
        entry: dict[str, Any] = {"t": t}
        try:
            plan = self.planner.solve(b, heading0=belief.heading, position0=belief.position,
                                      warm_start=self.plan)
            entry.update(status=plan.status, success=True)
            self.plan = plan
            self.playback = _TurnRatePlayback(plan, self.scenario)
        except PlanningError as exc:  # keep flying the previous plan
            entry.update(status=str(exc), success=False)
            log.info("re-plan at t=%.0f s failed (%s); keeping the previous plan", t, exc)
        entry["seconds"] = time.perf_counter() - t0
        self.log.append(entry)


def _subsample(weights: np.ndarray, n: int) -> np.ndarray:
    """Systematic subsample of ``n`` indices (deterministic: fixed offset 0.5)."""
    if weights.size <= n:
        return np.arange(weights.size)
    c = np.cumsum(weights)
    c[-1] = 1.0
    u = (np.arange(n) + 0.5) / n
    return np.searchsorted(c, u)


# --------------------------------------------------------------------------------------------
# ping policies
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class NoPing:
    """Never ping."""

    name: str = "no-ping"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller that never pings."""
        return _StepPings(np.zeros(0, dtype=int))


@dataclasses.dataclass(frozen=True, kw_only=True)
class UniformPings:
    """``budget`` pings evenly spaced over the horizon: steps ``round((i + ½)·K/budget)``."""

    budget: int | None = None
    name: str = "uniform"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller pinging at evenly spaced steps."""
        b = _budget(scenario, self.budget)
        K = scenario.n_steps
        steps = np.unique(np.clip(np.round((np.arange(b) + 0.5) * K / max(b, 1)), 1, K))
        return _StepPings(steps.astype(int))


@dataclasses.dataclass(frozen=True, kw_only=True)
class ScheduledPings:
    """Ping at the steps of an offline schedule (``tmaplan.planning.schedule_pings``)."""

    budget: int | None = None
    method: str = "relaxed"
    objective: str = "mean-range-bound"
    steps: tuple[int, ...] | None = None
    name: str = "scheduled"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller replaying the schedule (computed along the scenario's own track if no
        steps are given; :class:`Combined` schedules along its manoeuvre's nominal track)."""
        if self.steps is not None:
            return _StepPings(np.asarray(self.steps, dtype=int))
        return _StepPings(_offline_schedule(scenario, _budget(scenario, self.budget),
                                            self.method, self.objective))


_SCHEDULE_CACHE: dict[tuple[Any, ...], np.ndarray] = {}


def _offline_schedule(scenario: Scenario, budget: int, method: str, objective: str,
                      track: Any = None) -> np.ndarray:
    """Offline ping schedule from the prior along ``track`` (default: the scripted track)."""
    from tmaplan.scenario import dump

    tkey = None if track is None else np.asarray(track.position).tobytes()
    key = (dump(scenario), budget, method, objective, tkey)
    if key not in _SCHEDULE_CACHE:
        from tmaplan.planning import schedule_pings

        sched = schedule_pings(scenario, budget=budget, method=method, objective=objective,
                               observer=track)
        _SCHEDULE_CACHE[key] = np.asarray(sched.steps, dtype=int)
    return _SCHEDULE_CACHE[key]


class _StepPings:
    def __init__(self, steps: np.ndarray) -> None:
        self.steps = set(int(s) for s in steps)

    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(ping=(belief.step + 1) in self.steps)


@dataclasses.dataclass(frozen=True, kw_only=True)
class AdaptivePings:
    """Ping when the filter's relative range std exceeds ``threshold`` (σ_r / r̂), within the
    budget and at least ``min_spacing`` [s] after the previous ping."""

    threshold: float = 0.1
    budget: int | None = None
    min_spacing: float | None = None
    name: str = "adaptive"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller with its own ping count and last ping time."""
        pl = scenario.planning
        spacing = self.min_spacing if self.min_spacing is not None else (
            pl.ping_min_spacing if pl else 0.0)
        return _Adaptive(self.threshold, _budget(scenario, self.budget), float(spacing),
                         scenario)


class _Adaptive:
    def __init__(self, threshold: float, budget: int, spacing: float, scenario: Scenario) -> None:
        self.threshold, self.budget, self.spacing = threshold, budget, spacing
        self.last = -np.inf
        self.forbidden = scenario.planning.ping_forbidden if scenario.planning else ()
        self.dt = scenario.time.dt

    def act(self, belief: BeliefView, t: float) -> Action:
        t_next = t + self.dt
        if belief.pings_used >= self.budget or t_next - self.last < self.spacing - 1e-9:
            return Action()
        if any(a <= t_next <= b for a, b in self.forbidden):
            return Action()
        m, s = belief.range_stats()
        if s / max(m, 1.0) > self.threshold:
            self.last = t_next
            return Action(ping=True)
        return Action()


def _budget(scenario: Scenario, budget: int | None) -> int:
    if budget is not None:
        return int(budget)
    pl = scenario.planning
    return int(pl.ping_budget) if pl is not None else 0


# --------------------------------------------------------------------------------------------
# combination and parsing
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class Combined:
    """A manoeuvre policy and a ping policy acting together."""

    manoeuvre: Any
    ping: Any = dataclasses.field(default_factory=NoPing)

    @property
    def name(self) -> str:
        """``manoeuvre`` or ``manoeuvre+ping``."""
        return self.manoeuvre.name if isinstance(self.ping, NoPing) else \
            f"{self.manoeuvre.name}+{self.ping.name}"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller taking the turn rate of one and the ping of the other."""
        return _Both(self.manoeuvre.controller(scenario), self.ping.controller(scenario))


class _Both:
    def __init__(self, m: Controller, p: Controller) -> None:
        self.m, self.p = m, p

    @property
    def log(self) -> list[dict[str, Any]]:
        return getattr(self.m, "log", [])

    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=self.m.act(belief, t).turn_rate, ping=self.p.act(belief, t).ping)


_BASELINE_CACHE: dict[str, dict[str, Any]] = {}


def _best_baselines(scenario: Scenario) -> dict[str, Any]:
    from tmaplan.scenario import dump

    key = dump(scenario)
    if key not in _BASELINE_CACHE:
        from tmaplan.planning.baselines import evaluate_baselines

        res = evaluate_baselines(scenario, CLOSED_LOOP_OBJECTIVE)
        _BASELINE_CACHE[key] = {k: v[0].params for k, v in res.items()}
    return _BASELINE_CACHE[key]


def best_single_turn(scenario: Scenario) -> SingleTurn:
    """The single course change with the best :data:`CLOSED_LOOP_OBJECTIVE` from the prior,
    over the grid of :func:`tmaplan.planning.baselines.evaluate_baselines` (angles 30°…180°
    both ways, start times ¼…¾ of the horizon)."""
    p = _best_baselines(scenario)["single-turn"]
    return SingleTurn(angle=float(p["angle"]), time=scenario.time.t0 + float(p["time"]))


def best_zigzag(scenario: Scenario) -> Zigzag:
    """The best zig-zag of the baseline grid (legs ⅛…⅓ of the horizon, 60°…120° total)."""
    p = _best_baselines(scenario)["zigzag"]
    return Zigzag(leg_duration=float(p["leg_duration"]), angle=0.5 * float(p["angle"]),
                  start=scenario.time.t0)


_MANOEUVRES = {"straight", "single-turn", "zigzag", "planned", "receding"}
_PINGS = {"no-ping", "uniform", "scheduled", "scheduled-terminal", "adaptive"}


def parse_policy(spec: str, scenario: Scenario) -> Combined:
    """Policy from a CLI name: ``manoeuvre[+ping]``, e.g. ``receding+scheduled``.

    Manoeuvres: straight, single-turn and zigzag (the best of the baseline grids of
    :mod:`tmaplan.planning.baselines` for :data:`CLOSED_LOOP_OBJECTIVE`), planned,
    receding. Pings: no-ping, uniform, scheduled (offline schedule minimising the mean range
    bound over the horizon), scheduled-terminal (minimising the terminal range bound),
    adaptive.

    Raises
    ------
    PlanningError
        For an unknown name (the message lists the valid ones).
    """
    parts = spec.strip().split("+")
    if len(parts) > 2 or parts[0] not in _MANOEUVRES or (len(parts) == 2
                                                         and parts[1] not in _PINGS):
        raise PlanningError(f"unknown policy {spec!r}: expected MANOEUVRE[+PING] with MANOEUVRE "
                            f"in {sorted(_MANOEUVRES)} and PING in {sorted(_PINGS)}")
    name = parts[0]
    if name == "straight":
        man: Any = Straight()
    elif name == "single-turn":
        man = best_single_turn(scenario)
    elif name == "zigzag":
        man = best_zigzag(scenario)
    elif name == "planned":
        man = Planned()
    else:
        man = Receding()
    ping: Any = NoPing()
    if len(parts) == 2:
        ping = {"no-ping": NoPing(), "uniform": UniformPings(), "scheduled": ScheduledPings(),
                "scheduled-terminal": ScheduledPings(objective="terminal-range-bound",
                                                     name="scheduled-terminal"),
                "adaptive": AdaptivePings()}[parts[1]]
    return Combined(manoeuvre=man, ping=ping)
