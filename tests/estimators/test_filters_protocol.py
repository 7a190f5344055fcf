"""One suite run against every filter behind :class:`tmaplan.estimators.filter.Filter`.

Each filter must: satisfy the protocol; keep the state's step, mean (4,) and covariance (4, 4,
symmetric positive semi-definite) consistent through init / predict / update; predict exactly
``F x − H Δv`` and add the process noise (checked on the moments); pull the estimate onto a
noise-free truth; and give bit-identical results for the same seed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tmaplan.estimators import (
    Filter,
    FilterState,
    ParticleFilter,
    PFConfig,
    RangeOnlyConfig,
    RangeOnlyFilter,
    drive,
    run,
)
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import load_problem
from tmaplan.simulate import Measurement, measurement_batches, simulate

DT, Q = 60.0, 1e-6
pytestmark = pytest.mark.filterwarnings("ignore::tmaplan.estimators.DegeneracyWarning")


def _pf() -> ParticleFilter:
    return ParticleFilter(PFConfig(n_particles=40_000, dt=DT, q=Q))


def _ro(mode: str) -> RangeOnlyFilter:
    return RangeOnlyFilter(RangeOnlyConfig(dt=DT, q=Q, mode=mode))  # type: ignore[arg-type]


FILTERS = {"pf": _pf, "range-only-mixture": lambda: _ro("mixture"),
           "range-only-moments": lambda: _ro("moments"), "range-only-dirac": lambda: _ro("dirac")}
PARAMS = pytest.mark.parametrize("make", FILTERS.values(), ids=FILTERS.keys())


def _gaussian_state(f: Any, mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> Any:
    """A state N(mean, cov) for either filter (the protocol's init takes a scenario)."""
    if isinstance(f, ParticleFilter):
        return f.from_gaussian(mean, cov, rng)
    from tmaplan.estimators import from_gaussian

    return from_gaussian(mean, cov)


MEAN = np.array([6000.0, 8000.0, -3.0, 2.0])
COV = np.diag([400.0**2, 300.0**2, 1.0, 1.0])


@PARAMS
def test_satisfies_the_protocol_and_state_shapes(make: Any) -> None:
    f = make()
    assert isinstance(f, Filter) and isinstance(f.name, str)
    sc = load_problem("sharma2024-range-only")
    st = f.init(sc, np.random.default_rng(0))
    assert isinstance(st, FilterState) and st.step == 0
    for s in (st, f.update(f.predict(st, np.array([1.0, -1.0]), np.random.default_rng(1)),
                           [Measurement(kind="range", value=9000.0, sigma=10.0)],
                           np.random.default_rng(2))):
        assert s.mean.shape == (4,) and s.cov.shape == (4, 4)
        assert np.all(np.isfinite(s.mean)) and np.allclose(s.cov, s.cov.T)
        assert np.linalg.eigvalsh(s.cov).min() > -1e-9 * np.abs(s.cov).max()
        assert np.isfinite(f.diagnostic(s))
    assert f.predict(st, None, np.random.default_rng(1)).step == 1


@PARAMS
def test_predict_moments_are_the_ncv_model(make: Any) -> None:
    # Mean F x − H Δv and covariance F P F' + Q (the PF to its Monte Carlo error).
    f = make()
    rng = np.random.default_rng(3)
    st = _gaussian_state(f, MEAN, COV, rng)
    dv = np.array([2.0, -1.0])
    F, Qm = ncv_matrices(DT, Q)
    m_ref = F @ st.mean
    m_ref[:2] -= DT * dv
    m_ref[2:] -= dv
    P_ref = F @ st.cov @ F.T + Qm
    out = f.predict(st, dv, rng)
    sd = np.sqrt(np.diag(P_ref))
    tol = 1e-9 if not isinstance(f, ParticleFilter) else 0.03
    np.testing.assert_allclose(out.mean, m_ref, atol=tol * sd.max())
    np.testing.assert_allclose(np.sqrt(np.diag(out.cov)), sd, rtol=max(tol, 1e-9))


@PARAMS
def test_noise_free_ranges_pull_the_estimate_to_the_truth(make: Any) -> None:
    # Consistency: noise-free (σ-small) ranges from a truth inside the prior, observer
    # manoeuvring (two legs), so the geometry is observable; the posterior must end near
    # the truth, inside a few of its own standard deviations, and tighter than the prior.
    f = make()
    rng = np.random.default_rng(4)
    K = 60
    truth = np.empty((K + 1, 4))
    truth[0] = MEAN + np.array([250.0, -200.0, 0.5, -0.5])
    dv = np.zeros((K, 2))
    dv[K // 3] = [-8.0, 4.0]
    dv[2 * K // 3] = [10.0, 2.0]
    F, _ = ncv_matrices(DT, 0.0)
    for k in range(K):
        truth[k + 1] = F @ truth[k]
        truth[k + 1, :2] -= DT * dv[k]
        truth[k + 1, 2:] -= dv[k]
    st = _gaussian_state(f, MEAN, COV, rng)

    def step(k: int, _: Any) -> tuple[np.ndarray, list[Measurement]]:
        r = float(np.hypot(*truth[k + 1, :2]))
        return dv[k], [Measurement(kind="range", value=r, sigma=5.0)]

    fr = drive(f, st, K, step, rng)
    err = fr.estimates[-1, :2] - truth[-1, :2]
    sd = np.sqrt(np.diag(fr.covariances[-1])[:2])
    # measured: errors ≤ 13 m, posterior std 15–55 m against a 300–400 m prior
    assert np.hypot(*err) < 50.0, err
    assert np.all(np.abs(err) < 3.0 * sd), (err, sd)
    assert np.all(sd < 0.25 * np.sqrt(np.diag(COV)[:2])), sd


@pytest.mark.parametrize("estimator", ["pf", "range-only"])
def test_same_seed_same_track_other_seed_other_track(estimator: str) -> None:
    sc = load_problem("sharma2024-range-only")
    sim = simulate(sc, np.random.default_rng(5))
    a = run(estimator, sc, sim, rng=np.random.default_rng(6), n_particles=500)  # type: ignore[arg-type]
    b = run(estimator, sc, sim, rng=np.random.default_rng(6), n_particles=500)  # type: ignore[arg-type]
    assert np.array_equal(a.estimates, b.estimates, equal_nan=True)
    assert np.array_equal(a.covariances, b.covariances, equal_nan=True)
    c = run(estimator, sc, sim, rng=np.random.default_rng(7), n_particles=500)  # type: ignore[arg-type]
    assert not np.array_equal(a.estimates, c.estimates)  # the prior centre is drawn per run


def test_range_only_filter_uses_every_range_of_a_step_in_order() -> None:
    # Two ranges at one step = two sequential updates (the batches of measurement_batches).
    sc = load_problem("sharma2024-range-only")
    sim = simulate(sc, np.random.default_rng(0))
    batches = measurement_batches(sc, sim.measurements, sim.observer)
    f = _ro("moments")
    st = _gaussian_state(f, MEAN, COV, np.random.default_rng(0))
    m = batches[min(batches)][0]
    twice = f.update(st, [m, m], np.random.default_rng(0))
    seq = f.update(f.update(st, [m], None), [m], None)
    np.testing.assert_array_equal(twice.mean, seq.mean)
    bearing = Measurement(kind="bearing", value=0.3, sigma=0.01)
    assert f.update(st, [bearing], None) is st  # a range-only filter ignores bearings
