"""Particle-filter initialisation from bearings only (brehard2004, §3, Bréhard & Le Cadre 2004).

Before an observer manoeuvre only the reduced modified-polar (RMP) components
``Y^r = (β̇, ṙ/r, β)`` are observable. They are estimated at the *centre* k of a batch of
2k+1 bearings by Gauss–Newton on the exact regression of eq. (13),
``Z_t = β_k + atan2(τ β̇_k, 1 + τ (ṙ/r)_k) + V_t`` with ``τ = t_t − t_k`` [s], started from the
modified linear estimate of eqs. (16)–(17). The unobservable ``1/r`` is drawn from
``1/U([R_min, R_max])`` (eq. 30), and Y^r uniformly inside the confidence region CA
(eq. 21, eq. 29) with the Dezert–Musso recipe.

Corrections to the printed equations (docs/errata.md, all checked there numerically):

* eq. (16) prints ``Ŷ = (γ̂2, γ̂3, γ̂1)``; the start point is ``(γ̂2, −γ̂3/γ̂2, γ̂1)``
  (from eq. 15, γ3 ≈ −Y1·Y2);
* eqs. (83)–(84) drop δ_t: we use τ = (t−k)δ_t in seconds;
* eq. (26) misses the factor ``sqrt(det Q) = η⁴δ⁴/12``; eq. (28) applies the factor
  (1/R_min − 1/R_max) that (27) applies again (apply it once), and uses χ²₄ for a 3-D region
  (χ²₃ here);
* the batch-duration loop of Fig. 1 is "the smallest k ≥ 3 with V(CA) ≤ Σ V(B)".

The literal eq. (21) (total FIM *and* the 1/(2k+1) factor) is what reproduces the paper's
initialisation time (k = 35 on its scenario, docs/errata.md) and is used for the *decision*
rule; but that region covers the truth with probability ≈ 1 % only, so the *particles* are drawn
by default from the statistically consistent region ``(Y−Ŷ)'J_total(Y−Ŷ) ≤ χ²₃(1−α)``
(``region="consistent"``; ``"paper"`` gives the literal one).

With a π-ambiguous bearing (linear array), the fit is done on residuals wrapped modulo π and
half of the particles get the mirrored bearing ``β + π`` (same β̇, ṙ/r), so the filter starts
with both modes.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np
from scipy.special import gammaln

from tmaplan.errors import ArgumentError, EstimationError, finite_real, is_integer
from tmaplan.geometry import mp_to_cart, wrap_angle, wrap_half_angle

__all__ = [
    "BearingsInit",
    "RMPFit",
    "bearing_regression",
    "fit_rmp",
    "initialise_from_bearings",
    "rmp_fisher_information",
    "sample_ellipsoid",
]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RMPFit:
    """Gauss–Newton fit of the RMP state at the centre of a bearing batch.

    Attributes
    ----------
    estimate : ndarray, shape (3,)
        ``(β̇ [rad/s], ṙ/r [1/s], β [rad])`` at the batch centre.
    start : ndarray, shape (3,)
        Modified linear estimate (corrected eq. 16).
    fim : ndarray, shape (3, 3)
        Total Fisher information of the 2k+1 bearings (corrected eq. 84) at the estimate.
    cost : float
        Σ (residual/σ)².
    iterations : int
    converged : bool
    """

    estimate: np.ndarray
    start: np.ndarray
    fim: np.ndarray
    cost: float
    iterations: int
    converged: bool


@dataclasses.dataclass(frozen=True, kw_only=True)
class BearingsInit:
    """Result of the file-001 initialisation.

    Attributes
    ----------
    k : int
        Batch half-length: bearings 0..2k are used; the RMP estimate refers to bearing k.
    centre_index, end_index : int
        Indices (into the bearing sequence) of the batch centre and end.
    fit : RMPFit
    particles : ndarray, shape (N, 4)
        Relative Cartesian particles at the batch centre [m, m, m/s, m/s].
    volume_ratio : float
        V(CA) / Σ V(B) at the decision (≤ 1 when the rule was met).
    rule_met : bool
        Whether the batch-duration rule was met (else the largest batch allowed was used).
    """

    k: int
    centre_index: int
    end_index: int
    fit: RMPFit
    particles: np.ndarray
    volume_ratio: float
    rule_met: bool


def bearing_regression(Yr: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Noise-free bearings of eq. (13) for a non-manoeuvring geometry.

    Parameters
    ----------
    Yr : ndarray, shape (..., 3)
        ``(β̇, ṙ/r, β)`` at the reference time [rad/s, 1/s, rad].
    tau : ndarray, shape (n,)
        Time offsets from the reference [s].

    Returns
    -------
    ndarray, shape (..., n)
        Bearings [rad] (not wrapped).
    """
    Yr = np.asarray(Yr, float)
    t = np.asarray(tau, float)
    y1, y2, y3 = Yr[..., 0, None], Yr[..., 1, None], Yr[..., 2, None]
    return y3 + np.arctan2(t * y1, 1.0 + t * y2)


