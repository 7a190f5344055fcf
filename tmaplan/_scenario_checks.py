"""Cross-field validation of scenarios (what the type annotations alone cannot say).

Every rule raises :class:`tmaplan.errors.ScenarioError` naming the field, the expected and
the received value. Called by :func:`tmaplan.scenario.from_dict` and ``Scenario.replace``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tmaplan.errors import ScenarioError

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
    g = s.time
    k = g.horizon / g.dt
    if abs(k - round(k)) > 1e-9 * max(1.0, k) or round(k) < 1:
        raise _err("time.horizon", f"a whole number (>= 1) of steps of dt = {g.dt} s",
                   g.horizon, source)
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
        if leg.start > g.t0 + g.horizon:
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
        if sen.kind == "frequency":
            if len(sen.f0) == 0:
                raise _err(f"{f}.f0", "at least one frequency line", sen.f0, source)
            if len(sen.sigma) != len(sen.f0):
                raise _err(f"{f}.sigma", f"one std per line ({len(sen.f0)} values)",
                           len(sen.sigma), source)
        if sen.kind == "range" and sen.period is not None and sen.period < g.dt:
            raise _err(f"{f}.period", f">= dt = {g.dt} s", sen.period, source)

    p = s.prior
    if p is not None:
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
                if p.course_mode == "given" and p.course_mean is None:
                    raise _err("prior.course_mean", "a value for course_mode 'given'", None,
                               source)
            if t.model == "constant-turn" and (p.range_mean is None or p.bearing_mean is None):
                raise _err("prior", "explicit means for a constant-turn target", None, source)

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
        if pl.control_interval is not None:
            m = pl.control_interval / g.dt
            if abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
                raise _err("planning.control_interval", f"a whole number of steps of dt = "
                           f"{g.dt} s", pl.control_interval, source)
        if pl.ping_budget > n:
            raise _err("planning.ping_budget", f"<= the number of steps ({n})", pl.ping_budget,
                       source)
