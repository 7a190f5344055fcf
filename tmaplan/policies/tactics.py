"""Practitioner tactics as manoeuvre policies: the leg–turn–leg of bearing-rate doctrine and the
lead/lag turn.

These are the rules an operator flies without a planner; they are the baselines a planned
manoeuvre has to beat (``tmaplan compare --policies leg-turn-leg,lead-lag,planned``,
``tmaplan rank-costs``). Both decide their courses from the belief the controller sees (the
particle filter's line of sight and bearing drift at the moment of the turn), never from the
truth, and then turn at the observer's maximum turn rate and hold the new course.

Angles: courses and bearings clockwise from North [rad]; the *relative bearing* of the contact
is ``θ = wrap(β − ψ)`` (β the line-of-sight bearing, ψ the own-ship course), positive when the
contact is on the starboard side.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from tmaplan.errors import ArgumentError, as_real
from tmaplan.geometry import bearing_of, wrap_angle
from tmaplan.models.observer import ObserverTrack
from tmaplan.planning.baselines import course_program_track, single_turn_track, straight_track
from tmaplan.planning.belief import Belief
from tmaplan.policies.base import (
    Action,
    BeliefView,
    Controller,
    CourseKeeper,
    initial_course,
    turn_limits,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["LeadLag", "LegTurnLeg", "belief_line_of_sight", "doctrine_course",
           "lead_lag_course"]


# --------------------------------------------------------------------------------------------
# the rules (pure functions of the geometry)
# --------------------------------------------------------------------------------------------


def doctrine_course(bearing: float, course: float, beam_angle: float = 0.5 * np.pi) -> float:
    """New course of the bearing-rate doctrine: the contact on the *other* side at relative
    bearing ``beam_angle``.

    The own-ship contribution to the bearing rate is ``S·sin θ / r`` (S own speed, θ the
    relative bearing, r the range: an own ship heading North with the contact abeam to
    starboard, θ = +90°, sees the bearing grow), so a course change from relative bearing θ₁
    to θ₂ changes the bearing rate by ``S (sin θ₂ − sin θ₁) / r``, whatever the contact does.
    For a given first leg this is largest in magnitude with θ₂ = −sign(θ₁)·90°: the contact
    abeam on the other side (``beam_angle = π/2``), which is the two-leg bang-bang optimum of
    lecadre1997 (§VII.B, eq. 87: the bearing rate changes sign at its bound, θ̇₂ = −θ̇₁).

    Parameters
    ----------
    bearing : float
        Line-of-sight bearing β at the turn [rad].
    course : float
        Own-ship course ψ before the turn [rad].
    beam_angle : float
        |relative bearing| after the turn [rad], in (0, π).

    Returns
    -------
    float
        The new course ``β + s·beam_angle`` [rad] in (−π, π], s = +1 if the contact is on the
        starboard side before the turn (or dead ahead / astern), −1 if on the port side.
    """
    theta = float(wrap_angle(bearing - course))
    side = 1.0 if theta >= 0.0 else -1.0
    return float(wrap_angle(bearing + side * beam_angle))


def lead_lag_course(bearing: float, drift: float, angle: float, *, lead: bool) -> float:
    """Course that leads (``lead=True``) or lags the line of sight by ``angle`` [rad].

    Leading points the bow ``angle`` ahead of the line of sight in the direction the bearing
    drifts (``sign(drift)``, clockwise positive): the own ship follows the contact across the
    line of sight and the bearing rate drops; lagging points ``angle`` behind it and the
    bearing rate grows. The bearing-rate change between the two legs is
    ``2 S sin(angle) / r`` (see :func:`doctrine_course`).

    Parameters
    ----------
    bearing : float
        Line-of-sight bearing at the start of the leg [rad].
    drift : float
        Observed bearing rate [rad/s] (only its sign is used; 0 counts as clockwise).
    angle : float
        Offset of the course from the line of sight [rad], in (0, π).
    lead : bool

    Returns
    -------
    float
        Course [rad] in (−π, π].
    """
    d = 1.0 if drift >= 0.0 else -1.0
    return float(wrap_angle(bearing + (d if lead else -d) * angle))


def belief_line_of_sight(belief: BeliefView) -> tuple[float, float]:
    """Bearing [rad] and bearing rate [rad/s] of the line of sight that the belief holds.

    The bearing is the weighted circular mean of the particles' bearings; the bearing rate is
    the weighted mean of ``(r_y v_x − r_x v_y) / r²`` (the time derivative of
    ``β = atan2(r_x, r_y)``), both in the relative state ``[r_x, r_y, v_x, v_y]``.
    """
    p, w = belief.particles, belief.weights
    b = bearing_of(p)
    beta = float(np.arctan2(w @ np.sin(b), w @ np.cos(b)))
    r2 = np.maximum(p[:, 0] ** 2 + p[:, 1] ** 2, 1.0)
    rate = float(w @ ((p[:, 1] * p[:, 2] - p[:, 0] * p[:, 3]) / r2))
    return beta, rate


# --------------------------------------------------------------------------------------------
# policies
# --------------------------------------------------------------------------------------------


def _check_angle(field: str, value: float) -> float:
    if not (np.isfinite(v := as_real(value)) and 0.0 < v < np.pi):
        raise ArgumentError(field, "an angle in (0, 180) deg", value)
    return v


def _check_time(field: str, value: float | None, scenario: Scenario, default: float) -> float:
    """An instant ``t0 + value`` strictly inside the horizon (``value`` after t0 [s])."""
    t0, H = scenario.time.t0, scenario.time.horizon
    v = default * H if value is None else as_real(value)
    if not (np.isfinite(v) and 0.0 < v < H):
        raise ArgumentError(field, f"a time after t0 in (0, {H:g}) s", value)
    return t0 + v


def _prior_line_of_sight(scenario: Scenario, t: float, track: ObserverTrack
                         ) -> tuple[float, float]:
    """Bearing and bearing rate of the prior-mean relative state at time ``t`` along ``track``
    (the nominal view a controller would have without measurements)."""
    m = Belief.from_prior(scenario).mean
    # own position and velocity at t itself, between grid steps too (linear in time: exact
    # on a straight leg)
    own = np.array([np.interp(t, track.times, track.position[:, i]) for i in range(2)])
    vel = np.array([np.interp(t, track.times, track.velocity[:, i]) for i in range(2)])
    vt = m[2:] + track.velocity[0]   # mean target velocity (absolute)
    rel = m[:2] + vt * (t - scenario.time.t0) - (own - track.position[0])
    v = vt - vel
    r2 = max(float(rel @ rel), 1.0)
    return float(bearing_of(rel)), float((rel[1] * v[0] - rel[0] * v[1]) / r2)


@dataclasses.dataclass(frozen=True, kw_only=True)
class LegTurnLeg:
    """Leg–turn–leg sized by bearing-rate doctrine (Ekelund ranging).

    Rule: hold the initial course for ``first_leg`` [s] (long enough to measure the bearing
    rate of the first leg), then turn at the maximum rate to put the contact on the *other*
    side at relative bearing ``beam_angle`` (default abeam, 90°), which gives the largest
    change of bearing rate between the legs (:func:`doctrine_course`), and hold that course.
    The range then follows from the two bearing rates, as in Ekelund's classical ranging
    (range ≈ change of own-ship speed across the line of sight / change of bearing rate). The
    bearing of the turn is the filter's line of sight at that moment
    (:func:`belief_line_of_sight`).

    Sources: the bang-bang structure of the optimal manoeuvre in bearing rate, θ̇₂ = −θ̇₁ at
    the bound (lecadre1997, §VII.B, eq. 87), with its single switch near a third of the
    horizon for the det-FIM cost (lecadre1997 §VII, the reproduced optimum: the default
    ``first_leg`` is a third of the horizon); bearing rates as the carriers of range
    information (nardone1981).

    Attributes
    ----------
    first_leg : float, optional
        Duration of the first leg [s], in (0, horizon); default a third of the horizon.
    beam_angle : float
        |Relative bearing| of the contact after the turn [rad], in (0, π); default π/2.
    """

    first_leg: float | None = None
    beam_angle: float = 0.5 * np.pi
    name: str = "leg-turn-leg"

    def turn_time(self, scenario: Scenario) -> float:
        """Absolute time of the turn [s]."""
        return _check_time("leg-turn-leg.first_leg", self.first_leg, scenario, 1.0 / 3.0)

    def controller(self, scenario: Scenario) -> Controller:
        """A controller holding the course, then turning by the doctrine."""
        t_turn = self.turn_time(scenario)
        beam = _check_angle("leg-turn-leg.beam_angle", self.beam_angle)
        u_max, dt = turn_limits(scenario)
        return _LegTurnLegController(t_turn, beam, initial_course(scenario), u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The track flown when the line of sight at the turn is the prior mean's."""
        t_turn = self.turn_time(scenario)
        beam = _check_angle("leg-turn-leg.beam_angle", self.beam_angle)
        straight = straight_track(scenario)
        beta, _ = _prior_line_of_sight(scenario, t_turn, straight)
        c0 = initial_course(scenario)
        delta = float(wrap_angle(doctrine_course(beta, c0, beam) - c0))
        return single_turn_track(scenario, delta, t_turn - scenario.time.t0)