def _jacobian(Yr: np.ndarray, tau: np.ndarray) -> np.ndarray:
    # Corrected eq. (84): G_t = (τ(1+τY2), −τ²Y1, Den)/Den, τ in seconds.
    y1, y2 = Yr[0], Yr[1]
    a = 1.0 + tau * y2
    b = tau * y1
    den = a * a + b * b
    return np.stack([tau * a / den, -tau * b / den, np.ones_like(tau)], axis=-1)


def rmp_fisher_information(Yr: np.ndarray, tau: np.ndarray, sigma: float) -> np.ndarray:
    """Total FIM of the bearing batch for Y^r (corrected brehard2004 eq. 84), shape (3, 3)."""
    G = _jacobian(np.asarray(Yr, float), np.asarray(tau, float))
    return G.T @ G / sigma**2


def fit_rmp(z: np.ndarray, tau: np.ndarray, sigma: float, *,
            ambiguity: Literal["none", "pi"] = "none", max_iter: int = 50,
            tol: float = 1e-10) -> RMPFit:
    """Gauss–Newton estimate of Y^r at τ = 0 from bearings ``z`` at offsets ``tau``.

    Parameters
    ----------
    z : ndarray, shape (n,)
        Bearings [rad].
    tau : ndarray, shape (n,)
        Offsets from the reference time [s] (n ≥ 3).
    sigma : float
        Bearing std [rad].
    ambiguity : {"none", "pi"}
        Wrap residuals modulo 2π or π.
    max_iter : int
    tol : float
        Relative step tolerance.

    Returns
    -------
    RMPFit
    """
    z = np.asarray(z, float)
    tau = np.asarray(tau, float)
    if z.ndim != 1 or z.shape != tau.shape or z.shape[0] < 3:
        raise ArgumentError("bearings", "at least 3 bearings with matching times", z.shape)
    _check_common(z, tau, sigma, ambiguity)
    wrap = wrap_half_angle if ambiguity == "pi" else wrap_angle
    # Modified linear estimate, eqs. (15)-(17) with the corrected mapping of eq. (16).
    ref = z[np.argmin(np.abs(tau))]
    zu = ref + wrap(z - ref)
    X = np.stack([np.ones_like(tau), tau, tau * tau], axis=-1)
    g, *_ = np.linalg.lstsq(X, zu, rcond=None)
    y1 = g[1]
    y2 = -g[2] / g[1] if abs(g[1]) > 1e-15 else 0.0
    start = np.array([y1, y2, g[0]])
    Y = start.copy()
    cost = np.inf
    converged = False
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 - iteration count is reported
        r = wrap(zu - bearing_regression(Y, tau)) / sigma
        cost = float(r @ r)
        G = _jacobian(Y, tau) / sigma
        step, *_ = np.linalg.lstsq(G, r, rcond=None)
        # Backtracking keeps the GN step a descent step; a direction along which no step
        # lowers the cost ends the iteration at Y (never a worse point), converged if the
        # Gauss-Newton step is at round-off level there.
        lam = 1.0
        while lam > 1e-4:
            Yn = Y + lam * step
            rn = wrap(zu - bearing_regression(Yn, tau)) / sigma
            if float(rn @ rn) <= cost:
                break
            lam *= 0.5
        else:
            converged = bool(np.all(np.abs(step) <= np.sqrt(tol) * (np.abs(Y) + 1e-12)))
            break
        Y = Yn
        if np.all(np.abs(lam * step) <= tol * (np.abs(Y) + 1e-12)):
            converged = True
            break
    r = wrap(zu - bearing_regression(Y, tau)) / sigma
    return RMPFit(estimate=Y, start=start, fim=rmp_fisher_information(Y, tau, sigma),
                  cost=float(r @ r), iterations=it, converged=converged)


