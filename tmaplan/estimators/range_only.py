"""Range-only filter with GvM2 azimuth moments (sharma2024, Sharma et al. 2024, §VI), three modes.

One filter (:class:`RangeOnlyFilter`), one state type: the posterior of the relative
``X = [r_x, r_y, v_x, v_y]`` is a Gaussian mixture (:class:`RangeOnlyState`); the moment and
Dirac modes keep one component ``N(x̂, P)``, the paper's single Gaussian. Prediction is the
NCV model with the observer increment, ``x̂⁻ = F x̂ − H Δv`` (sharma2024 eq. 2/56 written with
docs/conventions.md's Δv), ``P⁻ = F P F' + Q``, per component. The range update uses
the linear-position view of eq. (9): given the azimuth θ, ``y = r·b(θ)``,
``b = [cos θ, sin θ]`` is a linear measurement of the position with noise σ_r²I (eq. 6
model), so with ``V = H P⁻ H' + σ_r² I``,
``K = P⁻ H' V⁻¹``:

* ``mode="mixture"`` (default): a Gaussian mixture kept across scans, every component split
  into azimuth sectors each updated with eqs. (12)–(13) restricted to its sector, weighted by
  its marginal range likelihood and reduced by Runnalls merging (see *Mixture mode* below).
  sharma2024 collapses to one Gaussian after every scan (§VI.A step 7) and names the
  mixture prior as future work; on ``sharma2024-range-only`` the collapse loses the
  second passing side near the closest approach: final position RMSE ≈ 2600 m against
  1154 m for the mixture (100 runs, seed 4; issue-5 report), with NEES in the thousands
  against ≈ 4. With one sector (``max_sectors=1``) the mixture update of one component *is*
  the moment update below;
* ``mode="moments"`` (the paper's recursion): the exact moment-matched posterior of eqs. (12)–(13),
  ``x̂ = (I−KH)x̂⁻ + r K E[b|r]``, ``P = (I−KH)P⁻ + r² K P_b K'`` with ``E[b|r]`` and ``P_b`` from
  the first two trigonometric moments (eqs. 40–44);
* ``mode="dirac"``: the paper's L-point wrapped Dirac mixture fitted to M moments (eq. 52), one
  Kalman component per point (eqs. 53–54) and a collapse to one Gaussian. The component
  covariance is ``component_cov="exact"`` ``(I−KH)P⁻`` (default) or ``"paper"``
  (eq. 55 as printed, which adds ``r²KP_bK'`` to every component and so double-counts the
  azimuth spread after the collapse, docs/errata.md).

Moments come from the max-shifted grid/FFT engine by default (``moments="grid"``); the
paper's Bessel series (``moments="series"``, N terms) is unreliable at the concentrations of
tracking (docs/errata.md) and kept for comparison. :meth:`RangeOnlyFilter.init` moment-matches
the scenario's prior; :func:`single_point_prior` is the paper's initialisation (one range and
one azimuth, sharma2024): position from polar coordinates with
``P_pos = J diag(σ_r², σ_β²) J'`` and a velocity prior given by the caller (the paper does not
specify it, docs/errata.md).

Mixture mode. Range-only data on a straight relative leg leave the target on a ring arc, and
close to the closest point of approach the two *passing sides* are both consistent with the
ranges; one Gaussian has to pick a side ("bimodality is lost across
time"). The mixture is kept across time (our extension):

* every component ``N(x̂_i, P_i)`` is predicted as above;
* at a range r the azimuth posterior of component i (the GvM2 of sharma2024 eq. 24) is evaluated
  on a grid restricted to the window where it has mass, together with the component's marginal
  range likelihood ``p_i(r) = ∫ p(r b(θ)) r dθ`` (eqs. 19/25 computed directly in logs,
  our derivation);
* the window is cut into azimuth sectors no wider than ``Δ = sqrt(8 s / r)`` so that the arc
  sagitta ``r Δ²/8`` stays below ``s = sagitta·σ_r``; on each sector the exact moment-matched
  update of eqs. (12)–(13) is applied with the sector-conditional moments ``E[b | r, θ ∈ S]``
  and ``Cov[b | r, θ ∈ S]`` (eqs. 40–44 restricted to the sector). The sector weights
  ``w_i p_i(r) P(θ ∈ S | r)`` are the exact masses of the pieces, and the sum of the pieces
  has the exact posterior mean and covariance of eqs. (12)–(13) for each component (law of
  total covariance), so with one sector this *is* the paper's moment update;
* the mixture is reduced by pruning negligible weights and Runnalls' (2007) KL-bound greedy
  pair merging down to ``max_components``.

This is the angle-parameterised Gaussian-sum idea (range-parameterised EKF of Peach 1995 and
Arulampalam & Ristic 2000, here in azimuth) with sharma2024's exact moments in each sector.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import ClassVar, Literal

import numpy as np
from scipy.special import logsumexp

from tmaplan.errors import ArgumentError, finite_real, is_integer
from tmaplan.estimators.gvm_moments import (
    dirac_mixture,
    gvm2_from_gaussian,
    log_range_density,
    moments_grid,
    moments_series,
)
from tmaplan.models.prior import prior_relative_moments
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import Scenario
from tmaplan.simulate import Measurement

__all__ = [
    "RangeOnlyConfig",
    "RangeOnlyFilter",
    "RangeOnlyState",
    "from_gaussian",
    "range_only_predict",
    "range_only_update",
    "reduce_mixture",
    "single_point_prior",
]

_LOG_2PI = float(np.log(2.0 * np.pi))


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeOnlyConfig:
    """Settings of the range-only filter.

    Attributes
    ----------
    dt : float
        [s].
    q : float
        Process-noise intensity of the filter [m²/s³].
    mode : {"mixture", "moments", "dirac"}
        "mixture": Gaussian-mixture filter (ours, default); "moments": sharma2024's single
        Gaussian with the exact moment update; "dirac": sharma2024's L-point Dirac mixture and
        collapse.
    component_cov : {"exact", "paper"}
        Dirac mode only.
    moments : {"grid", "series"}
    series_terms : int
        N for the series engine (5 in sharma2024 Table II).
    n_moments : int
        M (10 in Table II).
    n_points : int
        L (8 in Table II).
    max_components, max_sectors : int
        Mixture mode: components kept after each scan; sectors per component and scan.
    sagitta : float
        Mixture mode: allowed arc sagitta of one sector in units of σ_r (sector width
        ``Δ = sqrt(8·sagitta·σ_r / r)``).
    tail : float
        Mixture mode: azimuth probability left outside the split window on each side (folded
        into the end sectors, never dropped).
    prune : float
        Mixture mode: components with a relative weight below this are dropped before merging.
    """

    dt: float
    q: float
    mode: Literal["mixture", "moments", "dirac"] = "mixture"
    component_cov: Literal["exact", "paper"] = "exact"
    moments: Literal["grid", "series"] = "grid"
    series_terms: int = 5
    n_moments: int = 10
    n_points: int = 8
    max_components: int = 24
    max_sectors: int = 12
    sagitta: float = 1.0
    tail: float = 1e-4
    prune: float = 1e-7

    def __post_init__(self) -> None:
        finite_real("dt", self.dt, "a finite step > 0 s", lower=0.0, strict=True)
        finite_real("q", self.q, "a finite intensity >= 0 m²/s³", lower=0.0)
        if self.mode not in ("mixture", "moments", "dirac"):
            raise ArgumentError("mode", "'mixture', 'moments' or 'dirac'", self.mode)
        if self.component_cov not in ("exact", "paper"):
            raise ArgumentError("component_cov", "'exact' or 'paper'", self.component_cov)
        if self.moments not in ("grid", "series"):
            raise ArgumentError("moments", "'grid' or 'series'", self.moments)
        for name, low in (("series_terms", 0), ("n_moments", 1), ("n_points", 1),
                          ("max_components", 1), ("max_sectors", 1)):
            if not is_integer(getattr(self, name), low):
                raise ArgumentError(name, f"an integer >= {low}", getattr(self, name))
        finite_real("sagitta", self.sagitta, "a finite number > 0 (multiple of σ_r)", lower=0.0,
                    strict=True)
        if not 0.0 <= self.tail < 0.5:
            raise ArgumentError("tail", "a probability in [0, 0.5)", self.tail)
        if not 0.0 <= self.prune < 1.0:
            raise ArgumentError("prune", "a relative weight in [0, 1)", self.prune)


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeOnlyState:
    """Gaussian-mixture posterior of the relative state ``[r_x, r_y, v_x, v_y]`` (one
    component in the moment and Dirac modes).

    Attributes
    ----------
    step : int
    weights : ndarray, shape (C,)
        Normalised (Σ = 1).
    means : ndarray, shape (C, 4)
        [m, m, m/s, m/s].
    covs : ndarray, shape (C, 4, 4)
    log_likelihood : float
        Log of the last update's predictive range density ``p(r_k | r_{1:k−1})`` [log 1/m]
        (0 before any update).
    """

    step: int
    weights: np.ndarray
    means: np.ndarray
    covs: np.ndarray
    log_likelihood: float = 0.0

    @property
    def mean(self) -> np.ndarray:
        """Mixture mean, shape (4,)."""
        return self.weights @ self.means

    @property
    def cov(self) -> np.ndarray:
        """Mixture covariance (moment matched), shape (4, 4)."""
        d = self.means - self.mean
        C = np.einsum("c,cij->ij", self.weights, self.covs) + (d * self.weights[:, None]).T @ d
        return 0.5 * (C + C.T)

    @property
    def n_components(self) -> int:
        """C."""
        return self.weights.shape[0]


def from_gaussian(mean: np.ndarray, cov: np.ndarray, *, step: int = 0) -> RangeOnlyState:
    """One-component mixture ``N(mean, cov)``."""
    return RangeOnlyState(step=step, weights=np.ones(1),
                          means=np.asarray(mean, float).reshape(1, 4).copy(),
                          covs=np.asarray(cov, float).reshape(1, 4, 4).copy())


def single_point_prior(r0: float, bearing0: float, sigma_r: float, sigma_bearing: float,
                       velocity_mean: np.ndarray, velocity_std: float, *, step: int = 0
                       ) -> RangeOnlyState:
    """Single-point initialisation from one range and one bearing (sharma2024).

    Parameters
    ----------
    r0 : float
        Range [m].
    bearing0 : float
        Bearing [rad], clockwise from North.
    sigma_r, sigma_bearing : float
        [m], [rad].
    velocity_mean : ndarray, shape (2,)
        Relative velocity mean [m/s].
    velocity_std : float
        Per-axis std [m/s].
    step : int

    Returns
    -------
    RangeOnlyState
    """
    v = np.asarray(velocity_mean, float)
    finite_real("r0", r0, "a finite range > 0 [m]", lower=0.0, strict=True)
    finite_real("bearing0", bearing0, "a finite bearing [rad]")
    for name, value in (("sigma_r", sigma_r), ("sigma_bearing", sigma_bearing),
                        ("velocity_std", velocity_std)):
        finite_real(name, value, "a finite std >= 0", lower=0.0)
    if v.shape != (2,) or not np.isfinite(v).all():
        raise ArgumentError("velocity_mean", "a finite relative velocity of shape (2,) [m/s]",
                            v.tolist())
    s, c = np.sin(bearing0), np.cos(bearing0)
    J = np.array([[s, r0 * c], [c, -r0 * s]])  # ∂(x, y)/∂(r, β)
    P = np.zeros((4, 4))
    P[:2, :2] = J @ np.diag([sigma_r**2, sigma_bearing**2]) @ J.T
    P[2:, 2:] = velocity_std**2 * np.eye(2)
    mean = np.concatenate([[r0 * s, r0 * c], v])
    return from_gaussian(mean, P, step=step)


def range_only_predict(state: RangeOnlyState, dv: np.ndarray | None, config: RangeOnlyConfig
                       ) -> RangeOnlyState:
    """NCV prediction of every component, ``x ← F x − H Δv``, ``P ← F P F' + Q``.

    Parameters
    ----------
    state : RangeOnlyState
    dv : ndarray, shape (2,), optional
        Observer velocity increment [m/s] (None = 0).
    config : RangeOnlyConfig

    Returns
    -------
    RangeOnlyState
        At ``step + 1``.
    """
    F, Q = ncv_matrices(config.dt, config.q)
    X = state.means @ F.T
    if dv is not None:
        d = np.asarray(dv, float).reshape(2)
        X[:, :2] -= config.dt * d
        X[:, 2:] -= d
    P = F @ state.covs @ F.T + Q
    P = 0.5 * (P + np.swapaxes(P, 1, 2))
    return RangeOnlyState(step=state.step + 1, weights=state.weights, means=X, covs=P)


def range_only_update(state: RangeOnlyState, r: float, sigma_r: float,
                      config: RangeOnlyConfig) -> RangeOnlyState:
    """Range update: sector mixture (``mixture``), sharma2024 eqs. 12–14 (``moments``) or
    eqs. 52–55 + collapse (``dirac``).

    Parameters
    ----------
    state : RangeOnlyState
        Predicted state (the moment and Dirac modes collapse a mixture to one Gaussian first).
    r : float
        Measured range [m]; a non-positive range (possible under the truth's additive noise,
        eq. 58) skips the update; a NaN or infinite one is refused.
    sigma_r : float
        [m], finite and > 0; the filter uses sharma2024's eq. (6) model (noise σ_r²I inside
        the norm).
    config : RangeOnlyConfig

    Returns
    -------
    RangeOnlyState
        Its ``log_likelihood`` is ``log p(r)`` under the predicted mixture (moment and Dirac
        modes: under its collapse). Mixture mode: reduced to at most ``max_components``
        components; if the range has zero (underflowed) likelihood under every component the
        predicted mixture is returned unchanged with ``log_likelihood = −inf``.

    Raises
    ------
    ArgumentError
        If ``r`` is not finite or ``sigma_r`` is not finite and > 0.
    """
    finite_real("r", r, "a finite measured range [m]")
    finite_real("sigma_r", sigma_r, "a finite range std > 0 [m]", lower=0.0, strict=True)
    if not r > 0:
        return state
    if config.mode == "mixture":
        return _sector_update(state, r, sigma_r, config)
    x, P = state.mean, state.cov
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 1] = 1.0
    yhat = x[:2]
    V = P[:2, :2] + sigma_r**2 * np.eye(2)
    K = P[:, :2] @ np.linalg.inv(V)
    IKH = np.eye(4) - K @ H
    g = gvm2_from_gaussian(yhat, V, r)
    m_max = max(2, config.n_moments if config.mode == "dirac" else 2)
    if config.moments == "series":
        c = moments_series(g, m_max, config.series_terms)
    else:
        c = moments_grid(g, m_max)
    Eb = np.array([c[1].real, c[1].imag])
    Ebb = np.array([[0.5 + 0.5 * c[2].real, 0.5 * c[2].imag],
                    [0.5 * c[2].imag, 0.5 - 0.5 * c[2].real]])  # eqs. 42–44
    Pb = Ebb - np.outer(Eb, Eb)
    base = IKH @ x
    Pc = IKH @ P
    if config.mode == "moments":
        mean = base + r * K @ Eb
        cov = Pc + r * r * K @ Pb @ K.T
    else:
        d = dirac_mixture(c, config.n_points, g)
        b = np.stack([np.cos(d.theta), np.sin(d.theta)], axis=-1)  # (L, 2)
        comps = base + r * b @ K.T  # (L, 4), eq. 54
        mean = d.gamma @ comps
        dev = comps - mean
        cov = Pc + (dev * d.gamma[:, None]).T @ dev
        if config.component_cov == "paper":
            cov = cov + r * r * K @ Pb @ K.T  # eq. 55 as printed
    return dataclasses.replace(from_gaussian(mean, 0.5 * (cov + cov.T), step=state.step),
                               log_likelihood=log_range_density(g, yhat, V, r))


def _windows(yhat: np.ndarray, V: np.ndarray, r: float, drop: float = 30.0
             ) -> tuple[np.ndarray, np.ndarray]:
    """Centre and half-width [rad] of the azimuth window holding the mass of each component.

    Points ``r b(θ)`` whose squared Mahalanobis distance exceeds the best point's by more
    than ``2·drop`` (density ratio e^−drop) are outside. With λ_min ≤ λ ≤ λ_max the
    eigenvalues of V, the best point is ``r b(θ0)`` at distance ``d0 = |r − ρ|`` from ŷ
    (ρ = |ŷ|), so every kept point lies within ``dist² ≤ λ_max (2·drop + d0²/λ_min)`` of ŷ; the
    law of cosines turns this into a half-width about θ0 (π if the disc contains the origin).
    """
    lam = np.linalg.eigvalsh(V)  # (C, 2) ascending
    rho = np.hypot(yhat[:, 0], yhat[:, 1])
    d0 = np.abs(r - rho)
    dist2 = lam[:, 1] * (2.0 * drop + d0 * d0 / lam[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        cosw = (r * r + rho * rho - dist2) / (2.0 * r * rho)
    half = np.where(np.isfinite(cosw), np.arccos(np.clip(cosw, -1.0, 1.0)), np.pi)
    return np.arctan2(yhat[:, 1], yhat[:, 0]), half


def _sector_update(state: RangeOnlyState, r: float, sigma_r: float, config: RangeOnlyConfig
                   ) -> RangeOnlyState:
    """Mixture-mode range update with azimuth-sector splitting (eqs. 12–14 per sector)."""
    w, X, P = state.weights, state.means, state.covs
    C = w.shape[0]
    yhat = X[:, :2]
    V = P[:, :2, :2] + sigma_r**2 * np.eye(2)
    Vi = np.linalg.inv(V)
    K = P[:, :, :2] @ Vi  # (C, 4, 2)
    centre, half = _windows(yhat, V, r)
    # Grid spacing ≤ 1/(4 sqrt(κ)) with κ ≥ the curvature of the log-density in θ
    # (κ1 + 4κ2 ≤ r ρ λmax(V⁻¹) + r² λmax(V⁻¹), our derivation).
    lmax_inv = 1.0 / np.linalg.eigvalsh(V)[:, 0]
    rho = np.hypot(yhat[:, 0], yhat[:, 1])
    kappa = r * (rho + r) * lmax_inv + 1.0
    G = int(np.clip(np.max(np.ceil(8.0 * half * np.sqrt(kappa))) + 1, 64, 65536))
    u = np.linspace(-1.0, 1.0, G)
    theta = centre[:, None] + half[:, None] * u  # (C, G)
    h = 2.0 * half / (G - 1)  # (C,)
    bx, by = np.cos(theta), np.sin(theta)
    ex = r * bx - yhat[:, 0, None]
    ey = r * by - yhat[:, 1, None]
    maha = Vi[:, 0, 0, None] * ex * ex + 2.0 * Vi[:, 0, 1, None] * ex * ey \
        + Vi[:, 1, 1, None] * ey * ey
    logdet = np.linalg.slogdet(V)[1]
    # log p(θ, r) = log r − log 2π − ½ log|V| − ½ maha   (sharma2024 eq. 17)
    logp = np.log(r) - _LOG_2PI - 0.5 * logdet[:, None] - 0.5 * maha
    # Trapezoid weights on the (closed or full-circle) window.
    full = half >= np.pi - 1e-12
    tw = np.ones((C, G))
    tw[~full, 0] = tw[~full, -1] = 0.5
    tw[full, -1] = 0.0  # periodic: θ = ±π is one point
    with np.errstate(divide="ignore"):
        logp = logp + np.log(tw)
    logml = logsumexp(logp, axis=1) + np.log(h)  # (C,) log p_i(r)
    om = np.exp(logp - (logml - np.log(h))[:, None])  # normalised azimuth weights (C, G)
    # Sectors: equal width between the `tail` quantiles, folded tails, ≤ max_sectors.
    cdf = np.cumsum(om, axis=1)
    lo = np.argmax(cdf >= config.tail, axis=1)
    hi = np.argmax(cdf >= 1.0 - config.tail, axis=1)
    span = (hi - lo) * h
    width = np.sqrt(8.0 * config.sagitta * sigma_r / r)
    n_s = np.clip(np.ceil(span / width), 1, config.max_sectors).astype(int)
    idx = np.arange(G)
    frac = (idx[None, :] - lo[:, None]) / np.maximum(hi - lo, 1)[:, None]
    sec = np.clip(np.floor(frac * n_s[:, None]), 0, n_s[:, None] - 1).astype(int)
    S = int(config.max_sectors)
    flat = (np.arange(C)[:, None] * S + sec).ravel()
    mass = np.bincount(flat, om.ravel(), C * S)
    m1x = np.bincount(flat, (om * bx).ravel(), C * S)
    m1y = np.bincount(flat, (om * by).ravel(), C * S)
    c2 = np.cos(2.0 * theta)
    s2 = np.sin(2.0 * theta)
    m2c = np.bincount(flat, (om * c2).ravel(), C * S)
    m2s = np.bincount(flat, (om * s2).ravel(), C * S)
    keep = mass > 0.0
    comp = np.repeat(np.arange(C), S)[keep]
    ms = mass[keep]
    Eb = np.stack([m1x[keep], m1y[keep]], axis=-1) / ms[:, None]
    ec2, es2 = m2c[keep] / ms, m2s[keep] / ms
    # eqs. (42)–(44) on the sector: E[bb'] from the second trigonometric moments.
    Ebb = np.empty((ms.size, 2, 2))
    Ebb[:, 0, 0] = 0.5 + 0.5 * ec2
    Ebb[:, 1, 1] = 0.5 - 0.5 * ec2
    Ebb[:, 0, 1] = Ebb[:, 1, 0] = 0.5 * es2
    Pb = Ebb - Eb[:, :, None] * Eb[:, None, :]
    Kc = K[comp]
    base = X[comp] - np.einsum("cij,cj->ci", Kc, yhat[comp])  # (I − KH) x̂
    means = base + r * np.einsum("cij,cj->ci", Kc, Eb)  # eq. (12) on the sector
    Pc = P - K @ P[:, :2, :]  # (I − KH) P
    covs = Pc[comp] + r * r * Kc @ Pb @ np.swapaxes(Kc, 1, 2)  # eq. (13) on the sector
    logw = np.log(w[comp]) + logml[comp] + np.log(ms)
    total = logsumexp(logw)
    if not np.isfinite(total):  # the range has zero likelihood under every component
        return dataclasses.replace(state, log_likelihood=float(total))
    out = RangeOnlyState(step=state.step, weights=np.exp(logw - total), means=means,
                           covs=0.5 * (covs + np.swapaxes(covs, 1, 2)),
                           log_likelihood=float(total))
    return reduce_mixture(out, config.max_components, prune=config.prune)


def _merge_cost(w: np.ndarray, m: np.ndarray, P: np.ndarray, ld: np.ndarray, i: np.ndarray,
                j: np.ndarray) -> np.ndarray:
    """Runnalls' upper bound on the KL loss of merging pairs (i, j)."""
    wi, wj = w[i], w[j]
    ws = wi + wj
    a, b = wi / ws, wj / ws
    d = m[i] - m[j]
    Pm = a[:, None, None] * P[i] + b[:, None, None] * P[j] \
        + (a * b)[:, None, None] * d[:, :, None] * d[:, None, :]
    ldm = np.linalg.slogdet(Pm)[1]
    return 0.5 * (ws * ldm - wi * ld[i] - wj * ld[j])


