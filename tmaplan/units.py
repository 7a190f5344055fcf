"""Unit parsing and conversion at the edges of tmaplan.

Everything inside tmaplan is SI: metres, seconds, radians, m/s, rad/s, Hz and m²/s³
(see docs/conventions.md). Scenario files, CLI flags, plots and reports may use other units; this
module is the single place where they are converted, using a module-level :mod:`pint`
registry.

A quantity is either a plain number, taken to be SI already, or a string made of a number
followed by a unit, e.g. ``"12 kn"``, ``"3.5 km"``, ``"45 deg"``, ``"2 nmi"``, ``"10 min"``,
``"0.5 deg/s"``, ``"3 Hz"``, ``"1e-3 m^2/s^3"`` or a bare number string ``"12"`` (SI).

A unit is accepted only if its SI root unit is exactly the one of the requested dimension.
Pint treats angles as dimensionless, so this rule is stricter than a dimensionality check:
``"3 Hz"`` is a frequency but not an angular rate (write ``"3 rad/s"`` or ``"0.5 deg/s"``),
``"1 rad/s"`` is not a frequency, and ``"45 deg"`` is not a dimensionless number.
"""

from __future__ import annotations

import functools
import math
import numbers
import re
from collections.abc import Iterable, Mapping
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING, Any, Final, cast

from pydantic import BeforeValidator

from tmaplan.errors import UnitError

if TYPE_CHECKING:
    import pint  # annotations only: imported on first use (_registry)

__all__ = [
    "COMMON_UNITS",
    "DEG",
    "DIMENSIONS",
    "KNOT",
    "NMI",
    "format_quantity",
    "si_validator",
    "to_si",
    "to_si_vector",
    "ureg",  # noqa: F822 - made on first use (module __getattr__)
]

KNOT: Final[float] = 1852.0 / 3600.0
"""One knot in m/s (one nautical mile per hour)."""

NMI: Final[float] = 1852.0
"""One international nautical mile in m."""

DEG: Final[float] = math.pi / 180.0
"""One degree in rad."""


@functools.cache
def _registry() -> pint.UnitRegistry:
    """The unit registry, made on first use: building it takes about 0.5 s, which a process
    that never parses a unit string (a campaign's worker) need not pay."""
    import pint  # deferred: pint takes about half a second to import

    reg: pint.UnitRegistry = pint.UnitRegistry()
    # Recent pint versions define all of these; keep the definitions for older ones.
    for name, definition in (
        ("kn", "kn = 1852 / 3600 * meter / second"),
        ("nmi", "nmi = 1852 * meter"),
        ("deg", "deg = pi / 180 * radian"),
        ("°", "° = pi / 180 * radian"),
    ):
        if name not in reg:  # pragma: no cover - depends on the installed pint
            reg.define(definition)
    return reg


def __getattr__(name: str) -> Any:
    """``ureg``: the module-level unit registry (made on first use). Use it for every unit
    conversion in tmaplan."""
    if name == "ureg":
        return _registry()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# dimension name -> (SI unit as pint understands it, SI unit for messages, example string)
_DIMENSION_TABLE: Final[dict[str, tuple[str, str, str]]] = {
    "length": ("meter", "m", "3.5 km"),
    "time": ("second", "s", "10 min"),
    "angle": ("radian", "rad", "45 deg"),
    "speed": ("meter / second", "m/s", "12 kn"),
    "angular_rate": ("radian / second", "rad/s", "0.5 deg/s"),
    "frequency": ("1 / second", "Hz", "3 Hz"),
    "process_noise": ("meter ** 2 / second ** 3", "m^2/s^3", "1e-3 m^2/s^3"),
    "dimensionless": ("dimensionless", "", "0.5"),
}

DIMENSIONS: Final[tuple[str, ...]] = tuple(_DIMENSION_TABLE)
"""Names accepted as ``dimension`` by :func:`to_si` and :func:`to_si_vector`."""


@functools.cache
def _si_root(dimension: str) -> pint.Unit:
    """The SI unit of ``dimension`` as a pint unit."""
    return _registry().Unit(_DIMENSION_TABLE[dimension][0])

# A leading decimal number (sign, digits, optional fraction and exponent), then the unit.
_QUANTITY_RE: Final[re.Pattern[str]] = re.compile(
    r"^\s*(?P<number>[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)\s*(?P<unit>.*?)\s*$"
)


# "nan", "inf", "-infinity" in front of a unit: a number, but not a finite one
_NON_FINITE_RE: Final[re.Pattern[str]] = re.compile(r"^\s*[+-]?(?:nan|inf(?:inity)?)(?![A-Za-z_])",
                                                    re.IGNORECASE)

# "nm": pint's nanometre, but a nautical mile to many a sailor ("5 nm" of range would be 5e-9 m)
_AMBIGUOUS_NM_RE: Final[re.Pattern[str]] = re.compile(r"(?<![A-Za-z_])nm(?![A-Za-z_])")


