"""Tests of tmaplan.geometry: angle conventions, LPC/MP maps and their Jacobians."""

from __future__ import annotations

import types
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tmaplan import geometry as g
from tmaplan.display import objective_label
from tmaplan.errors import ArgumentError, UnitError
from tmaplan.geometry import range_of
from tmaplan.units import to_si, to_si_vector

DEG = np.pi / 180
I4 = np.eye(4)

# ---------------------------------------------------------------------------- strategies
# Relative states with ranges 10 m .. 200 km and velocity components within ±30 m/s.
ranges = st.floats(min_value=10.0, max_value=200e3)
angles = st.floats(min_value=-np.pi, max_value=np.pi)
speeds = st.floats(min_value=-30.0, max_value=30.0)


@st.composite
def states(draw: st.DrawFn) -> np.ndarray:
    r, b = draw(ranges), draw(angles)
    return np.array([r * np.sin(b), r * np.cos(b), draw(speeds), draw(speeds)])


SETTINGS = settings(max_examples=150, deadline=None)


def _scales(X: np.ndarray) -> np.ndarray:
    """Natural scale of each Cartesian component: range for positions, speed for velocities."""
    r = np.hypot(X[0], X[1])
    v = max(np.hypot(X[2], X[3]), 1.0)
    return np.array([r, r, v, v])


def _central_difference(
    f: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    steps: np.ndarray,
    angle_rows: tuple[int, ...] = (),
) -> np.ndarray:
    """Central-difference Jacobian of f at x (one vectorised call of f on 8 points).

    Output components listed in ``angle_rows`` are differenced with wrapping, so a bearing
    that crosses ±π between x − h and x + h does not produce a spurious 2π jump.
    """
    h = np.diag(steps)
    out = f(np.concatenate([x + h, x - h]))  # shape (8, 4)
    diff = out[:4] - out[4:]
    for i in angle_rows:
        diff[:, i] = g.angle_diff(out[:4, i], out[4:, i])
    return (diff / (2.0 * steps[:, None])).T


def _assert_jacobian_close(J: np.ndarray, J_fd: np.ndarray, in_scales: np.ndarray) -> None:
    """Compare Jacobians in input-normalised form, row by row.

    Each input j is perturbed by a relative step h = 1e-5 of its natural scale s_j, so we
    compare J·diag(s). The central difference has truncation error ~ h² ≈ 1e-10 and
    round-off error ~ eps·|f_i| / h ≈ 2e-11·|f_i| relative to the row's largest entry
    (the maps are smooth and every |f_i| is bounded by that entry times O(1..10)).
    A tolerance of 1e-7 times the row's largest entry therefore leaves a margin of more
    than 100 while still catching any wrong term, whose error would be O(1) of the row.
    """
    A = J * in_scales
    B = J_fd * in_scales
    row_scale = np.max(np.abs(A), axis=1, keepdims=True)
    _assert_close(B, A, 1e-7 * row_scale)


def _assert_close(actual: np.ndarray, desired: np.ndarray, atol: np.ndarray | float) -> None:
    """Assert |actual − desired| <= atol elementwise, with an array-valued (broadcast) atol."""
    err = np.abs(np.asarray(actual) - np.asarray(desired))
    tol = np.broadcast_to(atol, err.shape)
    bad = err > tol
    assert not np.any(bad), (
        f"{int(bad.sum())} entries out of tolerance; worst error/tolerance "
        f"{float(np.max(err / tol)):.3g}\nactual=\n{actual}\ndesired=\n{desired}"
    )


# -------------------------------------------------------------------------------- angles
@pytest.mark.parametrize(
    ("dx", "dy", "expected_deg"),
    [
        (1.0, 1.0, 45.0),  # NE
        (1.0, -1.0, 135.0),  # SE
        (-1.0, -1.0, -135.0),  # SW
        (-1.0, 1.0, -45.0),  # NW
        (0.0, 1.0, 0.0),  # N
        (1.0, 0.0, 90.0),  # E
        (0.0, -1.0, 180.0),  # S: +π, never −π
        (-0.0, -1.0, 180.0),  # signed zero: atan2 would give −π
        (-1.0, 0.0, -90.0),  # W
    ],
)
def test_bearing_quadrants(dx: float, dy: float, expected_deg: float) -> None:
    observer = np.array([1000.0, -2000.0])
    target = observer + 3000.0 * np.array([dx, dy])
    assert g.bearing_of([dx, dy]) == pytest.approx(expected_deg * DEG, abs=1e-15)
    X = np.array([*(target - observer), 0.0, 0.0])
    assert g.bearing_of(X) == pytest.approx(expected_deg * DEG, abs=1e-15)
    assert g.cart_to_lpc(X)[0] == pytest.approx(expected_deg * DEG, abs=1e-15)
    assert g.cart_to_mp(X)[2] == pytest.approx(expected_deg * DEG, abs=1e-15)


