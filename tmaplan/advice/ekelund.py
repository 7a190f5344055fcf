"""Ekelund's range: the classical range estimate from the bearing rates on two own-ship legs
(ekelund1958; the doctrine behind the ``leg-turn-leg`` tactic, :mod:`tmaplan.policies.tactics`).

A contact at range R in relative velocity ``v_t − v_o`` has the bearing rate
``β̇ = (v_t − v_o)·n / R`` with ``n = (cos β, −sin β)`` the unit vector across the line of
sight (clockwise; x = East, y = North). If the contact holds its velocity while the own ship
changes its velocity from ``v_o1`` to ``v_o2`` and the range changes little, the difference of
the bearing rates on the two legs gives

    R = (v_o2 − v_o1)·n / (β̇₁ − β̇₂)

(ekelund1958; the own ship's speed across the line of sight over the change of bearing
rate). Here the legs are the straight stretches of the own ship just before and just after
its last manoeuvre (course or speed change) within the bearings; each leg's bearing rate is
the least-squares slope of the (unwrapped) bearings over at most ``window`` seconds next to the
manoeuvre, ``n`` is taken at the bearing half-way between the two windows, and the standard
deviation follows from the slopes' (delta method). A cross-check of the batch estimate, not a
substitute: it neglects the change of range over the windows and the turn.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from tmaplan.display import short_repr
from tmaplan.geometry import course_speed

__all__ = ["EkelundRange", "ekelund_range", "manoeuvres"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class EkelundRange:
    """Ekelund's range at the own ship's last manoeuvre.

    Attributes
    ----------
    time : float
        [s]: the middle of the manoeuvre.
    range : float
        [m] (NaN when the bearing rates do not change).
    std : float
        [m], from the bearing-rate slopes' standard deviations.
    rates : tuple of float
        Bearing rates on the first and second leg [rad/s].
    legs : tuple of (float, float)
        The two windows [s].
    """

    __repr__ = short_repr

    time: float
    range: float
    std: float
    rates: tuple[float, float]
    legs: tuple[tuple[float, float], tuple[float, float]]


def manoeuvres(times: np.ndarray, velocity: np.ndarray, *, course_rate: float = np.deg2rad(0.05),
               window: float = 60.0, speed_change: float = 0.25) -> np.ndarray:
    """Whether the own ship manoeuvres at each time: its course changes faster than
    ``course_rate`` [rad/s], or its speed by more than ``speed_change`` [m/s] over ``window``
    [s], both judged on velocities averaged over ``window`` (navigation noise).

    Parameters
    ----------
    times : ndarray, shape (n,)
        [s], non-decreasing.
    velocity : ndarray, shape (n, 2)
        The own ship's velocity [m/s].

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    t = np.asarray(times, float)
    v = np.asarray(velocity, float)
    c = np.vstack([np.zeros((1, 2)),  # displacement since t[0]
                   np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t)[:, None], axis=0)])
    lo = np.searchsorted(t, t - 0.5 * window, side="left")
    hi = np.clip(np.searchsorted(t, t + 0.5 * window, side="right") - 1, 0, t.size - 1)
    span = t[hi] - t[lo]
    vm = np.where(span[:, None] > 0, (c[hi] - c[lo]) / np.where(span > 0, span, 1.0)[:, None], v)
    course, speed = course_speed(vm)
    course = np.unwrap(np.asarray(course, float))
    dt_win = np.maximum(span, 1e-9)
    rate = np.abs(course[hi] - course[lo]) / dt_win
    dspeed = np.abs(np.asarray(speed)[hi] - np.asarray(speed)[lo])
    moving = np.asarray(speed) > 0.1
    return ((rate > course_rate) & moving) | (dspeed > speed_change)


def _rate_at(t: np.ndarray, b: np.ndarray, sigma: np.ndarray, at: float
             ) -> tuple[float, float]:
    """Bearing rate at time ``at`` [rad/s] and its std: the slope at ``at`` of the weighted
    least-squares parabola through the bearings (the rate drifts along a leg as the range
    changes)."""
    d = t - at
    A = np.column_stack([np.ones_like(d), d, d * d]) / sigma[:, None]
    cov = np.linalg.inv(A.T @ A)
    coef = cov @ (A.T @ (b / sigma))
    return float(coef[1]), float(np.sqrt(cov[1, 1]))


def ekelund_range(times: np.ndarray, bearing: np.ndarray, sigma: np.ndarray,
                  velocity: np.ndarray, *, window: float = 600.0, min_bearings: int = 5
                  ) -> EkelundRange | None:
    """Ekelund's range at the own ship's last manoeuvre within the bearings (module doc).

    Parameters
    ----------
    times : ndarray, shape (n,)
        Bearing times [s], non-decreasing.
    bearing, sigma : ndarray, shape (n,)
        Bearings and their standard deviations [rad].
    velocity : ndarray, shape (n, 2)
        The own ship's velocity at the bearing times [m/s].
    window : float
        Longest stretch of each leg used for its bearing rate [s].
    min_bearings : int
        Fewest bearings on each leg.

    Returns
    -------
    EkelundRange or None
        None when the own ship has not manoeuvred between two legs of ``min_bearings``.
    """
    t = np.asarray(times, float)
    b = np.unwrap(np.asarray(bearing, float))
    s = np.asarray(sigma, float)
    v = np.asarray(velocity, float)
    man = manoeuvres(t, v)
    if not man.any():
        return None
    # the last manoeuvre with a straight leg of enough bearings after it, else before the end
    idx = np.flatnonzero(man)
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    for j in range(len(runs) - 1, -1, -1):  # the last manoeuvre with two legs around it
        i0, i1 = int(runs[j][0]), int(runs[j][-1])
        start = int(runs[j - 1][-1]) + 1 if j else 0  # a leg stops at another manoeuvre
        stop = int(runs[j + 1][0]) if j + 1 < len(runs) else t.size
        before = np.arange(start, i0)
        before = before[t[before] >= t[i0] - window]
        after = np.arange(i1 + 1, stop)
        after = after[t[after] <= t[i1] + window]
        if before.size >= min_bearings and after.size >= min_bearings:
            break
    else:
        return None
    mid = 0.5 * (t[i0] + t[i1])
    r1, s1 = _rate_at(t[before], b[before], s[before], mid)
    r2, s2 = _rate_at(t[after], b[after], s[after], mid)
    v1, v2 = v[before].mean(axis=0), v[after].mean(axis=0)
    beta = float(np.interp(mid, t, b))
    n = np.array([np.cos(beta), -np.sin(beta)])
    num = float((v2 - v1) @ n)
    den = r1 - r2
    rng = num / den if den != 0 else np.nan
    std = abs(rng) * float(np.hypot(s1, s2)) / abs(den) if den != 0 else np.nan
    if not np.isfinite(rng) or rng <= 0:  # the rates changed the wrong way: noise only
        rng = np.nan
    return EkelundRange(time=mid, range=float(rng), std=float(std), rates=(r1, r2),
                        legs=((float(t[before[0]]), float(t[before[-1]])),
                              (float(t[after[0]]), float(t[after[-1]]))))
