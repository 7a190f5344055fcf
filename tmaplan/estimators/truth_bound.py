"""Cartesian PCRB of the filters: along the true trajectories (default) or prior-averaged.

Two bounds for the position RMSE of a filter, both from Tichavský's recursion for the
linear-Gaussian NCV dynamics of the relative state (DESIGN §1)::

    J_{k+1} = (Q + F J_k⁻¹ F')⁻¹ + H̃(X_{k+1})' R⁻¹ H̃(X_{k+1}),    J_0 = P_0⁻¹ + H̃(X_0)'R⁻¹H̃(X_0)

* :func:`truth_pcrb` (the runner's default, BENCHMARK_SCENARIOS §B2): H̃ is evaluated along
  the *true* relative trajectory of each Monte Carlo run, with ``P_0`` the covariance of the
  prior centred on the truth (``r̄ = r``). This is the bound Ristic et al. (2004, ch. 6) plot.
  Over the runs we average the bound *covariance*, ``sqrt(mean_runs tr[J_k⁻¹]_pos)``, the
  quantity that a position RMSE over the same runs is compared with.
* :func:`cartesian_pcrb` (option ``bound="prior"``): the information is averaged over
  trajectories drawn from the prior and the process noise, ``E[H̃'R⁻¹H̃]``. Averaging the
  *information* over prior draws of very different geometries gives a full-rank (hence much
  more optimistic) bound before the ownship manoeuvre, where no single trajectory is
  observable: on ``ristic-bot-moderate`` it is ~150 m at scan 12 where the truth-conditional
  bound is ~1 km.

Bearings and ranges are included; frequency lines are not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import prior_relative_moments, relative_prior_samples
from tmaplan.models.target import ncv_matrices

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["cartesian_pcrb", "truth_bounds", "truth_pcrb"]


def _information_rates(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Per-step bearing and range information 1/σ² (summed over sensors), shape (K + 1,)."""
    from tmaplan.scenario import measurement_steps

    K = scenario.n_steps
    info_b = np.zeros(K + 1)
    info_r = np.zeros(K + 1)
    for s in scenario.sensors:
        steps = measurement_steps(s, scenario.time)
        if s.kind == "bearing":
            np.add.at(info_b, steps, 1.0 / s.sigma**2)
        elif s.kind == "range":
            np.add.at(info_r, steps, 1.0 / s.sigma**2)
    return info_b, info_r


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


def truth_pcrb(scenario: Scenario, relative: np.ndarray, *,
               prior_cov: np.ndarray | None = None) -> np.ndarray:
    """Position PCRB along given true relative trajectories, averaged over them.

    Parameters
    ----------
    scenario : Scenario
        Time grid, target q, sensors, prior.
    relative : ndarray, shape (R, K + 1, 4) or (K + 1, 4)
        True relative states ``target − observer`` of R runs [m, m/s].
    prior_cov : ndarray, shape (4, 4), optional
        ``P_0``; default the covariance of the scenario's prior centred on the truth
        (:func:`tmaplan.models.prior.prior_relative_moments`, reproducible).

    Returns
    -------
    ndarray, shape (K + 1,)
        ``sqrt(mean_runs tr [J_k⁻¹]_pos)`` [m].
    """
    return truth_bounds(scenario, relative, prior_cov=prior_cov)[0]


def truth_bounds(scenario: Scenario, relative: np.ndarray, *,
                 prior_cov: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Position and range PCRB along given true relative trajectories (see :func:`truth_pcrb`).

    Returns
    -------
    position : ndarray, shape (K + 1,)
        ``sqrt(mean_runs tr [J_k⁻¹]_pos)`` [m].
    range : ndarray, shape (K + 1,)
        ``sqrt(mean_runs uᵀ [J_k⁻¹]_pos u)`` [m], u the true line-of-sight unit vector (the
        range bound by the delta method).
    """
    X = np.asarray(relative, float)
    if X.ndim == 2:
        X = X[None]
    K = scenario.n_steps
    F, Q = ncv_matrices(scenario.time.dt, scenario.target.q)
    P0 = prior_relative_moments(scenario)[1] if prior_cov is None else np.asarray(prior_cov)
    info_b, info_r = _information_rates(scenario)
    R = X.shape[0]
    J = np.broadcast_to(np.linalg.inv(P0), (R, 4, 4)).copy()
    out = np.zeros(K + 1)
    out_r = np.zeros(K + 1)
    Fi = np.linalg.inv(F)
    for k in range(K + 1):
        if k > 0:
            if scenario.target.q > 0:
                J = np.linalg.inv(Q + F @ np.linalg.solve(J, np.broadcast_to(F.T, J.shape)))
            else:
                J = Fi.T @ J @ Fi
        J[:, :2, :2] += _meas_info(X[:, k], info_b[k], info_r[k])
        C = np.linalg.inv(J)
        out[k] = np.sqrt(np.mean(C[:, 0, 0] + C[:, 1, 1]))
        u = X[:, k, :2] / np.hypot(X[:, k, 0], X[:, k, 1])[:, None]
        out_r[k] = np.sqrt(np.mean(np.einsum("ri,rij,rj->r", u, C[:, :2, :2], u)))
    return out, out_r


def cartesian_pcrb(scenario: Scenario, *, samples: int, rng: np.random.Generator,
                   observer: ObserverTrack | None = None) -> np.ndarray:
    """Prior-averaged Cartesian PCRB position std per step (Tichavský, Monte Carlo).

    ``J_{k+1} = (Q + F J_k⁻¹ F')⁻¹ + E[H̃'R⁻¹H̃]`` with ``J_0 = P_0⁻¹`` from the prior and the
    expectation over ``samples`` trajectories drawn from the prior and the process noise.
    An independent, deliberately simple implementation kept as a cross-check of
    :func:`tmaplan.bounds.pcrb.monte_carlo_pcrb` (the runner uses the latter).

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
    info_b, info_r = _information_rates(scenario)
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
