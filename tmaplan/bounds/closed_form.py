"""Closed-form PCRB in log-polar coordinates (brehard2005 §4–5, corrected), ``tmaplan bound``.

:func:`closed_form_pcrb` evaluates the one closed-form engine
(:class:`tmaplan.bounds.closed_form_engine.ClosedFormEngine`, re-exported here) on a scenario's
prior: J₀ is the inverse of the LPC covariance of ``scenario.prior.samples`` prior samples
(eq. 56, read as an outer product; default 100 000 samples for the brehard2005 problems, drawn
with ``prior.seed``), the range truncation is the prior's ``range_min``; the result carries the
side-assumption diagnostic of docs/errata.md (:func:`side_assumption_density`).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import special

from tmaplan.bounds.closed_form_engine import ClosedFormEngine, StepInformation
from tmaplan.bounds.inputs import PCRBInputs, prepare, reached_range_weight
from tmaplan.bounds.pcrb import PCRBResult, SideAssumptionWarning
from tmaplan.display import seconds_text
from tmaplan.errors import ObservabilityError, ScenarioError, finite_real
from tmaplan.memory import check_steps
from tmaplan.models.observer import ObserverTrack
from tmaplan.scenario import Scenario

__all__ = [
    "ClosedFormEngine",
    "StepInformation",
    "closed_form_model",
    "closed_form_pcrb",
    "require_process_noise",
    "side_assumption_density",
    "side_density_gaussian",
]

#: Default tolerance on κ = (wrap period)·p_β(wrap) for the side assumption (docs/errata.md).
SIDE_TOL = 1e-3


def side_density_gaussian(theta: float, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Density of the bearing ``atan2(r_x, r_y)`` at ``theta`` for Gaussian positions.

    ``p(θ) = ∫₀^∞ ρ N(ρ u_θ; m, C) dρ``, u_θ = (sin θ, cos θ), in closed form:
    ``[e^{−c/2}/a + (b/a)·sqrt(2π/a)·e^{−(c − b²/a)/2}·Φ(b/√a)] / (2π sqrt(det C))`` with
    ``a = uᵀC⁻¹u, b = uᵀC⁻¹m, c = mᵀC⁻¹m`` (docs/errata.md).

    Parameters
    ----------
    theta : float
        Bearing [rad].
    mean : ndarray, shape (..., 2)
        Mean relative position [m].
    cov : ndarray, shape (..., 2, 2)
        Its covariance [m²].

    Returns
    -------
    ndarray, shape (...)
        Density [1/rad].
    """
    th = finite_real("theta", theta, "a finite bearing [rad]")
    u = np.array([np.sin(th), np.cos(th)])
    Ci = np.linalg.inv(cov)
    a = np.einsum("i,...ij,j->...", u, Ci, u)
    b = np.einsum("i,...ij,...j->...", u, Ci, mean)
    c = np.einsum("...i,...ij,...j->...", mean, Ci, mean)
    det = np.linalg.det(cov)
    term = (np.exp(-0.5 * c) / a + (b / a) * np.sqrt(2 * np.pi / a)
            * np.exp(-0.5 * (c - b**2 / a)) * special.ndtr(b / np.sqrt(a)))
    return term / (2 * np.pi * np.sqrt(det))


def closed_form_model(scenario: Scenario, *, ping_steps: Sequence[int] | None = None,
                      observer: ObserverTrack | None = None, prior_samples: int | None = None,
                      rng: np.random.Generator | None = None,
                      backend: str = "auto") -> ClosedFormEngine:
    """The :class:`ClosedFormEngine` of a scenario's prior (moments and J₀ from its samples).

    Parameters are those of :func:`closed_form_pcrb`; ``backend`` ("auto", "compiled",
    "casadi") selects how the moment recursion is evaluated.

    Raises
    ------
    ScenarioError
        Frequency sensors (no closed form; use the Monte Carlo PCRB), ``q = 0``, a prior with
        mass at zero range, no prior.
    ObservabilityError
        A non-positive-definite J₀.
    """
    return _engine(_inputs(scenario, ping_steps=ping_steps, observer=observer,
                           prior_samples=prior_samples, rng=rng),
                   float(scenario.target.q), backend)


def _inputs(scenario: Scenario, **kw: Any) -> PCRBInputs:
    if any(s.kind == "frequency" for s in scenario.sensors):
        raise ScenarioError("sensors", "bearing and range sensors only (frequency lines have "
                            "no LPC closed form; use method monte-carlo)",
                            [s.kind for s in scenario.sensors], source=scenario.name)
    require_process_noise(scenario)
    return prepare(scenario, **kw)