def test_bearing_signed_zeros() -> None:
    """−0.0 is 0: South is +π (atan2 gives −π), North is +0.0, in both ambiguity modes."""
    X = np.array([[-0.0, -1.0], [0.0, -1.0], [-0.0, 1.0], [0.0, 1.0]])
    b = g.bearing_of(X)
    np.testing.assert_array_equal(b, [np.pi, np.pi, 0.0, 0.0])
    assert not np.any(np.signbit(b))  # no −0.0 and no −π
    bp = g.bearing_of(X, ambiguity="pi")
    np.testing.assert_array_equal(bp, [0.0, 0.0, 0.0, 0.0])
    assert not np.any(np.signbit(bp))
    course, speed = g.course_speed([-0.0, -2.0])
    assert course == np.pi and speed == 2.0
    assert g.cart_to_lpc([-0.0, -5.0, 1.0, 0.0])[0] == np.pi


def test_bearing_ambiguity_pi() -> None:
    X = np.array([[1, 1, 0, 0], [1, -1, 0, 0], [-1, -1, 0, 0], [-1, 1, 0, 0], [1, 0, 0, 0.0]])
    expected = np.array([45.0, -45.0, 45.0, -45.0, 90.0]) * DEG
    np.testing.assert_allclose(g.bearing_of(X, ambiguity="pi"), expected, atol=1e-15)
    # Matches brehard2005's arctan(r_x/r_y) wherever r_y != 0.
    np.testing.assert_allclose(
        g.bearing_of(X[:4], ambiguity="pi"), np.arctan(X[:4, 0] / X[:4, 1]), atol=1e-15
    )
    # West is also π/2 modulo π: the range is (−π/2, π/2].
    assert g.bearing_of([-1.0, 0.0, 0, 0], ambiguity="pi") == pytest.approx(np.pi / 2)
    Y = g.cart_to_lpc(X, ambiguity="pi")
    np.testing.assert_allclose(Y[:, 0], expected, atol=1e-15)
    # eq. 7: lpc_to_cart returns X on the r_y > 0 branch and −X on the r_y < 0 branch.
    sign = np.where(X[:, 1] >= 0, 1.0, -1.0)[:, None]
    np.testing.assert_allclose(g.lpc_to_cart(Y), sign * X, atol=1e-14)
    with pytest.raises(ValueError, match="ambiguity"):
        g.bearing_of(X, ambiguity="2pi")  # type: ignore[arg-type]


def test_wrap_angle_examples() -> None:
    assert g.angle_diff(179 * DEG, -179 * DEG) == pytest.approx(-2 * DEG, abs=1e-14)
    assert g.angle_diff(-179 * DEG, 179 * DEG) == pytest.approx(2 * DEG, abs=1e-14)
    assert g.wrap_angle(np.pi) == np.pi
    assert g.wrap_angle(-np.pi) == np.pi
    assert g.wrap_angle(3 * np.pi) == pytest.approx(np.pi)
    assert g.wrap_angle(-1e-20) == -1e-20  # in range: returned bit for bit
    assert g.wrap_angle(2 * np.pi - 1e-17) <= np.pi
    np.testing.assert_allclose(
        g.wrap_angle([190 * DEG, -190 * DEG, 720 * DEG, 30 * DEG]),
        [-170 * DEG, 170 * DEG, 0.0, 30 * DEG],
        atol=1e-14,
    )
    assert isinstance(g.wrap_angle(1.0), float)
    assert g.wrap_angle(np.zeros((2, 3))).shape == (2, 3)