class _LegTurnLegController(CourseKeeper):
    def __init__(self, t_turn: float, beam: float, c0: float, u_max: float, dt: float) -> None:
        super().__init__(c0, u_max, dt)
        self.t_turn, self.beam, self.course = t_turn, beam, self.c0
        self.turned = False

    def act(self, belief: BeliefView, t: float) -> Action:
        if not self.turned and t + 1e-9 >= self.t_turn:
            beta, _ = belief_line_of_sight(belief)
            self.course = self.course_now(belief, doctrine_course(beta, belief.heading,
                                                                  self.beam))
            self.turned = True
        return Action(turn_rate=self.steer(belief, self.course))


@dataclasses.dataclass(frozen=True, kw_only=True)
class LeadLag:
    """Lead/lag turn: lead the contact's line of sight, then lag it.

    Rule: at ``lead_time`` [s after t0] (default t0), read the line of sight β and the
    direction of the bearing drift from the belief, and steer ``angle`` ahead of the line of
    sight in that direction (lead: the bearing rate drops); at ``lag_time`` (default half the
    horizon), steer ``angle`` behind the then line of sight on the same side of the drift (lag:
    the bearing rate grows) and hold it (:func:`lead_lag_course`). The change of bearing rate
    between the legs, ``2 S sin(angle) / r``, carries the range as in the leg–turn–leg
    (:class:`LegTurnLeg`; lecadre1997 §VII.B, eq. 87; nardone1981); unlike a beam-to-beam
    turn, both legs keep closing on the contact when ``angle < 90°``, which shortens the range
    and raises the bearing rate. The default offset (45°) is ours.

    Attributes
    ----------
    angle : float
        Offset of each leg's course from the line of sight [rad], in (0, π); default π/4.
    lead_time : float
        Start of the lead leg [s after t0], in [0, lag_time).
    lag_time : float, optional
        Start of the lag leg [s after t0], in (0, horizon); default half the horizon.
    """

    angle: float = 0.25 * np.pi
    lead_time: float = 0.0
    lag_time: float | None = None
    name: str = "lead-lag"

    def _times(self, scenario: Scenario) -> tuple[float, float]:
        t_lag = _check_time("lead-lag.lag_time", self.lag_time, scenario, 0.5)
        t0 = scenario.time.t0
        if not (np.isfinite(lead := as_real(self.lead_time)) and 0.0 <= lead < t_lag - t0):
            raise ArgumentError("lead-lag.lead_time", f"a time after t0 in [0, {t_lag - t0:g}) s"
                                " (before the lag leg)", self.lead_time)
        return t0 + lead, t_lag

    def controller(self, scenario: Scenario) -> Controller:
        """A controller flying the lead leg, then the lag leg."""
        t_lead, t_lag = self._times(scenario)
        ang = _check_angle("lead-lag.angle", self.angle)
        u_max, dt = turn_limits(scenario)
        return _LeadLagController(t_lead, t_lag, ang, initial_course(scenario), u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The track flown when the line of sight is the prior mean's."""
        t_lead, t_lag = self._times(scenario)
        ang = _check_angle("lead-lag.angle", self.angle)
        straight = straight_track(scenario)
        beta, drift = _prior_line_of_sight(scenario, t_lead, straight)
        c1 = lead_lag_course(beta, drift, ang, lead=True)
        lead_track = course_program_track(scenario, [(t_lead - scenario.time.t0, c1)])
        beta2, _ = _prior_line_of_sight(scenario, t_lag, lead_track)
        c2 = lead_lag_course(beta2, drift, ang, lead=False)
        return course_program_track(scenario, [(t_lead - scenario.time.t0, c1),
                                               (t_lag - scenario.time.t0, c2)])


class _LeadLagController(CourseKeeper):
    def __init__(self, t_lead: float, t_lag: float, angle: float, c0: float, u_max: float,
                 dt: float) -> None:
        super().__init__(c0, u_max, dt)
        self.t_lead, self.t_lag, self.angle, self.course = t_lead, t_lag, angle, self.c0
        self.drift: float | None = None
        self.lagging = False

    def act(self, belief: BeliefView, t: float) -> Action:
        if self.drift is None and t + 1e-9 >= self.t_lead:
            beta, self.drift = belief_line_of_sight(belief)
            self.course = self.course_now(belief, lead_lag_course(beta, self.drift, self.angle,
                                                                  lead=True))
        if self.drift is not None and not self.lagging and t + 1e-9 >= self.t_lag:
            beta, _ = belief_line_of_sight(belief)
            self.course = self.course_now(belief, lead_lag_course(beta, self.drift, self.angle,
                                                                  lead=False))
            self.lagging = True
        return Action(turn_rate=self.steer(belief, self.course))