def require_process_noise(scenario: Scenario, field: str = "target.q", who: str = "",
                          purpose: str = "") -> None:
    """Refuse a target without process noise where the closed-form bound is evaluated.

    The LPC transition density of brehard2005 (eq. 16) is Gaussian with covariance Q(q):
    with q = 0 it has no density and the bound's recursion inverts a singular Q. Every user
    of the closed form (the bound, the planners' objectives, the baseline grids, the ping
    scheduler) calls this before building anything.

    Parameters
    ----------
    scenario : Scenario
        A one-contact scenario (a contact's view).
    field : str
        The field to name (``contacts[1].target.q`` for a contact of several).
    who : str
        Appended to the message, e.g. ``" (contact 'bravo')"``.
    purpose : str
        What needs the bound, after the expected value, e.g. ``" for tmaplan plan"`` (the
        command line's check of every verb that evaluates it).

    Raises
    ------
    ScenarioError
        ``q`` not > 0, naming ``field``, the expected and the received value; a
        constant-turn target (``q = 0`` by its schema) naming its ``model`` instead.
    """
    q = float(scenario.target.q)
    bound = f"{purpose}: {'its' if purpose else 'the'} closed-form bound (brehard2005) " \
        "propagates the belief through the target's process noise"
    if scenario.target.model == "constant-turn":  # q = 0 by its schema: name the model
        raise ScenarioError(field.removesuffix("q") + "model", f"'ncv' or 'multi-leg'{bound}, "
                            "which the deterministic constant-turn model has not (q = 0; a "
                            f"q > 0 is refused there){who}", "constant-turn",
                            source=scenario.name)
    if not q > 0.0:
        raise ScenarioError(field, f"> 0{bound}, e.g. q = \"1e-5 m^2/s^3\" in the target's "
                            f"table{who}", q, source=scenario.name)


def _engine(inp: PCRBInputs, q: float, backend: str = "auto") -> ClosedFormEngine:
    assert inp.cov_lpc0 is not None  # prepare(lpc=True) always forms it
    return ClosedFormEngine.build(mean=inp.m0, second_moment=inp.S0,
                                  prior_information=np.linalg.inv(inp.cov_lpc0),
                                  observer=inp.observer, dt=inp.dt, q=q,
                                  bearing_info=inp.bearing_info, ping_sigma=inp.range_sigma,
                                  backend=backend)


def closed_form_pcrb(scenario: Scenario, *, ping_steps: Sequence[int] | None = None,
                     observer: ObserverTrack | None = None, prior_samples: int | None = None,
                     rng: np.random.Generator | None = None,
                     side_tol: float = SIDE_TOL) -> PCRBResult:
    """Closed-form PCRB in LPC, passive or with range pings at any steps (brehard2005 §4–5).

    Parameters
    ----------
    scenario : Scenario
        NCV target with q > 0, a prior, bearing (and range) sensors.
    ping_steps : sequence of int, optional
        Ping steps; None = the steps of the scenario's range sensors. A range sensor's
        ``max_range`` applies from the predicted range: the closed form propagates the
        moments of X_k only (not the distribution of r_k, which the expectation
        ``E[1[r_k ≤ max_range]·r_k²]`` of the Monte Carlo PCRB needs), so a reading counts
        wholly where ``r̂_k = sqrt(E r_k²) ≤ max_range`` and not at all elsewhere, the rule of
        the ping scheduler (:class:`tmaplan.planning.ping_contacts.ContactsPingEvaluator`);
        a warning says how many steps it left out. An approximation where the prior straddles
        the reach (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb` applies it sample by sample).
    observer : ObserverTrack, optional
        Default: the scenario's (scripted) observer.
    prior_samples : int, optional
        Samples for J₀ and the prior moments (default ``scenario.prior.samples``).
    rng : numpy.random.Generator, optional
        For those samples (default ``default_rng(scenario.prior.seed)``).
    side_tol : float
        Tolerance (finite, >= 0) on κ_k = (wrap period)·p_β(wrap); a
        :class:`SideAssumptionWarning` is issued where it is exceeded.

    Raises
    ------
    ScenarioError
        ``time.horizon`` with more steps than fit in the memory available
        (:func:`tmaplan.memory.check_steps`), before anything is built.

    Returns
    -------
    PCRBResult
        ``coords = "lpc"``, ``method = "closed-form"``, with ``range_bound`` (eq. 58 with
        ``r̂_k = sqrt(E r_k²)``), ``side_density`` (Gaussian approximation of X_k with the
        exact first two moments) and ``side_valid``.
    """
    t0 = time.perf_counter()
    tol = finite_real("side_tol", side_tol, "a finite number >= 0", lower=0.0,
                      source=scenario.name)
    check_steps(scenario.n_steps, (("bound", 1),), field="time.horizon", dt=scenario.time.dt,
                received=seconds_text(scenario.time.horizon), source=scenario.name)
    inp = _inputs(scenario, ping_steps=ping_steps, observer=observer,
                  prior_samples=prior_samples, rng=rng)
    engine = _engine(inp, float(scenario.target.q))
    weight = reached_range_weight(inp.ping_weight, inp.range_reach, np.sqrt(engine.er2))
    u = weight * inp.range_sigma**2 if inp.range_sigma else None
    var, info, _ = engine.evaluate(u)
    _check_information(scenario, inp.times, var, info)
    seconds = time.perf_counter() - t0
    std = np.sqrt(var)
    rb = np.sqrt(engine.er2 * var[:, 1])
    cov_lpc = np.linalg.inv(info)
    pos = np.sqrt(np.einsum("nij,nij->n", engine.position_weights(), cov_lpc))
    dens, kappa = side_assumption_density(inp)
    valid = kappa <= tol
    msgs: list[str] = []
    if (left := int(np.count_nonzero(weight < inp.ping_weight))):
        msg = (f"{scenario.name}: the closed form left out the range readings at {left} "
               "step(s) whose predicted range sqrt(E r²) is beyond the sensor's max_range "
               "(it has the moments only; the Monte Carlo bounds apply the reach sample by "
               "sample or with the true range)")
        warnings.warn(msg, UserWarning, stacklevel=2)
        msgs.append(msg)
    if not valid.all():
        bad = inp.times[~valid]
        msg = (f"{scenario.name}: side assumption (brehard2005 eq. 27) violated at "
               f"{(~valid).sum()} steps between t = {bad.min() / 60:.1f} and "
               f"{bad.max() / 60:.1f} min "
               f"(max κ = {kappa.max():.3g} > {side_tol}): the true bearing reaches the wrap "
               "point, the β bound is not valid there")
        warnings.warn(msg, SideAssumptionWarning, stacklevel=2)
        msgs.append(msg)
    return PCRBResult(
        times=inp.times, coords="lpc", method="closed-form", information=info, std=std,
        position_std=pos, range_std=rb, seconds=seconds, samples=0,
        prior_samples=inp.prior_samples, ping_steps=inp.ping_steps, range_bound=rb,
        side_density=dens, side_valid=valid, warnings=tuple(msgs))