def reduce_mixture(state: RangeOnlyState, max_components: int, *, prune: float = 0.0
                   ) -> RangeOnlyState:
    """Prune weights below ``prune`` and merge pairs greedily (Runnalls 2007) to ≤ C_max.

    Each merge is moment preserving, so the mixture mean and covariance are unchanged by
    merging (pruning renormalises).

    Parameters
    ----------
    state : RangeOnlyState
    max_components : int
        >= 1.
    prune : float
        Relative weight in [0, 1).

    Returns
    -------
    RangeOnlyState

    Raises
    ------
    ArgumentError
        If ``max_components`` is not an integer >= 1 or ``prune`` not in [0, 1).
    """
    if not is_integer(max_components, 1):
        raise ArgumentError("max_components", "an integer >= 1", max_components)
    if not 0.0 <= prune < 1.0:
        raise ArgumentError("prune", "a relative weight in [0, 1)", prune)
    w, m, P = state.weights, state.means, state.covs
    keep = w >= prune * w.max()
    if not keep.all():
        w, m, P = w[keep], m[keep], P[keep]
        w = w / w.sum()
    n = w.shape[0]
    if n <= max_components:
        return dataclasses.replace(state, weights=w, means=m, covs=P)
    w, m, P = w.copy(), m.copy(), P.copy()
    ld = np.linalg.slogdet(P)[1]
    iu, ju = np.triu_indices(n, 1)
    cost = np.full((n, n), np.inf)
    cost[iu, ju] = _merge_cost(w, m, P, ld, iu, ju)
    alive = np.ones(n, bool)
    for _ in range(n - max_components):
        flat = int(np.argmin(cost))
        i, j = divmod(flat, n)
        ws = w[i] + w[j]
        a, b = w[i] / ws, w[j] / ws
        d = m[i] - m[j]
        P[i] = a * P[i] + b * P[j] + a * b * np.outer(d, d)
        m[i] = a * m[i] + b * m[j]
        w[i] = ws
        ld[i] = np.linalg.slogdet(P[i])[1]
        alive[j] = False
        cost[j, :] = np.inf
        cost[:, j] = np.inf
        others = np.nonzero(alive)[0]
        others = others[others != i]
        if others.size:
            ci = _merge_cost(w, m, P, ld, np.full(others.size, i), others)
            lo = others < i
            cost[others[lo], i] = ci[lo]
            cost[i, others[~lo]] = ci[~lo]
    w, m, P = w[alive], m[alive], P[alive]
    return dataclasses.replace(state, weights=w / w.sum(), means=m, covs=P)


