"""Cross-field validation of scenarios (what the type annotations alone cannot say).

Every rule raises :class:`tmaplan.errors.ScenarioError` naming the field, the expected and
the received value. :func:`check` is called by :func:`tmaplan.scenario.from_dict` and
``Scenario.replace``; :func:`check_bare_numbers` by ``from_dict`` on the raw file data.

Plausibility limits (documented in docs/scenario-files.md):

* Speeds, in any unit: at most :data:`MAX_SPEED` = 150 m/s (≈ 292 kn) for the target (its
  unmodelled manoeuvres of ``[faults]`` too), the observer and the prior (speeds, velocity
  components and their stds). The sound speed of a
  frequency sensor is not a platform speed and is not limited.
* Bare numbers are SI, so a bare angle is radians. A bare number beyond :data:`BARE_LIMITS`
  is almost surely degrees and is refused with a message suggesting the unit: a direction
  (course, heading, bearing, phase) beyond 2π rad; a bearing noise (``sensors[].sigma`` of a
  bearing sensor) above 0.2 rad (11.5°); a prior angular std (``bearing_std``,
  ``course_std``) above 1 rad (57°); a turn rate (``omega``, ``turn_rate``,
  ``turn_rate_max``, ``turn_rates``) above 0.1 rad/s (5.7 °/s). Any of these values is
  accepted with an explicit unit (``"0.3 rad"``, ``"15 deg"``), and :func:`tmaplan.scenario.dump`
  writes such values with their unit so that files round-trip.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterator
from typing import Any

import numpy as np

from tmaplan.errors import ScenarioError, is_whole_count, whole_steps_text
from tmaplan.units import KNOT

__all__ = ["BARE_LIMITS", "MAX_SPEED", "check", "check_bare_numbers", "truth_fields",
           "with_units"]

MAX_SPEED = 150.0
"""Largest plausible platform speed [m/s] (≈ 292 kn)."""

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

_BARE_RE = re.compile(r"^\s*[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\s*$")


def _err(field: str, expected: str, received: Any, source: str | None) -> ScenarioError:
    return ScenarioError(field, expected, received, source=source)


def _check_velocity(obj: Any, field: str, source: str | None, *, required: bool) -> None:
    has_v = obj.velocity is not None
    has_cs = obj.course is not None
    if has_v and (has_cs or obj.speed is not None):
        raise _err(f"{field}.velocity", "either 'velocity' or 'course'/'speed', not both",
                   {"velocity": obj.velocity, "course": obj.course, "speed": obj.speed}, source)
    if required and not has_v and not (has_cs and obj.speed is not None):
        raise _err(f"{field}.velocity", "'velocity' = [v_x, v_y] or both 'course' and 'speed'",
                   None, source)


def check(s: Any, source: str | None) -> None:
    """Validate a constructed scenario; raise ScenarioError on the first violated rule."""
    name = s.name
    if not name.strip() or name in (".", "..") or any(c in "/\\" or ord(c) < 32 for c in name):
        raise _err("name", "a non-empty name without '/', '\\' or control characters (the "
                   "command line names its output files after it)", name, source)
    g = s.time
    if not is_whole_count(g.horizon / g.dt):
        raise _err("time.horizon", whole_steps_text(g.dt), g.horizon, source)
    n = g.n_steps
    t = s.target
    if t.model in ("ncv", "multi-leg"):
        if t.position is None:
            raise _err("target.position", f"[x, y] for model '{t.model}'", None, source)
        _check_velocity(t, "target", source, required=True)
        for name in ("centre", "radius", "phase", "omega"):
            if getattr(t, name) is not None:
                raise _err(f"target.{name}", f"absent for model '{t.model}'",
                           getattr(t, name), source)
        if t.model == "ncv" and t.legs:
            raise _err("target.legs", "no legs for model 'ncv' (use 'multi-leg')", t.legs, source)
        if t.model == "multi-leg" and not t.legs:
            raise _err("target.legs", "at least one leg for model 'multi-leg'", t.legs, source)
    else:
        for name in ("centre", "radius", "phase", "omega"):
            if getattr(t, name) is None:
                raise _err(f"target.{name}", "a value for model 'constant-turn'", None, source)
        if t.omega == 0.0:
            raise _err("target.omega", "a non-zero turn rate (use model 'ncv' for a straight "
                       "track)", t.omega, source)
        for name in ("position", "velocity", "course", "speed"):
            if getattr(t, name) is not None:
                raise _err(f"target.{name}", "absent for model 'constant-turn' (the circle "
                           "defines the track)", getattr(t, name), source)
        if t.legs:
            raise _err("target.legs", "no legs for model 'constant-turn'", t.legs, source)
        if t.q != 0.0:
            raise _err("target.q", "0 for the deterministic model 'constant-turn'", t.q, source)
    last = -np.inf
    for i, leg in enumerate(t.legs):
        _check_velocity(leg, f"target.legs[{i}]", source, required=True)
        if leg.start <= last:
            raise _err(f"target.legs[{i}].start", f"> {last} s (legs in time order)",
                       leg.start, source)
        if leg.start <= g.t0:
            raise _err(f"target.legs[{i}].start", f"> t0 = {g.t0} s (target.position and its "
                       "velocity hold at t0)", leg.start, source)
        if leg.start > g.t0 + g.horizon:
            raise _err(f"target.legs[{i}].start", f"within the horizon ({g.t0}, "
                       f"{g.t0 + g.horizon}] s", leg.start, source)
        last = leg.start

    o = s.observer
    if o.turn_rates:
        _check_velocity(o, "observer", source, required=True)
        if o.legs:
            raise _err("observer.turn_rates", "either 'legs' or 'turn_rates', not both",
                       len(o.turn_rates), source)
        if len(o.turn_rates) != n:
            raise _err("observer.turn_rates", f"one turn rate per step ({n} values)",
                       len(o.turn_rates), source)
    else:
        _check_velocity(o, "observer", source, required=True)
    if o.speed_max is not None and o.speed_max < o.speed_min:
        raise _err("observer.speed_max", f">= observer.speed_min = {o.speed_min} m/s",
                   o.speed_max, source)
    speeds: list[tuple[str, float]] = []
    v0 = (np.hypot(*o.velocity) if o.velocity is not None else float(o.speed or 0.0))
    speeds.append(("observer.speed" if o.velocity is None else "observer.velocity", v0))
    last = -np.inf
    for i, leg in enumerate(o.legs):
        f = f"observer.legs[{i}]"
        _check_velocity(leg, f, source, required=False)
        if leg.velocity is None and leg.course is None and leg.speed is None:
            raise _err(f"{f}.course", "'velocity', 'course' or 'speed'", None, source)
        if leg.start <= last:
            raise _err(f"{f}.start", f"> {last} s (legs in time order)", leg.start, source)
        if not g.t0 <= leg.start <= g.t0 + g.horizon:
            raise _err(f"{f}.start", f"within the horizon [{g.t0}, {g.t0 + g.horizon}] s",
                       leg.start, source)
        last = leg.start
        if leg.velocity is not None:
            speeds.append((f"{f}.velocity", float(np.hypot(*leg.velocity))))
        elif leg.speed is not None:
            speeds.append((f"{f}.speed", leg.speed))
        if leg.turn_rate is not None and o.turn_rate_max is not None \
                and leg.turn_rate > o.turn_rate_max * (1 + 1e-12):
            raise _err(f"{f}.turn_rate", f"<= observer.turn_rate_max = {o.turn_rate_max} rad/s",
                       leg.turn_rate, source)
    for field, v in speeds:
        if v < o.speed_min * (1 - 1e-12) or (o.speed_max is not None
                                              and v > o.speed_max * (1 + 1e-12)):
            raise _err(field, f"a speed within [{o.speed_min}, {o.speed_max}] m/s", v, source)
    if o.turn_rate_max is not None:
        for i, u in enumerate(o.turn_rates):
            if abs(u) > o.turn_rate_max * (1 + 1e-12):
                raise _err(f"observer.turn_rates[{i}]",
                           f"|u| <= observer.turn_rate_max = {o.turn_rate_max} rad/s", u, source)
    from tmaplan._scenario_plausible import check as check_turn_rates

    check_turn_rates(s, source)  # no ship turns faster than 10 °/s
    if any(leg.turn_rate is not None for leg in o.legs):
        from tmaplan.models.observer import observer_track

        observer_track(o, g, source=source)  # refuses a leg starting inside the previous turn
    if o.heading_min is not None and o.heading_max is not None \
            and o.heading_min >= o.heading_max:
        raise _err("observer.heading_max", f"> heading_min = {o.heading_min} rad",
                   o.heading_max, source)

    if not s.sensors:
        raise _err("sensors", "at least one sensor", [], source)
    for i, sen in enumerate(s.sensors):
        f = f"sensors[{i}]"
        steps = sen.steps if getattr(sen, "steps", None) is not None else ()
        for j, kk in enumerate(steps):
            if kk > n:
                raise _err(f"{f}.steps[{j}]", f"a step within the horizon, 0..{n}", kk, source)
        if getattr(sen, "first_step", 0) > n:
            raise _err(f"{f}.first_step", f"a step within the horizon, 0..{n}",
                       sen.first_step, source)
        _check_sensor_keys(sen, f, source)
        if sen.kind == "frequency":
            if len(sen.f0) == 0:
                raise _err(f"{f}.f0", "at least one frequency line", sen.f0, source)
            if len(sen.sigma) != len(sen.f0):
                raise _err(f"{f}.sigma", f"one std per line ({len(sen.f0)} values)",
                           len(sen.sigma), source)
        if sen.kind == "range" and sen.period is not None and sen.period < g.dt:
            raise _err(f"{f}.period", f">= dt = {g.dt} s", sen.period, source)

    _check_speeds(s, source)
    p = s.prior
    if p is not None:
        _check_prior(p, source)
        _check_prior_keys(p, source)
        if p.kind == "gaussian":
            if p.std is None:
                raise _err("prior.std", "[σ_x, σ_y, σ_vx, σ_vy] for a gaussian prior", None,
                           source)
        else:
            if p.range_distribution == "normal" and p.range_std is None:
                raise _err("prior.range_std", "a range std for range_distribution 'normal'",
                           None, source)
            if p.range_distribution in ("uniform", "log-uniform"):
                if p.range_max is None:
                    raise _err("prior.range_max", f"a value for '{p.range_distribution}'",
                               None, source)
                if p.range_distribution == "log-uniform" and p.range_min <= 0:
                    raise _err("prior.range_min", "> 0 for 'log-uniform'", p.range_min, source)
            if p.range_max is not None and p.range_max <= p.range_min:
                raise _err("prior.range_max", f"> range_min = {p.range_min} m", p.range_max,
                           source)
            if p.velocity_distribution == "speed-course":
                if p.speed_distribution == "uniform" and p.speed_max is None:
                    raise _err("prior.speed_max", "a value for speed_distribution 'uniform'",
                               None, source)
                if p.speed_max is not None and p.speed_max <= p.speed_min:
                    raise _err("prior.speed_max", f"> speed_min = {p.speed_min} m/s",
                               p.speed_max, source)
                if p.course_mode == "given" and p.course_mean is None:
                    raise _err("prior.course_mean", "a value for course_mode 'given'", None,
                               source)
            _check_point_means(p, source)
            if t.model == "constant-turn" and (p.range_mean is None or p.bearing_mean is None):
                raise _err("prior", "explicit means for a constant-turn target", None, source)
        _check_prior_spreads(p, source)

    est = s.estimation
    if est is not None and est.turn_direction != "either" and t.model != "constant-turn":
        raise _err("estimation.turn_direction", "'either' unless the target model is "
                   "'constant-turn'", est.turn_direction, source)

    pl = s.planning
    if pl is not None:
        for i, (a, b) in enumerate(pl.ping_forbidden):
            if b <= a:
                raise _err(f"planning.ping_forbidden[{i}]", "[start, end] with end > start",
                           [a, b], source)
        for field in ("control_interval", "replan_interval"):
            v = getattr(pl, field)
            if v is not None and not is_whole_count(v / g.dt):
                raise _err(f"planning.{field}", whole_steps_text(g.dt), v, source)
        if pl.ping_budget > n:
            raise _err("planning.ping_budget", f"<= the number of steps ({n})", pl.ping_budget,
                       source)
    if s.faults is not None:
        from tmaplan._scenario_faults import check_faults

        check_faults(s.faults, g, source)


def _ignored_prior_keys(p: Any) -> dict[str, str]:
    """Fields of prior ``p`` that :func:`tmaplan.models.prior.sample_prior` does not read (nor
    the consistency monitor, which bounds its rejuvenation by ``range_min``, ``range_max``
    and ``speed_max`` of any prior), each with the setting that makes it unused (``"kind"``,
    ``"range_distribution"``, …)."""
    gaussian = ("mean", "std")
    common = ("kind", "samples", "seed", "centred_on_truth")
    polar = tuple(f.name for f in dataclasses.fields(p) if f.name not in gaussian + common)
    speed_course = ("speed_distribution", "speed_mean", "speed_std", "speed_min", "speed_max",
                    "course_mode", "course_mean", "course_std")
    rules = (  # (selector, it makes the names unused, names); the first rule names the setting
        ("kind", p.kind == "gaussian", polar),
        ("kind", p.kind == "polar", gaussian),
        ("range_distribution", p.range_distribution != "normal", ("range_mean", "range_std")),
        ("velocity_distribution", p.velocity_distribution == "normal", speed_course),
        ("velocity_distribution", p.velocity_distribution == "speed-course",
         ("velocity_mean", "velocity_std")),
        ("speed_distribution", p.speed_distribution == "uniform", ("speed_mean", "speed_std")),
        ("course_mode", p.course_mode != "given", ("course_mean",)),
        ("course_mode", p.course_mode == "uniform", ("course_std",)),
    )
    # the support bounds of the consistency monitor's rejuvenation, whatever the sampling
    # (tmaplan.estimators.consistency): never unused
    monitor = ("range_min", "range_max", "speed_max")
    out: dict[str, str] = {}
    for selector, unused, names in rules:
        for name in names if unused else ():
            if name not in monitor:
                out.setdefault(name, selector)
    return out


def _check_prior_keys(p: Any, source: str | None) -> None:
    """Refuse a prior key that the chosen kind, distribution or course mode ignores, unless it
    keeps its default (:func:`tmaplan.scenario.dump` writes defaults, so files round-trip)."""
    ignored = _ignored_prior_keys(p)
    for f in dataclasses.fields(p):
        value = getattr(p, f.name)
        if f.name in ignored and value != f.default:
            selector = ignored[f.name]
            raise _err(f"prior.{f.name}", f"not set with prior.{selector} = "
                       f"{getattr(p, selector)!r} (it is ignored there)", value, source)


def _check_point_means(p: Any, source: str | None) -> None:
    """A normal range or speed prior with std 0 is a point mass at its mean: a given mean must
    lie in the support; with std > 0 the support must keep a non-negligible mass of the
    normal (:func:`tmaplan.models.prior.check_truncated_normal`). ``models.prior`` refuses a
    truth-centred mean for either when it samples."""
    parts = [("range", p.range_mean, p.range_std, p.range_min, p.range_max, "m")] \
        if p.range_distribution == "normal" else []
    if p.velocity_distribution == "speed-course" and p.speed_distribution == "normal":
        parts.append(("speed", p.speed_mean, p.speed_std, p.speed_min, p.speed_max, "m/s"))
    for name, mean, std, lo, hi, unit in parts:
        top = math.inf if hi is None else hi
        if mean is not None and not std and not lo <= mean <= top:
            raise _err(f"prior.{name}_mean", f"a value within [{lo}, {top}] {unit} (prior."
                       f"{name}_std is 0: every sample is the mean)", mean, source)
        if mean is not None and std:
            from tmaplan.models.prior import check_truncated_normal

            check_truncated_normal(name, mean, std, lo, top, unit, source)


def _check_prior_spreads(p: Any, source: str | None) -> None:
    """Every std the prior samples is > 0 but the point masses a normal range or speed allows
    (``range_std``, ``speed_std``: :func:`_check_point_means`) and the course about the
    reciprocal bearing (it follows the bearing's spread). Any other zero std leaves the prior
    without a density: its covariance is singular, so the bounds' prior information (its
    inverse) does not exist (NaN or "singular matrix" at step 0)."""
    from tmaplan.models.prior import zero_prior_stds

    why = ("a zero std leaves the prior without a density, and the bounds without its "
           "information, the inverse of the prior covariance")
    zero = zero_prior_stds(p, point_masses=False)  # the one list of the prior's zero stds
    if not zero:
        return
    field = zero[0]
    if field.startswith("prior.std["):
        raise _err(field, f"> 0 ({why})", 0.0, source)
    if field == "prior.bearing_std":
        raise _err(field, f"> 0 for a polar prior, e.g. \"2 deg\" ({why}; 0 is the default "
                   "when the key is left out)", p.bearing_std, source)
    if field == "prior.course_std":
        raise _err(field, f"> 0 with prior.course_mode = {p.course_mode!r} ({why}; 0 is the "
                   "default when the key is left out)", p.course_std, source)
    raise _err(field, f"> 0 ({why})", getattr(p, field.removeprefix("prior.")), source)


def _check_sensor_keys(sen: Any, field: str, source: str | None) -> None:
    """Refuse a sensor key that :func:`tmaplan.scenario.measurement_steps` ignores given the
    others, unless it keeps its default (as :func:`_check_prior_keys` for the prior): a
    bearing or frequency sensor's ``first_step`` and ``every`` when it lists ``steps``, a
    range sensor's ``first_step`` without ``every``."""
    ignored: tuple[str, ...]
    if sen.kind == "range":
        ignored = ("first_step",) if sen.every is None else ()
        setting = f"without {field}.every (it only starts the ranging every n steps)"
    else:
        ignored = ("first_step", "every") if sen.steps is not None else ()
        steps = list(sen.steps or ())
        shown = steps if len(steps) <= 10 else f"[{len(steps)} steps]"
        setting = (f"with {field}.steps = {shown} (it is ignored there: the sensor measures "
                   "at the listed steps only)")
    defaults = {f.name: f.default for f in dataclasses.fields(sen)}
    for name in ignored:
        value = getattr(sen, name)
        if value != defaults[name]:
            raise _err(f"{field}.{name}", f"not set {setting}", value, source)