def test_one_angle_wraps_as_in_an_array() -> None:
    # one angle (a closed loop's bearing) takes a shorter path: the same bits and types
    a = np.concatenate([np.linspace(-7.0, 7.0, 2001), [np.pi, -np.pi, -0.0, 0.0, 1e-300]])
    whole = g.wrap_angle(a)
    for i, x in enumerate(a):
        for one in (g.wrap_angle(float(x)), g.wrap_angle(np.array([x]))[0],
                    g.wrap_angle(np.array(x))):
            assert np.array_equal(one, whole[i]) and np.signbit(one) == np.signbit(whole[i])
    x = np.array([0.5])
    y = g.wrap_angle(x)
    assert y is not x and y.shape == (1,)  # a new array, never the caller's
    assert isinstance(g.wrap_angle(np.array(0.5)), np.floating)


def test_wrap_half_angle_at_half_pi() -> None:
    h = np.pi / 2
    assert g.wrap_half_angle(h) == h
    assert g.wrap_half_angle(-h) == pytest.approx(h)
    assert g.wrap_half_angle(h + 1e-9) == pytest.approx(-h + 1e-9, abs=1e-15)
    assert g.wrap_half_angle(-h + 1e-9) == -h + 1e-9
    assert g.wrap_half_angle(-h - 1e-9) == pytest.approx(h - 1e-9, abs=1e-15)
    assert g.wrap_half_angle(np.pi) == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(
        g.wrap_half_angle([135 * DEG, -135 * DEG, 270 * DEG]),
        [-45 * DEG, 45 * DEG, h],
        atol=1e-14,
    )


@SETTINGS
@given(st.floats(min_value=-1e4, max_value=1e4))
def test_wrap_properties(a: float) -> None:
    w = g.wrap_angle(a)
    assert -np.pi < w <= np.pi
    assert np.sin(w) == pytest.approx(np.sin(a), abs=1e-11)
    assert np.cos(w) == pytest.approx(np.cos(a), abs=1e-11)
    hw = g.wrap_half_angle(a)
    assert -np.pi / 2 < hw <= np.pi / 2
    assert np.sin(2 * hw) == pytest.approx(np.sin(2 * a), abs=1e-11)
    assert np.cos(2 * hw) == pytest.approx(np.cos(2 * a), abs=1e-11)


@SETTINGS
@given(st.floats(min_value=0.0, max_value=30.0), angles)
def test_course_speed_round_trip(speed: float, course: float) -> None:
    v = g.velocity_from_course(speed, course)
    assert v.shape == (2,)
    c, s = g.course_speed(v)
    assert s == pytest.approx(speed, rel=1e-14, abs=1e-14)
    if speed > 1e-6:
        assert g.angle_diff(c, course) == pytest.approx(0.0, abs=1e-12)


def test_velocity_from_course_conventions() -> None:
    v = g.velocity_from_course(10.0, [0.0, 90 * DEG, 180 * DEG, -90 * DEG])
    np.testing.assert_allclose(v, [[0, 10], [10, 0], [0, -10], [-10, 0]], atol=1e-14)
    assert g.velocity_from_course(np.ones((2, 3)), 0.0).shape == (2, 3, 2)


# ------------------------------------------------------------------- round trips and maps
@SETTINGS
@given(states())
def test_lpc_round_trip(X: np.ndarray) -> None:
    scale = _scales(X)
    Y = g.cart_to_lpc(X)
    _assert_close(g.lpc_to_cart(Y), X, 1e-13 * scale)
    assert Y[1] == pytest.approx(np.log(g.range_of(X)), rel=1e-15)


@SETTINGS
@given(states())
def test_mp_round_trip(X: np.ndarray) -> None:
    scale = _scales(X)
    Y = g.cart_to_mp(X)
    _assert_close(g.mp_to_cart(Y), X, 1e-13 * scale)
    assert Y[3] == pytest.approx(1.0 / g.range_of(X), rel=1e-15)
    np.testing.assert_allclose(g.lpc_to_mp(g.cart_to_lpc(X)), Y, rtol=1e-14, atol=0)
    np.testing.assert_allclose(g.mp_to_lpc(Y), g.cart_to_lpc(X), rtol=1e-14, atol=0)


