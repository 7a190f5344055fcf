"""GvM2 moments (file 004) and the range-only filter."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from tmaplan.estimators import (
    RangeOnlyConfig,
    RangeOnlyState,
    dirac_mixture,
    gvm2_from_gaussian,
    moments_grid,
    moments_series,
    monte_carlo,
    range_only_update,
)

# File 004 §VII.A (L365): ŷ = [−11, 20], V = [[50, −10], [−10, 50]], r = √521 (NOTES_004 §2.5a).
YHAT = np.array([-11.0, 20.0])
V = np.array([[50.0, -10.0], [-10.0, 50.0]])
R = np.sqrt(521.0)


def test_gvm2_parameters_match_notes() -> None:
    g = gvm2_from_gaussian(YHAT, V, R)
    # NOTES_004 §2.5a: κ1 = 9.09543, κ2 = 1.085417, φ1 = 1.945478 (atan2, not tan⁻¹).
    assert g.kappa1 == pytest.approx(9.09543, rel=1e-5)
    assert g.kappa2 == pytest.approx(1.085417, rel=1e-5)
    assert g.mu1 == pytest.approx(1.945478, abs=1e-6)


def test_grid_moments_match_quadrature() -> None:
    g = gvm2_from_gaussian(YHAT, V, R)
    c = moments_grid(g, 4)
    Z = quad(lambda t: np.exp(g.logf(t)), 0, 2 * np.pi, epsabs=0, epsrel=1e-13)[0]
    for m in range(5):
        re = quad(lambda t, m=m: np.cos(m * t) * np.exp(g.logf(t)), 0, 2 * np.pi, epsabs=0,
                  epsrel=1e-13)[0] / Z
        im = quad(lambda t, m=m: np.sin(m * t) * np.exp(g.logf(t)), 0, 2 * np.pi, epsabs=0,
                  epsrel=1e-13)[0] / Z
        assert abs(c[m] - (re + 1j * im)) < 1e-12


def test_series_convergence_magnitudes_table_I() -> None:
    # File 004 Table I (L391–394) magnitudes at N = 0, 2, 5, ≥10 (NOTES_004 §4.1 acceptance:
    # ~1e-1, ~1e-3, ≤ ~2e-7, ≤ 1e-14); the series is the corrected eqs. (29)–(34).
    g = gvm2_from_gaussian(YHAT, V, R)
    ref = moments_grid(g, 1)[1]
    err = {N: abs(moments_series(g, 1, N)[1] - ref) for N in (0, 2, 5, 10, 20)}
    assert 1e-2 < err[0] < 1.0
    assert 1e-4 < err[2] < 1e-2
    assert err[5] < 2e-7
    assert err[10] < 1e-14 and err[20] < 1e-14


def test_von_mises_limit_and_m0() -> None:
    # Isotropic V ⇒ κ2 = 0: the moments are I_m(κ1)/I_0(κ1) e^{imμ1}.
    from scipy.special import ive

    g = gvm2_from_gaussian(np.array([30.0, 40.0]), 25.0 * np.eye(2), 48.0)
    assert g.kappa2 == pytest.approx(0.0, abs=1e-12)
    c = moments_grid(g, 3)
    assert c[0] == 1.0
    for m in range(1, 4):
        assert c[m] == pytest.approx(ive(m, g.kappa1) / ive(0, g.kappa1)
                                     * np.exp(1j * m * g.mu1), abs=1e-13)


def test_grid_engine_concentrated_case_is_stable() -> None:
    # Range-only regime (NOTES_004 §2.5c): κ ~ 1e5–1e6 where the series is unusable.
    c_th = np.deg2rad(45.0)
    rot = np.array([[np.cos(c_th), -np.sin(c_th)], [np.sin(c_th), np.cos(c_th)]])
    Vc = rot @ np.diag([10.0**2, 174.0**2]) @ rot.T + 100.0 * np.eye(2)
    g = gvm2_from_gaussian(np.array([7071.0, 7071.0]), Vc, 9990.0)
    assert g.kappa1 > 1e5
    c1 = moments_grid(g, 2)
    from tmaplan.estimators.gvm_moments import grid_size

    c2 = moments_grid(g, 2, n_grid=2 * grid_size(g))
    assert np.max(np.abs(c1 - c2)) < 1e-12
    assert np.all(np.abs(c1) <= 1.0 + 1e-12)


def test_dirac_mixture_sum_to_one_and_matches_low_moments() -> None:
    g = gvm2_from_gaussian(YHAT, V, R)
    c = moments_grid(g, 10)
    d = dirac_mixture(c, 8, g)
    assert d.gamma.sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all(d.gamma >= 0)
    fit = np.exp(1j * np.outer(np.arange(1, 3), d.theta)) @ d.gamma
    assert np.max(np.abs(fit - c[1:3])) < 5e-3


def test_moment_update_equals_monte_carlo_posterior() -> None:
    # Eqs. (12)–(13) are the exact posterior mean/cov under the eq. (6) model: compare with
    # importance sampling from the Gaussian prior with the Rice-equivalent likelihood.
    rng = np.random.default_rng(0)
    x = np.array([3000.0, 4000.0, 1.0, -1.0])
    P = np.diag([400.0**2, 300.0**2, 1.0, 1.0])
    P[0, 2] = P[2, 0] = 100.0
    st = RangeOnlyState(step=0, mean=x, cov=P)
    s = 20.0
    post = range_only_update(st, 5100.0, s, RangeOnlyConfig(dt=1.0, q=0.0))
    n = 400_000
    Xs = x + rng.standard_normal((n, 4)) @ np.linalg.cholesky(P).T
    # Eq. (6) model: y = pos + v, v ~ N(0, s²I), r = ‖y‖: p(r|x) = Rice.
    from scipy.stats import rice

    rho = np.hypot(Xs[:, 0], Xs[:, 1])
    w = rice.pdf(5100.0, rho / s, scale=s)
    w /= w.sum()
    m = w @ Xs
    assert np.all(np.abs(post.mean - m) <= 0.03 * np.sqrt(np.diag(post.cov)))
    C = ((Xs - m) * w[:, None]).T @ (Xs - m)
    np.testing.assert_allclose(np.sqrt(np.diag(post.cov)), np.sqrt(np.diag(C)), rtol=0.05)


def test_dirac_exact_collapse_equals_moment_update() -> None:
    # NOTES_004 §3.4: with component_cov="exact" the collapse reproduces eq. (13) when the
    # Dirac points match c1 and c2.
    x = np.array([3000.0, 4000.0, 1.0, -1.0])
    P = np.diag([300.0**2, 300.0**2, 1.0, 1.0])
    st = RangeOnlyState(step=0, mean=x, cov=P)
    a = range_only_update(st, 5050.0, 20.0, RangeOnlyConfig(dt=1.0, q=0.0))
    b = range_only_update(st, 5050.0, 20.0, RangeOnlyConfig(dt=1.0, q=0.0, mode="dirac",
                                                            n_moments=3, n_points=6))
    np.testing.assert_allclose(b.mean, a.mean, atol=0.5)
    np.testing.assert_allclose(b.cov, a.cov, rtol=0.02, atol=1e-3)


def test_range_only_smoke_on_sharma() -> None:
    from tmaplan.scenario import load_problem

    sc = load_problem("sharma2024-range-only")
    res = monte_carlo(sc, "range-only", runs=3, seed=1, bound=False)
    assert np.isfinite(res.rmse_position).all()
    # The first scans are well inside the prior (range σ 10 m, azimuth 1° at 10 km).
    assert res.rmse_position[0] < 400.0


@pytest.mark.slow
def test_range_only_vs_pf_sharma() -> None:
    # Issue 5 target: range-only final RMSE ≤ 1.3× the PF's (10^4 particles, 100 runs) with a
    # consistent NEES. NOT MET at the time of writing (issue-5 report): both filters end ~6×
    # above the truth-conditional PCRB because the posterior is a ring arc (rotational
    # ambiguity of range-only tracking on straight relative legs, strong process noise), and
    # the single-Gaussian range-only filter becomes overconfident after the manoeuvre.
    from tmaplan.scenario import load_problem

    sc = load_problem("sharma2024-range-only")
    ro = monte_carlo(sc, "range-only", runs=100, seed=4, bound=False)
    pf = monte_carlo(sc, "pf", runs=100, seed=4, n_particles=10_000, bound=False)
    assert ro.rmse_position[-1] <= 1.3 * pf.rmse_position[-1]
    # NEES (4-D) in the 95 % band of NOTES_004 §4.2 (100 runs).
    from scipy.stats import chi2

    lo, hi = chi2.ppf([0.025, 0.975], 400) / 100
    assert lo < ro.nees[-1] < hi
