"""Particle filter on the relative Cartesian state, batched over particles.

State per particle: ``X = target − observer = [r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), with the
relative dynamics of DESIGN §1 ``X_{k+1} = F X_k − H Δv_k + w_k``, ``H = [dt·I; I]``,
``w ~ N(0, Q)`` (``tmaplan.models.target.ncv_matrices``). File 001 prints ``+H U_t`` in eq. (2)
(L113) but ``−H U_t`` in eq. (95) (L675); for a relative state the observer increment enters with
a minus sign (NOTES_001 §1.1), which is what :func:`predict` implements.

The API is explicit and stateless: a frozen :class:`PFConfig`, a frozen :class:`PFState` (arrays
inside), and pure functions :func:`predict` and :func:`update` returning new states, so a
receding-horizon controller can step the filter one measurement batch at a time::

    pf = ParticleFilter(PFConfig(n_particles=10_000, dt=60.0, q=9e-6))
    state = pf.from_prior(scenario, rng)
    state = pf.predict(state, dv, rng)
    state = pf.update(state, [Measurement(kind="bearing", value=z, sigma=s)], rng)

Measurements:

* bearings, full circle or known modulo π (3-term wrapped Gaussian of file 000 eq. 71 via
  :func:`tmaplan.models.sensors.bearing_loglik`: both modes keep their weight);
* range pings (Gaussian, noise after the norm);
* frequency lines ``f_p (1 − Ṙ/c)`` (file 002 eq. 3). **Choice:** the unknown tones f_p are
  *marginalised analytically* (Rao–Blackwellised): each particle carries a Gaussian posterior
  (mean, variance) per line, updated by a scalar Kalman filter since the measurement is linear in
  f_p given the particle; the weight uses the marginal likelihood. The first frequency of a line
  initialises it from a flat prior (marginal likelihood ``1/|a|``, ``a = 1 − Ṙ/c``).

Degeneracy: when the effective sample size (ESS) falls below ``degeneracy_ess`` particles, or
weights become non-finite, a :class:`DegeneracyWarning` is issued and the filter recovers by
resampling and *roughening* (Gordon et al. 1993: Gaussian jitter scaled by the spread of the
predicted cloud) instead of returning NaNs. The state records it in ``degenerate``.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from scipy.special import logsumexp

from tmaplan.errors import EstimationError, ScenarioError
from tmaplan.models.sensors import bearing_loglik
from tmaplan.models.target import ncv_matrices

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "DegeneracyWarning",
    "Measurement",
    "PFConfig",
    "PFState",
    "ParticleFilter",
    "predict",
    "systematic_resample",
    "update",
]

_TWO_PI = 2.0 * np.pi
# Large clouds: the (N, 4) × (4, 4) products run in single-threaded BLAS (≈ 0.3 ms at
# N = 10⁵); multi-threaded OpenBLAS spins threads on such thin products and, on a shared
# 2-core machine, is up to 100× slower. Entering the limit costs ≈ 0.4 ms, so small clouds
# use elementwise ufuncs instead.
_BLAS_MIN_N = 20_000
try:
    from threadpoolctl import threadpool_limits as _tpl

    def _single_thread_blas() -> Any:
        return _tpl(limits=1, user_api="blas")
except ImportError:  # pragma: no cover
    _single_thread_blas = None  # type: ignore[assignment]


class DegeneracyWarning(RuntimeWarning):
    """The particle weights collapsed; the filter recovered by roughening."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class Measurement:
    """One scalar (or multi-line) measurement at the current step.

    Attributes
    ----------
    kind : {"bearing", "range", "frequency"}
    value : float or ndarray, shape (P,)
        Bearing [rad] (from North, clockwise), range [m] or frequencies [Hz] (one per line).
    sigma : float or ndarray, shape (P,)
        Noise std in the same unit.
    ambiguity : {"none", "pi"}
        Bearings only: known modulo π.
    c : float
        Sound speed [m/s] (frequency only).
    velocity_offset : ndarray, shape (2,)
        Frequency only: observer instantaneous minus mean velocity [m/s] at this step, so that
        the Doppler uses the instantaneous relative velocity ``X[2:] − offset``.
    """

    kind: Literal["bearing", "range", "frequency"]
    value: float | np.ndarray
    sigma: float | np.ndarray
    ambiguity: Literal["none", "pi"] = "none"
    c: float = 1500.0
    velocity_offset: np.ndarray | None = None


