"""The compiled objective's kernel, its loops split for the vectoriser, against the kernel as
it was before (tests/oracles/compiled_objective_reference.py): the same bits.

Value (``==``), gradient and the A/V workspace the forward pass leaves for a reverse-only call
(``np.array_equal``, NaN where neither wrote; after a reverse sweep, V's row 0 apart: the kernel
before wrote the sweep's terms over it, so that a second reverse-only call at the same point
read them as variances, fixed), for a forward pass with and without the
reverse sweep and for a forward pass followed by a reverse-only call, on draws inside the
100 m range floor (and one exactly on it), with a prior information that is not positive
definite (``var ≤ 0``), and for draw counts below, at and beyond the vector width's multiples.
"""

from __future__ import annotations

import numpy as np
import pytest
from oracles.compiled_objective_reference import _value_grad as reference
from oracles.compiled_objective_reference import random_inputs, workspace

from tmaplan.planning.compiled_objective import _value_grad


def _explicit_none(*args):
    """The kernel as the closed loop calls it: ``seed=None`` given (another specialisation
    than the argument omitted)."""
    return _value_grad(*args, None)



def _outputs(kernel, args, K1, ns, calls):
    """(values, grad, A, V) after ``calls``: (store, forward, reverse) flags in turn."""
    grad, A, V, c, G, Z = workspace(K1, ns)
    values = [kernel(*args, grad, A, V, c, G, Z, *flags) for flags in calls]
    return values, grad, A, V


CALLS = {
    "forward": [(True, True, False)],
    "forward+reverse": [(True, True, True)],
    "forward, then reverse": [(True, True, False), (False, False, True)],
    "forward+reverse, then forward": [(True, True, True), (True, True, False)],
    "forward unstored": [(False, True, False)],
}


@pytest.mark.parametrize("ns", [1, 3, 7, 128, 129])
@pytest.mark.parametrize("K1", [1, 2, 5, 121])
@pytest.mark.parametrize("case", ["plain", "floor", "indefinite"])
def test_the_same_bits_as_before_the_loops_were_split(ns, K1, case):
    for seed in range(3):
        args = random_inputs(K1, ns, seed, floor=case == "floor",
                             indefinite=case == "indefinite")
        for name, calls in CALLS.items():
            old = _outputs(reference, args, K1, ns, calls)
            for kernel in (_value_grad, _explicit_none):
                (v0, g0, A0, V0), (v1, g1, A1, V1) = old, _outputs(kernel, args, K1, ns,
                                                                   calls)
                assert v0 == v1, name
                if any(flags[2] for flags in calls):  # the old sweep wrote over V[:, 0]
                    V0, V1 = V0[:, 1:], V1[:, 1:]
                for a, b in ((g0, g1), (A0, A1), (V0, V1)):
                    assert np.array_equal(a, b, equal_nan=True), (name, seed)


@pytest.mark.parametrize("case", ["plain", "floor"])
def test_a_second_gradient_at_the_same_point_is_the_first(case):
    """A reverse-only call after a reverse sweep at the same point (casadi may ask twice)
    gives the same gradient, bit for bit (the kernel before overwrote the forward pass's
    variances with the sweep's terms and returned another gradient, by up to 0.8 of it)."""
    K1, ns = 121, 128
    args = random_inputs(K1, ns, 1, floor=case == "floor")
    grad, A, V, c, G, Z = workspace(K1, ns)
    _value_grad(*args, grad, A, V, c, G, Z, True, True, True)
    first = grad.copy()
    for _ in range(2):
        _value_grad(*args, grad, A, V, c, G, Z, False, False, True)
        assert np.array_equal(grad, first)


def test_the_inputs_reach_the_floor_and_a_negative_variance():
    """The cases above take the branches they are meant to: draws with ``r² ≤ m2`` (one with
    ``r² = m2`` exactly) and ``var ≤ 0``; and the gradient is finite and not zero there."""
    K1, ns = 121, 128
    sx, sy, svx, svy, t, dx, dy, *_, m2 = random_inputs(K1, ns, 0, floor=True)
    rx = sx[:, None] + svx[:, None] * t - dx
    ry = sy[:, None] + svy[:, None] * t - dy
    r2 = rx * rx + ry * ry
    assert (r2 < m2).sum() > 10 and (r2 == m2).any()
    args = random_inputs(K1, ns, 0, indefinite=True)
    _, grad, _, V = _outputs(_value_grad, args, K1, ns, CALLS["forward"])
    assert (V[:, 0] <= 0.0).mean() > 0.5 and (V[:, 0] > 0.0).any()
    _, grad, _, _ = _outputs(_value_grad, args, K1, ns, CALLS["forward+reverse"])
    assert np.isfinite(grad).all() and np.abs(grad).max() > 0.0
