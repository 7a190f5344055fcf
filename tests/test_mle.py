"""Batch maximum likelihood (file 002) and its CRLB."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ScenarioError
from tmaplan.estimators import MLEConfig, fisher_information, mle, state_track, tma_data
from tmaplan.estimators.mle import acceptance_threshold, residuals
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate


def _truth(sc):
    t = sc.target
    return np.array([*t.centre, t.radius, t.phase, t.omega])


def _crlb(name: str, nf: int):
    sc = load_problem(name)
    sim = simulate(sc, None)
    d = tma_data(sc, sim.measurements, sim.observer, frequencies=nf)
    p = np.concatenate([_truth(sc), np.asarray(sc.sensors[1].f0[:nf])])
    C = np.linalg.inv(fisher_information(d, p))
    S, Cs = state_track(d, p, C, sc.times[-1:])
    g = S[0, :2] - sim.observer.position[-1]
    R = np.hypot(*g)
    g = g / R
    sd = np.sqrt(np.diag(Cs[0]))
    return (np.array([sd[0], sd[1], np.sqrt(C[2, 2]), np.degrees(np.sqrt(C[3, 3])),
                      np.degrees(np.sqrt(C[4, 4])), np.sqrt(g @ Cs[0, :2, :2] @ g)]), R)


@pytest.mark.parametrize(("name", "nf", "paper"), [
    # File 002 Table 1 (L402–410) and Table 2 (L412–420): σ_CRLB of x_N, y_N [m], ρ [m],
    # φ [deg], ω [deg/s], R_N [m]; Table 4 (L603–611) with the typo 0.077 → 0.0077 (NOTES_002
    # §1.7). Tolerance ±3 % (NOTES_002 §4.8: the geometry is a reconstruction, ±2 %).
    ("clavard2013-halfturn-cw", 0, [290, 650, 90, 7.28, 0.025, 710]),
    ("clavard2013-halfturn-acw", 0, [1080, 2590, 250, 28.5, 0.06, 2810]),
    ("clavard2013-halfturn-cw", 1, [90, 200, 40, 2.79, 0.0077, None]),
    ("clavard2013-halfturn-cw", 4, [60, 120, 30, 1.81, 0.005, None]),
])
def test_crlb_reproduces_paper_tables(name: str, nf: int, paper: list) -> None:
    sd, _ = _crlb(name, nf)
    # Half a unit of the last printed digit (km with 2 decimals, degrees with 2, °/s with 3;
    # 4 for the corrected 0.0077), added to the ±3 % reconstruction tolerance.
    half_unit = [5.0, 5.0, 5.0, 0.005, 0.00005 if nf == 1 else 0.0005, 5.0]
    for got, want, hu in zip(sd, paper, half_unit):
        if want is None:
            continue
        assert abs(got - want) <= 0.03 * want + hu, (got, want)


def test_jacobian_matches_finite_differences() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, np.random.default_rng(0))
    d = tma_data(sc, sim.measurements, sim.observer, frequencies=2)
    p = np.concatenate([_truth(sc) * [1.01, 0.99, 1.1, 1, 0.9] + [0, 0, 0, 0.1, 0],
                        [3001.0, 3499.0]])
    _, J = residuals(d, p)
    for i in range(p.size):
        h = np.zeros_like(p)
        h[i] = 1e-6 * max(1.0, abs(p[i]))
        fd = (residuals(d, p + h, jacobian=False)[0] - residuals(d, p - h,
                                                                  jacobian=False)[0]) / (2 * h[i])
        np.testing.assert_allclose(J[:, i], fd, rtol=1e-4, atol=1e-6 * np.abs(fd).max())


def test_acceptance_threshold_is_the_papers() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, None)
    N = 628
    d0 = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
    assert acceptance_threshold(d0) == pytest.approx(N - 5 + 3 * np.sqrt(2 * N - 10))
    d4 = tma_data(sc, sim.measurements, sim.observer, frequencies=4)
    P = 4
    assert acceptance_threshold(d4) == pytest.approx(
        N - 5 + P * (N - 6) + 3 * np.sqrt(2 * N - 10) + 3 * P * np.sqrt(2 * N - 12))


def test_mle_noise_free_recovers_truth_from_grid() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, None)
    res = mle(tma_data(sc, sim.measurements, sim.observer, frequencies=0))
    assert res.status == "converged" and res.accepted
    np.testing.assert_allclose(res.params, _truth(sc), atol=1e-3)


def test_mle_with_frequencies_efficient_small_mc() -> None:
    # With one line the MLE is efficient in both directions (file 002 §IV.3.b). 30 seeded runs:
    # final-range RMSE within [0.6, 1.5]× the CRLB std (std-of-std ≈ 13 % at 30 runs).
    sc = load_problem("clavard2013-halfturn-acw")
    sd, R = _crlb("clavard2013-halfturn-acw", 1)
    errs = []
    for ch in np.random.SeedSequence(7).spawn(30):
        sim = simulate(sc, np.random.default_rng(ch))
        d = tma_data(sc, sim.measurements, sim.observer, frequencies=1)
        res = mle(d)
        assert res.status == "converged"
        S, _ = state_track(d, res.params, None, sc.times[-1:])
        errs.append(np.hypot(*(S[0, :2] - sim.observer.position[-1])) - R)
    rmse = np.sqrt(np.mean(np.square(errs)))
    assert 0.6 * sd[5] < rmse < 1.5 * sd[5]


def test_mle_cv_model_translation_invariance() -> None:
    sc = load_problem("ristic-bot-moderate")
    sim = simulate(sc, np.random.default_rng(3))
    d = tma_data(sc, sim.measurements, sim.observer)
    r1 = mle(d, MLEConfig(n_starts=3))
    shift = np.array([1234.0, -567.0])
    import dataclasses

    d2 = dataclasses.replace(d, b_obs=d.b_obs + shift)
    r2 = mle(d2, initial=r1.params + np.concatenate([shift, [0, 0]]))
    np.testing.assert_allclose(r2.params[:2] - shift, r1.params[:2], atol=1e-3)
    assert r2.cost == pytest.approx(r1.cost, rel=1e-9)


def test_too_few_measurements_raise_named_error() -> None:
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, None)
    d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
    import dataclasses

    d = dataclasses.replace(d, b_times=d.b_times[:4], b_values=d.b_values[:4],
                            b_sigma=d.b_sigma[:4], b_obs=d.b_obs[:4])
    with pytest.raises(ScenarioError, match="measurements"):
        mle(d)


def test_halfturn_mirror_ghost_is_genuine_and_reported() -> None:
    # Noise-free cw bearings: a distinct solution turning the other way (ω < 0, final range
    # ≈ 1.9 km instead of 9.76 km) fits with cost ≈ 0.10 (RMS bearing gap 0.006°). Bearings
    # are recomputed here independently of `residuals` (plain atan2 on the kinematics).
    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, None)
    d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
    res = mle(d, MLEConfig(init="multistart"))
    np.testing.assert_allclose(res.params, _truth(sc), atol=1e-3)
    assert res.ambiguous
    ghost, cost = res.alternatives[0]
    assert ghost[4] < 0 < sc.target.omega and cost < 0.2
    xc, yc, rho, phi, om = ghost
    t = d.b_times
    pos = np.stack([xc + rho * np.sin(om * t + phi), yc + rho * np.cos(om * t + phi)], -1)
    rel = pos - d.b_obs
    b = np.arctan2(rel[:, 0], rel[:, 1])
    gap = np.angle(np.exp(1j * (b - sim.measurements[0].truth)))
    assert np.sqrt(np.mean(gap**2)) < np.radians(0.02)
    assert abs(np.sum((gap / d.b_sigma) ** 2) - cost) < 1e-6
    S, _ = state_track(d, ghost, None, sc.times[-1:])
    assert np.hypot(*(S[0, :2] - sim.observer.position[-1])) < 3000.0
    # The paper's initialisation (single best grid node) is a one-start refine.
    assert mle(d, MLEConfig(init="paper")).alternatives == ()


def test_ghost_wins_about_as_often_as_predicted_small_mc() -> None:
    # With noise, the cost gap ghost − truth-basin minimum is ≈ N(Δ, 4Δ), Δ = 0.10 (local
    # linear-Gaussian argument), so the ghost wins with probability Φ(−√Δ/2) ≈ 0.44. 40
    # seeded runs: the count must be in a binomial 99.9 % band [0.2, 0.7]·40; a grid or
    # model artefact (ghost never / always wins) fails.
    from scipy.stats import norm

    sc = load_problem("clavard2013-halfturn-cw")
    truth = _truth(sc)
    sim0 = simulate(sc, None)
    d0 = tma_data(sc, sim0.measurements, sim0.observer, frequencies=0)
    ghost = mle(d0).alternatives[0][0]
    wins = 0
    for ch in np.random.SeedSequence(3).spawn(40):
        sim = simulate(sc, np.random.default_rng(ch))
        d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
        wins += mle(d, initial=ghost).cost < mle(d, initial=truth).cost
    p = norm.cdf(-np.sqrt(0.1025) / 2)
    assert 0.2 * 40 <= wins <= 0.7 * 40, (wins, p)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["clavard2013-halfturn-cw", "clavard2013-halfturn-acw"])
def test_mle_halfturn_500_runs(name: str) -> None:
    # Issue 5 / file 002 §III.4, 500 runs, the paper's procedure (best grid node → 10 GN →
    # descent → acceptance test). Honest version (see the issue-5 report): the reconstructed
    # geometry has a genuine mirror-turn near-ambiguity (noise-free cost 0.10), so the
    # *unconditional* RERMSE is ~6× the RSD (cw). Checked here: (i) about one rejection in
    # 500 (paper: 1 cw, 7 acw; ≤ 10 allowed), (ii) cw: on the runs that end in the true
    # basin (|final-range error| < 5 RSD) the RERMSE is within 15 % of the RSD (efficiency),
    # (iii) acw: φ and ω biased as file 002 Table 2 reports (|bias ω| > 0.05 °/s, φ > 10°).
    sc = load_problem(name)
    sd, R = _crlb(name, 0)
    errs, phis, oms, rej = [], [], [], 0
    for ch in np.random.SeedSequence(2013).spawn(500):
        sim = simulate(sc, np.random.default_rng(ch))
        d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
        res = mle(d, MLEConfig(init="paper"))
        if not res.success:
            rej += 1
            continue
        S, _ = state_track(d, res.params, None, sc.times[-1:])
        errs.append(np.hypot(*(S[0, :2] - sim.observer.position[-1])) - R)
        phis.append(res.params[3])
        oms.append(res.params[4])
    errs_a = np.asarray(errs)
    assert rej <= 10
    if name.endswith("-cw"):
        near = np.abs(errs_a) < 5 * sd[5]
        rermse = np.sqrt(np.mean(errs_a[near] ** 2)) / R
        assert abs(rermse / (sd[5] / R) - 1) < 0.15
    else:
        assert abs(np.degrees(np.mean(oms) - sc.target.omega)) > 0.05
        assert abs(np.degrees(np.mean(np.angle(np.exp(1j * np.asarray(phis)))))) > 10.0
