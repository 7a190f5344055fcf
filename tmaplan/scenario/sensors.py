"""The scenario's sensors: bearings, ranges (pings or continuous) and frequency lines.

Each is a frozen dataclass told apart by its ``kind`` (the ``[[sensors]]`` tables of a file);
:func:`measurement_steps` gives the grid steps at which one measures.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, StrictBool

from tmaplan.scenario.quantities import (
    NonNegInt,
    PositiveAngle,
    PositiveFrequency,
    PositiveInt,
    PositiveLength,
    PositiveSpeed,
    PositiveTime,
    frozen,
)

__all__ = ["BearingSensor", "FrequencySensor", "RangeSensor", "Sensor", "measurement_steps"]


@frozen
class BearingSensor:
    """Passive bearing sensor: ``z = atan2(Δx, Δy) + v``, v ~ N(0, σ²).

    Measurement steps: ``steps`` if given, else ``first_step, first_step + every, ...``.

    Attributes
    ----------
    kind : "bearing"
    sigma : float
        Bearing noise std [rad].
    first_step : int
        First measurement step (1 by default: no bearing at t0).
    every : int
        Steps between measurements.
    steps : tuple of int, optional
        Explicit measurement steps (``first_step`` and ``every`` then keep their default 1).
    ambiguity : {"none", "pi"}
        "pi": bearing known modulo π, in (−π/2, π/2] (linear array, brehard2005 eq. 4).
    """

    kind: Literal["bearing"] = "bearing"
    sigma: PositiveAngle
    first_step: NonNegInt = 1
    every: PositiveInt = 1
    steps: tuple[NonNegInt, ...] | None = None
    ambiguity: Literal["none", "pi"] = "none"


@frozen
class RangeSensor:
    """Range sensor: active pings at chosen steps, or continuous range-only measurement.

    ``z = ‖r‖ + v``, v ~ N(0, σ²). Steps: the union of ``steps``; for ``period`` the first
    grid step at or after each multiple of the period (brehard2005 §6's "every 80 s" with
    δ = 6 s gives k = 14, 27, 40, 54, ...); for ``every`` the steps ``first_step + i·every``.
    No steps at all is allowed (a ping sensor left to the scheduler).

    Attributes
    ----------
    kind : "range"
    sigma : float
        Range noise std [m].
    steps : tuple of int
        Explicit ping steps.
    period : float, optional
        Ping period [s].
    every : int, optional
        Continuous ranging every n steps (range-only tracking).
    first_step : int
        First step for ``every`` (without ``every`` it keeps its default 1).
    active : bool
        True for an active sonar ping (reveals own ship; counts against the budget).
    max_range : float, optional
        Reach [m], > 0: a reading returns the range of every contact whose true range is at
        most ``max_range`` (one ping, several ranges); None (default): unlimited.
    """

    kind: Literal["range"] = "range"
    sigma: PositiveLength
    steps: tuple[NonNegInt, ...] = ()
    period: PositiveTime | None = None
    every: PositiveInt | None = None
    first_step: NonNegInt = 1
    active: StrictBool = True
    max_range: PositiveLength | None = None


@frozen
class FrequencySensor:
    """Narrow-band frequency lines: ``f_p(t) = f_p·(1 − Ṙ(t)/c) + v`` (clavard2013 eq. 3).

    Attributes
    ----------
    kind : "frequency"
    f0 : tuple of float
        Emitted tones f_p [Hz] (unknown to estimators).
    sigma : tuple of float
        Noise std per line [Hz].
    c : float
        Sound speed [m/s].
    first_step, every, steps
        As for :class:`BearingSensor`.
    """

    kind: Literal["frequency"] = "frequency"
    f0: tuple[PositiveFrequency, ...]
    sigma: tuple[PositiveFrequency, ...]
    c: PositiveSpeed = 1500.0
    first_step: NonNegInt = 1
    every: PositiveInt = 1
    steps: tuple[NonNegInt, ...] | None = None


Sensor = Annotated[BearingSensor | RangeSensor | FrequencySensor, Field(discriminator="kind")]


def measurement_steps(sensor: Any, grid: Any) -> np.ndarray:
    """Grid steps at which ``sensor`` measures, sorted, unique, shape (n,), dtype int.

    Parameters
    ----------
    sensor : BearingSensor | RangeSensor | FrequencySensor
    grid : TimeGrid
    """
    k_max = grid.n_steps
    if isinstance(sensor, RangeSensor):
        parts = [np.asarray(sensor.steps, dtype=int)]
        if sensor.period is not None:
            m = np.arange(1, int(np.floor(grid.horizon / sensor.period + 1e-9)) + 1)
            k = np.ceil(m * sensor.period / grid.dt - 1e-9).astype(int)
            parts.append(k[k <= k_max])
        if sensor.every is not None:
            parts.append(np.arange(sensor.first_step, k_max + 1, sensor.every))
        return np.unique(np.concatenate(parts)).astype(int)
    if sensor.steps is not None:
        return np.unique(np.asarray(sensor.steps, dtype=int))
    return np.arange(sensor.first_step, k_max + 1, sensor.every, dtype=int)