class RangeOnlyFilter:
    """The range-only filter behind :class:`tmaplan.estimators.filter.Filter`.

    ``init`` moment-matches the scenario's prior (20 000 samples) to one Gaussian; ``update``
    uses the range measurements of the step (bearings and frequencies are not used by a
    range-only filter); ``diagnostic`` is the number of mixture components.

    Parameters
    ----------
    config : RangeOnlyConfig
    """

    name: ClassVar[str] = "range-only"
    #: Sensor kinds it assimilates.
    applies_to: ClassVar[frozenset[str]] = frozenset({"range"})

    def __init__(self, config: RangeOnlyConfig) -> None:
        self.config = config

    def init(self, scenario: Scenario, rng: np.random.Generator) -> RangeOnlyState:
        """One Gaussian with the prior's relative mean and covariance."""
        return from_gaussian(*prior_relative_moments(scenario, 20_000, rng))

    def predict(self, state: RangeOnlyState, dv: np.ndarray | None,
                rng: np.random.Generator | None = None) -> RangeOnlyState:
        """See :func:`range_only_predict` (deterministic: ``rng`` is unused)."""
        return range_only_predict(state, dv, self.config)

    def update(self, state: RangeOnlyState, measurements: Sequence[Measurement],
               rng: np.random.Generator | None = None) -> RangeOnlyState:
        """See :func:`range_only_update`, once per range measurement."""
        for m in measurements:
            if m.kind == "range":
                state = range_only_update(state, float(m.value), float(m.sigma), self.config)
        return state

    def diagnostic(self, state: RangeOnlyState) -> float:
        """Number of mixture components."""
        return float(state.n_components)