@dataclasses.dataclass(frozen=True, kw_only=True)
class PFConfig:
    """Particle-filter settings.

    Attributes
    ----------
    n_particles : int
        N.
    dt : float
        Step [s].
    q : float
        Process-noise intensity of the filter's NCV model [m²/s³].
    variant : {"bootstrap", "regularised"}
        "regularised": after each resampling, add Gaussian kernel jitter with the
        Musso–Oudjane–Le Gland bandwidth ``h = bandwidth_scale·(4/(N(d+2)))^{1/(d+4)}`` times
        the Cholesky factor of the weighted covariance.
    ess_threshold : float
        Resample when ESS < ess_threshold·N (systematic resampling).
    bandwidth_scale : float
        Multiplier of the optimal kernel bandwidth (regularised variant).
    degeneracy_ess : float
        ESS [particles] below which the update is declared degenerate (warning + roughening).
    roughening : float
        Std of the roughening jitter, as a fraction of the predicted cloud's std per component.
    """

    n_particles: int = 10_000
    dt: float
    q: float
    variant: Literal["bootstrap", "regularised"] = "regularised"
    ess_threshold: float = 0.5
    bandwidth_scale: float = 0.5
    degeneracy_ess: float = 2.0
    roughening: float = 0.2

    def __post_init__(self) -> None:
        if not isinstance(self.n_particles, int | np.integer) or self.n_particles < 2:
            raise ScenarioError("n_particles", "an integer >= 2", self.n_particles)
        if not self.dt > 0:
            raise ScenarioError("dt", "> 0 s", self.dt)
        if not self.q >= 0:
            raise ScenarioError("q", ">= 0 m²/s³", self.q)
        if self.variant not in ("bootstrap", "regularised"):
            raise ScenarioError("variant", "'bootstrap' or 'regularised'", self.variant)
        if not 0.0 <= self.ess_threshold <= 1.0:
            raise ScenarioError("ess_threshold", "in [0, 1]", self.ess_threshold)


@dataclasses.dataclass(frozen=True, kw_only=True)
class PFState:
    """Particle cloud at one step (arrays are not copied; treat them as read-only).

    Attributes
    ----------
    step : int
        Grid step k.
    particles : ndarray, shape (N, 4)
        Relative states [m, m, m/s, m/s].
    log_weights : ndarray, shape (N,)
        Normalised log-weights (logsumexp = 0).
    freq_mean, freq_var : ndarray, shape (N, P), optional
        Rao–Blackwellised Gaussian posterior of the unknown tones [Hz], [Hz²] (NaN = line not
        yet initialised).
    ess : float
        Effective sample size ``1/Σw²`` after the last update (before any resampling).
    resampled : bool
        Whether the last update resampled.
    degenerate : bool
        Whether the last update hit degeneracy and recovered by roughening.
    """

    step: int
    particles: np.ndarray
    log_weights: np.ndarray
    freq_mean: np.ndarray | None = None
    freq_var: np.ndarray | None = None
    ess: float
    resampled: bool = False
    degenerate: bool = False

    @property
    def weights(self) -> np.ndarray:
        """Normalised weights, shape (N,)."""
        return np.exp(self.log_weights)

    @property
    def mean(self) -> np.ndarray:
        """Posterior mean of X, shape (4,)."""
        return self.weights @ self.particles

    @property
    def cov(self) -> np.ndarray:
        """Posterior covariance of X, shape (4, 4)."""
        w = self.weights
        d = self.particles - w @ self.particles
        return (d * w[:, None]).T @ d

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.particles.shape[0]


# --------------------------------------------------------------------------------------------
# Resampling
# --------------------------------------------------------------------------------------------