def test_lpc_components_by_hand() -> None:
    # Target 3 km North-East-ish at r = 5 km, moving East at 10 m/s.
    X = np.array([3000.0, 4000.0, 10.0, 0.0])
    Y = g.cart_to_lpc(X)
    np.testing.assert_allclose(
        Y, [np.arctan2(3, 4), np.log(5000.0), 10 * 4000 / 5000**2, 10 * 3000 / 5000**2]
    )
    np.testing.assert_allclose(g.cart_to_mp(X), [Y[2], Y[3], Y[0], 1 / 5000.0])


def test_vectorised_over_leading_dimensions() -> None:
    rng = np.random.default_rng(1)
    r = rng.uniform(10, 200e3, size=(3, 5))
    b = rng.uniform(-np.pi, np.pi, size=(3, 5))
    X = np.stack([r * np.sin(b), r * np.cos(b), *rng.uniform(-30, 30, size=(2, 3, 5))], axis=-1)
    Y = g.cart_to_lpc(X)
    assert Y.shape == (3, 5, 4)
    for fn in (
        g.jacobian_cart_wrt_lpc_from_cart,
        g.jacobian_lpc_wrt_cart,
        g.jacobian_mp_wrt_cart,
    ):
        assert fn(X).shape == (3, 5, 4, 4)
    assert g.jacobian_cart_wrt_lpc(Y).shape == (3, 5, 4, 4)
    assert g.jacobian_cart_wrt_mp(g.cart_to_mp(X)).shape == (3, 5, 4, 4)
    assert g.bearing_of(X).shape == (3, 5)
    assert g.range_of(X).shape == (3, 5)
    # Batched results equal the per-sample ones.
    J = g.jacobian_lpc_wrt_cart(X)
    np.testing.assert_array_equal(J[1, 2], g.jacobian_lpc_wrt_cart(X[1, 2]))
    np.testing.assert_array_equal(Y[2, 4], g.cart_to_lpc(X[2, 4]))


def test_zero_range_raises() -> None:
    X = np.array([[1000.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0]])
    for fn in (g.cart_to_lpc, g.cart_to_mp, g.jacobian_lpc_wrt_cart, g.jacobian_mp_wrt_cart):
        with pytest.raises(ValueError, match="range is zero: observer at the target"):
            fn(X)
    for Y in ([0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -1e-3]):
        for fn_y in (g.mp_to_cart, g.jacobian_cart_wrt_mp, g.mp_to_lpc):
            with pytest.raises(ValueError, match="inverse range"):
                fn_y(Y)


def test_bad_shapes_raise() -> None:
    with pytest.raises(ValueError, match="shape"):
        g.cart_to_lpc(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="shape"):
        g.lpc_to_cart(1.0)


# ------------------------------------------------------------------------------ Jacobians
@SETTINGS
@given(states())
def test_lpc_jacobians_match_finite_differences(X: np.ndarray) -> None:
    Y = g.cart_to_lpc(X)
    r = np.hypot(X[0], X[1])
    y_scales = np.array([1.0, 1.0, *(2 * [max(np.hypot(X[2], X[3]), 1.0) / r])])
    x_scales = _scales(X)

    J_xy = g.jacobian_cart_wrt_lpc(Y)
    J_fd = _central_difference(g.lpc_to_cart, Y, 1e-5 * y_scales)
    _assert_jacobian_close(J_xy, J_fd, y_scales)

    J_yx = g.jacobian_lpc_wrt_cart(X)
    J_fd = _central_difference(g.cart_to_lpc, X, 1e-5 * x_scales, angle_rows=(0,))
    _assert_jacobian_close(J_yx, J_fd, x_scales)


@SETTINGS
@given(states())
def test_mp_jacobians_match_finite_differences(X: np.ndarray) -> None:
    Y = g.cart_to_mp(X)
    r = np.hypot(X[0], X[1])
    rate = max(np.hypot(X[2], X[3]), 1.0) / r
    y_scales = np.array([rate, rate, 1.0, 1.0 / r])
    x_scales = _scales(X)

    J_xy = g.jacobian_cart_wrt_mp(Y)
    J_fd = _central_difference(g.mp_to_cart, Y, 1e-5 * y_scales)
    _assert_jacobian_close(J_xy, J_fd, y_scales)

    J_yx = g.jacobian_mp_wrt_cart(X)
    J_fd = _central_difference(g.cart_to_mp, X, 1e-5 * x_scales, angle_rows=(2,))
    _assert_jacobian_close(J_yx, J_fd, x_scales)


