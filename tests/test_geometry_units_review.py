"""Review of geometry, units, plotting and the planning graphs' parameter layout: defects found
and fixed (each test failed on the code before its fix)."""

import types

import numpy as np
import pytest

from tmaplan.display import objective_label
from tmaplan.errors import ArgumentError, UnitError
from tmaplan.geometry import range_of
from tmaplan.units import to_si, to_si_vector


@pytest.mark.parametrize("shape", [(3,), (5, 3), (2, 6), (1,)])
def test_range_of_refuses_a_wrong_last_dimension(shape: tuple[int, ...]) -> None:
    # bearing_of refuses these; range_of returned the norm of the first two components
    with pytest.raises(ValueError, match=r"\(\.\.\., 4\) or \(\.\.\., 2\)"):
        range_of(np.ones(shape))


def test_range_of_refuses_a_scalar() -> None:
    with pytest.raises(ValueError, match="shape"):  # was an IndexError
        range_of(3.0)


def test_range_of_valid_shapes_unchanged() -> None:
    assert range_of([3.0, 4.0]) == 5.0
    assert range_of([3.0, 4.0, 1.0, 2.0]) == 5.0
    assert range_of(np.ones((2, 3, 4))).shape == (2, 3)


@pytest.mark.parametrize("text, dimension", [("5 nm", "length"), ("12 nm/h", "speed"),
                                             ("2 nm", "dimensionless")])
def test_nm_is_refused_as_ambiguous(text: str, dimension: str) -> None:
    # pint reads "nm" as the nanometre: "5 nm" of range silently became 5e-9 m
    with pytest.raises(UnitError, match="nmi"):
        to_si(text, dimension, "target.range")


def test_nautical_miles_and_nanometres_spelled_out_still_work() -> None:
    assert to_si("5 nmi", "length", "f") == 5 * 1852.0
    assert to_si("12 nmi/h", "speed", "f") == pytest.approx(12 * 1852.0 / 3600.0)
    assert to_si("5 nanometer", "length", "f") == pytest.approx(5e-9)


@pytest.mark.parametrize("values", [types.MappingProxyType({"a": 1.0}), {1.0, 2.0},
                                    frozenset({1.0})])
def test_to_si_vector_refuses_mappings_and_sets(values: object) -> None:
    # the docstring refuses a mapping; only a dict was; a set has no order
    with pytest.raises(UnitError, match="field 'pos'"):
        to_si_vector(values, "length", "pos")  # type: ignore[arg-type]


@pytest.mark.parametrize("name, expected", [
    ("1e+06*range-bound", "1e+06*range-bound [m]"),
    ("1e+06*range-bound+turn-penalty", "1e+06*range-bound [m] + turn-penalty [–]"),
    ("2*mean-position-bound+1e+07*turn-penalty",
     "2*mean-position-bound [m] + 1e+07*turn-penalty [–]"),
    ("range-bound+turn-penalty", "range-bound [m] + turn-penalty [–]"),
])
def test_objective_label_keeps_exponent_weights(name: str, expected: str) -> None:
    # Objective.__mul__ names a weight with format "g": 1e6 -> "1e+06", whose "+" was taken
    # for a sum of terms ("1e [...] + 06*range-bound [m]")
    assert objective_label(name) == expected


@pytest.mark.parametrize("kw, field", [
    ({"n_steps": 10, "n_samples": 0}, "n_samples"),
    ({"n_steps": 10, "n_samples": -2}, "n_samples"),
    ({"n_steps": 10, "n_samples": 2.5}, "n_samples"),
    ({"n_steps": -1, "n_samples": 1}, "n_steps"),
    ({"n_steps": True, "n_samples": 1}, "n_steps"),
])
def test_param_layout_validates_its_sizes(kw: dict[str, object], field: str) -> None:
    from tmaplan.planning.objectives import ParamLayout

    # n_samples = 0 gave a layout of 4·0 samples while vector() packs one (the mean)
    with pytest.raises(ArgumentError, match=field):
        ParamLayout(**kw)  # type: ignore[arg-type]


def test_objective_with_zero_samples_is_refused_by_name() -> None:
    from tmaplan.planning.objectives import Objective, ObjectiveEvaluator, range_bound
    from tmaplan.scenario import load_problem

    with pytest.raises(ArgumentError, match="n_samples"):
        ObjectiveEvaluator(load_problem("default"), Objective("rb", range_bound().terms, 0),
                           n_steps=4)


def test_weighted_sum_objective_is_named_by_its_terms() -> None:
    # 2 * (a + b) was named "2*range-bound+logdet", which reads (and is labelled) as 2a + b
    from tmaplan.planning.objectives import make_objective

    a, b = make_objective("range-bound"), make_objective("logdet")
    assert (2 * (a + b)).name == "2*range-bound+2*logdet"
    assert (2 * a).name == "2*range-bound"
    assert (3 * (1e6 * a + b)).name == "3*1e+06*range-bound+3*logdet"
    assert objective_label((2 * (a + b)).name).count("2*") == 2
    # the value was right all along: the weights are on the terms
    base = [w for w, _ in (a + 0.5 * b).terms]
    assert [w for w, _ in (2 * (a + 0.5 * b)).terms] == [2 * w for w in base]