def systematic_resample(log_weights: np.ndarray, rng: np.random.Generator,
                        n: int | None = None) -> np.ndarray:
    """Systematic resampling indices (one uniform draw, N stratified points).

    Parameters
    ----------
    log_weights : ndarray, shape (N,)
        Normalised log-weights.
    rng : numpy.random.Generator
    n : int, optional
        Number of draws (default N).

    Returns
    -------
    ndarray of int, shape (n,)
    """
    m = log_weights.shape[0] if n is None else n
    cdf = np.cumsum(np.exp(log_weights))
    cdf /= cdf[-1]
    u = (rng.random() + np.arange(m)) / m
    idx = np.searchsorted(cdf, u, side="right")
    np.minimum(idx, log_weights.shape[0] - 1, out=idx)
    return idx


def _systematic(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Systematic resampling from normalised weights ``w`` (no exp)."""
    n = w.shape[0]
    cdf = np.cumsum(w)
    u = np.arange(n, dtype=float)
    u += rng.random()
    u *= cdf[-1] / n
    idx = np.searchsorted(cdf, u, side="right")
    np.minimum(idx, n - 1, out=idx)
    return idx


def _ess(log_weights: np.ndarray) -> float:
    return float(np.exp(-logsumexp(2.0 * log_weights)))


def _weighted_cov(particles: np.ndarray, log_weights: np.ndarray) -> np.ndarray:
    w = np.exp(log_weights)
    d = particles - w @ particles
    return (d * w[:, None]).T @ d


def _safe_cholesky(C: np.ndarray) -> np.ndarray:
    C = 0.5 * (C + C.T)
    scale = np.sqrt(np.maximum(np.diag(C), 1e-300))
    Cn = C / np.outer(scale, scale)
    for eps in (0.0, 1e-12, 1e-9, 1e-6, 1e-3):
        try:
            return scale[:, None] * np.linalg.cholesky(Cn + eps * np.eye(C.shape[0]))
        except np.linalg.LinAlgError:
            continue
    return np.diag(scale)


# --------------------------------------------------------------------------------------------
# Predict and update (pure functions)
# --------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=64)
def _dynamics(dt: float, q: float) -> tuple[float, float, float]:
    """Per-axis Cholesky factor ``[[l11, 0], [l21, l22]]`` of the NCV ``Q`` (DESIGN §1)."""
    l11 = np.sqrt(q * dt**3 / 3.0)
    l21 = (q * dt**2 / 2.0) / l11 if l11 > 0 else 0.0
    l22 = np.sqrt(max(q * dt - l21 * l21, 0.0))
    return float(l11), float(l21), float(l22)


@functools.lru_cache(maxsize=64)
def _matrices(dt: float, l11: float, l21: float, l22: float) -> tuple[np.ndarray, np.ndarray]:
    """C-contiguous ``F'`` and ``L'`` (a transposed view would miss BLAS)."""
    F, _ = ncv_matrices(dt, 0.0)
    L = np.zeros((4, 4))
    L[0, 0] = L[1, 1] = l11
    L[2, 0] = L[3, 1] = l21
    L[2, 2] = L[3, 3] = l22
    return np.ascontiguousarray(F.T), np.ascontiguousarray(L.T)


def _noise_factor(config: PFConfig) -> tuple[np.ndarray, np.ndarray]:
    F, Q = ncv_matrices(config.dt, config.q)
    L = np.linalg.cholesky(Q + 1e-300 * np.eye(4)) if config.q > 0 else np.zeros((4, 4))
    return F, L


def predict(state: PFState, dv: np.ndarray | None, rng: np.random.Generator,
            config: PFConfig, *, steps: int = 1) -> PFState:
    """Propagate the cloud ``steps`` grid steps: ``X ← F X − H Δv + w``.

    Small clouds: elementwise ufuncs, ``pos += dt·vel`` and the NCV noise per axis from its
    cached 2×2 Cholesky factor (``w_pos = l11 z1``, ``w_vel = l21 z1 + l22 z2``). Large clouds
    (N ≥ 20 000): two single-threaded BLAS products with cached contiguous ``F'``, ``L'``
    (see ``_BLAS_MIN_N``). The input state is not modified.

    Parameters
    ----------
    state : PFState
    dv : ndarray, shape (2,) or (steps, 2), optional
        Observer velocity increments Δv_k = v̄_{k+1} − v̄_k [m/s]
        (:attr:`tmaplan.models.observer.ObserverTrack.velocity_increments`); None = 0.
    rng : numpy.random.Generator
    config : PFConfig
    steps : int
        Number of steps.

    Returns
    -------
    PFState
        At ``state.step + steps``, same weights.
    """
    l11, l21, l22 = _dynamics(float(config.dt), float(config.q))
    dt = config.dt
    X = state.particles
    dvs = np.zeros((steps, 2)) if dv is None else np.asarray(dv, float).reshape(-1, 2)
    if dvs.shape[0] == 1 and steps > 1:
        dvs = np.vstack([dvs, np.zeros((steps - 1, 2))])
    big = X.shape[0] >= _BLAS_MIN_N and _single_thread_blas is not None
    for s in range(steps):
        if big:
            Ft, Lt = _matrices(float(dt), l11, l21, l22)
            with _single_thread_blas():
                Xn = X @ Ft
                if config.q > 0:
                    Xn += rng.standard_normal(X.shape) @ Lt
        else:
            Xn = np.empty_like(X)
            np.multiply(X[:, 2:], dt, out=Xn[:, :2])
            Xn[:, :2] += X[:, :2]
            Xn[:, 2:] = X[:, 2:]
            if config.q > 0:
                Z = rng.standard_normal(X.shape)
                Z[:, 2:] *= l22
                Z[:, 2:] += l21 * Z[:, :2]
                Z[:, :2] *= l11
                Xn += Z
        d = dvs[s]
        if d[0] != 0.0 or d[1] != 0.0:
            Xn[:, 0:2] -= dt * d
            Xn[:, 2:4] -= d
        X = Xn
    return PFState(step=state.step + steps, particles=X, log_weights=state.log_weights,
                   freq_mean=state.freq_mean, freq_var=state.freq_var, ess=state.ess)


def _bearing_ll(X: np.ndarray, m: Measurement) -> np.ndarray:
    if m.ambiguity == "pi":
        return bearing_loglik(m.value, X, float(m.sigma), "pi")
    d = np.arctan2(X[:, 0], X[:, 1])
    np.subtract(float(m.value), d, out=d)
    # wrap to [−π, π): d − 2π·round(d/2π) (cheaper than np.mod)
    d -= _TWO_PI * np.rint(d * (1.0 / _TWO_PI))
    d *= np.sqrt(0.5) / float(m.sigma)
    d *= d
    np.negative(d, out=d)
    return d


def _range_ll(X: np.ndarray, m: Measurement) -> np.ndarray:
    d = (float(m.value) - np.hypot(X[:, 0], X[:, 1])) / float(m.sigma)
    return -0.5 * d * d


def _frequency_update(X: np.ndarray, m: Measurement, fm: np.ndarray | None,
                      fv: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


def update(state: PFState, measurements: Sequence[Measurement], rng: np.random.Generator,
           config: PFConfig) -> PFState:
    """Weight the cloud by the measurements of this step, then resample if ESS is low.

    Parameters
    ----------
    state : PFState
    measurements : sequence of Measurement
        All measurements taken at ``state.step`` (independent given X).
    rng : numpy.random.Generator
    config : PFConfig

    Returns
    -------
    PFState
        New state; ``ess`` is computed before resampling, ``resampled`` and ``degenerate``
        tell what happened.
    """
    if not measurements:
        return dataclasses.replace(state, resampled=False, degenerate=False)
    X = state.particles
    ll: np.ndarray | None = None
    fm, fv = state.freq_mean, state.freq_var
    for m in measurements:
        if m.kind == "bearing":
            c = _bearing_ll(X, m)
        elif m.kind == "range":
            c = _range_ll(X, m)
        elif m.kind == "frequency":
            c, fm, fv = _frequency_update(X, m, fm, fv)
        else:
            raise ScenarioError("measurement.kind", "'bearing', 'range' or 'frequency'",
                                m.kind)
        ll = np.asarray(c, dtype=float) if ll is None else ll + c
    assert ll is not None
    lw = ll
    lw += state.log_weights
    degenerate = False
    mx = lw.max()
    if not np.isfinite(mx):  # NaN somewhere or all −inf / +inf
        finite = np.isfinite(lw)
        if not finite.any():
            degenerate = True
            lw = np.zeros_like(lw)
        else:
            lw = np.where(finite, lw, -np.inf)
        mx = lw.max()
    # Normalise with one exp (max-shifted), no logsumexp overhead.
    w = np.exp(lw - mx)
    tot = w.sum()
    w *= 1.0 / tot
    lw -= mx + np.log(tot)
    ess = float(1.0 / (w @ w))
    if ess < config.degeneracy_ess:
        degenerate = True
    resampled = False
    if degenerate:
        warnings.warn(
            f"particle filter degenerate at step {state.step} (ESS = {ess:.2f}); "
            "recovering by resampling and roughening", DegeneracyWarning, stacklevel=2)
        # Roughening with the spread of the *predicted* cloud (before weighting).
        spread = np.std(X, axis=0)
        idx = _systematic(w, rng)
        X = X[idx] + rng.standard_normal(X.shape) * (config.roughening * spread)
        if fm is not None and fv is not None:
            fm, fv = fm[idx], fv[idx]
        lw = np.full(X.shape[0], -np.log(X.shape[0]))
        resampled = True
    elif ess < config.ess_threshold * X.shape[0]:
        idx = _systematic(w, rng)
        if config.variant == "regularised":
            C = _weighted_cov(X, lw)
            d = X.shape[1]
            h = config.bandwidth_scale * (4.0 / (X.shape[0] * (d + 2))) ** (1.0 / (d + 4))
            Lc = _safe_cholesky(C)
            X = np.take(X, idx, axis=0)
            X += h * (rng.standard_normal(X.shape) @ np.ascontiguousarray(Lc.T))
        else:
            X = np.take(X, idx, axis=0)
        if fm is not None and fv is not None:
            fm, fv = fm[idx], fv[idx]
        lw = np.full(X.shape[0], -np.log(X.shape[0]))
        resampled = True
    return PFState(step=state.step, particles=X, log_weights=lw, freq_mean=fm, freq_var=fv,
                   ess=ess, resampled=resampled, degenerate=degenerate)


# --------------------------------------------------------------------------------------------
# Convenience wrapper
# --------------------------------------------------------------------------------------------


class ParticleFilter:
    """A :class:`PFConfig` with initialisers and bound :func:`predict` / :func:`update`.

    Parameters
    ----------
    config : PFConfig
    """

    def __init__(self, config: PFConfig) -> None:
        self.config = config

    def from_particles(self, particles: np.ndarray, *, step: int = 0,
                       log_weights: np.ndarray | None = None) -> PFState:
        """State from given relative particles, shape (N, 4) (equal weights by default)."""
        X = np.array(particles, dtype=float, copy=True)
        if X.ndim != 2 or X.shape[1] != 4 or not np.isfinite(X).all():
            raise ScenarioError("particles", "a finite (N, 4) array", getattr(X, "shape", X))
        n = X.shape[0]
        lw = (np.full(n, -np.log(n)) if log_weights is None
              else np.asarray(log_weights, float) - logsumexp(log_weights))
        return PFState(step=step, particles=X, log_weights=lw, ess=_ess(lw))

    def from_prior(self, scenario: Scenario, rng: np.random.Generator, *,
                   observer_state0: np.ndarray | None = None) -> PFState:
        """Draw N particles from the scenario's prior (relative to the observer at step 0).

        Uses :func:`tmaplan.models.prior.relative_prior_samples`; never the true state
        (beyond what the prior itself is defined from).
        """
        from tmaplan.models.prior import relative_prior_samples

        X = relative_prior_samples(scenario, self.config.n_particles, rng, observer_state0)
        return self.from_particles(X, step=0)

    def from_gaussian(self, mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator, *,
                      step: int = 0) -> PFState:
        """Draw N particles from N(mean, cov) (relative state)."""
        L = _safe_cholesky(np.asarray(cov, float))
        Z = rng.standard_normal((self.config.n_particles, 4))
        X = np.asarray(mean, float) + Z @ np.ascontiguousarray(L.T)
        return self.from_particles(X, step=step)

    def predict(self, state: PFState, dv: np.ndarray | None, rng: np.random.Generator,
                *, steps: int = 1) -> PFState:
        """See :func:`predict`."""
        return predict(state, dv, rng, self.config, steps=steps)

    def update(self, state: PFState, measurements: Sequence[Measurement],
               rng: np.random.Generator) -> PFState:
        """See :func:`update`."""
        return update(state, measurements, rng, self.config)