@SETTINGS
@given(states())
def test_lpc_jacobian_is_linear_in_x(X: np.ndarray) -> None:
    Y = g.cart_to_lpc(X)
    J_y = g.jacobian_cart_wrt_lpc(Y)
    J_x = g.jacobian_cart_wrt_lpc_from_cart(X)
    # Entries are O(r) in the ω and ρ columns of the velocity rows: use the largest entry.
    atol = 1e-12 * np.max(np.abs(J_x))
    _assert_close(J_y, J_x, atol)
    # Linearity: J(aX + bX') = a J(X) + b J(X').
    X2 = X[::-1].copy()
    np.testing.assert_allclose(
        g.jacobian_cart_wrt_lpc_from_cart(2 * X - 3 * X2),
        2 * J_x - 3 * g.jacobian_cart_wrt_lpc_from_cart(X2),
        rtol=1e-12,
    )
    # Also valid on the r_y < 0 branch of the π-ambiguous LPC, where X = −f(Y).
    Y_pi = g.cart_to_lpc(X, ambiguity="pi")
    sign = 1.0 if X[1] >= 0 else -1.0
    _assert_close(sign * g.jacobian_cart_wrt_lpc(Y_pi), J_x, atol)


@SETTINGS
@given(states())
def test_jacobian_determinants(X: np.ndarray) -> None:
    r = np.hypot(X[0], X[1])
    Y = g.cart_to_lpc(X)
    # The LPC Jacobian is block lower triangular with two blocks r·R(β): det = r⁴ > 0.
    assert np.linalg.det(g.jacobian_cart_wrt_lpc(Y)) == pytest.approx(r**4, rel=1e-9)
    assert np.linalg.det(g.jacobian_lpc_wrt_cart(X)) == pytest.approx(r**-4, rel=1e-9)
    Ymp = g.cart_to_mp(X)
    u = Ymp[3]
    # MP: det ∂X/∂Y = −1/Y4⁵ (brehard2004 gives |det| = 1/Y4⁵). LU round-off grows with the
    # column-scale spread (~r), hence rel=1e-8 rather than 1e-9.
    assert np.linalg.det(g.jacobian_cart_wrt_mp(Ymp)) == pytest.approx(-(u**-5), rel=1e-8)
    assert np.linalg.det(g.jacobian_mp_wrt_cart(X)) == pytest.approx(-(u**5), rel=1e-8)


@SETTINGS
@given(states())
def test_inverse_jacobian_identity(X: np.ndarray) -> None:
    # Compare in scaled coordinates so that every entry of the identity is O(1):
    # D_x⁻¹ J_XY J_YX D_x = I and D_y⁻¹ J_YX J_XY D_y = I.
    x_scales = _scales(X)
    r = x_scales[0]
    rate = x_scales[2] / r
    for to_y, J_xy_of, J_yx_of, y_scales in (
        (g.cart_to_lpc, g.jacobian_cart_wrt_lpc, g.jacobian_lpc_wrt_cart,
         np.array([1.0, 1.0, rate, rate])),
        (g.cart_to_mp, g.jacobian_cart_wrt_mp, g.jacobian_mp_wrt_cart,
         np.array([rate, rate, 1.0, 1.0 / r])),
    ):  # fmt: skip
        Y = to_y(X)
        J_xy, J_yx = J_xy_of(Y), J_yx_of(X)
        P = (J_xy @ J_yx) * x_scales[None, :] / x_scales[:, None]
        Q = (J_yx @ J_xy) * y_scales[None, :] / y_scales[:, None]
        np.testing.assert_allclose(P, I4, rtol=0, atol=1e-12)
        np.testing.assert_allclose(Q, I4, rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# From test_geometry_units_review.py (folded in, issue 39):
# Review of geometry, units, plotting and the planning graphs' parameter layout: defects found
# and fixed (each test failed on the code before its fix).
# ----------------------------------------------------------------------------------------------

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