class _ParseError(Exception):
    """Internal: a string could not be converted; carries no field name."""


def _expected(dimension: str) -> str:
    """Describe a valid value of ``dimension`` for error messages."""
    _, si, example = _DIMENSION_TABLE[dimension]
    article = "an" if dimension[0] in "aeiou" else "a"
    noun = dimension.replace("_", " ")
    if dimension == "dimensionless":
        return f"a dimensionless number: a number or a string like '{example}'"
    return f"{article} {noun}: a number in {si} or a string like '{example}'"


def _check_dimension(dimension: str) -> None:
    if dimension not in _DIMENSION_TABLE:
        raise ValueError(f"unknown dimension {dimension!r}; expected one of {list(DIMENSIONS)}")


@functools.lru_cache(maxsize=1024)
def _unit_factor(unit: str) -> tuple[float, pint.Unit]:
    """Return ``(factor, root)`` such that one ``unit`` equals ``factor`` ``root`` (SI).

    Raises
    ------
    _ParseError
        If pint does not know ``unit``.
    """
    try:
        reg = _registry()
        parsed = reg.parse_units(unit)
        factor, root = reg.get_root_units(parsed)
        # a logarithmic (dB, octave) or offset (degC) unit is no factor: 0 dB is 1
        zero = float(reg.Quantity(0.0, parsed).to_root_units().magnitude)
    except Exception as exc:  # any failure to parse a user string is a unit error
        raise _ParseError(f"unknown unit {unit!r}") from exc
    if zero != 0.0:
        raise _ParseError(f"unit {unit!r} is logarithmic or has an offset (not a scale factor)")
    return float(cast(float, factor)), root


#: The units of the built-in problems and of most scenario files: unit string -> (factor to
#: the SI unit, dimension), pint's own factors (a test checks each against pint bit for bit).
#: A scenario in these units loads without pint's registry (about 0.8 s to import and build),
#: so a command refuses a bad input in well under a second; any other unit goes to pint.
COMMON_UNITS: Final[dict[str, tuple[float, str]]] = {
    "m": (1.0, "length"), "km": (1000.0, "length"), "nmi": (1852.0, "length"),
    "s": (1.0, "time"), "min": (60.0, "time"), "h": (3600.0, "time"), "d": (86400.0, "time"),
    "deg": (0.017453292519943295, "angle"), "°": (0.017453292519943295, "angle"),
    "rad": (1.0, "angle"),
    "kn": (0.5144444444444445, "speed"), "m/s": (1.0, "speed"),
    "km/h": (0.2777777777777778, "speed"),
    "deg/s": (0.017453292519943295, "angular_rate"),
    "deg/min": (0.0002908882086657216, "angular_rate"), "rad/s": (1.0, "angular_rate"),
    "Hz": (1.0, "frequency"),
    "m^2/s^3": (1.0, "process_noise"), "km^2/s^3": (1000000.0, "process_noise"),
}


@functools.lru_cache(maxsize=4096)
def _parse(text: str, dimension: str) -> float:
    """Convert ``text`` (number + optional unit) to SI ``dimension``; cached.

    Raises
    ------
    _ParseError
        On a malformed string, an unknown unit, a wrong dimension or a non-finite number.
    """
    match = _QUANTITY_RE.match(text)
    if match is None:
        if _NON_FINITE_RE.match(text):
            raise _ParseError("the value is not finite")
        raise _ParseError("the string does not start with a number")
    magnitude = float(match["number"])
    unit = match["unit"]
    if unit.startswith("/"):  # "0.5/s" means 0.5 per second
        unit = "1" + unit
    if not unit:
        value = magnitude
    elif _AMBIGUOUS_NM_RE.search(unit):
        raise _ParseError(f"unit {unit!r}: 'nm' is ambiguous (pint reads the nanometre); "
                          "write 'nmi' for nautical miles or 'nanometer'")
    elif COMMON_UNITS.get(unit, (0.0, ""))[1] == dimension:
        value = magnitude * COMMON_UNITS[unit][0]
    else:
        factor, root = _unit_factor(unit)
        if root != _si_root(dimension):
            raise _ParseError(f"unit {unit!r} is not {_expected(dimension).split(':')[0]}")
        value = magnitude * factor
    if not math.isfinite(value):
        raise _ParseError("the value is not finite")
    return value


