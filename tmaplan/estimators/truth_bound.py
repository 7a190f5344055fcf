"""Cartesian PCRB of the filters along the true trajectories.

A bound for the position RMSE of a filter, from Tichavský's recursion for the
linear-Gaussian NCV dynamics of the relative state (docs/conventions.md)::

    J_{k+1} = (Q + F J_k⁻¹ F')⁻¹ + H̃(X_{k+1})' R⁻¹ H̃(X_{k+1}),    J_0 = P_0⁻¹ + H̃(X_0)'R⁻¹H̃(X_0)

:func:`truth_pcrb` (the runner's default, ristic2004, ch. 6) evaluates H̃ along the
*true* relative trajectory of each Monte Carlo run, with ``P_0`` the covariance of the prior
centred on the truth (``r̄ = r``). This is the bound ristic2004 (ch. 6) plot. Over the runs we
average the bound *covariance*, ``sqrt(mean_runs tr[J_k⁻¹]_pos)``, the quantity that a position
RMSE over the same runs is compared with. (The prior-averaged Cartesian PCRB, option
``bound="prior"``, is :func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`: averaging the *information*
over prior draws of very different geometries gives a full-rank, much more optimistic bound
before the ownship manoeuvre: on ``ristic-bot-moderate`` ~150 m at scan 12 where the
truth-conditional bound is ~1 km.)

Bearings and ranges are included (per-step information
:func:`tmaplan.bounds.inputs.information_rates`, conditional Fisher information
:func:`tmaplan.bounds.pcrb.conditional_information`); frequency lines are not.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tmaplan.bounds.inputs import information_rates
from tmaplan.bounds.pcrb import conditional_information
from tmaplan.models.prior import prior_relative_moments
from tmaplan.models.target import ncv_matrices

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["truth_bounds", "truth_pcrb"]


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
    info_b, info_r = information_rates(scenario)
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
        J += conditional_information(X[:, k], info_b[k], info_r[k])
        C = np.linalg.inv(J)
        out[k] = np.sqrt(np.mean(C[:, 0, 0] + C[:, 1, 1]))
        u = X[:, k, :2] / np.hypot(X[:, k, 0], X[:, k, 1])[:, None]
        out_r[k] = np.sqrt(np.mean(np.einsum("ri,rij,rj->r", u, C[:, :2, :2], u)))
    return out, out_r