# --------------------------------------------------------------------------------------------
# Plausibility
# --------------------------------------------------------------------------------------------


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
        raise _err(field, f"{what} of at most {limit:.4g} {unit} ({math.degrees(limit):.3g}°"
                   f"{per}) as a bare number (bare numbers are SI): {v:g} {unit} "
                   f"({math.degrees(v):.4g}°{per}) is implausible; write \"{v:g} {deg}\" if "
                   f"you meant degrees (or \"{v:g} {unit}\" to keep it)", value, source)


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


def _check_speeds(s: Any, source: str | None) -> None:
    for field, v in _speeds(s):
        if v > MAX_SPEED:
            raise _err(field, f"a speed of at most {MAX_SPEED:g} m/s ({MAX_SPEED / KNOT:.0f} kn, "
                       "the plausibility limit for a ship, a submarine or a contact)",
                       f"{v:.6g} m/s ({v / KNOT:.5g} kn)", source)


def truth_fields(p: Any) -> tuple[str, ...]:
    """Fields of prior ``p`` whose value is the target's true initial value, in file order
    (see :class:`tmaplan.scenario.Prior`)."""
    if p.kind == "gaussian":
        return ("mean",) if p.mean is None else ()
    out = []
    if p.bearing_mean is None:
        out.append("bearing_mean")
    if p.range_distribution == "normal" and p.range_mean is None:
        out.append("range_mean")
    if p.velocity_distribution == "normal":
        if p.velocity_mean is None:
            out.append("velocity_mean")
    else:
        if p.speed_distribution == "normal" and p.speed_mean is None:
            out.append("speed_mean")
        if p.course_mode == "true":
            out.append("course_mode")
    return tuple(out)


