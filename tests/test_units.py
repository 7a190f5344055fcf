"""Tests of tmaplan.units: parsing quantities at the edges."""

from __future__ import annotations

import math
import subprocess
import sys
import time

import numpy as np
import pytest

from tmaplan import units
from tmaplan.errors import ScenarioError, UnitError
from tmaplan.units import DEG, DIMENSIONS, KNOT, NMI, format_quantity, to_si, to_si_vector

# (string, dimension, exact SI value)
EXAMPLES = [
    ("12 kn", "speed", 12 * 1852 / 3600),
    ("3.5 km", "length", 3500.0),
    ("45 deg", "angle", math.pi / 4),
    ("0.5 deg", "angle", 0.5 * math.pi / 180),
    ("2 nmi", "length", 3704.0),
    ("10 min", "time", 600.0),
    ("0.5 deg/s", "angular_rate", 0.5 * math.pi / 180),
    ("3 Hz", "frequency", 3.0),
    ("1e-3 m^2/s^3", "process_noise", 1e-3),
    ("6 s", "time", 6.0),
    ("100 m", "length", 100.0),
    ("0.05 rad", "angle", 0.05),
    ("12", "speed", 12.0),
    ("12", "dimensionless", 12.0),
    ("45°", "angle", math.pi / 4),
    ("45 °", "angle", math.pi / 4),
    ("  -7.5e1   m  ", "length", -75.0),
    ("2 rad/s", "angular_rate", 2.0),
    ("6 rpm", "angular_rate", 6 * 2 * math.pi / 60),
    ("50 %", "dimensionless", 0.5),
    ("0.5/s", "frequency", 0.5),
    ("1 1/s", "frequency", 1.0),
]


def test_constants() -> None:
    assert KNOT == 1852 / 3600
    assert NMI == 1852.0
    assert DEG == math.pi / 180


@pytest.mark.parametrize(("text", "dimension", "expected"), EXAMPLES)
def test_examples_are_exact(text: str, dimension: str, expected: float) -> None:
    value = to_si(text, dimension, "x")
    assert type(value) is float
    # Exact to float precision: at most a few ulps apart.
    assert value == pytest.approx(expected, rel=1e-15, abs=0.0)


@pytest.mark.parametrize("dimension", DIMENSIONS)
@pytest.mark.parametrize("number", [0, 12, -3, 2.5, np.float64(1.25), np.int64(7)])
def test_plain_numbers_are_si(dimension: str, number: float) -> None:
    value = to_si(number, dimension, "x")
    assert type(value) is float
    assert value == float(number)


def test_unknown_unit_names_the_field() -> None:
    with pytest.raises(UnitError) as info:
        to_si("5 foobars", "length", "observer.depth")
    message = str(info.value)
    assert "observer.depth" in message
    assert "a length: a number in m or a string like '3.5 km'" in message
    assert "foobars" in message
    assert info.value.field == "observer.depth"
    assert info.value.received == "5 foobars"
    # UnitError is a ScenarioError and a ValueError.
    assert isinstance(info.value, ScenarioError)
    assert isinstance(info.value, ValueError)


@pytest.mark.parametrize(
    ("text", "dimension"),
    [
        ("5 km", "time"),
        ("12 kn", "length"),
        ("10 min", "speed"),
        ("45 deg", "dimensionless"),
        ("45 deg", "length"),
        ("3 Hz", "angular_rate"),  # ambiguous by 2π: an angular rate needs an angle unit
        ("2 1/s", "angular_rate"),
        ("2/s", "angular_rate"),
        ("1 rad/s", "frequency"),
        ("2 m", "angle"),
        ("1 m^2/s^2", "process_noise"),
        ("1 sr", "angle"),
    ],
)
def test_wrong_dimension_names_the_field(text: str, dimension: str) -> None:
    with pytest.raises(UnitError, match=r"field 'sensors\[0\]\.dt'") as info:
        to_si(text, dimension, "sensors[0].dt")
    assert "is not a" in str(info.value)


def test_wrong_dimension_message() -> None:
    with pytest.raises(UnitError) as info:
        to_si("5 km", "time", "grid.dt")
    assert str(info.value) == (
        "field 'grid.dt': expected a time: a number in s or a string like '10 min' "
        "(unit 'km' is not a time), received '5 km'"
    )


@pytest.mark.parametrize(
    "value",
    [
        True,
        False,
        np.bool_(True),
        None,
        [1.0],
        {"value": 1},
        float("nan"),
        float("inf"),
        -math.inf,
        10**400,  # a TOML integer beyond the float range (was a raw OverflowError)
        "nan",
        "inf m",
        "1e400 m",
        "",
        "   ",
        "km",
        "twelve knots",
        "12 kn kn",
        "3 +",
        "2 m + 3 m",
        "5 degC",
    ],
)
def test_invalid_values(value: object) -> None:
    with pytest.raises(UnitError, match=r"field 'target\.speed'"):
        to_si(value, "speed", "target.speed")


def test_unknown_dimension_is_a_programming_error() -> None:
    with pytest.raises(ValueError, match="unknown dimension"):
        to_si(1.0, "mass", "x")


