"""Bare numbers in a scenario file are SI: a bare angle or turn rate implausible in SI is refused.

A bare number (no unit) is SI, so a bare angle is radians. A bare number beyond
:data:`BARE_LIMITS` is almost surely degrees and is refused with a message suggesting the unit
(:func:`check_bare_numbers`, run by :func:`tmaplan.scenario.from_dict` on the raw file data): a
direction (course, heading, bearing, phase) beyond 2π rad; a bearing noise (``sensors[].sigma``
of a bearing sensor) above 0.2 rad (11.5°); a prior angular std (``bearing_std``,
``course_std``) above 1 rad (57°); a turn rate (``omega``, ``turn_rate``, ``turn_rate_max``,
``turn_rates``) above 0.1 rad/s (5.7 °/s); a bearing bias above 0.2 rad. Any of these values is
accepted with an explicit unit (``"0.3 rad"``, ``"15 deg"``), and :func:`tmaplan.scenario.dump`
writes such values with their unit so that files round-trip (:func:`with_units`). Documented
in docs/scenario-files.md.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from typing import Any

from tmaplan.errors import ScenarioError

__all__ = ["BARE_LIMITS", "check_bare_numbers", "with_units"]

#: role -> (largest plausible bare value in SI, SI unit, what the value is)
BARE_LIMITS: dict[str, tuple[float, str, str]] = {
    "direction": (2 * math.pi, "rad", "a direction (course, heading, bearing)"),
    "bearing_noise": (0.2, "rad", "a bearing noise"),
    "angle_std": (1.0, "rad", "an angular prior std"),
    "turn_rate": (0.1, "rad/s", "a turn rate"),
    "bearing_bias": (0.2, "rad", "a bearing bias"),
}

# dotted path in the file ("*" = every list item) -> role
_BARE_FIELDS: tuple[tuple[str, str], ...] = (
    ("target.course", "direction"), ("target.phase", "direction"),
    ("target.omega", "turn_rate"), ("target.legs.*.course", "direction"),
    ("observer.course", "direction"), ("observer.heading_min", "direction"),
    ("observer.heading_max", "direction"), ("observer.legs.*.course", "direction"),
    ("observer.legs.*.turn_rate", "turn_rate"), ("observer.turn_rate_max", "turn_rate"),
    ("observer.turn_rates.*", "turn_rate"), ("sensors.*.sigma", "bearing_noise"),
    ("prior.bearing_mean", "direction"), ("prior.course_mean", "direction"),
    ("prior.bearing_std", "angle_std"), ("prior.course_std", "angle_std"),
    ("faults.bearing_bias", "bearing_bias"), ("faults.wild_bearing_spread", "direction"),
    ("faults.target_manoeuvres.*.course", "direction"),
    ("faults.target_manoeuvres.*.course_change", "direction"),
)

# the same fields of each [[contacts]] table
_BARE_FIELDS += tuple((f"contacts.*.{path}", role) for path, role in _BARE_FIELDS
                      if path.split(".", 1)[0] in ("target", "prior"))

_BARE_RE = re.compile(r"^\s*[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\s*$")

def _walk(node: Any, parts: list[str], where: str, parent: Any = None
          ) -> Iterator[tuple[str, Any, Any, Any]]:
    """Yield ``(field, container, key, value)`` for every value at ``parts`` under ``node``
    (``parent`` is the table holding a list item, to read a sensor's ``kind``)."""
    if not parts:
        return
    head, rest = parts[0], parts[1:]
    if head == "*":
        if not isinstance(node, list):
            return
        for i, item in enumerate(node):
            if rest:
                yield from _walk(item, rest, f"{where}[{i}]", item)
            else:
                yield f"{where}[{i}]", node, i, item
        return
    if not isinstance(node, dict) or head not in node:
        return
    field = f"{where}.{head}" if where else head
    if rest:
        yield from _walk(node[head], rest, field, parent)
    else:
        yield field, node, head, node[head]


def _role_values(data: Any) -> Iterator[tuple[str, str, Any, Any, Any]]:
    """``(field, role, container, key, value)`` of every angle/turn-rate value in ``data``."""
    for path, role in _BARE_FIELDS:
        for field, box, key, value in _walk(data, path.split("."), ""):
            if role == "bearing_noise" and box.get("kind") != "bearing":
                continue
            yield field, role, box, key, value


def _bare(value: Any) -> float | None:
    """The value of a bare number (int, float or unit-less string), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str) and _BARE_RE.match(value):
        return float(value)
    return None


def check_bare_numbers(data: Any, source: str | None) -> None:
    """Refuse bare angles and turn rates that are implausible in SI (see the module notes).

    Raises
    ------
    ScenarioError
        ``field 'sensors[0].sigma': expected a bearing noise of at most 0.2 rad (11.5°) as a
        bare number: 1.5 rad (85.9°) is implausible; write "1.5 deg" if you meant degrees
        (or "1.5 rad" to keep radians), received 1.5``.
    """
    for field, role, _, _, value in _role_values(data):
        v = _bare(value)
        limit, unit, what = BARE_LIMITS[role]
        if v is None or not math.isfinite(v) or abs(v) <= limit:
            continue
        per = "/s" if unit == "rad/s" else ""
        deg = "deg/s" if per else "deg"
        raise ScenarioError(
            field, f"{what} of at most {limit:.4g} {unit} ({math.degrees(limit):.3g}°{per}) "
            f"as a bare number (bare numbers are SI): {v:g} {unit} ({math.degrees(v):.4g}°"
            f"{per}) is implausible; write \"{v:g} {deg}\" if you meant degrees (or \"{v:g} "
            f"{unit}\" to keep it)", value, source=source)


def with_units(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (from :func:`tmaplan.scenario.to_dict`, SI) with every angle or turn rate that
    :func:`check_bare_numbers` would refuse as a bare number written with its SI unit
    (``"0.2617993877991494 rad"``), so that ``loads(dump(s)) == s`` for every scenario.
    Modifies and returns ``data``."""
    for _, role, box, key, value in list(_role_values(data)):
        limit, unit, _ = BARE_LIMITS[role]
        if isinstance(value, float) and abs(value) > limit:
            box[key] = f"{value!r} {unit}"
    return data
