"""Numbers for people: display units (km, kn, °, min) and short reprs of results.

Everything inside tmaplan is SI (:mod:`tmaplan.units`); what a person reads (the HTML reports,
console summaries, ``repr`` of a result) uses the units of the scenario files' examples:
distances in km (m below 1 km), speeds in knots, angles in degrees, times in minutes.
:func:`scenario_text` writes a scenario (its plain-dict form, :func:`tmaplan.scenario.to_dict`:
this module sits below the scenario package) as TOML in those units (a valid scenario file);
:func:`short_repr` is the ``__repr__`` of the result dataclasses: scalars, array shapes and
nested results by name, never the arrays themselves.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np
import tomli_w

from tmaplan.units import KNOT

__all__ = ["OBJECTIVE_UNITS", "angle", "distance", "minute_list", "minutes", "objective_label",
           "rate", "scenario_text", "seconds_text", "short_repr", "speed", "timespan"]


def _num(x: float, digits: int = 4) -> str:
    return f"{x:.{digits}g}"


def distance(x: float) -> str:
    """``"850 m"`` below 1 km, else ``"8.49 km"`` (``x`` in m)."""
    if not math.isfinite(x):
        return "undefined"
    return f"{x:.0f} m" if abs(x) < 1000.0 else f"{x / 1000.0:.3g} km"


def minutes(t: float) -> str:
    """``"12.5 min"`` (``t`` in s); ``"never"`` for +inf."""
    if t == math.inf:
        return "never"
    return "undefined" if not math.isfinite(t) else f"{t / 60.0:.1f} min"


def minute_list(seconds: float | Any, digits: int = 1) -> str:
    """Scenario times for console lines, in minutes: ``minute_list([840, 1620]) ==
    "14.0, 27.0 min"``; ``"none"`` for no time (``seconds``: a scalar or a sequence, in s)."""
    values = np.atleast_1d(np.asarray(seconds, float))
    if values.size == 0:
        return "none"
    return ", ".join(f"{v / 60:.{digits}f}" for v in values) + " min"


def timespan(t: float) -> str:
    """A span for a sentence: ``"40 s"`` below a minute, else minutes to two decimals without
    trailing zeros (``"45 min"``, ``"12.5 min"``, ``"11.67 min"``); ``t`` in s."""
    if not math.isfinite(t):
        return "undefined"
    if abs(t) < 60.0:
        return f"{t:.3g} s"
    return f"{t / 60.0:.2f}".rstrip("0").rstrip(".") + " min"


def seconds_text(value: float) -> str:
    """A duration for messages, in seconds as given and in hours or days when long:
    ``'100000 s (27.8 h)'``, ``'2.592e+06 s (30 d)'`` (``value`` in s)."""
    if value >= 2 * 86400:
        return f"{value:g} s ({value / 86400:.3g} d)"
    if value >= 7200:
        return f"{value:g} s ({value / 3600:.3g} h)"
    if value >= 120:
        return f"{value:g} s ({value / 60:.3g} min)"
    return f"{value:g} s"


def speed(v: float) -> str:
    """``"8.0 kn"`` (``v`` in m/s)."""
    return "undefined" if not math.isfinite(v) else f"{v / KNOT:.1f} kn"


def angle(a: float, *, signed: bool = False) -> str:
    """``"200°"`` (``a`` in rad), ``"+60°"`` with ``signed``."""
    if not math.isfinite(a):
        return "undefined"
    d = math.degrees(a)
    return f"{d:+.3g}°" if signed else f"{d:.3g}°"


def rate(r: float) -> str:
    """``"0.5 °/s"`` (``r`` in rad/s)."""
    return "undefined" if not math.isfinite(r) else f"{math.degrees(r):.3g} °/s"


# --------------------------------------------------------------------------------------------
# Scenario in display units
# --------------------------------------------------------------------------------------------

#: Unit family per key of a scenario file ("sigma" depends on the sensor kind).
_KIND: dict[str, str] = {
    **dict.fromkeys(("position", "centre", "radius", "range_min", "range_max", "range_mean",
                     "range_std", "keep_out_range", "ping_sigma"), "length"),
    **dict.fromkeys(("dt", "horizon", "t0", "start", "ping_min_spacing", "control_interval",
                     "replan_interval", "period", "ping_forbidden"), "time"),
    **dict.fromkeys(("speed", "speed_min", "speed_max", "speed_mean", "speed_std", "velocity",
                     "velocity_mean", "velocity_std"), "speed"),
    **dict.fromkeys(("course", "heading_min", "heading_max", "phase", "bearing_mean",
                     "bearing_std", "course_mean", "course_std"), "angle"),
    **dict.fromkeys(("omega", "turn_rate", "turn_rate_max", "turn_rates"), "rate"),
    "q": "process_noise", "f0": "frequency", "c": "sound_speed",
}


def _text(kind: str, x: float) -> str:
    if kind == "length":
        return f"{x:.6g} m" if abs(x) < 1000.0 else f"{x / 1000.0:.6g} km"
    if kind == "time":
        return f"{x / 60.0:.6g} min" if x >= 60.0 and abs(x / 60.0 - round(x / 60.0)) < 1e-9 \
            else f"{x:.6g} s"
    if kind == "speed":
        return f"{x / KNOT:.6g} kn"
    if kind == "angle":
        return f"{math.degrees(x):.6g} deg"
    if kind == "rate":
        return f"{math.degrees(x):.6g} deg/s"
    if kind == "process_noise":
        return f"{x:.6g} m^2/s^3"
    if kind in ("frequency", "frequency_noise"):
        return f"{x:.6g} Hz"
    if kind == "sound_speed":
        return f"{x:.6g} m/s"
    return f"{x:.6g}"


def _convert(value: Any, kind: str | None) -> Any:
    if kind is None or isinstance(value, bool | str) or value is None:
        return value
    if isinstance(value, list | tuple):
        return [_convert(v, kind) for v in value]
    if isinstance(value, int | float):
        return _text(kind, float(value))
    return value


def _display(data: Any) -> Any:
    if isinstance(data, list):
        return [_display(v) for v in data]
    if not isinstance(data, dict):
        return data
    out: dict[str, Any] = {}
    for k, v in data.items():
        kind = _KIND.get(k)
        if k == "sigma":
            kind = {"bearing": "angle", "range": "length",
                    "frequency": "frequency_noise"}.get(str(data.get("kind")))
        if k in ("mean", "std") and isinstance(v, list) and len(v) == 4:  # gaussian prior
            out[k] = [_text("length", float(x)) for x in v[:2]] + \
                [_text("speed", float(x)) for x in v[2:]]
        elif isinstance(v, dict | list) and kind is None:
            out[k] = _display(v)
        else:
            out[k] = _convert(v, kind)
    return out


def scenario_text(data: Mapping[str, Any]) -> str:
    """A scenario as TOML in display units: km (m below 1 km), kn, deg, deg/s, min (s when
    not whole minutes), Hz.

    Parameters
    ----------
    data : mapping
        The scenario's plain-dict form, SI (:func:`tmaplan.scenario.to_dict`).

    Returns
    -------
    str
        A valid scenario file: loading it gives the scenario back to the 6 significant digits
        printed.
    """
    return tomli_w.dumps(_display(dict(data)))


# --------------------------------------------------------------------------------------------
# Short reprs
# --------------------------------------------------------------------------------------------


def _brief(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"<{value.dtype} array {value.shape}>" if value.size > 4 else \
            np.array2string(value, precision=4, separator=", ")
    if isinstance(value, bool | np.bool_):
        return str(bool(value))
    if isinstance(value, float | np.floating):
        return _num(float(value))
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, str):
        return repr(value if len(value) <= 60 else value[:57] + "...")
    if isinstance(value, dict):
        keys = ", ".join(str(k) for k in list(value)[:6])
        return f"{{{keys}{', ...' if len(value) > 6 else ''}}} ({len(value)} items)"
    if isinstance(value, list | tuple):
        if len(value) <= 4 and all(isinstance(v, int | float | str | np.number) for v in value):
            items = ", ".join(_brief(v) for v in value)
            return f"[{items}]" if isinstance(value, list) else \
                f"({items}{',' if len(value) == 1 else ''})"
        return f"<{type(value).__name__} of {len(value)}>"
    if value is None:
        return "None"
    name = getattr(value, "name", None)
    label = f" {name!r}" if isinstance(name, str) else ""
    return f"<{type(value).__name__}{label}>"


def short_repr(obj: Any) -> str:
    """A one-line repr of a result dataclass: every field, arrays by dtype and shape, nested
    objects by type (and name), long strings cut; a few hundred characters at most for the
    results of tmaplan (``repr(plan)`` of a heading plan: its objective, status, sizes).
    """
    if not dataclasses.is_dataclass(obj):
        return object.__repr__(obj)
    parts = [f"{f.name}={_brief(getattr(obj, f.name))}" for f in dataclasses.fields(obj)
             if f.repr]
    return f"{type(obj).__name__}({', '.join(parts)})"


#: Units of the planning and scheduling functionals (plot labels), by base name.
OBJECTIVE_UNITS: dict[str, str] = {
    "logdet": "−ln det FIM, SI units",
    "range-bound": "m", "terminal-range-bound": "m", "mean-range-bound": "m",
    "position-bound": "m", "terminal-position-bound": "m", "mean-position-bound": "m",
    "relative-range-bound": "σ_r/r, –", "mean-relative-range-bound": "σ_r/r, –",
    "relative-range-crlb": "σ_r/r, –", "mean-relative-range-crlb": "σ_r/r, –",
    "time-to-accuracy": "fraction of the horizon not localised, –",
    "expected-time-to-accuracy": "s",
    "turn-penalty": "–",
}


def objective_label(name: str) -> str:
    """``name [unit]`` of a planning / scheduling functional for titles and axes.

    Composite objectives (``a+b``, weights ``w*a``) label each term. A name outside
    :data:`OBJECTIVE_UNITS` gets its unit from its family (``…range-bound``,
    ``…position-bound``: m; ``relative…``: –) or none.
    """
    parts = []
    # a "+" after a digit and an "e" is a weight's exponent ("1e+06*range-bound"), not a sum
    for term in re.split(r"(?<![0-9][eE])\+", name):
        base = term.split("*")[-1]
        unit = OBJECTIVE_UNITS.get(base)
        if unit is None:
            unit = ("σ_r/r, –" if "relative" in base else
                    "m" if base.endswith(("range-bound", "position-bound")) else None)
        parts.append(f"{term} [{unit}]" if unit else term)
    return " + ".join(parts)
