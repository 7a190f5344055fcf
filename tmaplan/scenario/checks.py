"""Cross-field validation of scenarios (what the type annotations alone cannot say).

Every rule raises :class:`tmaplan.errors.ScenarioError` naming the field, the expected and
the received value. :func:`check` is called by :func:`tmaplan.scenario.from_dict` and
:meth:`tmaplan.scenario.Scenario.replace`, with the rules of the prior
(:mod:`tmaplan.scenario.prior_checks`), of the ``[faults]`` table
(:func:`tmaplan.scenario.faults.check_faults`) and the plausibility limits of speeds and turn
rates (:mod:`tmaplan.scenario.plausible`). Bare numbers are checked on the raw file data
(:mod:`tmaplan.scenario.bare`).

These rules read the scenario's own values. The ones that need its motion model (an observer
leg starting inside the previous leg's turn) are :func:`tmaplan.models.checks.check_scenario`'s,
run by the command line after it loads a scenario (docs/architecture.md).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tmaplan.errors import ScenarioError, is_whole_count, whole_steps_text
from tmaplan.scenario.contacts import contact_parts, in_contact
from tmaplan.scenario.faults import check_faults
from tmaplan.scenario.plausible import check_speeds, check_turn_rates
from tmaplan.scenario.prior_checks import check_prior

__all__ = ["check"]


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
    _check_contact_names(s, source)
    for i, _ in enumerate(s.contacts):
        with in_contact(s, i):
            _check_target(s.contacts[i].target, g, source)

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
    for i, part in contact_parts(s):  # no ship turns faster than 10 °/s
        with in_contact(s, i):
            check_turn_rates(part, source)
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

    for i, part in contact_parts(s):
        with in_contact(s, i):
            check_speeds(part, source)
    for i, c in enumerate(s.contacts):
        with in_contact(s, i):
            if c.prior is not None:
                check_prior(c.prior, c.target.model, source)

    est = s.estimation
    if est is not None and est.turn_direction != "either" and any(
            c.target.model != "constant-turn" for c in s.contacts):
        raise _err("estimation.turn_direction", "'either' unless the target model is "
                   "'constant-turn'" + ("" if len(s.contacts) == 1 else " for every contact"),
                   est.turn_direction, source)

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
        check_faults(s.faults, g, source)


def _check_target(t: Any, g: Any, source: str | None) -> None:
    """The rules of one contact's ``[target]`` on time grid ``g``."""
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


def _check_contact_names(s: Any, source: str | None) -> None:
    """Contact names: non-empty, unique (the keys of the per-contact output)."""
    if not s.contacts:
        raise _err("contacts", "at least one contact ([target] or [[contacts]])", [], source)
    seen: dict[str, int] = {}
    for i, c in enumerate(s.contacts):
        if not c.name.strip() or any(ch in "/\\" or ord(ch) < 32 for ch in c.name):
            raise _err(f"contacts[{i}].name", "a non-empty name without '/', '\\' or control "
                       "characters (the command line names its figures after it)", c.name,
                       source)
        if c.name in seen:
            raise _err(f"contacts[{i}].name", f"a name not used by another contact (contacts"
                       f"[{seen[c.name]}] is already '{c.name}')", c.name, source)
        seen[c.name] = i


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