#: most prior samples a scenario may ask for (4 floats each: 320 MB)
MAX_PRIOR_SAMPLES = 10_000_000


def _check_prior(p: Any, source: str | None) -> None:
    """A prior states its velocity and never takes the truth silently."""
    if not 5 <= p.samples <= MAX_PRIOR_SAMPLES:  # 5: a belief's fewest samples (moments)
        raise _err("prior.samples", f"between 5 and {MAX_PRIOR_SAMPLES}", p.samples, source)
    if p.kind == "polar":
        if p.velocity_distribution == "normal" and not p.velocity_std > 0:
            raise _err("prior.velocity_std", "a velocity prior: velocity_mean = [v_x, v_y] with "
                       "velocity_std > 0 per axis (e.g. velocity_mean = [0, 0], velocity_std = "
                       "\"7.5 kn\"), or velocity_distribution = \"speed-course\" with "
                       "speed_distribution = \"uniform\", speed_max (e.g. \"15 kn\") and "
                       "course_mode = \"uniform\"", p.velocity_std, source)
        if p.velocity_distribution == "speed-course" and p.course_mode is None:
            raise _err("prior.course_mode", "a course prior for velocity_distribution "
                       "'speed-course': \"uniform\", \"given\" (with course_mean and "
                       "course_std), \"reciprocal-bearing\", or \"true\" (the true course, "
                       "on purpose)", None, source)
    means = p.truth_means  # course_mode "true" is itself the explicit choice
    if p.centred_on_truth and not means:
        raise _err("prior.centred_on_truth", "false (or the key left out): every mean of this "
                   "prior is given, so nothing would be centred on the truth", "true", source)
    if p.centred_on_truth:
        return
    for name in means:
        raise _err(f"prior.{name}", f"a value: without '{name}' the prior would take the "
                   "target's true initial value; add the key, or set prior.centred_on_truth "
                   "= true to centre the prior on the truth on purpose (as the papers' bounds "
                   "do)", None, source)
