"""Common pieces of the policies: the interfaces, the action, the belief a controller sees,
turn helpers."""

from __future__ import annotations

import dataclasses
import logging
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from tmaplan.errors import ScenarioError
from tmaplan.geometry import course_speed, range_of, wrap_angle
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import initial_velocity

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["CLOSED_LOOP_OBJECTIVE", "Action", "BeliefView", "Controller", "CourseKeeper",
           "CourseSteering", "ManoeuvrePolicy", "Policy", "initial_course", "turn_limits"]

log = logging.getLogger("tmaplan.policies")

#: Planning objective of the closed-loop policies (``planned``, ``receding``) and of the choice
#: of the best single turn / zig-zag: the default objective of ``tmaplan plan``
#: (:data:`tmaplan.planning.objectives.DEFAULT_OBJECTIVE`, the expected time to 10 % range
#: accuracy over prior draws), which ranks manoeuvres as the filter's Monte Carlo time to
#: accuracy does (``tmaplan rank-costs``, docs/findings.md).
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
        Particle filter's relative-state particles [m, m/s] (a read-only view in the
        closed loop).
    weights : ndarray, shape (N,)
        Normalised weights (read-only likewise).
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
class CourseSteering(Protocol):
    """A controller that steers to courses rather than replaying turn rates (single turn,
    zig-zag, leg–turn–leg, lead–lag): a turn another controller makes in its place (the alarm
    responder, :mod:`tmaplan.policies.alarms`) offsets its courses, or it would turn back.
    Courses it decides afterwards from the belief (relative to the line of sight: the
    doctrine's beam, the lead and lag offsets) are decided from the heading flown, as ever."""

    def offset_courses(self, angle: float) -> None:
        """Offset every course, present and future, by ``angle`` [rad] (+ starboard)."""


@runtime_checkable
class ManoeuvrePolicy(Policy, Protocol):
    """A policy that steers the own ship and knows the track it nominally flies."""

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown without feedback (used to schedule pings offline)."""


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def turn_limits(scenario: Scenario) -> tuple[float, float]:
    """The manoeuvre policies' ``(maximum turn rate [rad/s], time step [s])``.

    Raises
    ------
    ScenarioError
        ``observer.turn_rate_max`` not set.
    """
    o = scenario.observer
    if o.turn_rate_max is None:
        raise ScenarioError("observer.turn_rate_max", "a turn-rate limit for manoeuvre policies",
                            None, source=scenario.name)
    return float(o.turn_rate_max), float(scenario.time.dt)


class CourseKeeper:
    """Steering to courses held in a continuous (unwrapped) heading frame, at the maximum
    turn rate: the base of the course-steering controllers (:class:`CourseSteering`).

    A course is a target heading [rad] in the frame of the initial course ``c0`` (``c0 + a``
    is reached by a turn of ``a`` from ``c0``, to starboard if ``a > 0``, even for
    ``|a| >= π``), as in the nominal tracks of :mod:`tmaplan.planning.baselines`: a wrapped
    difference would fly a −180° turn to starboard (``wrap_angle(−π) = π``). The own-ship
    heading is unwrapped step by step from ``c0`` (it changes by less than π between calls), so
    a caller may give it wrapped or not.
    :meth:`offset_courses` shifts every course, present and future, by the turns somebody
    else made (the alarm responder, :mod:`tmaplan.policies.alarms`).

    Parameters
    ----------
    c0 : float
        Initial course [rad].
    u_max : float
        Maximum turn rate [rad/s].
    dt : float
        Step [s].
    """

    def __init__(self, c0: float, u_max: float, dt: float) -> None:
        self.c0, self.u_max, self.dt = float(c0), u_max, dt
        self.course_offset = 0.0  # [rad], added to every course
        self._heading: float | None = None  # unwrapped heading [rad]
        self._last = 0.0  # heading as last given [rad]

    def offset_courses(self, angle: float) -> None:
        """Offset every course, present and future, by ``angle`` [rad] (+ starboard)."""
        self.course_offset += float(angle)

    def heading(self, belief: BeliefView) -> float:
        """The belief's own-ship heading [rad], unwrapped continuously from ``c0``."""
        h = float(belief.heading)
        if self._heading is None:
            self._heading = self.c0 + float(wrap_angle(h - self.c0))
        else:
            self._heading += float(wrap_angle(h - self._last))
        self._last = h
        return self._heading

    def course_now(self, belief: BeliefView, course: float) -> float:
        """The course (in the frame of :meth:`steer`, before the offset) of an absolute
        course [rad] decided now from the belief: reached the shorter way from the present
        heading."""
        return (self.heading(belief) + float(wrap_angle(course - belief.heading))
                - self.course_offset)

    def steer(self, belief: BeliefView, course: float) -> float:
        """Turn rate [rad/s] that reaches ``course`` + the offset as fast as the limit allows,
        turning the way the unwrapped difference says."""
        delta = course + self.course_offset - self.heading(belief)
        return float(np.clip(delta / self.dt, -self.u_max, self.u_max))


def initial_course(scenario: Scenario) -> float:
    """The own ship's initial course [rad, clockwise from North]."""
    v = initial_velocity(scenario.observer)
    return float(course_speed(v)[0])


