"""Faults applied to the truth and the measurements of a simulated run.

The scenario's ``[faults]`` table (:class:`tmaplan.scenario.Faults`, its fields and rules in
:mod:`tmaplan.scenario.faults`) is applied here by :mod:`tmaplan.simulate`, never to the
filter's model: dropouts remove measurements (:func:`dropped`), wild bearings and a bias
corrupt the bearings (:func:`corrupt_bearings`), and unmodelled manoeuvres change the true
track (:func:`apply_manoeuvres`).

A manoeuvre at time t acts at the first grid instant t_j ≥ t: the velocity from t_j on is offset
by ``v_new − v_old`` (the process-noise increments of the track are kept), and the positions
follow (``Δx_k = (t_k − t_j)·Δv``).
"""

from __future__ import annotations

import numpy as np

from tmaplan.geometry import course_speed, velocity_from_course, wrap_angle, wrap_half_angle
from tmaplan.scenario.faults import Faults

__all__ = ["apply_manoeuvres", "corrupt_bearings", "dropped"]


def dropped(faults: Faults | None, t: np.ndarray | float, kind: str) -> np.ndarray:
    """Whether measurements of ``kind`` ("bearing", "range" or "frequency") at times ``t`` [s]
    fall in a dropout window; boolean array of the shape of ``t``. Frequency lines drop only
    in an "all" window (:class:`tmaplan.scenario.faults.Dropout`)."""
    t = np.asarray(t, float)
    out = np.zeros(t.shape, bool)
    for d in faults.dropouts if faults is not None else ():
        if d.sensors in ("all", kind):
            out |= (t >= d.start) & (t < d.end)
    return out


def corrupt_bearings(faults: Faults | None, values: np.ndarray, truth: np.ndarray,
                     u: np.ndarray, *, ambiguity: str = "none") -> np.ndarray:
    """Bearings with bias and wild values.

    Parameters
    ----------
    faults : Faults or None
        None returns ``values`` unchanged.
    values, truth : ndarray, shape (n,)
        Noisy and noise-free bearings [rad].
    u : ndarray, shape (n, 2)
        Uniform draws on [0, 1): column 0 decides wildness, column 1 the wild value.
    ambiguity : {"none", "pi"}
        Wrapping of the result ((−π, π] or (−π/2, π/2]).

    Returns
    -------
    ndarray, shape (n,)
        [rad].
    """
    values = np.asarray(values, float)
    if faults is None:
        return values
    u = np.asarray(u, float).reshape(-1, 2)
    wild = u[:, 0] < faults.wild_bearing_probability
    wild_value = np.asarray(truth, float) + faults.wild_bearing_spread * (2.0 * u[:, 1] - 1.0)
    out = np.where(wild, wild_value, values) + faults.bearing_bias
    return wrap_half_angle(out) if ambiguity == "pi" else wrap_angle(out)


def apply_manoeuvres(faults: Faults | None, target: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The absolute target track with the unmodelled manoeuvres applied (module docstring).

    Parameters
    ----------
    faults : Faults or None
    target : ndarray, shape (K + 1, 4)
        [x, y, v_x, v_y] [m, m/s].
    times : ndarray, shape (K + 1,)
        [s].

    Returns
    -------
    ndarray, shape (K + 1, 4)
        A new array (``target`` itself if there is no manoeuvre).
    """
    if faults is None or not faults.target_manoeuvres:
        return target
    x = np.array(target, float, copy=True)
    times = np.asarray(times, float)
    for m in faults.target_manoeuvres:
        after = np.nonzero(times >= m.time - 1e-9)[0]
        if after.size == 0:
            continue
        j = int(after[0])
        course, speed = (float(c) for c in course_speed(x[j, 2:]))
        if m.course is not None:
            course = float(m.course)
        elif m.course_change is not None:
            course += float(m.course_change)
        if m.speed is not None:
            speed = float(m.speed)
        dv = np.asarray(velocity_from_course(speed, course), float) - x[j, 2:]
        x[j:, 2:] += dv
        x[j:, :2] += (times[j:] - times[j])[:, None] * dv
    return x
