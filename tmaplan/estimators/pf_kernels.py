"""Batched numerical kernels of the particle filter (resampling, noise, likelihoods).

The kernels of :mod:`tmaplan.estimators.particle_filter`, split out by role (and shared with
its compiled twin :mod:`tmaplan.estimators.pf_numba`). Clouds are
handled in the (4, N) row layout (see :func:`particle_rows`); every function is vectorised over
particles.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.special import logsumexp

from tmaplan.errors import ArgumentError, EstimationError
from tmaplan.models.sensors import bearing_loglik
from tmaplan.simulate import Measurement

if TYPE_CHECKING:  # the filter imports these kernels
    from tmaplan.estimators.particle_filter import PFConfig

__all__ = ["check_measurement", "clutter_floor", "effective_sample_size", "frequency_update",
           "gated", "measurement_ll", "mh_move", "ncv_noise_factor", "normals_f32",
           "particle_rows", "safe_cholesky", "systematic_indices", "systematic_resample",
           "weighted_cov"]

_TWO_PI = 2.0 * np.pi
_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)
# Layout: the cloud is stored column-major, ``particles`` (N, 4) being the transpose of a
# C-contiguous (4, N) array, so every per-component operation (x, y, vx, vy) runs on a
# contiguous vector and no thin (N, 4) × (4, 4) BLAS product is needed (multi-threaded
# OpenBLAS spins on those, and limiting its threads per call costs milliseconds).


def particle_rows(X: np.ndarray) -> np.ndarray:
    """The (4, N) C-contiguous row view of a cloud (a copy if X is not column-major)."""
    A = X.T
    return A if A.flags.c_contiguous else np.ascontiguousarray(A)


# --------------------------------------------------------------------------------------------
# Input validation
# --------------------------------------------------------------------------------------------


def check_measurement(m: Any) -> None:
    """ArgumentError naming the field of an invalid :class:`Measurement` (kind, finite value,
    finite std > 0 per line, ping only on a range)."""
    if m.kind not in ("bearing", "range", "frequency"):
        raise ArgumentError("measurement.kind", "'bearing', 'range' or 'frequency'", m.kind)
    scalars = (m.kind != "frequency" and type(m.value) is float
               and type(m.sigma) is float)  # a bearing or range as a closed loop makes them
    sigma = m.sigma if scalars else np.asarray(m.sigma, dtype=float)
    if (not (math.isfinite(sigma) and sigma > 0) if scalars else
            sigma.size == 0 or not (np.isfinite(sigma).all() and (sigma > 0).all())):
        # σ = 0 or NaN would reset the weights
        raise ArgumentError("measurement.sigma",
                            f"a finite std > 0 (per line) of the {m.kind} measurement", m.sigma)
    value = m.value if scalars else np.asarray(m.value, dtype=float)
    if (not math.isfinite(value) if scalars else
            value.size == 0 or not np.isfinite(value).all()):
        raise ArgumentError("measurement.value", f"a finite {m.kind} value", m.value)
    if m.kind != "frequency" and not scalars and (value.size != 1 or sigma.size != 1):
        raise ArgumentError("measurement.value", f"a scalar {m.kind} value and std",
                            (m.value, m.sigma))
    if m.kind == "bearing" and m.ambiguity not in ("none", "pi"):
        raise ArgumentError("measurement.ambiguity", "'none' or 'pi'", m.ambiguity)
    if m.kind == "frequency" and sigma.ndim > 0 and sigma.shape != np.atleast_1d(value).shape:
        raise ArgumentError("measurement.sigma", "a scalar or one std per frequency line "
                            f"(shape {np.atleast_1d(value).shape})", m.sigma)
    if m.ping and m.kind != "range":
        raise ArgumentError("measurement.ping", "True only for a range measurement", m.kind)



# --------------------------------------------------------------------------------------------
# Resampling
# --------------------------------------------------------------------------------------------


def systematic_resample(log_weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """Systematic resampling indices (one uniform draw, N stratified points).

    Parameters
    ----------
    log_weights : ndarray, shape (N,)
        Log-weights (normalised or not: they are shifted by their maximum, so very negative
        ones do not underflow); −inf for a zero weight, no NaN or +inf.
    rng : numpy.random.Generator
    n : int, optional
        Number of draws (default N), >= 1.

    Returns
    -------
    ndarray of int, shape (n,)
    """
    log_weights = np.asarray(log_weights, float)
    if (log_weights.ndim != 1 or np.isnan(log_weights).any() or np.isposinf(log_weights).any()
            or not np.isfinite(log_weights).any()):
        raise ArgumentError("log_weights", "a 1-D array without NaN or +inf, not all -inf",
                            log_weights)
    m = log_weights.shape[0] if n is None else n
    if not isinstance(m, int | np.integer) or isinstance(m, bool) or m < 1:
        raise ArgumentError("n", "an integer >= 1 (number of draws)", n)
    cdf = np.cumsum(np.exp(log_weights - log_weights.max()))
    cdf /= cdf[-1]
    u = (rng.random() + np.arange(m)) / m
    idx = np.searchsorted(cdf, u, side="right")
    np.minimum(idx, log_weights.shape[0] - 1, out=idx)
    return idx


def systematic_indices(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling from normalised weights ``w`` (no exp), in O(N).

    Same draw as :func:`systematic_resample` (``u_j = (u + j)/N``, index = number of CDF
    values ≤ u_j) without a binary search: ``c_i = ⌈N·cdf_i − u⌉`` counts the points below
    ``cdf_i``, and the index of point j is ``#{i : c_i ≤ j}``, a cumulative ``bincount``.
    """
    n = w.shape[0]
    c = np.cumsum(w)
    c *= n / c[-1]
    c -= rng.random()
    np.ceil(c, out=c)
    ci = c.astype(np.intp)
    np.maximum(ci, 0, out=ci)
    ci[-1] = n  # guard against rounding in the last CDF value
    idx = np.cumsum(np.bincount(ci, minlength=n + 1)[:n])
    np.minimum(idx, n - 1, out=idx)
    return idx