def _check_common(z: np.ndarray, t: np.ndarray, sigma: float, ambiguity: str) -> None:
    """Refuse non-finite bearings or times, a bearing std that is not finite and > 0 and an
    unknown ambiguity."""
    if not (np.isfinite(z).all() and np.isfinite(t).all()):
        raise ArgumentError("bearings", "finite bearings [rad] at finite times [s]",
                            "a NaN or infinite value")
    finite_real("sigma", sigma, "a finite bearing std > 0 [rad]", lower=0.0, strict=True)
    if ambiguity not in ("none", "pi"):
        raise ArgumentError("ambiguity", "'none' or 'pi'", ambiguity)


def sample_ellipsoid(centre: np.ndarray, info: np.ndarray, c: float, n: int,
                     rng: np.random.Generator) -> np.ndarray:
    """Uniform samples in ``{Y : (Y−centre)' info (Y−centre) ≤ c}`` (Dezert–Musso).

    Parameters
    ----------
    centre : ndarray, shape (d,)
    info : ndarray, shape (d, d)
        Positive definite.
    c : float
        Threshold.
    n : int
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n, d)
    """
    d = centre.shape[0]
    g = rng.standard_normal((n, d))
    u = g / np.linalg.norm(g, axis=1, keepdims=True) * rng.random((n, 1)) ** (1.0 / d)
    L = np.linalg.cholesky(info)
    # Y − centre = sqrt(c)·L^{-T} u  ⇒  (Y−c)'LL'(Y−c) = c‖u‖².
    return centre + np.sqrt(c) * np.linalg.solve(L.T, u.T).T


def _log_ellipsoid_volume(dim: int, c: float, logdet: float) -> float:
    return 0.5 * dim * np.log(np.pi * c) - gammaln(dim / 2 + 1) - 0.5 * logdet


