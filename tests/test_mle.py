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


@pytest.mark.slow
@pytest.mark.parametrize("name", ["clavard2013-halfturn-cw", "clavard2013-halfturn-acw"])
def test_mle_halfturn_500_runs(name: str) -> None:
    # Issue 5 acceptance: cw final-range RERMSE within 15 % of the CRLB RSD (7.3 %), about one
    # rejection in 500; acw: biased φ and ω (file 002 Table 2). See the report: the
    # reconstructed geometry has a mirror-turn near-ambiguity (noise-free cost 0.10) that this
    # test exposes.
    sc = load_problem(name)
    sd, R = _crlb(name, 0)
    errs, phis, oms, rej = [], [], [], 0
    for ch in np.random.SeedSequence(2013).spawn(500):
        sim = simulate(sc, np.random.default_rng(ch))
        d = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
        res = mle(d)
        if not res.accepted:
            rej += 1
            continue
        S, _ = state_track(d, res.params, None, sc.times[-1:])
        errs.append(np.hypot(*(S[0, :2] - sim.observer.position[-1])) - R)
        phis.append(res.params[3])
        oms.append(res.params[4])
    rermse = np.sqrt(np.mean(np.square(errs))) / R
    if name.endswith("-cw"):
        assert abs(rermse / (sd[5] / R) - 1) < 0.15
        assert rej <= 5
    else:
        assert abs(np.degrees(np.mean(oms) - sc.target.omega)) > 0.05