def to_si(value: Any, dimension: str, field: str) -> float:
    """Convert a scalar quantity to its SI value.

    Parameters
    ----------
    value
        A real number (int or float, not bool), taken to be in SI units already, or a string
        of a number followed by an optional unit: ``"12 kn"``, ``"3.5 km"``, ``"45 deg"``,
        ``"2 nmi"``, ``"10 min"``, ``"0.5 deg/s"``, ``"3 Hz"``, ``"1e-3 m^2/s^3"``, ``"12"``.
    dimension
        One of :data:`DIMENSIONS`: ``"length"`` (m), ``"time"`` (s), ``"angle"`` (rad),
        ``"speed"`` (m/s), ``"angular_rate"`` (rad/s), ``"frequency"`` (Hz),
        ``"process_noise"`` (m²/s³) or ``"dimensionless"``.
    field
        Name of the field being read (e.g. ``"observer.speed"``), used in error messages.

    Returns
    -------
    float
        The value in the SI unit of ``dimension``.

    Raises
    ------
    tmaplan.errors.UnitError
        If ``value`` is a bool, not a number or string, not finite, has an unknown unit or a
        unit of another dimension. The message names ``field``.
    ValueError
        If ``dimension`` is not one of :data:`DIMENSIONS` (a programming error).

    Notes
    -----
    Strings are parsed once and cached, so repeated calls cost about a microsecond.
    An angular rate needs an explicit angle unit (``"rad/s"``, ``"deg/s"``, ``"rpm"``):
    ``"1/s"`` and ``"Hz"`` are rejected because they are ambiguous by a factor 2π. For the
    same reason ``"nm"`` (nanometre to pint, nautical mile to many) is rejected: write
    ``"nmi"`` (or ``"nanometer"``).

    Examples
    --------
    >>> to_si("12 kn", "speed", "target.speed")
    6.173333333333334
    >>> to_si(100, "length", "sensor.sigma")
    100.0
    """
    _check_dimension(dimension)
    if isinstance(value, bool) or not isinstance(value, numbers.Real | str):
        raise UnitError(field, _expected(dimension), value)
    if isinstance(value, str):
        try:
            return _parse(value, dimension)
        except _ParseError as exc:
            raise UnitError(field, f"{_expected(dimension)} ({exc})", value) from None
    try:
        number = float(value)
    except OverflowError:  # an integer beyond the float range (TOML integers are unbounded)
        number = math.inf
    if not math.isfinite(number):
        raise UnitError(field, f"{_expected(dimension)} (the value is not finite)", value)
    return number


def to_si_vector(values: Iterable[Any], dimension: str, field: str) -> tuple[float, ...]:
    """Convert a sequence of quantities to SI values.

    Parameters
    ----------
    values
        A list, tuple or 1-D array of items accepted by :func:`to_si`, shape (n,).
        Each item may use its own unit, e.g. ``["1 km", 2000, "3 nmi"]``.
    dimension
        One of :data:`DIMENSIONS`, shared by all items.
    field
        Name of the field; errors on item ``i`` name ``f"{field}[{i}]"``.

    Returns
    -------
    tuple of float
        The n values in the SI unit of ``dimension``.

    Raises
    ------
    tmaplan.errors.UnitError
        If ``values`` is a string, a mapping, a set (no order) or not iterable, or if any
        item is invalid.
    """
    _check_dimension(dimension)
    if isinstance(values, str | bytes | Mapping | AbstractSet) or not isinstance(values, Iterable):
        raise UnitError(field, f"a list of {_expected(dimension)}", values)
    return tuple(to_si(item, dimension, f"{field}[{i}]") for i, item in enumerate(values))


def format_quantity(value_si: float, unit: str, digits: int = 4) -> str:
    """Format an SI value in a display unit.

    Parameters
    ----------
    value_si
        The value in the SI unit matching ``unit`` (m for ``"nmi"``, rad for ``"deg"``, ...).
    unit
        Any unit pint knows, e.g. ``"kn"``, ``"nmi"``, ``"km"``, ``"deg"``, ``"min"``,
        ``"deg/s"``; ``""`` for a plain number.
    digits
        Number of significant digits (``format`` spec ``g``: trailing zeros are dropped).

    Returns
    -------
    str
        ``"<number> <unit>"``, e.g. ``format_quantity(6.1733, "kn") == "12 kn"``.
        A degree sign is attached without a space (``"45°"``).

    Raises
    ------
    tmaplan.errors.UnitError
        If pint does not know ``unit`` (the field is ``"unit"``).
    """
    try:
        factor, _ = _unit_factor(unit) if unit else (1.0, _registry().Unit("dimensionless"))
    except _ParseError as exc:
        raise UnitError("unit", f"a unit known to pint ({exc})", unit) from None
    number = f"{float(value_si) / factor:.{digits}g}"
    if not unit:
        return number
    if unit == "°":
        return f"{number}°"
    return f"{number} {unit}"



def si_validator(dimension: str) -> Any:
    """A pydantic ``BeforeValidator`` converting a field in ``dimension`` with :func:`to_si`
    (a plain SI number or a string with a unit; a bool is refused by name), for annotations
    ``Annotated[float, si_validator("time"), Field(...)]``.

    Parameters
    ----------
    dimension
        One of :data:`DIMENSIONS`.

    Returns
    -------
    pydantic.BeforeValidator
    """
    _check_dimension(dimension)

    def convert(value: Any, info: Any) -> Any:
        if isinstance(value, str | int | float):  # bool too: to_si refuses it by name
            return to_si(value, dimension, info.field_name or "value")
        return value

    return BeforeValidator(convert)
