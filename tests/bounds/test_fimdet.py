"""Tests of tmaplan.bounds.fimdet: exact log det FIM and lecadre1997's approximations."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tmaplan.bounds.fimdet import (
    bearing_derivatives,
    bearing_rate_det_approx,
    det4_eq68,
    det4_second_order,
    det4_subset,
    exact_det_piecewise,
    fim_bearings,
    fim_bearings_generic,
    inverse_quadratic_generic,
    logdet_bearing_rate_approx,
    logdet_fim_bearings,
    logdet_fim_from_bearings,
    logdet_generic,
    nardone_aidala,
    quartic_coefficients,
    single_leg_det,
    single_leg_small_rate_constant,
)
from tmaplan.errors import ArgumentError, ObservabilityError


def _G(ph, t):
    return np.stack([np.cos(ph), -np.sin(ph), t * np.cos(ph), -t * np.sin(ph)])


def _manoeuvre_geometry():
    t = np.arange(0.0, 1800.0, 15.0)
    obs = np.where(t[:, None] < 900, t[:, None] * [5.0, 0.0],
                   [4500.0, 0.0] + (t[:, None] - 900) * [-3.0, 4.0])
    tgt = np.array([3000.0, 15000.0]) + t[:, None] * [-2.0, 1.0]
    return t, tgt - obs


def test_logdet_qr_matches_slogdet_and_is_batched():
    t, rel = _manoeuvre_geometry()
    sig = np.radians(1.0)
    F = fim_bearings(rel, t, sig, t_ref=0.0)
    ld = logdet_fim_bearings(rel, t, sig)
    assert ld == pytest.approx(np.linalg.slogdet(F)[1], rel=1e-9)
    # det is invariant to the reference time (lecadre1997)
    assert logdet_fim_bearings(rel, t, sig, t_ref=1234.0) == pytest.approx(ld, rel=1e-9)
    # batch: scaling all ranges by 2 divides det by 2^8
    both = logdet_fim_bearings(np.stack([rel, 2 * rel]), t, sig)
    np.testing.assert_allclose(both, [ld, ld - 8 * np.log(2.0)], rtol=1e-9)
    # from measured bearings and true ranges
    b = np.arctan2(rel[:, 0], rel[:, 1])
    r = np.hypot(rel[:, 0], rel[:, 1])
    assert logdet_fim_from_bearings(b, t, sig, r) == pytest.approx(ld, rel=1e-9)


def test_logdet_straight_legs_is_much_smaller():
    """Without an observer manoeuvre the CV/CV FIM is singular (lecadre1997 §III): its log det
    collapses by tens of nats (numerical noise only)."""
    t, rel = _manoeuvre_geometry()
    obs_straight = t[:, None] * [5.0, 0.0]
    tgt = np.array([3000.0, 15000.0]) + t[:, None] * [-2.0, 1.0]
    assert logdet_fim_bearings(tgt - obs_straight, t, 0.01) < logdet_fim_bearings(
        rel, t, 0.01) - 30.0


def test_generic_numpy_and_casadi_agree():
    casadi = pytest.importorskip("casadi")
    t, rel = _manoeuvre_geometry()
    tau = t - t.mean()
    F = fim_bearings(rel, t, 0.01, t_ref=t.mean())
    Fg = np.array(fim_bearings_generic(rel[:, 0], rel[:, 1], tau, 1e4))
    np.testing.assert_allclose(Fg, F, rtol=1e-12)
    ld = logdet_fim_bearings(rel, t, 0.01)
    assert logdet_generic(fim_bearings_generic(rel[:, 0], rel[:, 1], tau, 1e4)) == \
        pytest.approx(ld, rel=1e-9)
    g = np.array([1.0, -2.0, 300.0, 50.0])
    assert inverse_quadratic_generic(Fg.tolist(), g) == pytest.approx(g @ np.linalg.solve(F, g),
                                                                      rel=1e-8)
    # casadi, in scaled units (km, 900 s): log det F = log det F' − 8 log L + 4 log T
    x = casadi.SX.sym("x", t.size)
    y = casadi.SX.sym("y", t.size)
    L, T = 1e4, 900.0
    expr = logdet_generic(fim_bearings_generic(x / L, y / L, casadi.DM(tau / T), 1e4)) \
        - 8 * np.log(L) + 4 * np.log(T)
    f = casadi.Function("f", [x, y], [expr, casadi.gradient(expr, x)])
    val, grad = f(rel[:, 0], rel[:, 1])
    assert float(val) == pytest.approx(ld, rel=1e-9)
    # casadi's exact gradient against a finite difference of the numpy implementation
    k = 17
    e = np.zeros_like(rel)
    e[k, 0] = 1e-2
    fd = (logdet_fim_bearings(rel + e, t, 0.01) - logdet_fim_bearings(rel - e, t, 0.01)) / 2e-2
    assert float(grad[k]) == pytest.approx(fd, rel=1e-5)


def test_general_four_sample_identity():
    """docs/errata.md identity, exact for arbitrary phases and non-integer times."""
    rng = np.random.default_rng(3)
    ph = rng.normal(size=(50, 4))
    t = np.sort(rng.uniform(0.0, 7.0, size=(50, 4)), axis=1)
    exact = np.array([np.linalg.det(_G(p, s)) for p, s in zip(ph, t)])
    np.testing.assert_allclose(det4_subset(ph, t), exact, rtol=1e-9, atol=1e-12)


def test_eq68_exact_and_printed_form():
    """Eq. (68): det 𝒢_{k,4} = α1(2α3β'2 − α2β'3) = 4α1α3c2 − 3α1α2c3 − α2α3c1, exact."""
    rng = np.random.default_rng(4)
    for p in rng.normal(size=(20, 3)):
        ph = np.r_[0.0, p]
        exact = np.linalg.det(_G(ph, np.arange(4.0)))
        assert det4_eq68(*p) == pytest.approx(exact, rel=1e-9, abs=1e-12)
        a1, a2, a3 = np.sin(p)
        c1, c2, c3 = np.cos(p)
        b2p = 2 * c2 - (a2 / a1) * c1
        b3p = 3 * c3 - (a3 / a1) * c1
        assert a1 * (2 * a3 * b2p - a2 * b3p) == pytest.approx(exact, rel=1e-9, abs=1e-12)


def test_property5_identity_and_regime():
    """Property 5 (eq. 69): with the truncated α_i = iθ̇ + i²θ̈/2, 1+β_i = 1 − i²θ̇²/2 the
    determinant is exactly 6θ̇⁴ − 3θ̈²; against the exact determinant it holds when θ̈²
    dominates and fails (ratio 6/4) when θ̈ = 0 (the truncation drops −θ̇³/6)."""
    for a, b in [(0.01, 0.003), (0.2, -0.05), (0.03, 0.0)]:
        i = np.arange(1, 4)
        al = i * a + i**2 * b / 2
        c = 1 - i**2 * a**2 / 2
        form = 4 * al[0] * al[2] * c[1] - 3 * al[0] * al[1] * c[2] - al[1] * al[2] * c[0]
        assert form == pytest.approx(det4_second_order(a, b), rel=1e-9)
    t = np.arange(4.0)
    eps = 1e-3
    exact = np.linalg.det(_G(eps * t**2 / 2, t))  # θ̇ = 0, θ̈ = ε
    assert exact == pytest.approx(det4_second_order(0.0, eps), rel=1e-3)
    exact = np.linalg.det(_G(eps * t, t))  # θ̈ = 0
    assert exact / det4_second_order(eps, 0.0) == pytest.approx(4.0 / 6.0, rel=1e-4)


def test_nardone_aidala_third_order_regime_and_failure():
    """Eq. (73) with θ⃛ restored: ratio → 1 for small rates, fails for large ones."""
    t = np.arange(4.0)

    def ratio(eps):
        a, b, c = 0.7 * eps, 0.9 * eps**2, -1.3 * eps**3
        return np.linalg.det(_G(a * t + b * t**2 / 2 + c * t**3 / 6, t)) / nardone_aidala(
            a, b, c)

    assert ratio(1e-4) == pytest.approx(1.0, abs=1e-3)
    assert abs(ratio(0.5) - 1.0) > 0.5


def test_nardone_aidala_vanishes_on_rectilinear_motion():
    rng = np.random.default_rng(5)
    X = np.column_stack([rng.uniform(-2e4, 2e4, (20, 2)), rng.uniform(-10, 10, (20, 2))])
    d1, d2, d3 = bearing_derivatives(X)
    scale = np.abs(d1) ** 4 + d2**2
    assert np.max(np.abs(nardone_aidala(d1, d2, d3)) / scale) < 1e-9
    # the analytic derivatives against finite differences of the bearing
    h = 1e-2
    x0 = X[0]

    def brg(s):
        p = x0[:2] + s * x0[2:]
        return np.arctan2(p[0], p[1])

    assert d1[0] == pytest.approx((brg(h) - brg(-h)) / (2 * h), rel=1e-6)
    assert d2[0] == pytest.approx((brg(h) - 2 * brg(0) + brg(-h)) / h**2, rel=1e-4)


@pytest.mark.parametrize("n", [4, 5, 6, 8])
def test_single_leg_result1_exact(n):
    """Result 1 (eq. 76) exact under the linear-bearing, constant-range model (T10–T13)."""
    for x in (1e-2, 0.37, 1.1):
        assert single_leg_det(x, n) == pytest.approx(exact_det_piecewise([x], [n]), rel=1e-9)


def test_printed_3867_is_wrong():
    x = 0.37
    coeffs = (26691, 44912, 27608, 12368, 3867, 816, 136, 16, 1)  # as printed
    printed = 32 * np.sin(x) ** 8 * sum(c * np.cos(2 * j * x) for j, c in enumerate(coeffs))
    assert abs(printed / exact_det_piecewise([x], [8]) - 1) > 1e-5


def test_small_rate_constant():
    assert single_leg_small_rate_constant(4) == pytest.approx(16.0)
    for n in (5, 7):
        k = single_leg_small_rate_constant(n)
        assert exact_det_piecewise([1e-3], [n]) == pytest.approx(k * 1e-24, rel=1e-4)
        assert abs(exact_det_piecewise([0.8], [n]) / (k * 0.8**8) - 1) > 0.5


def test_two_and_three_leg_polynomials_match_printed():
    """Eq. (90)–(91) and Appendix B under Model A (docs/errata.md), with the corrections
    784x⁴/−5488x³y for F_{3,6} and −5264 for F_{3,3,3}."""
    key = [(4, 0), (3, 1), (2, 2), (1, 3), (0, 4)]

    def vec(lengths):
        q = quartic_coefficients(lengths)
        return [q.get(k, 0) for k in key]

    assert vec([3, 4]) == [200, -800, 5120, -8640, 4120]  # printed "F_{4,3}"
    assert vec([6, 6]) == [694820, -2075640, 3599540, -3751440, 1532720]  # "F_{6,7}"
    assert vec([2, 7]) == [0, 0, 56448, -112896, 56448]
    assert vec([3, 6]) == [784, -5488, 103488, -193648, 94864]
    q3 = quartic_coefficients([3, 3, 3])
    printed = {(4, 0, 0): 784, (3, 0, 1): -5264, (3, 1, 0): -224, (2, 0, 2): 147114,
               (2, 1, 1): -56928, (2, 2, 0): 13302}
    for k, v in printed.items():
        assert q3[k] == v
    # (x − y)² divides every two-leg polynomial: P(1, 1) = 0
    for lengths in ([3, 4], [6, 6], [2, 7], [3, 6]):
        assert sum(vec(lengths)) == 0


@pytest.mark.parametrize("lengths", [[3, 4], [6, 6], [3, 3, 3]])
def test_bearing_rate_approx_regime_and_failure(lengths):
    L = len(lengths)
    x = np.array([1e-3, -1e-3, 1e-3][:L])
    assert bearing_rate_det_approx(x, lengths) == pytest.approx(
        exact_det_piecewise(x, lengths), rel=1e-4)
    # fails without a manoeuvre (equal rates: the cross-leg terms vanish; eq. 89 regime)
    same = np.full(L, 1e-3)
    assert bearing_rate_det_approx(same, lengths) < 0.1 * exact_det_piecewise(same, lengths)
    # and at large per-sample rates
    big = 0.3 * np.sign(x)
    assert abs(bearing_rate_det_approx(big, lengths) / exact_det_piecewise(big, lengths)
               - 1) > 0.1


def test_two_leg_optimum_is_bang_bang_opposite():
    """Eq. (87): over |θ̇_i| ≤ θ̇max the exact det is maximal at θ̇_2 = −θ̇_1 = ±θ̇max."""
    g = np.linspace(-1e-3, 1e-3, 21)
    X, Y = np.meshgrid(g, g, indexing="ij")
    vals = exact_det_piecewise(np.stack([X, Y], axis=-1), [6, 6])
    i, j = np.unravel_index(np.argmax(vals), vals.shape)
    assert {(i, j)} <= {(0, 20), (20, 0)}


def test_realistic_long_range_check():
    """docs/errata.md: fixed source 20 km north, observer 5 m/s, 3 samples heading 090° then 4
    heading 270°, σ = 1°: the SI log det matches P_{3,4}·dt⁴/(σ r̄)^8 for small dt and drifts
    as dt grows."""
    sig = np.radians(1.0)
    errs = []
    for dt in (1.0, 10.0, 60.0):
        k = np.arange(7.0)
        xo = np.where(k <= 2, 5.0 * dt * k, 10.0 * dt - 5.0 * dt * (k - 2))
        rel = np.stack([-xo, np.full(7, 20000.0)], axis=-1)
        ph = np.unwrap(np.arctan2(rel[:, 0], rel[:, 1]))
        rates = [(ph[2] - ph[0]) / 2, (ph[6] - ph[2]) / 4]
        exact = logdet_fim_bearings(rel, k * dt, sig)
        approx = logdet_bearing_rate_approx(rates, [3, 4], sig,
                                            float(np.mean(np.hypot(*rel.T))), dt)
        errs.append(abs(approx - exact))
    assert errs[0] < 1e-3
    assert errs[0] < errs[1] < errs[2]


def test_bad_inputs():
    t, rel = _manoeuvre_geometry()
    b = np.arctan2(rel[:, 0], rel[:, 1])
    b[5] = np.nan
    with pytest.raises(ArgumentError, match="bearings"):
        logdet_fim_from_bearings(b, t, 0.01, 1e4)
    with pytest.raises(ArgumentError, match="sigma"):
        logdet_fim_bearings(rel, t, 0.0)
    with pytest.raises(ObservabilityError, match="too few"):
        logdet_fim_bearings(rel[:3], t[:3], 0.01)
    rel0 = rel.copy()
    rel0[4] = 0.0
    with pytest.raises(ObservabilityError, match="observer is at the target"):
        logdet_fim_bearings(rel0, t, 0.01)
    with pytest.raises(ArgumentError, match=r"field 'n'.*\[4, 5, 6, 8\].*received 7"):
        single_leg_det(0.1, 7)


def test_cauchy_binet_sum_equals_det():
    """Eq. (75): det F = Σ_E det²𝒢_E (checked with the subset identity)."""
    t = np.arange(7.0)
    ph = np.r_[0.0, 0.01, 0.02, 0.05, 0.07, 0.08, 0.12]
    E = np.array(list(itertools.combinations(range(7), 4)))
    total = np.sum(det4_subset(ph[E], t[E]) ** 2)
    G = _G(ph, t)
    assert total == pytest.approx(np.linalg.det(G @ G.T), rel=1e-8)


@pytest.mark.parametrize("call, field", [
    (lambda t, rel: fim_bearings(rel, t, 0.01, t_ref=np.nan), "t_ref"),
    (lambda t, rel: logdet_fim_bearings(rel, t, 0.01, t_ref=np.inf), "t_ref"),
    (lambda t, rel: fim_bearings(rel, t, 0.01, t_ref="3"), "t_ref"),
    (lambda t, rel: logdet_fim_bearings(rel, t * np.nan, 0.01), "times"),
    (lambda t, rel: logdet_fim_bearings(rel, t, np.full(3, 0.01)), "sigma"),
    (lambda t, rel: logdet_fim_from_bearings(np.arctan2(rel[:, 0], rel[:, 1]), t, 0.01,
                                             np.full(3, 1e4)), "ranges"),
    (lambda t, rel: single_leg_small_rate_constant(5.5), "n"),
    (lambda t, rel: single_leg_small_rate_constant(True), "n"),
    (lambda t, rel: exact_det_piecewise([1e-3, -1e-3], [2.7, 4]), "leg_lengths"),
    (lambda t, rel: exact_det_piecewise([1e-3, -1e-3], [True, 4]), "leg_lengths"),
    (lambda t, rel: bearing_rate_det_approx([1e-3, -1e-3, 1e-3], [3, 4]), "rates"),
    (lambda t, rel: exact_det_piecewise(1e-3, [3, 4]), "rates"),
    (lambda t, rel: logdet_bearing_rate_approx([1e-3, -1e-3], [3, 4], np.inf, 1e4), "sigma"),
    (lambda t, rel: logdet_bearing_rate_approx([1e-3, -1e-3], [3, 4], "0.1", 1e4), "sigma"),
    (lambda t, rel: logdet_bearing_rate_approx([1e-3, -1e-3], [3, 4], 0.1, 1e4, np.nan),
     "dt"),
])
def test_bad_arguments_name_their_field(call, field):
    """A NaN t_ref gave a NaN FIM/log det, non-integer leg lengths or sample counts were
    truncated (2.7 -> 2, True -> 1), an infinite σ gave -inf; shape mismatches were raw numpy
    errors and NaN times were blamed on rel_pos."""
    t, rel = _manoeuvre_geometry()
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        call(t, rel)