def effective_sample_size(log_weights: np.ndarray) -> float:
    """Kish's effective sample size ``1 / Σ w²`` of normalised log-weights (N,)."""
    return float(np.exp(-logsumexp(2.0 * log_weights)))


def weighted_cov(A: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted covariance of a (4, N) row-layout cloud with normalised weights w."""
    D = A - (A @ w)[:, None]
    return (D * w) @ D.T


def safe_cholesky(C: np.ndarray) -> np.ndarray:
    """A lower Cholesky factor of the symmetric part of ``C`` (d, d), scaled to unit diagonal
    first and regularised by the smallest jitter in 0, 1e-12, …, 1e-3 that factorises (else the
    diagonal of square roots)."""
    C = 0.5 * (C + C.T)
    scale = np.sqrt(np.maximum(np.diag(C), 1e-300))
    Cn = C / np.outer(scale, scale)
    for eps in (0.0, 1e-12, 1e-9, 1e-6, 1e-3):
        try:
            return scale[:, None] * np.linalg.cholesky(Cn + eps * np.eye(C.shape[0]))
        except np.linalg.LinAlgError:
            continue
    return np.diag(scale)



_TWO_PI_F32 = np.float32(_TWO_PI)


def normals_f32(rng: np.random.Generator, out: np.ndarray) -> None:
    """Fill ``out`` (2m, n) float64 with standard normals by float32 Box–Muller.

    ``z1 = ρ cos φ``, ``z2 = ρ sin φ`` with ``ρ = sqrt(−2 ln(1 − u1))``, ``φ = 2π u2`` for
    independent uniforms u1, u2 ∈ [0, 1) (so 1 − u1 > 0 and ρ ≤ sqrt(2·24 ln 2) = 5.77).
    """
    h = out.shape[0] // 2
    u = rng.random((2, h, out.shape[1]), dtype=np.float32)
    rho, phi = u[0], u[1]
    np.negative(rho, out=rho)
    np.log1p(rho, out=rho)
    rho *= np.float32(-2.0)
    np.sqrt(rho, out=rho)
    phi *= _TWO_PI_F32
    np.multiply(rho, np.cos(phi), out=out[:h])
    np.sin(phi, out=phi)
    np.multiply(rho, phi, out=out[h:])


@functools.lru_cache(maxsize=64)
def ncv_noise_factor(dt: float, q: float) -> tuple[float, float, float]:
    """Per-axis Cholesky factor ``[[l11, 0], [l21, l22]]`` of the NCV
    ``Q`` (docs/conventions.md)."""
    l11 = np.sqrt(q * dt**3 / 3.0)
    l21 = (q * dt**2 / 2.0) / l11 if l11 > 0 else 0.0
    l22 = np.sqrt(max(q * dt - l21 * l21, 0.0))
    return float(l11), float(l21), float(l22)



def _bearing_ll(X: np.ndarray, m: Measurement) -> np.ndarray:
    """Bearing log-likelihood ``−d²/(2σ²)`` of the wrapped residual d, without the constant
    ``−log(√(2π) σ)`` (the π-ambiguous one the three-term wrapped Gaussian of
    :func:`tmaplan.models.sensors.bearing_loglik` on the half circle, with the same constant
    removed): what :func:`_clutter` expects."""
    if m.ambiguity == "pi":
        sigma = float(m.sigma)
        return bearing_loglik(m.value, X, sigma, "pi") + (_LOG_SQRT_2PI + np.log(sigma))
    A = particle_rows(X)
    d = np.arctan2(A[0], A[1])  # one atan2, contiguous rows
    np.subtract(float(m.value), d, out=d)
    # wrap to [−π, π]: d − 2π·round(d/2π) (cheaper than np.mod), in place
    t = np.multiply(d, 1.0 / _TWO_PI)
    np.rint(t, out=t)
    t *= _TWO_PI
    d -= t
    d *= np.sqrt(0.5) / float(m.sigma)
    np.square(d, out=d)
    np.negative(d, out=d)
    return d


def _clutter(ll: np.ndarray, sigma: float, eps: float, period: float = _TWO_PI) -> np.ndarray:
    """Clutter-mixture bearing log-likelihood from the Gaussian one ``ll = −d²/(2σ²)``
    (:func:`_bearing_ll`): ``log((1 − ε) N(d; 0, σ²) + ε/period)`` up to the constant
    ``log((1 − ε)/(√(2π) σ))``; ``period`` 2π, or π for a bearing known modulo π (clutter
    uniform on the half circle its density lives on)."""
    return np.logaddexp(ll, clutter_floor(sigma, eps, period))


def clutter_floor(sigma: float, eps: float, period: float) -> float:
    """The clutter term ``log(ε √(2π) σ / ((1 − ε) period))`` of :func:`_clutter`."""
    return float(np.log(eps * np.sqrt(2.0 * np.pi) * sigma / ((1.0 - eps) * period)))


def measurement_ll(X: np.ndarray, m: Measurement, clutter: float = 0.0) -> np.ndarray:
    """Log-likelihood (N,) of a bearing (with the clutter mixture when ``clutter`` > 0) or
    range measurement for the cloud X (N, 4), up to a constant: the one likelihood the
    filter's update and its Metropolis–Hastings moves share."""
    if m.kind == "range":
        return _range_ll(X, m)
    c = _bearing_ll(X, m)
    if clutter > 0.0:
        c = _clutter(c, float(m.sigma), clutter, np.pi if m.ambiguity == "pi" else _TWO_PI)
    return c


def gated(state: Any, m: Measurement, gate: float | None) -> bool:
    """Whether ping ``m`` falls outside ``gate`` σ of the cloud's predicted range."""
    if gate is None:
        return False
    w = state.weights
    r = np.hypot(state.particles[:, 0], state.particles[:, 1])
    mean = float(w @ r)
    var = float(w @ (r - mean) ** 2)
    return abs(float(m.value) - mean) > gate * np.sqrt(float(m.sigma) ** 2 + var)


def _range_ll(X: np.ndarray, m: Measurement) -> np.ndarray:
    A = particle_rows(X)
    d = np.hypot(A[0], A[1])
    np.subtract(float(m.value), d, out=d)
    d *= np.sqrt(0.5) / float(m.sigma)
    np.square(d, out=d)
    np.negative(d, out=d)
    return d


def frequency_update(X: np.ndarray, m: Measurement, fm: np.ndarray | None,
                      fv: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-particle Rao–Blackwellised update of the emitted frequencies (P lines) by one
    frequency measurement: (log-likelihoods (N,), means (N, P), variances (N, P)); a line seen
    for the first time (NaN mean) starts from a flat prior."""
    z = np.atleast_1d(np.asarray(m.value, float))
    s2 = np.atleast_1d(np.asarray(m.sigma, float)) ** 2 * np.ones_like(z)
    P = z.shape[0]
    N = X.shape[0]
    if fm is None or fv is None:
        fm = np.full((N, P), np.nan)
        fv = np.full((N, P), np.nan)
    elif fm.shape[1] != P:
        raise EstimationError(f"frequency measurement has {P} lines, the filter tracks "
                              f"{fm.shape[1]}")
    v = X[:, 2:4]
    if m.velocity_offset is not None:
        v = v - np.asarray(m.velocity_offset, float)
    r = np.hypot(X[:, 0], X[:, 1])
    rdot = (X[:, 0] * v[:, 0] + X[:, 1] * v[:, 1]) / r
    a = (1.0 - rdot / m.c)[:, None]  # (N, 1)
    new = np.isnan(fm)
    # Flat prior on f_p: posterior N(z/a, σ²/a²), marginal likelihood 1/|a|.
    S = a * a * fv + s2
    innov = z - a * fm
    ll_old = -0.5 * innov * innov / S - 0.5 * np.log(S)
    K = fv * a / S
    fm_up = fm + K * innov
    fv_up = fv - K * a * fv
    ll_new = -np.log(np.abs(a)) + np.zeros_like(fm)
    fm_out = np.where(new, z / a, fm_up)
    fv_out = np.where(new, s2 / (a * a), fv_up)
    ll = np.where(new, ll_new, ll_old).sum(axis=1)
    return ll, fm_out, fv_out


def _loglik(A: np.ndarray, measurements: Sequence[Measurement], clutter: float = 0.0
            ) -> np.ndarray:
    """Σ log p(z | x) over bearing and range measurements, (4, N) cloud → (N,): the
    likelihood of the filter's update (the same clutter mixture), up to a constant."""
    ll = np.zeros(A.shape[1])
    for m in measurements:
        ll += measurement_ll(A.T, m, clutter)
    return ll


def mh_move(A: np.ndarray, parent: np.ndarray, dv: np.ndarray | None, ll: np.ndarray,
             measurements: Sequence[Measurement], rng: np.random.Generator,
             config: PFConfig) -> np.ndarray:
    """Random-walk Metropolis–Hastings sweeps on x_k with target ``f(x_k | x_{k−1}) g(z | x_k)``.

    Parameters
    ----------
    A : ndarray, shape (4, N)
        Resampled cloud (modified in place and returned).
    parent : ndarray, shape (4, N)
        Each particle's ancestor at k − 1.
    dv : ndarray, shape (2,) or None
        Observer increment of the prediction [m/s].
    ll : ndarray, shape (N,)
        log g(z | x) of the resampled particles.
    """
    l11, l21, l22 = ncv_noise_factor(float(config.dt), float(config.q))
    dt = float(config.dt)
    d = np.zeros(2) if dv is None else np.asarray(dv, float)
    mu = np.empty_like(parent)  # F x_{k−1} − H Δv
    mu[:2] = parent[:2] + dt * parent[2:] - (dt * d)[:, None]
    mu[2:] = parent[2:] - d[:, None]

    def logf(X: np.ndarray) -> np.ndarray:
        # −½ (x − μ)' Q⁻¹ (x − μ) with the per-axis 2×2 Cholesky factor of Q.
        y1 = (X[:2] - mu[:2]) / l11
        y2 = (X[2:] - mu[2:] - l21 * y1) / l22
        return -0.5 * (np.sum(y1 * y1, axis=0) + np.sum(y2 * y2, axis=0))

    lp = ll + logf(A)
    s = float(config.move_scale)
    Z = np.empty_like(A)
    for _ in range(int(config.move_steps)):
        if config.noise == "float32":
            normals_f32(rng, Z)
        else:
            rng.standard_normal(out=Z)
        prop = A.copy()
        prop[:2] += (s * l11) * Z[:2]
        prop[2:] += s * (l21 * Z[:2] + l22 * Z[2:])
        lp_prop = _loglik(prop, measurements, config.bearing_clutter) + logf(prop)
        acc = np.log(rng.random(A.shape[1])) < lp_prop - lp
        A[:, acc] = prop[:, acc]
        lp[acc] = lp_prop[acc]
    return A
