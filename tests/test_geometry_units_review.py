"""Review of geometry, units, plotting and the planning graphs' parameter layout: defects found
and fixed (each test failed on the code before its fix)."""

import types

import numpy as np
import pytest

from tmaplan.errors import ArgumentError, UnitError
from tmaplan.geometry import range_of
from tmaplan.plotting import objective_label
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