def test_vector() -> None:
    assert to_si_vector(["1 km", 2, "3 nmi", 4.5], "length", "pos") == (
        1000.0,
        2.0,
        3 * 1852.0,
        4.5,
    )
    assert to_si_vector((), "time", "t") == ()
    assert to_si_vector(np.array([1.0, 2.0]), "time", "t") == (1.0, 2.0)
    with pytest.raises(UnitError, match=r"field 'pos\[1\]'"):
        to_si_vector(["1 km", "2 s"], "length", "pos")
    for bad in ("1 km", 3.0, {"a": 1}):
        with pytest.raises(UnitError, match="field 'pos'"):
            to_si_vector(bad, "length", "pos")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("value_si", "unit", "digits", "expected"),
    [
        (6.1733, "kn", 4, "12 kn"),
        (12 * KNOT, "kn", 4, "12 kn"),
        (3704.0, "nmi", 4, "2 nmi"),
        (math.pi / 4, "deg", 4, "45 deg"),
        (math.pi / 4, "°", 4, "45°"),
        (0.5, "m", 4, "0.5 m"),
        (2500.0, "km", 2, "2.5 km"),
        (600.0, "min", 4, "10 min"),
        (0.5 * DEG, "deg/s", 3, "0.5 deg/s"),
        (0.25, "", 4, "0.25"),
        (1 / 3, "s", 3, "0.333 s"),
    ],
)
def test_format_quantity(value_si: float, unit: str, digits: int, expected: str) -> None:
    assert format_quantity(value_si, unit, digits) == expected


def test_format_quantity_unknown_unit() -> None:
    with pytest.raises(UnitError, match="field 'unit'"):
        format_quantity(1.0, "furlongz")


def test_format_round_trip() -> None:
    for text, dimension, _ in EXAMPLES[:12]:
        _, unit = text.split(" ", 1)
        shown = format_quantity(to_si(text, dimension, "x"), unit, digits=6)
        assert to_si(shown, dimension, "x") == pytest.approx(to_si(text, dimension, "x"))


def test_cached_parsing_is_fast() -> None:
    # A scenario load converts a few hundred fields; cached strings must cost microseconds.
    texts = [text for text, _, _ in EXAMPLES]
    dims = [dim for _, dim, _ in EXAMPLES]
    start = time.perf_counter()
    for _ in range(50):
        for text, dim in zip(texts, dims):
            to_si(text, dim, "x")
    elapsed = time.perf_counter() - start
    assert elapsed < 0.5, f"{50 * len(texts)} conversions took {elapsed:.3f} s"


@pytest.mark.parametrize("text", ["0 dB", "3 dB", "1 octave", "0.5 neper"])
def test_logarithmic_units_are_refused(text: str) -> None:
    # pint's root-unit factor of a logarithmic unit is 1: "0 dB" became 0 (it is a ratio of 1)
    with pytest.raises(UnitError, match="logarithmic") as info:
        to_si(text, "dimensionless", "faults.missed_ping_probability")
    assert info.value.field == "faults.missed_ping_probability"
    assert to_si("50 %", "dimensionless", "p") == pytest.approx(0.5)


@pytest.mark.parametrize("text", ["nan deg", "inf s", "-Infinity km", " +INF "])
def test_a_non_finite_number_is_called_so(text: str) -> None:
    # it used to say "the string does not start with a number"
    with pytest.raises(UnitError, match=r"field 'f'.*the value is not finite"):
        to_si(text, "length", "f")


@pytest.mark.parametrize("text", ["information", "infs", "nanometer", "km"])
def test_a_word_is_still_not_a_number(text: str) -> None:
    with pytest.raises(UnitError, match="does not start with a number"):
        to_si(text, "length", "f")


@pytest.mark.parametrize("unit", sorted(units.COMMON_UNITS))
def test_common_units_are_pints_factors_bit_for_bit(unit: str) -> None:
    """The table that spares a scenario's load pint's registry holds pint's own factor and
    dimension for each unit, to the last bit (a plan from "12 kn" is the same either way)."""
    factor, dimension = units.COMMON_UNITS[unit]
    pint_factor, root = units.ureg.get_root_units(units.ureg.parse_units(unit))
    si = {"length": "m", "time": "s", "angle": "rad", "speed": "m/s", "angular_rate": "rad/s",
          "frequency": "1/s", "process_noise": "m**2/s**3"}[dimension]
    assert factor == float(pint_factor)
    assert root == units.ureg.get_root_units(units.ureg.parse_units(si))[1]
    assert to_si(f"2.5 {unit}", dimension, "f") == 2.5 * float(pint_factor)


def test_a_scenario_in_common_units_loads_without_pint() -> None:
    """Loading a built-in problem (all in common units) imports no pint: a bad input is
    refused before pint's 0.8 s import; a unit outside the table still goes to pint."""
    code = ("import sys; from tmaplan.scenario import load_problem; load_problem('default'); "
            "print('pint' in sys.modules); from tmaplan.units import to_si; "
            "to_si('3 furlong', 'length', 'f'); print('pint' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()
    assert out == ["False", "True"]
