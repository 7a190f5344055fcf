"""Suspicious but legal scenarios that need the target's motion: warnings, one line each.

The truth (the target's true initial state, :func:`tmaplan.models.prior.true_initial_state`)
against the own ship and against the scenario's own prior; each rule gives a
:class:`tmaplan.errors.ScenarioWarning` naming the field (:func:`warn_suspicious`; the
command line runs it before every verb, :func:`tmaplan.cli.preflight.preflight`). The rules
that read a field alone are :mod:`tmaplan.scenario.plausible`'s, at load.

* The contact on the own ship: a true initial range below :data:`MIN_RANGE` (100 m, less
  than a ship's length): its bearing is undefined at zero range, and every bound's
  log-range coordinates with it.
* The truth outside its own prior (only for a prior's values that are given: a mean left to
  the truth is the truth): a polar prior's range outside [range_min, range_max], a true
  range, bearing, speed, course or velocity component more than :data:`SIGMAS` = 3 stds
  from the prior's mean (outside its 99.7 % interval; a normal range or speed is taken
  before its truncation), a gaussian prior's component likewise. A bearing more than 90°
  from the prior's is said to look the other way (a bearing of the own ship from the
  contact, 180° off, is the usual slip).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator

import numpy as np

from tmaplan.display import angle, distance, speed
from tmaplan.errors import warn_field
from tmaplan.geometry import angle_diff, bearing_of, course_speed, range_of
from tmaplan.models.prior import true_initial_state
from tmaplan.scenario import Prior, Scenario

__all__ = ["MIN_RANGE", "SIGMAS", "suspicious", "warn_suspicious"]

MIN_RANGE = 100.0
"""True initial range [m] below which the contact is on the own ship."""
SIGMAS = 3.0
"""Stds from a prior's mean beyond which the truth lies outside its prior."""


def _far(field: str, what: str, truth: float, mean: float, std: float,
         show: Callable[[float], str]) -> Iterator[tuple[str, str]]:
    """The warning when ``truth`` is more than :data:`SIGMAS` ``std`` from ``mean``;
    ``show`` formats a value in display units."""
    if std > 0 and abs(truth - mean) > SIGMAS * std:
        yield field, (f"the contact's true initial {what}, {show(truth)}, lies "
                      f"{abs(truth - mean) / std:.3g} σ from the prior's mean (more than "
                      f"{SIGMAS:g} σ: outside its own prior), received {show(mean)} ± "
                      f"{show(std)}")


def _outside(name: str, what: str, truth: float, lo: float, hi: float | None,
             show: Callable[[float], str]) -> list[tuple[str, str]]:
    """The warning when ``truth`` lies outside the prior's [``lo``, ``hi``] (``prior.<name>_min``
    or ``_max``; ``hi`` None: no upper bound)."""
    top = math.inf if hi is None else hi
    if lo <= truth <= top:
        return []
    field = f"prior.{name}_{'min' if truth < lo else 'max'}"
    return [(field, f"the contact's true {what}, {show(truth)}, lies outside the prior's "
                    f"{name} interval [{show(lo)}, {show(top) if hi is not None else '∞'}] "
                    f"(outside its own prior), received {show(lo if truth < lo else top)}")]


