"""Faults: what breaks the filter's assumptions, applied to the truth and the measurements only.

A scenario's optional ``[faults]`` table (:class:`Faults`) describes sensor and target faults
that :mod:`tmaplan.simulate` applies when it generates a run, never the filter's model (the
filters keep assuming Gaussian bearings, no bias and a nearly-constant-velocity target):

* ``wild_bearing_probability`` p and ``wild_bearing_spread`` s: each bearing is, with
  probability p, replaced by the true bearing plus a uniform error on [−s, s] (s = π: uniform
  on the circle, a clutter detection);
* ``bearing_bias``: a constant offset added to every bearing (misaligned array);
* ``dropouts``: time windows [start, end) in which a sensor kind delivers nothing (fades);
* ``missed_ping_probability``: a ping is transmitted (it counts against the budget) but,
  with this probability, no echo comes back;
* ``target_manoeuvres``: course and speed changes at given times the filter does not model.

A manoeuvre at time t acts at the first grid instant t_j ≥ t: the velocity from t_j on is offset
by ``v_new − v_old`` (the process-noise increments of the track are kept), and the positions
follow (``Δx_k = (t_k − t_j)·Δv``).

Example::

    [faults]
    wild_bearing_probability = 0.05
    wild_bearing_spread = "180 deg"
    bearing_bias = "0.5 deg"
    missed_ping_probability = 0.25
    dropouts = [{start = "10 min", end = "15 min", sensors = "bearing"}]
    target_manoeuvres = [{time = "22.5 min", course_change = "60 deg"}]
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field
from pydantic.dataclasses import dataclass as _pydantic_dataclass

from tmaplan.geometry import course_speed, velocity_from_course, wrap_angle, wrap_half_angle
from tmaplan.units import si_validator

__all__ = [
    "Dropout",
    "Faults",
    "TargetManoeuvre",
    "apply_manoeuvres",
    "corrupt_bearings",
    "dropped",
]

_CONFIG = ConfigDict(extra="forbid", arbitrary_types_allowed=False)

Probability = Annotated[float, si_validator("dimensionless"),
                        Field(allow_inf_nan=False, ge=0.0, le=1.0)]
WildProbability = Annotated[float, si_validator("dimensionless"),
                            Field(allow_inf_nan=False, ge=0.0, lt=1.0)]
Spread = Annotated[float, si_validator("angle"), Field(allow_inf_nan=False, gt=0.0, le=math.pi)]
Bias = Annotated[float, si_validator("angle"),
                 Field(allow_inf_nan=False, ge=-math.pi / 2, le=math.pi / 2)]
Angle = Annotated[float, si_validator("angle"), Field(allow_inf_nan=False)]
PositiveTime = Annotated[float, si_validator("time"), Field(allow_inf_nan=False, gt=0.0)]
NonNegTime = Annotated[float, si_validator("time"), Field(allow_inf_nan=False, ge=0.0)]
NonNegSpeed = Annotated[float, si_validator("speed"), Field(allow_inf_nan=False, ge=0.0)]


@_pydantic_dataclass(frozen=True, kw_only=True, config=_CONFIG)
class Dropout:
    """A sensor fade: no measurement of ``sensors`` at grid instants in [start, end).

    Attributes
    ----------
    start : float
        [s] on the scenario clock.
    end : float
        [s], > start.
    sensors : {"all", "bearing", "range"}
        Which measurements drop ("range": passive ranges and ping echoes; frequency lines
        only with "all").
    """

    start: NonNegTime
    end: PositiveTime
    sensors: Literal["all", "bearing", "range"] = "all"


@_pydantic_dataclass(frozen=True, kw_only=True, config=_CONFIG)
class TargetManoeuvre:
    """An unmodelled change of the target's course and/or speed.

    Give ``course_change`` (relative, clockwise positive) or ``course`` (absolute), and/or
    ``speed``.

    Attributes
    ----------
    time : float
        [s] on the scenario clock (acts at the first grid instant at or after it).
    course_change : float, optional
        [rad], added to the course at that instant.
    course : float, optional
        New course [rad], clockwise from North.
    speed : float, optional
        New speed [m/s] (default: keep the speed).
    """

    time: PositiveTime
    course_change: Angle | None = None
    course: Angle | None = None
    speed: NonNegSpeed | None = None


@_pydantic_dataclass(frozen=True, kw_only=True, config=_CONFIG)
class Faults:
    """Faults applied to the truth and the measurements of a simulated run (module docstring).

    Attributes
    ----------
    wild_bearing_probability : float
        Probability that a bearing is wild, in [0, 1).
    wild_bearing_spread : float
        Half-width of a wild bearing's uniform error about the truth [rad], in (0, π]
        (π: uniform on the circle).
    bearing_bias : float
        Constant bearing offset [rad], in [−π/2, π/2].
    missed_ping_probability : float
        Probability that a ping's echo is missed, in [0, 1].
    dropouts : tuple of Dropout
        Sensor fades.
    target_manoeuvres : tuple of TargetManoeuvre
        Unmodelled course/speed changes, in time order.
    """

    wild_bearing_probability: WildProbability = 0.0
    wild_bearing_spread: Spread = math.pi
    bearing_bias: Bias = 0.0
    missed_ping_probability: Probability = 0.0
    dropouts: tuple[Dropout, ...] = ()
    target_manoeuvres: tuple[TargetManoeuvre, ...] = ()


def dropped(faults: Faults | None, t: np.ndarray | float, kind: str) -> np.ndarray:
    """Whether measurements of ``kind`` ("bearing", "range" or "frequency") at times ``t`` [s]
    fall in a dropout window; boolean array of the shape of ``t``. Frequency lines drop only
    in an "all" window (:class:`Dropout`)."""
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
