"""Cartesian PCRB of the filters along the true trajectories.

A bound for the position RMSE of a filter, from Tichavský's recursion for the
linear-Gaussian NCV dynamics of the relative state (docs/conventions.md)::

    J_{k+1} = (Q + F J_k⁻¹ F')⁻¹ + H̃(X_{k+1})' R⁻¹ H̃(X_{k+1}),    J_0 = P_0⁻¹ + H̃(X_0)'R⁻¹H̃(X_0)

(the prediction step is :func:`tmaplan.bounds.pcrb.predicted_information`, shared with the
prior-averaged Cartesian PCRB).

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
:func:`tmaplan.bounds.pcrb.conditional_information`); frequency lines are not. A range
sensor's ``max_range`` applies run by run with the *true* range of that run (as the simulation
and the batch CRLB apply it): a reading beyond the reach has no echo and adds nothing
(:func:`tmaplan.bounds.inputs.reached_range_weight`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence

import numpy as np

from tmaplan.bounds.inputs import (
    information_rates,
    prepare,
    range_reach_terms,
    reached_range_weight,
)
from tmaplan.bounds.pcrb import PCRBResult, conditional_information, predicted_information
from tmaplan.errors import ArgumentError, ScenarioError
from tmaplan.geometry import range_of
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.prior import prior_relative_moments
from tmaplan.models.target import ncv_matrices, target_track
from tmaplan.scenario import RangeSensor, Scenario

__all__ = ["closed_loop_truth_bounds", "truth_bounds", "truth_conditioned_pcrb",
           "truth_covariance", "truth_pcrb"]


def truth_covariance(scenario: Scenario, relative: np.ndarray, *,
                     prior_cov: np.ndarray | None = None,
                     range_info: np.ndarray | None = None,
                     range_reach: Sequence[tuple[float, np.ndarray]] | None = None,
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Run-averaged PCRB covariance along given true relative trajectories.

    The one implementation of the recursion in the module docstring; :func:`truth_bounds`,
    :func:`truth_pcrb`, :func:`truth_conditioned_pcrb` and :func:`closed_loop_truth_bounds`
    report it.

    Parameters
    ----------
    scenario : Scenario
        Time grid, target q, bearing sensors (and range sensors unless ``range_info``), prior.
    relative : ndarray, shape (R, K + 1, 4), (R, K + 1, 2) or (K + 1, 4)
        True relative states (or positions: the information depends on positions only)
        ``target − observer`` of R runs [m, m/s].
    prior_cov : ndarray, shape (4, 4), optional
        ``P_0``; default the covariance of the scenario's prior
        (:func:`tmaplan.models.prior.prior_relative_moments`, reproducible).
    range_info : ndarray, shape (K + 1,) or (R, K + 1), optional
        Range information per step Σ 1/σ_r² [m⁻²] (per run: closed-loop pings); default the
        scenario's range sensors (:func:`tmaplan.bounds.inputs.information_rates`).
    range_reach : sequence of (float, ndarray of shape (K + 1,) or (R, K + 1)), optional
        The parts of the range information read by sensors with a ``max_range`` [m]
        (:func:`tmaplan.bounds.inputs.range_reach_terms`), applied with each run's true range
        (:func:`tmaplan.bounds.inputs.reached_range_weight`). Default: with ``range_info``
        None, the reach of the scenario's range sensors; with ``range_info``, none.

    Returns
    -------
    cov : ndarray, shape (K + 1, 4, 4)
        ``mean_runs J_k⁻¹`` [m², m²/s, m²/s²].
    range_var : ndarray, shape (K + 1,)
        ``mean_runs uᵀ [J_k⁻¹]_pos u`` [m²], u the true line-of-sight unit vector.
    """
    X = np.asarray(relative, float)
    if X.ndim == 2:
        X = X[None]
    if X.shape[-1] == 2:
        X = np.concatenate([X, np.zeros_like(X)], axis=-1)
    K = scenario.n_steps
    R = X.shape[0]
    if X.shape[1] != K + 1:
        raise ArgumentError("relative", f"{K + 1} steps (the grid of {scenario.name})",
                            f"{X.shape[1]} steps")
    F, Q = ncv_matrices(scenario.time.dt, scenario.target.q)
    P0 = prior_relative_moments(scenario)[1] if prior_cov is None else np.asarray(prior_cov)
    info_b, info_r = information_rates(scenario)
    if range_reach is None:
        range_reach = range_reach_terms(scenario) if range_info is None else ()
    w_r = reached_range_weight(np.broadcast_to(
        info_r if range_info is None else np.asarray(range_info, float), (R, K + 1)),
        range_reach, range_of(X))
    J = np.broadcast_to(np.linalg.inv(P0), (R, 4, 4)).copy()
    cov = np.zeros((K + 1, 4, 4))
    rvar = np.zeros(K + 1)
    for k in range(K + 1):  # recursion over time, batched over runs
        if k > 0:
            J = predicted_information(F, Q, information=J)
        J += conditional_information(X[:, k], info_b[k], 0.0)
        if np.any(w_r[:, k]):
            J += w_r[:, k, None, None] * conditional_information(X[:, k], 0.0, 1.0)
        C = np.linalg.inv(J)
        cov[k] = C.mean(axis=0)
        u = X[:, k, :2] / range_of(X[:, k])[:, None]
        rvar[k] = np.mean(np.einsum("ri,rij,rj->r", u, C[:, :2, :2], u))
    return cov, rvar


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
                 prior_cov: np.ndarray | None = None,
                 range_info: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Position and range PCRB along given true relative trajectories (see :func:`truth_pcrb`
    and, for ``range_info``, :func:`truth_covariance`).

    Returns
    -------
    position : ndarray, shape (K + 1,)
        ``sqrt(mean_runs tr [J_k⁻¹]_pos)`` [m].
    range : ndarray, shape (K + 1,)
        ``sqrt(mean_runs uᵀ [J_k⁻¹]_pos u)`` [m], u the true line-of-sight unit vector (the
        range bound by the delta method).
    """
    cov, rvar = truth_covariance(scenario, relative, prior_cov=prior_cov,
                                 range_info=range_info)
    return np.sqrt(cov[:, 0, 0] + cov[:, 1, 1]), np.sqrt(rvar)


def truth_conditioned_pcrb(scenario: Scenario, *, samples: int, rng: np.random.Generator,
                           ping_steps: Sequence[int] | None = None,
                           observer: ObserverTrack | None = None) -> PCRBResult:
    """Cartesian PCRB conditioned on the scenario's true target (ristic2004, ch. 6).

    The bound ristic2004 (ch. 6) plot against a filter's RMSE: Tichavský's recursion along
    ``samples`` realisations of the *true* target track (the scenario's own initial state,
    propagated with its process noise, as ``tmaplan track`` simulates it), ``J_0 = P_0⁻¹``
    with ``P_0`` the prior's covariance, the bound covariance averaged over the realisations
    (:func:`truth_covariance`). A range sensor's ``max_range`` applies with each
    realisation's true range (the echo exists, as in the simulation and the batch CRLB): the
    bound is conditioned on the truth, so the reach is the truth's, not an expectation over
    the prior. This is the bound a filter run on that truth can approach;
    the prior-averaged PCRB (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`) averages the
    *information* over geometries drawn from the prior and is much more optimistic while the
    geometry is weakly observable (on ``ristic-bot-moderate`` tens of metres where this bound
    is near a kilometre, before the own-ship manoeuvre has been seen).

    Parameters
    ----------
    scenario : Scenario
        NCV or multi-leg target with a true initial state, a prior, bearing / range sensors
        (frequency lines are not included).
    samples : int
        Realisations of the true track's process noise (>= 2).
    rng : numpy.random.Generator
        For the process noise.
    ping_steps : sequence of int, optional
        Range-ping steps; None = the steps of the scenario's range sensors.
    observer : ObserverTrack, optional
        Default the scenario's.

    Returns
    -------
    PCRBResult
        ``method = "monte-carlo"``, ``coords = "cartesian"``, ``over = "truth"``;
        ``information`` is the inverse of the averaged covariance.
    """
    t_start = time.perf_counter()
    if not isinstance(samples, int | np.integer) or samples < 2:
        raise ArgumentError("samples", "an integer >= 2", samples, source=scenario.name)
    inp = prepare(scenario, ping_steps=ping_steps, observer=observer, lpc=False)
    base = target_track(scenario.target, scenario.time, None)
    K = scenario.n_steps
    truths = np.broadcast_to(base, (int(samples), K + 1, 4)).copy()
    if scenario.target.q > 0:
        F, Q = ncv_matrices(scenario.time.dt, scenario.target.q)
        w = rng.standard_normal((int(samples), K, 4)) @ np.linalg.cholesky(Q).T
        e = np.zeros((int(samples), 4))
        for k in range(K):  # noise through the CV dynamics, batched over samples
            e = e @ F.T + w[:, k]
            truths[:, k + 1] += e
    rel = truths - inp.observer.state[None]
    cov, rvar = truth_covariance(scenario, rel, prior_cov=inp.cov_cart0,
                                 range_info=inp.ping_weight, range_reach=inp.range_reach)
    std = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    return PCRBResult(
        times=inp.times, coords="cartesian", method="monte-carlo",
        information=np.linalg.inv(cov), std=std, position_std=np.sqrt(std[:, 0] ** 2
                                                                       + std[:, 1] ** 2),
        range_std=np.sqrt(rvar), seconds=time.perf_counter() - t_start, samples=int(samples),
        prior_samples=inp.prior_samples, ping_steps=inp.ping_steps, over="truth")


def closed_loop_truth_bounds(scenario: Scenario, observer: np.ndarray, target: np.ndarray,
                             ping_steps: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Truth-conditioned position and range PCRB of closed-loop runs (ristic2004, ch. 6).

    Each run has its own truth, own-ship track and pings; the bound covariance is averaged
    over the runs (:func:`truth_covariance`), the quantity an RMSE over the same runs is
    compared with. ``P_0`` is the covariance of the scenario's prior (the filters' prior).

    Parameters
    ----------
    scenario : Scenario
    observer, target : ndarray, shape (R, K + 1, 2)
        Own-ship and true target positions of R runs [m].
    ping_steps : sequence of R int arrays
        Steps (>= 0; those past K are ignored) at which each run pinged (σ and ``max_range``
        of the scenario's first active range sensor); passive range sensors count at their
        own steps. A reading counts only where the run's true range is within its sensor's
        ``max_range`` (the closed loop's echoes, :func:`tmaplan.simulate.measure_step`).

    Returns
    -------
    position, range : ndarray, shape (K + 1,)
        [m].

    Raises
    ------
    ArgumentError
        Not one ping array per run, shapes that differ, or a negative step.
    ScenarioError
        Pings on a scenario without an active range sensor.
    """
    K = scenario.n_steps
    obs, tgt = np.asarray(observer, float), np.asarray(target, float)
    if obs.ndim != 3 or obs.shape != tgt.shape or len(ping_steps) != obs.shape[0]:
        # one ping list for R runs was broadcast to every run
        raise ArgumentError("ping_steps", f"one ping-step array per run, with observer and "
                            f"target of one shape (R, {K + 1}, 2)",
                            f"{len(ping_steps)} arrays, observer {obs.shape}, target "
                            f"{tgt.shape}", source=scenario.name)
    if any(np.any(np.asarray(st) < 0) for st in ping_steps):
        # np.add.at counted a negative step from the end
        raise ArgumentError("ping_steps", "steps >= 0", [np.asarray(st).tolist()
                                                         for st in ping_steps],
                            source=scenario.name)
    active = [s for s in scenario.sensors if isinstance(s, RangeSensor) and s.active]
    if not active and any(np.asarray(st).size for st in ping_steps):
        # the pings were dropped without a word
        raise ScenarioError("sensors", "an active range sensor (kind = 'range', active = "
                            "true) for the runs' pings", "none", source=scenario.name)
    # the scenario without its active range sensors (their steps are the runs' pings); an
    # internal copy, not re-validated (it may still hold a ping budget)
    passive = dataclasses.replace(scenario, sensors=tuple(
        s for s in scenario.sensors if not (isinstance(s, RangeSensor) and s.active)))
    base = information_rates(passive)[1]
    w = np.tile(base, (len(ping_steps), 1))
    if active:
        for i, st in enumerate(ping_steps):  # per-run ping weights (bookkeeping)
            np.add.at(w[i], np.asarray(st, int)[np.asarray(st, int) <= K],
                      1.0 / float(active[0].sigma) ** 2)
    reach = list(range_reach_terms(passive))
    if active and active[0].max_range is not None:  # an echo only within reach
        reach.append((float(active[0].max_range), w - base))
    cov, rvar = truth_covariance(passive, tgt - obs, range_info=w, range_reach=reach)
    return np.sqrt(cov[:, 0, 0] + cov[:, 1, 1]), np.sqrt(rvar)
