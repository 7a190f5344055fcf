"""Ping policies: none, uniformly spaced, offline schedule, adaptive to the filter."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.errors import ArgumentError, as_real, is_integer
from tmaplan.models.sensors import default_ping_budget
from tmaplan.planning import ping_candidates, schedule_pings, uniform_ping_steps
from tmaplan.planning.objectives import PingObjectiveName
from tmaplan.policies.base import Action, BeliefView, Controller

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["AdaptivePings", "NoPing", "ScheduledPings", "UniformPings", "offline_schedule",
           "resolve_ping_budget"]


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
    """``budget`` evenly spaced pings: :func:`tmaplan.planning.uniform_ping_steps` under the
    scenario's ping constraints (the scheduler's ``uniform_steps``)."""

    budget: int | None = None
    name: str = "uniform"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller pinging at evenly spaced steps."""
        times = np.asarray(scenario.time.times)
        cand, gap, _ = ping_candidates(scenario, times)
        steps = uniform_ping_steps(times, resolve_ping_budget(scenario, self.budget),
                                   candidates=cand, gap=gap)
        return _StepPings(np.asarray(steps, dtype=int))


@dataclasses.dataclass(frozen=True, kw_only=True)
class ScheduledPings:
    """Ping at the steps of an offline schedule (``tmaplan.planning.schedule_pings``)."""

    budget: int | None = None
    method: Literal["exact", "relaxed", "greedy"] = "relaxed"
    objective: PingObjectiveName = "mean-range-bound"
    steps: tuple[int, ...] | None = None
    name: str = "scheduled"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller replaying the schedule (computed along the scenario's own track if no
        steps are given; :class:`Combined` schedules along its manoeuvre's nominal track).

        Raises
        ------
        ArgumentError
            Given ``steps`` that are not integers in [1, K] (step 0 cannot be pinged: a ping
            is decided one step ahead).
        """
        if self.steps is not None:
            K = scenario.time.n_steps
            steps = list(self.steps)
            # a ping is decided one step ahead (``act`` at step k pings at k + 1): step 0 and
            # steps past the horizon would silently never be pinged, a float be truncated
            if not all(is_integer(s, 1) and s <= K for s in steps):
                raise ArgumentError("scheduled.steps", f"integer steps in [1, {K}]",
                                    self.steps)
            return _StepPings(np.asarray(steps, dtype=int))
        return _StepPings(offline_schedule(scenario, resolve_ping_budget(scenario, self.budget),
                                           self.method, self.objective))


#: Offline schedules kept by :func:`offline_schedule`, the 64 most recently used
#: (:mod:`tmaplan.caching`): a campaign resolves one per scheduled policy (and manoeuvre track).
_SCHEDULE_CACHE: LRUCache[tuple[Any, ...], np.ndarray] = LRUCache(64)


def offline_schedule(scenario: Scenario, budget: int,
                      method: Literal["exact", "relaxed", "greedy"],
                      objective: PingObjectiveName,
                      track: Any = None) -> np.ndarray:
    """Offline ping steps from the prior along ``track`` (default: the scripted track).

    Parameters
    ----------
    scenario : Scenario
    budget : int
        Pings at most.
    method, objective
        As :func:`tmaplan.planning.schedule_pings` (no certificate is computed).
    track : ObserverTrack, optional
        The own-ship track flown.

    Returns
    -------
    ndarray of int, shape (n_pings,)
        The ping steps, read only (cached, the 64 most recently used, shared by callers).
    """
    tkey = None if track is None else np.asarray(track.position).tobytes()
    key = (scenario, budget, method, objective, tkey)  # a frozen Scenario hashes its fields
    if key in _SCHEDULE_CACHE:
        return _SCHEDULE_CACHE[key]

    # the policy needs the steps only: no certificate (it costs a conic solve per track)
    sched = schedule_pings(scenario, budget=budget, method=method, objective=objective,
                           observer=track, gap_reference="none")
    steps = np.array(sched.steps, dtype=int)
    steps.flags.writeable = False  # shared by every caller
    _SCHEDULE_CACHE[key] = steps
    return steps


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
        """Controller with its own ping count and last ping time.

        Raises
        ------
        ArgumentError
            A threshold that is not a positive number, or a minimum spacing that is not a
            time >= 0 (a NaN threshold would never ping, a NaN spacing always).
        """
        threshold = as_real(self.threshold)
        if not (np.isfinite(threshold) and threshold > 0):
            raise ArgumentError("adaptive.threshold", "a relative range std > 0", self.threshold)
        if self.min_spacing is not None:
            ms = as_real(self.min_spacing)
            if not (np.isfinite(ms) and ms >= 0):
                raise ArgumentError("adaptive.min_spacing", "a time >= 0 s (None: the "
                                    "scenario's)", self.min_spacing)
        pl = scenario.planning
        spacing = self.min_spacing if self.min_spacing is not None else (
            pl.ping_min_spacing if pl else 0.0)
        return _Adaptive(self.threshold, resolve_ping_budget(scenario, self.budget),
                         float(spacing), scenario)


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


def resolve_ping_budget(scenario: Scenario, budget: int | None) -> int:
    """The policy's ping budget ``budget``, else (None) the scenario's
    ``planning.ping_budget`` (0 without planning settings).

    Raises
    ------
    ArgumentError
        ``budget`` not an integer >= 0 (field ``pings.budget``).
    """
    if budget is not None:
        if not is_integer(budget, 0):
            raise ArgumentError("pings.budget", "an integer >= 0 (None: the scenario's)",
                                budget)
        return int(budget)
    return default_ping_budget(scenario)


