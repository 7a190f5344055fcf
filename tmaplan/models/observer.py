"""Observer (own-ship) kinematics: scripted legs and turn-rate control sequences.

Convention (docs/conventions.md): the relative state ``X = target − observer`` obeys
``X_{k+1} = A X_k − H Δv_k + w_k``. This is exact when the observer velocity stored at step k
is its *mean velocity over the interval (t_{k−1}, t_k]* (``mean_velocity``), so that
``p_{k+1} = p_k + dt·v̄_{k+1}``. For straight legs switching on grid instants this equals the
instantaneous velocity; during a turn it is the chord velocity. The instantaneous velocity
and heading are kept too (for Doppler and plots).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.display import short_repr
from tmaplan.errors import ScenarioError
from tmaplan.geometry import course_speed, velocity_from_course, wrap_angle
from tmaplan.models.target import initial_velocity
from tmaplan.scenario import Observer, TimeGrid

_EPS = float(np.finfo(np.float64).eps)  # np.sinc's value of πa at a = 0

__all__ = ["ObserverTrack", "arc_displacement", "observer_track", "turn_rate_track"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class ObserverTrack:
    """Observer trajectory on the time grid.

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    position : ndarray, shape (K + 1, 2)
        [m].
    velocity : ndarray, shape (K + 1, 2)
        Instantaneous velocity [m/s].
    mean_velocity : ndarray, shape (K + 1, 2)
        Mean velocity over (t_{k−1}, t_k] [m/s]; row 0 is the initial velocity.
    heading : ndarray, shape (K + 1,)
        Instantaneous heading [rad], clockwise from North.
    speed : ndarray, shape (K + 1,)
        [m/s].
    """

    __repr__ = short_repr

    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    mean_velocity: np.ndarray
    heading: np.ndarray
    speed: np.ndarray

    @property
    def state(self) -> np.ndarray:
        """``[x, y, v̄_x, v̄_y]`` per step, shape (K + 1, 4): the state that enters X."""
        return np.hstack([self.position, self.mean_velocity])

    @property
    def velocity_increments(self) -> np.ndarray:
        """Δv_k = v̄_{k+1} − v̄_k, shape (K, 2) [m/s] (enters X_{k+1} = A X_k − H Δv_k)."""
        return np.diff(self.mean_velocity, axis=0)


def arc_displacement(heading: ArrayLike, turn_rate: ArrayLike, speed: ArrayLike,
                     dt: float) -> np.ndarray:
    """Exact displacement over ``dt`` at constant speed and turn rate.

    ``∫ V [sin ψ(τ), cos ψ(τ)] dτ = V dt sinc(u dt/2) [sin(ψ + u dt/2), cos(ψ + u dt/2)]``,
    with sinc(a) = sin a / a (no branch at u = 0).

    Parameters
    ----------
    heading : ndarray
        Heading at the start of the interval [rad].
    turn_rate : ndarray
        [rad/s].
    speed : ndarray
        [m/s].
    dt : float
        [s].

    Returns
    -------
    ndarray, shape (..., 2)
        [m].
    """
    if type(heading) is type(turn_rate) is type(speed) is float:  # one step (a closed loop)
        # the same operations as below on floats, numpy's sin and cos (libm's may differ in
        # the last bit where numpy has its own): the same bits, without 0-d arrays
        half = turn_rate * dt / 2.0
        x = np.pi * (half / np.pi)  # np.sinc(a) = sin(πa)/(πa), π·0 replaced by eps
        y = x if x else _EPS
        scale = speed * dt * (np.sin(y) / y)
        mid = heading + half
        return np.array([scale * np.sin(mid), scale * np.cos(mid)])
    half = np.asarray(turn_rate) * dt / 2.0
    mid = np.asarray(heading) + half
    scale = np.asarray(speed) * dt * np.sinc(half / np.pi)
    return np.stack([scale * np.sin(mid), scale * np.cos(mid)], axis=-1)


def turn_rate_track(position0: np.ndarray, heading0: float, speed: float,
                    turn_rates: np.ndarray, dt: float, t0: float = 0.0) -> ObserverTrack:
    """Observer track under a piecewise-constant turn-rate sequence at constant speed.

    Parameters
    ----------
    position0 : ndarray, shape (2,)
        [m].
    heading0 : float
        [rad].
    speed : float
        [m/s].
    turn_rates : ndarray, shape (K,)
        Turn rate over each interval [rad/s] (positive = starboard/clockwise).
    dt : float
        [s].
    t0 : float
        [s].

    Returns
    -------
    ObserverTrack
    """
    u = np.asarray(turn_rates, dtype=float)
    K = u.shape[0]
    heading = heading0 + dt * np.concatenate([[0.0], np.cumsum(u)])
    disp = arc_displacement(heading[:-1], u, speed, dt)
    position = np.asarray(position0, float) + np.vstack([np.zeros((1, 2)),
                                                          np.cumsum(disp, axis=0)])
    velocity = velocity_from_course(np.full(K + 1, float(speed)), heading)
    mean_velocity = np.vstack([velocity[:1], disp / dt])
    return ObserverTrack(times=t0 + dt * np.arange(K + 1), position=position,
                         velocity=velocity, mean_velocity=mean_velocity,
                         heading=wrap_angle(heading), speed=np.full(K + 1, float(speed)))


def observer_track(observer: Observer, grid: TimeGrid, *,
                   source: str | None = None) -> ObserverTrack:
    """Observer track for a scenario's observer (scripted legs or turn-rate sequence).

    Instantaneous course changes happen exactly at the leg start; turns at a given rate start
    at the leg start and stop when the commanded course is reached. Positions are integrated
    exactly (piecewise circular arcs and straight segments).

    Parameters
    ----------
    observer : Observer
    grid : TimeGrid
    source : str, optional
        File or problem name for error messages.

    Returns
    -------
    ObserverTrack

    Raises
    ------
    ScenarioError
        If a leg starts before t0 or before the previous leg's turn has ended (it could not
        start at its start).
    """
    v0 = initial_velocity(observer)
    course0, spd0 = course_speed(v0)
    heading0, speed0 = float(course0), float(spd0)
    p0 = np.asarray(observer.position, float)
    if observer.turn_rates:
        return turn_rate_track(p0, heading0, speed0, np.asarray(observer.turn_rates), grid.dt,
                               grid.t0)
    times = grid.times
    # Build an event list of piecewise-constant (heading-rate, speed) segments in time.
    # Each segment: (t_start, t_end, psi_start, rate, speed).
    t_end_all = float(times[-1])
    segments: list[tuple[float, float, float, float, float]] = []
    t, psi, spd = float(times[0]), heading0, speed0
    for i, leg in enumerate(observer.legs):
        start = float(leg.start)
        if start < t - 1e-9 * max(1.0, abs(t)):
            after = (f"t0 = {t} s" if t == float(times[0]) else
                     f"{t} s, the end of the previous leg's turn (a leg starts at its start)")
            raise ScenarioError(f"observer.legs[{i}].start", f">= {after}", start, source=source)
        if start > t:
            segments.append((t, start, psi, 0.0, spd))
            t = start
        if leg.velocity is not None:
            c, s = course_speed(np.asarray(leg.velocity, float))
            target_course, new_speed = float(c), float(s)
        else:
            target_course = float(leg.course) if leg.course is not None else psi
            new_speed = float(leg.speed) if leg.speed is not None else spd
        spd = new_speed
        delta = float(wrap_angle(target_course - psi))
        if leg.turn_direction == "starboard" and delta < 0:
            delta += 2 * np.pi
        elif leg.turn_direction == "port" and delta > 0:
            delta -= 2 * np.pi
        if leg.turn_rate is None or delta == 0.0:
            psi = psi + delta
        else:
            duration = abs(delta) / float(leg.turn_rate)
            rate = float(np.sign(delta)) * float(leg.turn_rate)
            segments.append((t, t + duration, psi, rate, spd))
            psi, t = psi + delta, t + duration
    segments.append((t, max(t, t_end_all) + grid.dt, psi, 0.0, spd))

    # positions at segment starts
    seg_pos = [p0]
    for s0, s1, psi0, r, v in segments[:-1]:
        seg_pos.append(seg_pos[-1] + arc_displacement(psi0, r, v, s1 - s0))
    seg_pos_a = np.array(seg_pos)
    starts = np.array([seg[0] for seg in segments])
    idx = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(segments) - 1)
    tau = times - starts[idx]
    ps = np.array([segments[i][2] for i in idx])
    rr = np.array([segments[i][3] for i in idx])
    sp = np.array([segments[i][4] for i in idx])
    # exact displacement from the segment start over tau
    half = rr * tau / 2.0
    scale = sp * tau * np.sinc(half / np.pi)
    disp = np.stack([scale * np.sin(ps + half), scale * np.cos(ps + half)], axis=-1)
    position = seg_pos_a[idx] + disp
    heading = ps + rr * tau
    # The speed at t_k: instantaneous; before the first leg starts, the initial speed.
    velocity = velocity_from_course(sp, heading)
    mean_velocity = np.vstack([velocity[:1], np.diff(position, axis=0) / grid.dt])
    return ObserverTrack(times=times, position=position, velocity=velocity,
                         mean_velocity=mean_velocity, heading=wrap_angle(heading), speed=sp)