def _polar(p: Prior, rel: np.ndarray, vel: np.ndarray) -> Iterator[tuple[str, str]]:
    r, b = float(range_of(rel)), float(bearing_of(rel))
    course, spd = (float(x) for x in course_speed(vel))
    outside = _outside("range", "initial range", r, p.range_min, p.range_max, distance)
    yield from outside
    if not outside and p.range_distribution == "normal" and p.range_mean is not None:
        yield from _far("prior.range_mean", "range", r, p.range_mean, p.range_std or 0.0,
                        distance)
    if p.bearing_mean is not None:
        off = abs(float(angle_diff(b, p.bearing_mean)))
        if off > math.pi / 2:
            yield "prior.bearing_mean", (
                f"the prior looks the other way: its bearing is {angle(off)} from the "
                f"contact's true initial bearing {angle(b % (2 * math.pi))} (the bearing of "
                "the contact from the own ship is meant, not the reverse), received "
                f"{angle(p.bearing_mean)}")
        elif off > SIGMAS * p.bearing_std:
            yield "prior.bearing_mean", (
                f"the contact's true initial bearing, {angle(b % (2 * math.pi))}, lies "
                f"{off / p.bearing_std:.3g} σ from the prior's mean (more than {SIGMAS:g} σ: "
                f"outside its own prior), received {angle(p.bearing_mean)} ± "
                f"{angle(p.bearing_std)}")
    if p.velocity_distribution == "normal":
        if p.velocity_mean is not None:
            for i, axis in enumerate(("east", "north")):
                yield from _far(f"prior.velocity_mean[{i}]", f"{axis} velocity",
                                float(vel[i]), p.velocity_mean[i], p.velocity_std, speed)
        return
    outside = _outside("speed", "speed", spd, p.speed_min, p.speed_max, speed)
    yield from outside
    if not outside and p.speed_distribution == "normal" and p.speed_mean is not None:
        yield from _far("prior.speed_mean", "speed", spd, p.speed_mean, p.speed_std, speed)
    c_mean = {"given": p.course_mean,
              "reciprocal-bearing": None if p.bearing_mean is None else p.bearing_mean + math.pi,
              }.get(p.course_mode or "")
    if c_mean is not None and p.course_std > 0:
        off = abs(float(angle_diff(course, c_mean)))
        if off > SIGMAS * p.course_std:
            field = "prior.course_mean" if p.course_mode == "given" else "prior.course_std"
            yield field, (f"the contact's true course, {angle(course % (2 * math.pi))}, lies "
                          f"{off / p.course_std:.3g} σ from the prior's course "
                          f"{angle(c_mean % (2 * math.pi))} (more than {SIGMAS:g} σ: outside "
                          f"its own prior), received ± {angle(p.course_std)}")


def suspicious(scenario: Scenario) -> list[tuple[str, str]]:
    """``(field, text)`` of every rule of the module notes that the scenario breaks.

    Parameters
    ----------
    scenario : Scenario

    Returns
    -------
    list of (str, str)
        The field named and the one-line text of its warning, in the notes' order.
    """
    x0 = true_initial_state(scenario)
    rel = x0[:2] - np.asarray(scenario.observer.position, float)
    out: list[tuple[str, str]] = []
    r = float(range_of(rel))
    if r < MIN_RANGE:
        field = "target.position" if scenario.target.position is not None else "target.centre"
        out.append((field, f"the contact starts {distance(r)} from the own ship (less than "
                           f"{distance(MIN_RANGE)}: on the own ship, where its bearing is "
                           "undefined), received a true initial range of "
                           f"{distance(r)}"))
        return out  # no bearing to compare with the prior's
    p = scenario.prior
    if p is None:
        return out
    if p.kind == "gaussian":
        if p.mean is not None:
            show = (distance, distance, speed, speed)
            for i in range(4):
                out += _far(f"prior.mean[{i}]", ("east position", "north position",
                                                 "east velocity", "north velocity")[i],
                            float(x0[i]), p.mean[i], p.std[i] if p.std else 0.0, show[i])
        return out
    out += _polar(p, rel, x0[2:])
    return out


def warn_suspicious(scenario: Scenario, *, prior: bool = True) -> None:
    """Issue a :class:`tmaplan.errors.ScenarioWarning` for each of :func:`suspicious`,
    naming the scenario; ``prior=False``: not those on the prior (a computation that does
    not read it)."""
    for field, text in suspicious(scenario):
        if prior or not field.startswith("prior."):
            warn_field(field, text, source=scenario.name, stacklevel=2)
