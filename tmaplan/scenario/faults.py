"""The scenario's ``[faults]`` table: what breaks the filter's assumptions.

A scenario's optional ``[faults]`` table (:class:`Faults`) describes sensor and target faults
that :mod:`tmaplan.simulate` applies to the truth and the measurements when it generates a run
(:mod:`tmaplan.models.faults`), never to the filter's model (the filters keep assuming
Gaussian bearings, no bias and a nearly-constant-velocity target):

* ``wild_bearing_probability`` p and ``wild_bearing_spread`` s: each bearing is, with
  probability p, replaced by the true bearing plus a uniform error on [−s, s] (s = π: uniform
  on the circle, a clutter detection);
* ``bearing_bias``: a constant offset added to every bearing (misaligned array);
* ``dropouts``: time windows [start, end) in which a sensor kind delivers nothing (fades);
* ``missed_ping_probability``: a ping is transmitted (it counts against the budget) but,
  with this probability, no echo comes back;
* ``target_manoeuvres``: course and speed changes at given times the filter does not model.

Example::

    [faults]
    wild_bearing_probability = 0.05
    wild_bearing_spread = "180 deg"
    bearing_bias = "0.5 deg"
    missed_ping_probability = 0.25
    dropouts = [{start = "10 min", end = "15 min", sensors = "bearing"}]
    target_manoeuvres = [{time = "22.5 min", course_change = "60 deg"}]

The per-value rules (probabilities in [0, 1], a wild-bearing spread in (0, π], a bias within
±π/2, units) are in the dataclass annotations; :func:`check_faults` checks what they cannot:
dropout windows with ``end > start`` inside the horizon, and target manoeuvres inside the
horizon, in time order, each changing something and giving a course one way only. Every rule
raises :class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received
value.
"""

from __future__ import annotations

import math
from typing import Any, Literal

from tmaplan.errors import ScenarioError
from tmaplan.scenario.quantities import (
    Angle,
    Bias,
    NonNegSpeed,
    NonNegTime,
    PositiveTime,
    Probability,
    Spread,
    WildProbability,
    frozen,
)

__all__ = ["Dropout", "Faults", "TargetManoeuvre", "check_faults"]


@frozen
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


@frozen
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


@frozen
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


def check_faults(faults: Faults, grid: Any, source: str | None) -> None:
    """Validate ``faults`` against the time grid; raise ScenarioError on the first violation.

    Parameters
    ----------
    faults : Faults
    grid : TimeGrid
    source : str or None
        File or problem name for the message.
    """
    t0, t1 = float(grid.t0), float(grid.t0 + grid.horizon)
    for i, d in enumerate(faults.dropouts):
        f = f"faults.dropouts[{i}]"
        if d.end <= d.start:
            raise ScenarioError(f"{f}.end", f"> start = {d.start} s", d.end, source=source)
        if not t0 <= d.start <= t1:
            raise ScenarioError(f"{f}.start", f"within the horizon [{t0}, {t1}] s", d.start,
                                source=source)
    last = t0
    for i, m in enumerate(faults.target_manoeuvres):
        f = f"faults.target_manoeuvres[{i}]"
        if not t0 < m.time <= t1:
            raise ScenarioError(f"{f}.time", f"within the horizon ({t0}, {t1}] s", m.time,
                                source=source)
        if i and m.time <= last:
            raise ScenarioError(f"{f}.time", f"> {last} s (manoeuvres in time order)", m.time,
                                source=source)
        last = m.time
        if m.course is not None and m.course_change is not None:
            raise ScenarioError(f"{f}.course", "either 'course' or 'course_change', not both",
                                {"course": m.course, "course_change": m.course_change},
                                source=source)
        if m.course is None and m.course_change is None and m.speed is None:
            raise ScenarioError(f"{f}.course_change", "'course_change', 'course' or 'speed'",
                                None, source=source)