def initialise_from_bearings(
    times: np.ndarray,
    bearings: np.ndarray,
    sigma: float,
    *,
    r_min: float,
    r_max: float,
    n_particles: int,
    rng: np.random.Generator,
    q: float,
    dt: float | None = None,
    alpha: float = 0.05,
    k_min: int = 3,
    k_max: int | None = None,
    k_fixed: int | None = None,
    region: Literal["consistent", "paper"] = "consistent",
    ambiguity: Literal["none", "pi"] = "none",
) -> BearingsInit:
    """brehard2004 initialisation: batch length rule, RMP fit, particles in MP → Cartesian.

    Parameters
    ----------
    times : ndarray, shape (n,)
        Bearing times [s] (uniformly spaced; the observer must not manoeuvre in the batch).
    bearings : ndarray, shape (n,)
        [rad], clockwise from North.
    sigma : float
        Bearing std [rad].
    r_min, r_max : float
        Range interval [m] (the only prior, brehard2004).
    n_particles : int
    rng : numpy.random.Generator
    q : float
        Process-noise intensity η² [m²/s³] of the filter (enters V(B), corrected eq. 26).
    dt : float, optional
        Bearing spacing δ_t [s] (default: from ``times``).
    alpha : float
        1 − confidence level.
    k_min : int
        First batch half-length tried (3 in Fig. 1).
    k_max : int, optional
        Largest half-length (default: as many as the bearings allow).
    k_fixed : int, optional
        Skip the rule and use this k.
    region : {"consistent", "paper"}
        Confidence region the Y^r particles are drawn from (see the module notes).
    ambiguity : {"none", "pi"}

    Returns
    -------
    BearingsInit

    Raises
    ------
    ArgumentError
        On invalid inputs (too few bearings, bad range interval).
    EstimationError
        If the Gauss–Newton fit fails to produce a finite estimate.
    """
    t = np.asarray(times, float)
    z = np.asarray(bearings, float)
    if t.ndim != 1 or z.shape != t.shape:
        raise ArgumentError("bearings", f"one bearing per time, shape {t.shape}", z.shape)
    _check_common(z, t, sigma, ambiguity)
    if not 0 < r_min < r_max < np.inf:
        raise ArgumentError("r_min/r_max", "0 < r_min < r_max < inf [m]", (r_min, r_max))
    if not is_integer(n_particles, 1):
        raise ArgumentError("n_particles", "an integer >= 1", n_particles)
    finite_real("q", q, "a finite process-noise intensity >= 0 [m²/s³]", lower=0.0)
    if dt is not None:
        finite_real("dt", dt, "a finite bearing spacing > 0 [s] or None", lower=0.0, strict=True)
    if not 0.0 < alpha < 1.0:
        raise ArgumentError("alpha", "a probability in (0, 1)", alpha)
    if region not in ("consistent", "paper"):
        raise ArgumentError("region", "'consistent' or 'paper'", region)
    if not is_integer(k_min, 1):
        raise ArgumentError("k_min", "an integer >= 1", k_min)
    if k_max is not None and not is_integer(k_max, k_min):
        raise ArgumentError("k_max", f"an integer >= k_min = {k_min} or None", k_max)
    n = t.shape[0]
    if k_fixed is not None and not (is_integer(k_fixed, 1) and 2 * k_fixed + 1 <= n):
        raise ArgumentError("k_fixed", f"an integer in [1, {(n - 1) // 2}] ({n} bearings) or "
                            "None", k_fixed)
    if n < 2 * k_min + 1:
        raise ArgumentError("bearings", f"at least {2 * k_min + 1} bearings", n)
    delta = float(dt) if dt is not None else float(np.median(np.diff(t)))
    k_hi = (n - 1) // 2 if k_max is None else min(k_max, (n - 1) // 2)
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    chi3 = stats.chi2.ppf(1 - alpha, 3)
    chi4 = stats.chi2.ppf(1 - alpha, 4)
    # Σ V(B) (corrected eq. 26): N·E[Y4⁵]·(π χ²₄)²/Γ(3)·sqrt(det Q), sqrt det Q = q²δ⁴/12.
    e_y4_5 = (r_min**-4 - r_max**-4) / (4.0 * (r_max - r_min))
    log_vb = (np.log(n_particles * e_y4_5) + 2 * np.log(np.pi * chi4) - gammaln(3.0)
              + np.log(max(q, 1e-300) ** 2 * delta**4 / 12.0))
    ks = [k_fixed] if k_fixed is not None else range(k_min, k_hi + 1)
    fit = None
    ratio = np.inf
    met = False
    k = k_min
    for k in ks:
        idx = np.arange(2 * k + 1)
        tau = t[idx] - t[k]
        fit = fit_rmp(z[idx], tau, sigma, ambiguity=ambiguity)
        sign, logdet = np.linalg.slogdet(fit.fim)
        if sign <= 0 or not np.isfinite(fit.estimate).all():
            continue
        # V(CA) (corrected eqs. 27-28, literal eq. 21 reading (a) of docs/errata.md).
        log_vca = (np.log(1 / r_min - 1 / r_max)
                   + _log_ellipsoid_volume(3, chi3 / (2 * k + 1), logdet))
        ratio = float(np.exp(log_vca - log_vb))
        if k_fixed is not None or ratio <= 1.0:
            met = ratio <= 1.0
            break
    if fit is None or not np.isfinite(fit.estimate).all() \
            or np.linalg.slogdet(fit.fim)[0] <= 0:
        raise EstimationError("bearings-only initialisation: the RMP fit failed")
    c = chi3 if region == "consistent" else chi3 / (2 * k + 1)
    Yr = sample_ellipsoid(fit.estimate, fit.fim, c, n_particles, rng)
    y4 = 1.0 / rng.uniform(r_min, r_max, n_particles)  # eq. (30)
    if ambiguity == "pi":
        flip = rng.random(n_particles) < 0.5
        Yr[flip, 2] += np.pi
    Y = np.column_stack([Yr[:, 0], Yr[:, 1], Yr[:, 2], y4])
    X = mp_to_cart(Y)
    return BearingsInit(k=int(k), centre_index=int(k), end_index=int(2 * k), fit=fit,
                        particles=X, volume_ratio=ratio, rule_met=met)
