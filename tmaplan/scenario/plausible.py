"""Plausibility of the values the schema accepts: impossible speeds and turn rates refused,
suspicious but legal values warned (one line naming the field, :func:`tmaplan.errors.warn_field`).

These rules read the scenario's own fields only (no motion model): :func:`check_speeds` and
:func:`check_turn_rates` are called by :func:`tmaplan.scenario.checks.check` (every
construction path), :func:`warn` by :func:`tmaplan.scenario.from_dict` (files and dicts; a
Python ``Scenario.replace`` is taken as meant). The rules that need the target's motion (a
contact outside its own prior, on the own ship) are in :mod:`tmaplan.models.plausibility`,
and the planner's (keep-out, memory) in :mod:`tmaplan.planning.feasibility`. Documented in
docs/scenario-files.md, "Plausibility".

Speeds
    In any unit: at most :data:`MAX_SPEED` = 150 m/s (≈ 292 kn) for the target (its
    unmodelled manoeuvres of ``[faults]`` too), the observer and the prior (speeds, velocity
    components and their stds). The sound speed of a frequency sensor is not a platform speed
    and is not limited.
Turn rates
    ``observer.turn_rate_max``, ``observer.legs[].turn_rate``, ``observer.turn_rates[]``
    and ``target.omega`` are refused above :data:`MAX_TURN_RATE` = 10 °/s (600 °/min, a
    full circle in 36 s): a ship turns on a circle of a few ship lengths (imo2002, the
    standards for ship manoeuvrability: tactical diameter at most 5 lengths; merchant ships
    turn in 3–4), so 10 °/s is a 60 m craft turning on its tightest circle at 30 kn, or a
    circle of 18 m radius at 6 kn; no ship or submarine that carries a sonar turns so fast,
    and a planner given such a limit plans turns on the spot that no ship flies (after
    minutes of solving; on ``default`` IPOPT also failed from every start). Warned above
    :data:`PLAUSIBLE_TURN_RATE` = 0.1 rad/s (5.7 °/s, the limit of a bare turn rate,
    :data:`tmaplan.scenario.bare.BARE_LIMITS`): a frigate's hard turn at 30 kn, not a
    ship's at a tracking speed. Rates of turn are often quoted per minute (a ship's
    rate-of-turn indicator): the messages give the per-minute reading.
Directions (courses, the prior's bearing and course means, the circle's phase)
    A direction beyond ±360° is taken modulo 360°: ``course = "400 deg"`` flies 40°, warned.
Angular spreads with an explicit unit
    Warned beyond the limits of a bare number (:data:`tmaplan.scenario.bare.BARE_LIMITS`):
    a bearing noise (``sensors[].sigma`` of a bearing sensor) above 0.2 rad (11.5°, a
    bearing that hardly informs, with an error model that ignores the wrap at ±180°); a
    prior's ``bearing_std`` or ``course_std`` above 1 rad (57°): a normal angle that wide
    wraps around the circle (almost uniform; say ``course_mode = "uniform"`` for an unknown
    course).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from tmaplan.display import angle, distance, rate, speed
from tmaplan.errors import ScenarioError, warn_field
from tmaplan.scenario.bare import BARE_LIMITS
from tmaplan.scenario.contacts import contact_field, contact_parts
from tmaplan.units import KNOT

__all__ = ["MAX_SPEED", "MAX_TURN_RATE", "PLAUSIBLE_TURN_RATE", "check_speeds",
           "check_turn_rates", "warn", "warnings_of"]

MAX_SPEED = 150.0
"""Largest plausible platform speed [m/s] (≈ 292 kn)."""

MAX_TURN_RATE = math.radians(10.0)
"""Largest turn rate of a ship [rad/s] (10 °/s); above it a scenario is refused."""
PLAUSIBLE_TURN_RATE = BARE_LIMITS["turn_rate"][0]
"""Turn rate [rad/s] above which a scenario is warned (0.1 rad/s, 5.7 °/s)."""


def _turn_rates(s: Any) -> Iterator[tuple[str, float, float | None]]:
    """``(field, |turn rate| [rad/s], speed [m/s] at which it is flown or None)``."""
    o, t = s.observer, s.target
    v0 = math.hypot(*o.velocity) if o.velocity is not None else o.speed
    if o.turn_rate_max is not None:
        yield "observer.turn_rate_max", o.turn_rate_max, o.speed_max or v0
    for i, leg in enumerate(o.legs):
        if leg.turn_rate is not None:
            yield f"observer.legs[{i}].turn_rate", leg.turn_rate, leg.speed or v0
    if o.turn_rates:
        i = max(range(len(o.turn_rates)), key=lambda j: abs(o.turn_rates[j]))
        yield f"observer.turn_rates[{i}]", abs(o.turn_rates[i]), v0
    if t.omega is not None:
        circle_speed = abs(t.omega) * t.radius if t.radius is not None else None
        yield "target.omega", abs(t.omega), circle_speed


def _circle(u: float, v: float | None) -> str:
    """``", a circle of radius 2 m at 6.0 kn"`` for turn rate ``u`` at speed ``v``."""
    if not v or not u:
        return ""
    return f", a circle of radius {distance(v / u)} at {speed(v)}"


def _per_minute(u: float) -> str:
    return f"{math.degrees(u) * 60:.4g} °/min"


def check_turn_rates(s: Any, source: str | None) -> None:
    """Refuse a turn rate above :data:`MAX_TURN_RATE` (module notes)."""
    for field, u, v in _turn_rates(s):
        if u > MAX_TURN_RATE * (1 + 1e-12):
            deg = math.degrees(u)
            raise ScenarioError(
                field, f"a ship's turn rate, at most {rate(MAX_TURN_RATE)} (600 °/min): a ship "
                "turns on a circle of a few ship lengths (imo2002: tactical diameter "
                f"at most 5 lengths); rates of turn are often given per minute: \"{deg:.4g} "
                f"deg/min\" is {deg / 60:.3g} °/s", f"{rate(u)} = {_per_minute(u)}"
                f"{_circle(u, v)}", source=source)


def _speeds(s: Any) -> Iterator[tuple[str, float]]:
    """Every platform speed of a scenario (SI), with its field name."""
    def norm(v: Any) -> float:
        return float(np.hypot(*v))

    t, o, p = s.target, s.observer, s.prior
    for name, obj in (("target", t), ("observer", o)):
        if obj.velocity is not None:
            yield f"{name}.velocity", norm(obj.velocity)
        if obj.speed is not None:
            yield f"{name}.speed", obj.speed
        for i, leg in enumerate(obj.legs):
            if leg.velocity is not None:
                yield f"{name}.legs[{i}].velocity", norm(leg.velocity)
            if leg.speed is not None:
                yield f"{name}.legs[{i}].speed", leg.speed
    if t.omega is not None and t.radius is not None:
        yield "target.omega", abs(t.omega) * t.radius
    for name in ("speed_min", "speed_max"):
        if getattr(o, name) is not None:
            yield f"observer.{name}", getattr(o, name)
    if p is not None:
        if p.velocity_mean is not None:
            yield "prior.velocity_mean", norm(p.velocity_mean)
        for name in ("velocity_std", "speed_mean", "speed_std", "speed_min", "speed_max"):
            if getattr(p, name) is not None:
                yield f"prior.{name}", getattr(p, name)
        if p.mean is not None:
            yield "prior.mean", norm(p.mean[2:])
        if p.std is not None:
            yield "prior.std", norm(p.std[2:])
    for i, m in enumerate(s.faults.target_manoeuvres if s.faults is not None else ()):
        if m.speed is not None:
            yield f"faults.target_manoeuvres[{i}].speed", m.speed


def check_speeds(s: Any, source: str | None) -> None:
    """Refuse a platform speed above :data:`MAX_SPEED` (module notes)."""
    for field, v in _speeds(s):
        if v > MAX_SPEED:
            raise ScenarioError(
                field, f"a speed of at most {MAX_SPEED:g} m/s ({MAX_SPEED / KNOT:.0f} kn, the "
                "plausibility limit for a ship, a submarine or a contact)",
                f"{v:.6g} m/s ({v / KNOT:.5g} kn)", source=source)


#: (file path of a direction, the values it holds)
def _directions(s: Any) -> Iterator[tuple[str, float]]:
    t, o, p = s.target, s.observer, s.prior
    for name in ("course", "phase"):
        if getattr(t, name) is not None:
            yield f"target.{name}", getattr(t, name)
    for i, leg in enumerate(t.legs):
        if leg.course is not None:
            yield f"target.legs[{i}].course", leg.course
    if o.course is not None:
        yield "observer.course", o.course
    for i, leg in enumerate(o.legs):
        if leg.course is not None:
            yield f"observer.legs[{i}].course", leg.course
    if p is not None:
        for name in ("bearing_mean", "course_mean"):
            if getattr(p, name) is not None:
                yield f"prior.{name}", getattr(p, name)
    for i, m in enumerate(s.faults.target_manoeuvres if s.faults is not None else ()):
        if m.course is not None:
            yield f"faults.target_manoeuvres[{i}].course", m.course


def _spreads(s: Any) -> Iterator[tuple[str, float, str]]:
    """``(field, angular std [rad], role in BARE_LIMITS)`` of the spreads that are used."""
    for i, sen in enumerate(s.sensors):
        if sen.kind == "bearing":
            yield f"sensors[{i}].sigma", sen.sigma, "bearing_noise"
    p = s.prior
    if p is None or p.kind != "polar":
        return
    yield "prior.bearing_std", p.bearing_std, "angle_std"
    if p.velocity_distribution == "speed-course" and p.course_mode not in (None, "uniform"):
        yield "prior.course_std", p.course_std, "angle_std"


def warnings_of(s: Any) -> list[tuple[str, str]]:
    """``(field, text)`` of every suspicious value (module notes), in file order."""
    out: list[tuple[str, str]] = []
    for field, a in _directions(s):
        if abs(a) > 2 * math.pi * (1 + 1e-12):
            wrapped = math.remainder(a, 2 * math.pi) % (2 * math.pi)
            out.append((field, f"a direction beyond ±360° is taken modulo 360°: "
                               f"{angle(a)} flies {angle(wrapped)} (write \""
                               f"{math.degrees(wrapped):.4g} deg\" if that is meant), "
                               f"received {angle(a)}"))
    for field, sd, role in _spreads(s):
        limit, _, what = BARE_LIMITS[role]
        if sd > limit * (1 + 1e-12):
            hint = ("a bearing barely informs and its normal error ignores the wrap at ±180°"
                    if role == "bearing_noise" else "a normal angle this wide wraps around "
                    "the circle, close to uniform" + (" (course_mode = \"uniform\" says an "
                                                      "unknown course)"
                                                      if field == "prior.course_std" else ""))
            out.append((field, f"{what} of at most {angle(limit)} is plausible ({hint}), "
                               f"received {angle(sd)}"))
    for field, u, v in _turn_rates(s):
        if u > PLAUSIBLE_TURN_RATE * (1 + 1e-12):
            out.append((field, f"a turn rate above {rate(PLAUSIBLE_TURN_RATE)} is a fast "
                               "craft's, not a ship's at a tracking speed (rates of turn are "
                               f"often given per minute), received {rate(u)} = "
                               f"{_per_minute(u)}{_circle(u, v)}"))
    return out


def warn(s: Any, source: str | None) -> None:
    """Issue a :class:`tmaplan.errors.ScenarioWarning` for each of :func:`warnings_of`, per
    contact (a shared field's once; a contact's field named by
    :func:`tmaplan.scenario.contacts.contact_field`)."""
    seen: set[tuple[str, str]] = set()
    for i, part in contact_parts(s):
        for field, text in warnings_of(part):
            field = contact_field(s, i, field)
            if (field, text) not in seen:
                seen.add((field, text))
                warn_field(field, text, source=source, stacklevel=3)
    manoeuvres = s.faults.target_manoeuvres if s.faults is not None else ()
    if manoeuvres and len(s.contacts) > 1:
        names = ", ".join(repr(c.name) for c in s.contacts)
        warn_field("faults.target_manoeuvres", f"a fault names no contact: every contact "
                   f"({names}) makes these {len(manoeuvres)} unmodelled course/speed "
                   "change(s) at the same times, received "
                   f"{len(manoeuvres)} manoeuvre(s) and {len(s.contacts)} contacts",
                   source=source, stacklevel=3)
