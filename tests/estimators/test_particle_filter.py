"""Particle filter and the file-001 bearings-only initialisation."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.estimators import (
    DegeneracyWarning,
    Measurement,
    ParticleFilter,
    PFConfig,
    fit_rmp,
    initialise_from_bearings,
    run,
    systematic_resample,
)
from tmaplan.estimators.init_bearings import bearing_regression, sample_ellipsoid
from tmaplan.estimators.particle_filter import PFState
from tmaplan.evaluation.tracking import monte_carlo
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate

# brehard2004 §4 scenario: relative X0 = (−10000, 10000) m, (16, 3) m/s, δ = 6 s.
X0_001 = np.array([-10000.0, 10000.0, 16.0, 3.0])


def _bearings_001(n: int = 100) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * 6.0
    rel = X0_001[None, :2] + t[:, None] * X0_001[None, 2:]
    return t, np.arctan2(rel[:, 0], rel[:, 1])


def test_regression_eq13_exact_for_cv_geometry() -> None:
    # brehard2004 eq. (13) is exact for a non-manoeuvring geometry (docs/errata.md: 1e-16).
    t, z = _bearings_001(71)
    tk = t[35]
    X = X0_001[:2] + tk * X0_001[2:]
    r2 = X @ X
    yr = np.array([(X0_001[2] * X[1] - X0_001[3] * X[0]) / r2,
                   (X0_001[2] * X[0] + X0_001[3] * X[1]) / r2, np.arctan2(X[0], X[1])])
    assert np.max(np.abs(bearing_regression(yr, t - tk) - z)) < 1e-12
    # Truth at k = 35 from docs/errata.md table: Y1 = 1.2095e-3, Y2 = −4.733e-4, Y3 = −0.5583.
    np.testing.assert_allclose(yr, [1.2095e-3, -4.733e-4, -0.5583], rtol=2e-3)


def test_rmp_fit_and_corrected_start_point() -> None:
    t, z = _bearings_001(71)
    fit = fit_rmp(z, t - t[35], 0.05)
    assert fit.converged
    np.testing.assert_allclose(fit.estimate, [1.2095e-3, -4.733e-4, -0.55835], rtol=1e-3)
    # Corrected eq. (16) start (γ̂2, −γ̂3/γ̂2, γ̂1) lands within a few % of the truth
    # (docs/errata.md item 4); the printed (γ̂2, γ̂3, γ̂1) would give Y2 ≈ 5.7e-7 instead.
    np.testing.assert_allclose(fit.start, fit.estimate, rtol=0.05)


def test_rmp_fim_matches_finite_differences() -> None:
    t, _ = _bearings_001(21)
    tau = t - t[10]
    y = np.array([1.2e-3, -4.7e-4, -0.55])
    from tmaplan.estimators.init_bearings import rmp_fisher_information

    J = np.zeros((tau.size, 3))
    for i in range(3):
        h = np.zeros(3)
        h[i] = 1e-6 * max(abs(y[i]), 1e-3)
        J[:, i] = (bearing_regression(y + h, tau) - bearing_regression(y - h, tau)) / (2 * h[i])
    np.testing.assert_allclose(rmp_fisher_information(y, tau, 0.05), J.T @ J / 0.05**2,
                               rtol=1e-6)


def test_initialisation_time_reproduces_paper_k35() -> None:
    # brehard2004: condition met at 420 s, PF initialised at 210 s (k = 35), with N = 1e4,
    # R in [1, 40] km, α = 5 %, η = 0.05 (q = η²). Noise-free data; docs/errata.md tolerance
    # ±2 steps.
    t, z = _bearings_001(100)
    res = initialise_from_bearings(t, z, 0.05, r_min=1e3, r_max=4e4, n_particles=10_000,
                                   rng=np.random.default_rng(0), q=0.0025)
    assert abs(res.k - 35) <= 2
    assert res.rule_met
    r = np.hypot(res.particles[:, 0], res.particles[:, 1])
    assert r.min() >= 1e3 - 1e-6 and r.max() <= 4e4 + 1e-6
    # Bearings of the particles sit in the confidence region around the true bearing.
    b = np.arctan2(res.particles[:, 0], res.particles[:, 1])
    assert np.max(np.abs(b - (-0.5583))) < 0.05


def test_ellipsoid_sampling_is_uniform_inside() -> None:
    rng = np.random.default_rng(1)
    info = np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 0.5], [0.0, 0.5, 2.0]])
    Y = sample_ellipsoid(np.zeros(3), info, 2.0, 20_000, rng)
    m = np.einsum("ni,ij,nj->n", Y, info, Y) / 2.0
    assert m.max() <= 1.0 + 1e-12
    # Uniform in a 3-D ellipsoid: the normalised radius³ = m^{3/2} is U(0, 1).
    u = m**1.5
    assert abs(u.mean() - 0.5) < 0.01 and abs(np.mean(u < 0.25) - 0.25) < 0.01


def test_systematic_resampling_counts() -> None:
    w = np.array([0.1, 0.2, 0.3, 0.4])
    idx = systematic_resample(np.log(w), np.random.default_rng(0), n=1000)
    counts = np.bincount(idx, minlength=4)
    # Systematic resampling: each count is floor or ceil of N·w.
    assert np.all(np.abs(counts - 1000 * w) <= 1)


def test_fast_systematic_equals_searchsorted_version() -> None:
    # The O(N) bincount resampler of update() must return exactly the indices of the binary
    # search of systematic_resample() for the same uniform draw (independent formulations).
    from tmaplan.estimators.pf_kernels import systematic_indices as _systematic

    for seed in range(5):
        rng = np.random.default_rng(seed)
        w = rng.gamma(0.3, size=5000)
        w[rng.random(5000) < 0.3] = 0.0  # zero weights must never be drawn
        w /= w.sum()
        with np.errstate(divide="ignore"):
            a = systematic_resample(np.log(w), np.random.default_rng(100 + seed))
        b = _systematic(w, np.random.default_rng(100 + seed))
        assert np.count_nonzero(a != b) <= 1  # ≤ 1 floating tie at a CDF boundary
        assert np.all(w[b] > 0)


def test_float32_box_muller_normals() -> None:
    # The default process-noise generator: standard normal by a KS test on 4·10⁵ draws
    # (D ≈ 0.002 at the 5 % level; a missing factor 2 under the log gives D ≈ 0.1),
    # uncorrelated rows (the cos and sin halves of one Box–Muller pair), kurtosis 3.
    from scipy.stats import kstest

    from tmaplan.estimators.pf_kernels import normals_f32 as _normals_f32

    Z = np.empty((4, 100_000))
    _normals_f32(np.random.default_rng(0), Z)
    assert Z.dtype == np.float64
    assert kstest(Z.ravel(), "norm").pvalue > 0.01
    C = np.corrcoef(Z)
    assert np.max(np.abs(C - np.eye(4))) < 0.015
    assert abs(np.mean(Z.ravel() ** 4) - 3.0) < 0.06


def test_regularised_jitter_has_kernel_covariance() -> None:
    # After resampling from uniform weights, the regularised PF adds h·L·z jitter with
    # L L' = weighted covariance: the cloud covariance becomes (1 + h²) C. A jitter applied
    # with L' instead of L (or without the lower-triangular cross terms) changes it.
    rng = np.random.default_rng(1)
    C = np.array([[4.0, 1.5, 0.3, 0.0], [1.5, 2.0, 0.2, 0.4], [0.3, 0.2, 1.0, 0.3],
                  [0.0, 0.4, 0.3, 0.5]]) * 1e4
    n = 200_000
    X = rng.multivariate_normal([5000.0, 5000.0, 0.0, 0.0], C, n)
    cfg = PFConfig(n_particles=n, dt=1.0, q=0.0, ess_threshold=1.0, bandwidth_scale=5.0)
    pf = ParticleFilter(cfg)
    st = pf.from_particles(X)
    st = pf.update(st, [Measurement(kind="range", value=7071.0, sigma=1e9)], rng)
    assert st.resampled
    h = 5.0 * (4.0 / (n * 6)) ** (1 / 8)
    np.testing.assert_allclose(st.cov, (1 + h * h) * np.cov(X.T), rtol=0.03, atol=0.03 * 1e4)


def test_resample_move_leaves_the_posterior_invariant() -> None:
    # After predict + range update, the resample-move cloud (30 MH sweeps with a wide
    # proposal) must have the moments of the importance-weighted posterior of a large
    # independent sample. An acceptance ratio without the transition density f(x_k|x_{k-1})
    # lets the velocities random-walk (their spread roughly doubles) and fails this test.
    dt, q = 60.0, 1e-3
    m0 = np.array([3000.0, 4000.0, 5.0, -3.0])
    s0 = np.array([300.0, 300.0, 2.0, 2.0])
    z = Measurement(kind="range", value=5000.0, sigma=10.0)

    def cloud(n: int, seed: int) -> np.ndarray:
        return m0 + s0 * np.random.default_rng(seed).standard_normal((n, 4))

    ref = ParticleFilter(PFConfig(n_particles=400_000, dt=dt, q=q, ess_threshold=0.0))
    r = ref.update(ref.predict(ref.from_particles(cloud(400_000, 1)), None,
                               np.random.default_rng(2)), [z], np.random.default_rng(3))
    cfg = PFConfig(n_particles=20_000, dt=dt, q=q, variant="resample-move", ess_threshold=1.0,
                   move_steps=30, move_scale=3.0)
    pf = ParticleFilter(cfg)
    rng = np.random.default_rng(4)
    st = pf.update(pf.predict(pf.from_particles(cloud(20_000, 5)), None, rng), [z], rng)
    assert st.resampled
    sd = np.sqrt(np.diag(r.cov))
    assert np.all(np.abs(st.mean - r.mean) < 0.1 * sd)
    np.testing.assert_allclose(np.sqrt(np.diag(st.cov)), sd, rtol=0.1)


def test_predict_matches_relative_dynamics() -> None:
    cfg = PFConfig(n_particles=3, dt=10.0, q=0.0)
    pf = ParticleFilter(cfg)
    X = np.array([[1000.0, 2000.0, 1.0, -2.0], [0.0, 500.0, 0.0, 0.0], [-5.0, 7.0, 3.0, 4.0]])
    s = pf.predict(pf.from_particles(X), np.array([2.0, -1.0]), np.random.default_rng(0))
    F, _ = ncv_matrices(10.0, 0.0)
    H = np.vstack([10.0 * np.eye(2), np.eye(2)])
    np.testing.assert_allclose(s.particles, X @ F.T - H @ np.array([2.0, -1.0]))


def test_predict_noise_covariance() -> None:
    cfg = PFConfig(n_particles=200_000, dt=6.0, q=0.01)
    pf = ParticleFilter(cfg)
    s = pf.predict(pf.from_particles(np.zeros((200_000, 4))), None, np.random.default_rng(3))
    _, Q = ncv_matrices(6.0, 0.01)
    np.testing.assert_allclose(s.cov, Q, atol=0.02 * Q.max())


def test_pi_ambiguity_keeps_both_modes() -> None:
    # Two mirrored clouds; a π-ambiguous bearing must not favour either of them.
    rng = np.random.default_rng(2)
    X = np.vstack([np.array([3000.0, 3000.0, 0, 0]) + rng.normal(0, 50, (500, 4)),
                   np.array([-3000.0, -3000.0, 0, 0]) + rng.normal(0, 50, (500, 4))])
    pf = ParticleFilter(PFConfig(n_particles=1000, dt=1.0, q=0.0, ess_threshold=0.0))
    st = pf.update(pf.from_particles(X), [Measurement(kind="bearing", value=np.pi / 4,
                                                      sigma=0.02, ambiguity="pi")], rng)
    w = st.weights
    assert abs(w[:500].sum() - 0.5) < 0.1
    st2 = pf.update(pf.from_particles(X), [Measurement(kind="bearing", value=np.pi / 4,
                                                       sigma=0.02)], rng)
    assert st2.weights[:500].sum() > 0.999


def test_degeneracy_warns_and_recovers_without_nan() -> None:
    rng = np.random.default_rng(0)
    pf = ParticleFilter(PFConfig(n_particles=500, dt=1.0, q=0.0))
    st = pf.from_particles(np.tile([1000.0, 1000.0, 0.0, 0.0], (500, 1))
                           + rng.normal(0, 1, (500, 4)))
    with pytest.warns(DegeneracyWarning):
        st = pf.update(st, [Measurement(kind="range", value=5000.0, sigma=1.0)], rng)
    assert st.degenerate and np.isfinite(st.particles).all() and np.isfinite(st.mean).all()
    assert np.unique(st.particles[:, 0]).size > 400  # roughened, not 500 copies


def test_frequency_update_rao_blackwellised_tone() -> None:
    # Static geometry: known Ṙ; the per-particle tone posterior must converge to f0.
    rng = np.random.default_rng(4)
    X = np.tile([0.0, 1000.0, 0.0, 5.0], (50, 1))  # Ṙ = +5 m/s
    pf = ParticleFilter(PFConfig(n_particles=50, dt=1.0, q=0.0, ess_threshold=0.0))
    st = pf.from_particles(X)
    f0, c = 3000.0, 1500.0
    for _ in range(100):
        z = f0 * (1 - 5.0 / c) + rng.normal(0, 3.0)
        st = pf.update(st, [Measurement(kind="frequency", value=np.array([z]),
                                        sigma=np.array([3.0]), c=c)], rng)
    assert st.freq_mean is not None and st.freq_var is not None
    # Posterior std 3/sqrt(100)/a; the mean is within 4σ of f0.
    sd = np.sqrt(st.freq_var[0, 0])
    assert abs(sd - 0.3 / (1 - 5 / c)) < 1e-6
    assert abs(st.freq_mean[0, 0] - f0) < 4 * sd


def test_bad_config_raises_named_field() -> None:
    with pytest.raises(ArgumentError, match="n_particles"):
        PFConfig(n_particles=1, dt=1.0, q=0.0)


def test_rotation_invariance_of_update() -> None:
    # Rotating particles and the bearing by the same angle leaves the weights unchanged.
    rng = np.random.default_rng(5)
    X = np.array([4000.0, 1000.0, 1.0, -2.0]) + rng.normal(0, [500, 500, 1, 1], (2000, 4))
    a = 0.7
    R = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])  # clockwise rotation
    Xr = X.copy()
    Xr[:, :2] = X[:, :2] @ R.T
    Xr[:, 2:] = X[:, 2:] @ R.T
    pf = ParticleFilter(PFConfig(n_particles=2000, dt=1.0, q=0.0, ess_threshold=0.0))
    z = np.arctan2(4000.0, 1000.0)
    w1 = pf.update(pf.from_particles(X), [Measurement(kind="bearing", value=z, sigma=0.03)],
                   rng).weights
    w2 = pf.update(pf.from_particles(Xr), [Measurement(kind="bearing", value=z + a,
                                                       sigma=0.03)], rng).weights
    np.testing.assert_allclose(w1, w2, atol=1e-12)


@pytest.mark.solver_sensitive
def test_pf_tracks_ristic_small_seeded() -> None:
    # Small seeded version of the slow statistical test: after the ownship turn (scans 13–16)
    # the error falls from km to ~100 m. A filter that ignores Δv or mis-signs it fails.
    sc = load_problem("ristic-bot-moderate")
    res = monte_carlo(sc, "pf", runs=6, seed=11, n_particles=3000, bound_samples=1000)
    before = res.rmse_position[10]
    after = res.rmse_position[26:].max()
    assert before > 800.0
    assert after < 0.25 * before and after < 400.0
    assert np.all(np.isfinite(res.nees))


def test_pf_run_track_shapes_and_no_truth_needed() -> None:
    sc = load_problem("ristic-bot-moderate")
    sim = simulate(sc, np.random.default_rng(0))
    tr = run("pf", sc, sim.measurements, rng=np.random.default_rng(1), n_particles=500)
    K = sc.n_steps
    assert tr.estimates.shape == (K + 1, 4) and tr.covariances.shape == (K + 1, 4, 4)
    assert tr.ess is not None and tr.ess.shape == (K + 1,)
    assert tr.status in ("ok", "recovered")


@pytest.mark.slow
def test_pf_ristic_statistics() -> None:
    # Issue 5 acceptance (10^4 particles, 200 runs) against the PCRB along the runs' truths
    # (BENCHMARK §B2). From scan 18 (one scan after the last course change at scan 16) the
    # RMSE must lie in [1.0, 2.0]× the bound; the lower limit 0.9 allows 2σ of the Monte Carlo
    # error of a 200-run RMSE (std ≈ 1/√(2·200) = 5 %) where the PF sits on the bound
    # (measured 0.94–1.17 with seed 2024). Scan 17 is excluded: there the RMSE is
    # 2.1–2.2× the bound with 10^4 *and* 10^5 particles and every tuning tried (measured, see
    # the issue-5 report), i.e. the transient where the PCRB is not tight, not a filter loss.
    sc = load_problem("ristic-bot-moderate")
    res = monte_carlo(sc, "pf", runs=200, seed=2024, n_particles=10_000)
    assert res.bound_kind == "truth"
    ratio = res.rmse_position[18:] / res.bound_position[18:]
    assert np.all(ratio >= 0.9), ratio
    assert np.all(ratio <= 2.0), ratio
    assert np.mean(res.position_errors[:, -1] > 5.0 * res.bound_position[-1]) < 0.05
    assert res.divergence_rate < 0.05
    # 4-D NEES after the turn inside a wide consistency band (χ² mean 4).
    assert 2.0 < np.nanmean(res.nees[18:]) < 8.0


@pytest.mark.slow
def test_pf_bearings_init_brehard_s2_converges_after_manoeuvre() -> None:
    sc = load_problem("brehard2005-s2")
    errs_before, errs_after = [], []
    # 12 runs: the median after the manoeuvre is ≈ 0.16–0.2 of the range over seeds (20-seed
    # check in the issue-5 report) against ≈ 0.9–1.2 before it; 5 runs were too few.
    for i in range(12):
        rng = np.random.default_rng(100 + i)
        sim = simulate(sc, rng)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DegeneracyWarning)
            tr = run("pf-bearings", sc, sim, rng=rng, n_particles=10_000)
        e = np.hypot(*(tr.estimates[:, :2] - sim.relative[:, :2]).T)
        r = np.hypot(*sim.relative[:, :2].T)
        errs_before.append(e[240] / r[240])  # t = 1440 s, before the 1500 s manoeuvre
        errs_after.append(e[450] / r[450])  # t = 2700 s
    assert np.median(errs_after) < 0.3
    assert np.median(errs_after) < 0.5 * np.median(errs_before)


# ----------------------------------------------------------------------------------------------
# From test_pf_review.py (folded in, issue 39):
# Review of the particle filter: input validation and multi-line frequency measurements.
# ----------------------------------------------------------------------------------------------

def _state(n: int = 200) -> tuple[ParticleFilter, PFState]:
    rng = np.random.default_rng(0)
    X = np.array([3000.0, 4000.0, 1.0, 1.0]) + rng.normal(0, [100, 100, 1, 1], (n, 4))
    pf = ParticleFilter(PFConfig(n_particles=n, dt=1.0, q=0.0))
    return pf, pf.from_particles(X)


def test_frequency_lines_with_one_std_each_are_assimilated() -> None:
    # simulate builds multi-line frequency measurements with sigma of shape (P,): the σ check
    # must not take the truth value of an array (it raised ValueError).
    pf, st = _state()
    m = Measurement(kind="frequency", value=np.array([100.0, 200.0]),
                    sigma=np.array([1.0, 2.0]))
    out = pf.update(st, [m], np.random.default_rng(1))
    assert out.freq_mean is not None and out.freq_mean.shape == (200, 2)
    assert np.isfinite(out.log_weights).all()
    with pytest.raises(ArgumentError, match=r"measurement\.sigma"):
        pf.update(st, [Measurement(kind="frequency", value=np.array([100.0, 200.0]),
                                   sigma=np.array([1.0, 0.0]))], np.random.default_rng(1))


@pytest.mark.parametrize("sigma", [0.0, -50.0, np.nan])
def test_ping_std_is_validated(sigma: float) -> None:
    # σ = 0 raised ZeroDivisionError and σ < 0 was silently used as |σ| by the progressive
    # correction; a plain range with the same σ is refused.
    pf, st = _state()
    m = Measurement(kind="range", value=5000.0, sigma=sigma, ping=True)
    with pytest.raises(ArgumentError, match=r"measurement\.sigma"):
        pf.update(st, [m], np.random.default_rng(1))


@pytest.mark.parametrize("m", [
    Measurement(kind="bearing", value=np.nan, sigma=0.01),
    Measurement(kind="range", value=np.inf, sigma=10.0),
    Measurement(kind="frequency", value=np.array([100.0, np.nan]), sigma=1.0),
])
def test_non_finite_measurement_value_is_refused(m: Measurement) -> None:
    # It was taken as a weight collapse: a DegeneracyWarning and a roughened cloud.
    pf, st = _state()
    with pytest.raises(ArgumentError, match=r"measurement\.value"):
        pf.update(st, [m], np.random.default_rng(1))


def test_ping_on_a_bearing_is_refused() -> None:
    # A bearing flagged as a ping was assimilated as a *range* by the progressive correction.
    pf, st = _state()
    m = Measurement(kind="bearing", value=0.6, sigma=0.01, ping=True)
    with pytest.raises(ArgumentError, match=r"measurement\.ping"):
        pf.update(st, [m], np.random.default_rng(1))


@pytest.mark.parametrize(("field", "value"), [
    ("dt", np.inf), ("dt", "60"), ("q", np.inf), ("bandwidth_scale", np.nan),
    ("bandwidth_scale", -1.0), ("roughening", np.nan), ("roughening", -0.2),
    ("move_scale", np.nan), ("degeneracy_ess", np.nan), ("move_steps", 1.5),
    ("move_steps", True),
])
def test_config_refuses_invalid_values(field: str, value: object) -> None:
    kw: dict[str, object] = {"n_particles": 100, "dt": 1.0, "q": 0.0, field: value}
    with pytest.raises(ArgumentError, match=field):
        PFConfig(**kw)  # type: ignore[arg-type]


def test_from_particles_validates_log_weights() -> None:
    pf = ParticleFilter(PFConfig(n_particles=10, dt=1.0, q=0.0))
    X = np.ones((10, 4))
    for lw in (np.zeros(5), np.full(10, np.nan), np.full(10, -np.inf),
               np.r_[np.inf, np.zeros(9)]):
        with pytest.raises(ArgumentError, match="log_weights"):
            pf.from_particles(X, log_weights=lw)
    with pytest.raises(ArgumentError, match="particles"):
        pf.from_particles(np.zeros((0, 4)))
    st = pf.from_particles(X, log_weights=np.r_[-np.inf, np.zeros(9)])
    assert st.weights[0] == 0.0 and abs(st.ess - 9.0) < 1e-9


def test_predict_and_from_gaussian_validate_vectors() -> None:
    pf, st = _state()
    rng = np.random.default_rng(2)
    for dv in (np.array([np.nan, 0.0]), np.zeros(3)):
        with pytest.raises(ArgumentError, match="dv"):
            pf.predict(st, dv, rng)
    with pytest.raises(ArgumentError, match="mean"):
        pf.from_gaussian(np.zeros(3), np.eye(4), rng)
    with pytest.raises(ArgumentError, match="cov"):
        pf.from_gaussian(np.zeros(4), -np.eye(4), rng)


def test_systematic_resample_of_unnormalised_log_weights() -> None:
    # exp(−1000) underflowed to 0: the CDF was NaN and every index 0.
    idx = systematic_resample(np.full(10, -1000.0), np.random.default_rng(0))
    np.testing.assert_array_equal(np.sort(idx), np.arange(10))
    with pytest.raises(ArgumentError, match="n"):
        systematic_resample(np.zeros(4), np.random.default_rng(0), n=0)
    with pytest.raises(ArgumentError, match="log_weights"):
        systematic_resample(np.full(4, np.nan), np.random.default_rng(0))