def _check_information(scenario: Scenario, times: np.ndarray, var: np.ndarray,
                       info: np.ndarray) -> None:
    """Refuse a recursion that lost positive definiteness (round-off, not a bound).

    The recursion subtracts terms of order 1/q; with a process noise q tiny against the
    prior's spread (information eigenvalues 10 orders apart) the difference can come out
    indefinite, and its inverse has negative variances: the result is not a bound.
    """
    bad = ~(np.all(np.isfinite(var), axis=1) & np.all(var > 0, axis=1))
    if not bad.any():
        return
    k = int(np.argmax(bad))
    ev = np.linalg.eigvalsh(0.5 * (info[k] + info[k].T))
    raise ObservabilityError(
        f"{scenario.name}: closed-form PCRB: the information at step {k} (t = {times[k]:.6g} "
        f"s) is not positive definite (eigenvalues {ev.min():.3g} to {ev.max():.3g}): the "
        f"recursion lost precision, e.g. a process noise q = {scenario.target.q:.3g} m²/s³ "
        "tiny against the prior's spread; use the Monte Carlo PCRB (--method monte-carlo) "
        "or a larger target.q")


def side_assumption_density(inp: PCRBInputs, floor: float = 1.0
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Density of the true bearing at the wrap point per step, and κ (docs/errata.md).

    Given X₀ the relative position at step k is exactly Gaussian (linear dynamics), with mean
    ``(A^k X₀ + Σ A^{k−1−s} c_s)_pos`` and the process-noise covariance ``C_k``; the density is
    the average over ``inp.prior_subsample`` of :func:`side_density_gaussian` (with ``C_k +
    floor²·I`` [m²], ``floor`` > 0 [m], so step 0 is a narrow kernel estimate).

    Returns
    -------
    density : ndarray, shape (K + 1,)
        [1/rad]: of β mod π at π/2 for π-ambiguous bearings, of β at ±π otherwise.
    kappa : ndarray, shape (K + 1,)
        (wrap period)·density: the brehard2005 eq. 25 correction 1 − κ of the β bound.
    """
    fl = finite_real("floor", floor, "a finite std > 0 [m]", lower=0.0, strict=True)
    K, A, Q = inp.n_steps, inp.A, inp.Q
    X = inp.prior_subsample.copy()
    C = np.zeros((4, 4))
    means = np.empty((K + 1, X.shape[0], 2))
    covs = np.empty((K + 1, 2, 2))
    for k in range(K + 1):
        means[k] = X[:, :2]
        covs[k] = C[:2, :2] + fl**2 * np.eye(2)
        if k < K:
            X = X @ A.T + inp.c[k]
            C = A @ C @ A.T + Q
    cv = covs[:, None]
    if inp.ambiguity == "pi":
        dens = (side_density_gaussian(np.pi / 2, means, cv)
                + side_density_gaussian(-np.pi / 2, means, cv)).mean(axis=1)
        return dens, np.pi * dens
    dens = side_density_gaussian(np.pi, means, cv).mean(axis=1)
    return dens, 2 * np.pi * dens
