"""Common pieces of the policies: the interfaces, the action, the belief a controller sees,
turn helpers."""

from __future__ import annotations

import dataclasses
import logging
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from tmaplan.errors import ScenarioError
from tmaplan.geometry import course_speed, range_of, wrap_angle

if TYPE_CHECKING:
    from tmaplan.models.observer import ObserverTrack
    from tmaplan.scenario import Scenario

__all__ = ["CLOSED_LOOP_OBJECTIVE", "Action", "BeliefView", "Controller", "ManoeuvrePolicy",
           "Policy"]

log = logging.getLogger("tmaplan.policies")

#: Planning objective of the closed-loop policies (``planned``, ``receding``) and of the choice
#: of the best single turn / zig-zag: the default objective of ``tmaplan plan``
#: (:data:`tmaplan.planning.objectives.DEFAULT_OBJECTIVE`, the expected time to 10 % range
#: accuracy over prior draws), which ranks manoeuvres as the filter's Monte Carlo time to
#: accuracy does (``tmaplan rank-costs``, README).
CLOSED_LOOP_OBJECTIVE = "expected-time-to-accuracy"


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
    alarms : int
        Consistency-monitor alarms so far (:mod:`tmaplan.estimators.consistency`; 0 without
        a monitor).
    """

    step: int
    t: float
    heading: float
    position: np.ndarray
    particles: np.ndarray
    weights: np.ndarray
    pings_used: int
    alarms: int = 0

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
        r = range_of(self.particles)
        m = float(self.weights @ r)
        return m, float(np.sqrt(max(float(self.weights @ (r - m) ** 2), 0.0)))


@runtime_checkable
class Controller(Protocol):
    """Per-run decision maker made by a policy (the only place where per-run state lives)."""

    def act(self, belief: BeliefView, t: float) -> Action:
        """Decide the action at time ``t`` [s] from the belief."""


@runtime_checkable
class Policy(Protocol):
    """A tactical policy: frozen parameters that make one :class:`Controller` per run."""

    @property
    def name(self) -> str:
        """CLI name (``straight``, ``uniform``, ``planned+scheduled``, ...)."""

    def controller(self, scenario: Scenario) -> Controller:
        """A fresh controller for one closed-loop run."""


@runtime_checkable
class ManoeuvrePolicy(Policy, Protocol):
    """A policy that steers the own ship and knows the track it nominally flies."""

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown without feedback (used to schedule pings offline)."""


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
    return float(course_speed(v)[0])


