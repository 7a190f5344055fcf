"""Oracle: an independent, deliberately simple prior-averaged Cartesian PCRB (Tichavský, MC).

Kept in the tests as a cross-check of :func:`tmaplan.bounds.pcrb.monte_carlo_pcrb` (the one
implementation the package and the runner use): its own measurement information, propagation
and recursion; shared are the models and the per-step 1/σ² bookkeeping.
"""

from __future__ import annotations

import numpy as np

from tmaplan.bounds.inputs import information_rates
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import prior_relative_moments, relative_prior_samples
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import Scenario


def _meas_info(X: np.ndarray, ib: float, ir: float) -> np.ndarray:
    """Position-block information of a bearing and a range at X, shape (..., 2, 2)."""
    r2 = X[..., 0] ** 2 + X[..., 1] ** 2
    M = np.zeros((*X.shape[:-1], 2, 2))
    if ib:
        g = np.stack([X[..., 1] / r2, -X[..., 0] / r2], -1)
        M += ib * g[..., :, None] * g[..., None, :]
    if ir:
        g = X[..., :2] / np.sqrt(r2)[..., None]
        M += ir * g[..., :, None] * g[..., None, :]
    return M


def cartesian_pcrb(scenario: Scenario, *, samples: int, rng: np.random.Generator,
                   observer: ObserverTrack | None = None) -> np.ndarray:
    """Prior-averaged Cartesian PCRB position std per step (Tichavský, Monte Carlo).

    ``J_{k+1} = (Q + F J_k⁻¹ F')⁻¹ + E[H̃'R⁻¹H̃]`` with ``J_0 = P_0⁻¹`` from the prior and the
    expectation over ``samples`` trajectories drawn from the prior and the process noise.
    An independent, deliberately simple implementation kept as a cross-check of
    :func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`.

    Returns
    -------
    ndarray, shape (K + 1,)
        ``sqrt(tr [J_k⁻¹]_{pos})`` [m].
    """
    obs = observer or observer_track(scenario.observer, scenario.time)
    K = scenario.n_steps
    F, Q = ncv_matrices(scenario.time.dt, scenario.target.q)
    _, P0 = prior_relative_moments(scenario)
    X = relative_prior_samples(scenario, samples, rng)
    info_b, info_r = information_rates(scenario)
    dv = obs.velocity_increments
    L = np.linalg.cholesky(Q) if scenario.target.q > 0 else np.zeros((4, 4))
    J = np.linalg.inv(P0)
    out = np.zeros(K + 1)
    J = J.copy()
    J[:2, :2] += _meas_info(X, info_b[0], info_r[0]).mean(axis=0)
    out[0] = np.sqrt(np.trace(np.linalg.inv(J)[:2, :2]))
    Fi = np.linalg.inv(F)
    for k in range(K):
        X = X @ np.ascontiguousarray(F.T) + rng.standard_normal(X.shape) @ np.ascontiguousarray(L.T)
        X[:, :2] -= scenario.time.dt * dv[k]
        X[:, 2:] -= dv[k]
        if scenario.target.q > 0:
            J = np.linalg.inv(Q + F @ np.linalg.solve(J, F.T))
        else:
            J = Fi.T @ J @ Fi
        J[:2, :2] += _meas_info(X, info_b[k + 1], info_r[k + 1]).mean(axis=0)
        out[k + 1] = np.sqrt(np.trace(np.linalg.inv(J)[:2, :2]))
    return out
