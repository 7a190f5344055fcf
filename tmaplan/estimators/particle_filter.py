"""Particle filter on the relative Cartesian state, batched over particles.

State per particle: ``X = target − observer = [r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), with the
relative dynamics of docs/conventions.md ``X_{k+1} = F X_k − H Δv_k + w_k``, ``H = [dt·I; I]``,
``w ~ N(0, Q)`` (``tmaplan.models.target.ncv_matrices``). brehard2004 prints ``+H U_t`` in eq. (2)
but ``−H U_t`` in eq. (95); for a relative state the observer increment enters with
a minus sign (docs/errata.md), which is what :func:`predict` implements.

The API is explicit and stateless: a frozen :class:`PFConfig`, a frozen :class:`PFState` (arrays
inside), and pure functions :func:`predict` and :func:`update` returning new states, so a
receding-horizon controller can step the filter one measurement batch at a time::

    pf = ParticleFilter(PFConfig(n_particles=10_000, dt=60.0, q=9e-6))
    state = pf.from_prior(scenario, rng)
    state = pf.predict(state, dv, rng)
    state = pf.update(state, [Measurement(kind="bearing", value=z, sigma=s)], rng)

Measurements:

* bearings, full circle or known modulo π (3-term wrapped Gaussian of brehard2005 eq. 71 via
  :func:`tmaplan.models.sensors.bearing_loglik`: both modes keep their weight);
* ranges (Gaussian, noise after the norm); an active ping (``Measurement.ping``), far more
  informative than the cloud's spread, is assimilated by progressive correction (Oudjane &
  Musso): see :func:`update`;
* frequency lines ``f_p (1 − Ṙ/c)`` (clavard2013 eq. 3). **Choice:** the unknown tones f_p are
  *marginalised analytically* (Rao–Blackwellised): each particle carries a Gaussian posterior
  (mean, variance) per line, updated by a scalar Kalman filter since the measurement is linear in
  f_p given the particle; the weight uses the marginal likelihood. The first frequency of a line
  initialises it from a flat prior (marginal likelihood ``1/|a|``, ``a = 1 − Ṙ/c``).

Variants: "regularised" (default; Gaussian kernel jitter after resampling, needed on the
bearings-only benchmarks with small q), "bootstrap", and "resample-move" (exact
Metropolis–Hastings moves given each particle's ancestor; suited to ring-shaped range-only
posteriors, where the global-covariance kernel throws particles off the ring: on
``sharma2024-range-only`` it ends at ≈ 1050 m against ≈ 1900–2100 m for the default, 100 runs).
Speed: the cloud is stored column-major; compiled kernels (the default, ``pf_numba``) and the
numpy reference (``pf_kernels``: O(N) systematic resampling, float32 Box–Muller noise).

Degeneracy: when the effective sample size (ESS) falls below ``degeneracy_ess`` particles, or
every weight becomes non-finite, a :class:`DegeneracyWarning` is issued and the filter recovers
by resampling and *roughening* (Gordon et al. 1993: Gaussian jitter scaled by the spread of the
predicted cloud) instead of returning NaNs. The state records it in ``degenerate``. Particles
whose log-weight alone is NaN or infinite (e.g. one exactly at zero range) get weight zero;
the warning follows only if the ESS of the rest is too small.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Sequence
from typing import Any, ClassVar, Literal

import numpy as np
from scipy.special import logsumexp

from tmaplan.errors import ArgumentError, finite_real, is_integer
from tmaplan.estimators.pf_kernels import (
    check_measurement,
    effective_sample_size,
    frequency_update,
    gated,
    measurement_ll,
    mh_move,
    ncv_noise_factor,
    normals_f32,
    particle_rows,
    safe_cholesky,
    systematic_indices,
    systematic_resample,
    weighted_cov,
)
from tmaplan.geometry import range_of
from tmaplan.models.prior import relative_prior_samples
from tmaplan.scenario import Scenario
from tmaplan.simulate import Measurement

__all__ = [
    "DEFAULT_KERNEL",
    "DegeneracyWarning",
    "Measurement",
    "PFConfig",
    "PFState",
    "ParticleFilter",
    "predict",
    "systematic_resample",
    "update",
]


class DegeneracyWarning(RuntimeWarning):
    """The particle weights collapsed; the filter recovered by roughening."""


#: The default :attr:`PFConfig.kernel` (a campaign's key holds the kernel its filters ran).
DEFAULT_KERNEL: Literal["numba", "numpy"] = "numba"


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
    variant : {"bootstrap", "regularised", "resample-move"}
        "regularised": after each resampling, add Gaussian kernel jitter with the
        Musso–Oudjane–Le Gland bandwidth ``h = bandwidth_scale·(4/(N(d+2)))^{1/(d+4)}`` times
        the Cholesky factor of the weighted covariance.
    ess_threshold : float
        Resample when ESS < ess_threshold·N (systematic resampling); 1: at every update
        (ESS = N up to rounding for uniform weights, which must not decide it).
        "resample-move" (Gilks & Berzuini 2001): after each resampling, ``move_steps``
        Metropolis–Hastings moves of every particle targeting ``p(x_k | x_{k−1}, z_k)`` with
        its own ancestor ``x_{k−1}`` (random-walk proposal ``move_scale·chol(Q)·z``), which
        leaves the posterior invariant whatever its shape (ring arcs of range-only tracking,
        where a Gaussian kernel scaled by the global covariance throws particles off the
        ring). Needs the previous cloud (kept by a one-step :func:`predict`) and q > 0;
        otherwise, and for frequency measurements, it resamples without moving.
    bandwidth_scale : float
        Multiplier of the optimal kernel bandwidth (regularised variant).
    degeneracy_ess : float
        ESS [particles] below which the update is declared degenerate (warning + roughening).
    roughening : float
        Std of the roughening jitter, as a fraction of the predicted cloud's std per component.
    move_steps : int
        Resample-move: MH sweeps after each resampling.
    move_scale : float
        Resample-move: random-walk step in units of the process-noise Cholesky factor.
    kernel : {"numba", "numpy"}
        Default :data:`DEFAULT_KERNEL`. "numba": the compiled kernels of
        :mod:`tmaplan.estimators.pf_numba`
        (the default: multi-threaded over fixed blocks of particles, bit-identical for any
        thread count; Philox4x32-10 noise keyed by the injected Generator; arrays recycled,
        :mod:`tmaplan.estimators.pf_buffers`; compiled once per machine, ~8 s). "numpy": the
        batched numpy kernels (the default before issue 42's campaign throughput; they give
        the runs flown before again), the reference the compiled kernels are tested
        against (other random numbers: the same results in distribution, not bit for bit).
        ``noise`` applies to "numpy" only.
    noise : {"float32", "float64"}
        The numpy kernel's process-noise normals (the compiled kernels': Philox). "float64": numpy's
        ziggurat ``standard_normal``. "float32" (default, ≈ 3.5× faster, the largest single
        cost of a step): Box–Muller on float32 uniforms, returned in float64. Its draws are
        exact normals up to float32 rounding (relative 6e-8) with the tail truncated at
        |z| ≤ 5.77 (probability 8e-9 per draw); the particle states and weights stay float64.
        ``benchmarks/particle_filter.py`` shows the RMSE unchanged within Monte Carlo error.
    bearing_clutter : float
        Robust bearing model: probability ε in [0, 1) that a bearing is clutter, uniform on the
        circle; the likelihood is ``(1 − ε) N(z; β, σ²) + ε/(2π)`` (0: plain Gaussian).
    ping_gate : float, optional
        Ping gating [σ]: a ping whose innovation ``|z − r̂|/sqrt(σ² + var r)`` over the cloud
        exceeds this is ignored (None: every ping is assimilated).
    """

    n_particles: int = 10_000
    dt: float
    q: float
    variant: Literal["bootstrap", "regularised", "resample-move"] = "regularised"
    ess_threshold: float = 0.5
    bandwidth_scale: float = 0.5
    degeneracy_ess: float = 2.0
    roughening: float = 0.2
    noise: Literal["float32", "float64"] = "float32"
    kernel: Literal["numba", "numpy"] = DEFAULT_KERNEL
    move_steps: int = 2
    move_scale: float = 0.5
    bearing_clutter: float = 0.0
    ping_gate: float | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.bearing_clutter < 1.0:
            raise ArgumentError("bearing_clutter", "a probability in [0, 1)",
                                self.bearing_clutter)
        if self.ping_gate is not None and not self.ping_gate > 0:
            raise ArgumentError("ping_gate", "> 0 (in σ) or None", self.ping_gate)
        if not is_integer(self.n_particles, 2):
            raise ArgumentError("n_particles", "an integer >= 2", self.n_particles)
        finite_real("dt", self.dt, "a finite number > 0", lower=0.0, strict=True)  # [s]
        for name in ("q", "bandwidth_scale", "degeneracy_ess", "roughening", "move_scale"):
            finite_real(name, getattr(self, name), "a finite number >= 0", lower=0.0)
        if self.variant not in ("bootstrap", "regularised", "resample-move"):
            raise ArgumentError("variant", "'bootstrap', 'regularised' or 'resample-move'",
                                self.variant)
        if not is_integer(self.move_steps, 0):
            raise ArgumentError("move_steps", "an integer >= 0", self.move_steps)
        if not 0.0 <= self.ess_threshold <= 1.0:
            raise ArgumentError("ess_threshold", "in [0, 1]", self.ess_threshold)
        if self.noise not in ("float32", "float64"):
            raise ArgumentError("noise", "'float32' or 'float64'", self.noise)
        if self.kernel not in ("numba", "numpy"):
            raise ArgumentError("kernel", "'numba' or 'numpy'", self.kernel)


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
    parent : ndarray, shape (N, 4), optional
        The cloud before the last one-step :func:`predict` (resample-move only uses it).
    parent_dv : ndarray, shape (2,), optional
        The observer increment of that prediction [m/s].
    kernel : {"numpy", "numba"}
        The kernel that computes :attr:`mean` and :attr:`cov` (:attr:`PFConfig.kernel`).
    """

    step: int
    particles: np.ndarray
    log_weights: np.ndarray
    freq_mean: np.ndarray | None = None
    freq_var: np.ndarray | None = None
    ess: float
    resampled: bool = False
    degenerate: bool = False
    parent: np.ndarray | None = dataclasses.field(default=None, repr=False)
    parent_dv: np.ndarray | None = dataclasses.field(default=None, repr=False)
    kernel: Literal["numpy", "numba"] = dataclasses.field(default="numpy", repr=False)

    # weights and mean are computed once per state (a closed-loop step reads them four
    # times) and returned read-only, so that no caller can change the state's cached value

    @functools.cached_property
    def weights(self) -> np.ndarray:
        """Normalised weights, shape (N,) (read-only)."""
        return read_only(np.exp(self.log_weights))

    @functools.cached_property
    def mean(self) -> np.ndarray:
        """Posterior mean of X, shape (4,) (read-only)."""
        if self.kernel == "numba":
            return read_only(self._moments[0])
        return read_only(self.weights @ self.particles)

    @property
    def cov(self) -> np.ndarray:
        """Posterior covariance of X, shape (4, 4)."""
        if self.kernel == "numba":
            return self._moments[1].copy()
        w = self.weights
        d = self.particles - self.mean
        return (d * w[:, None]).T @ d

    @functools.cached_property
    def _moments(self) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance in one pass of the numba kernel."""
        return _fast().moments(particle_rows(self.particles), self.weights)

    @property
    def n(self) -> int:
        """Number of particles."""
        return self.particles.shape[0]


def read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@functools.cache
def _fast() -> Any:
    """The numba kernels (imported on first use: numba loads in about a second)."""
    from tmaplan.estimators import pf_numba  # deferred: numba takes about a second to import
    return pf_numba


def _with_weights(state: PFState, w: np.ndarray) -> PFState:
    """``state`` with its :attr:`PFState.weights` already known (``exp(log_weights)``)."""
    state.__dict__["weights"] = read_only(w)
    return state


# --------------------------------------------------------------------------------------------
# Predict and update (pure functions)
# --------------------------------------------------------------------------------------------


def predict(state: PFState, dv: np.ndarray | None, rng: np.random.Generator,
            config: PFConfig) -> PFState:
    """Propagate the cloud one grid step: ``X ← F X − H Δv + w``.

    Contiguous row operations on the (4, N) layout: ``pos += dt·vel`` and the NCV noise per
    axis from the cached 2×2 Cholesky factor of Q (``w_pos = l11 z1``,
    ``w_vel = l21 z1 + l22 z2``), no (N, 4) × (4, 4) product. The input state is not modified.

    Parameters
    ----------
    state : PFState
    dv : ndarray, shape (2,), optional
        Observer velocity increment Δv_k = v̄_{k+1} − v̄_k [m/s]
        (:attr:`tmaplan.models.observer.ObserverTrack.velocity_increments`); None = 0.
    rng : numpy.random.Generator
    config : PFConfig

    Returns
    -------
    PFState
        At ``state.step + 1``, same weights.
    """
    l11, l21, l22 = ncv_noise_factor(float(config.dt), float(config.q))
    dt = float(config.dt)
    A = particle_rows(state.particles)
    d = np.zeros(2) if dv is None else np.asarray(dv, float)
    if d.size != 2 or not np.isfinite(d).all():
        raise ArgumentError("dv", "a finite observer velocity increment of shape (2,) [m/s]",
                            dv)
    d = d.reshape(2)
    lazy = config.kernel == "numba" and config.q > 0
    if lazy:  # the arithmetic below in one compiled pass (Philox normals), when the particles
        # are first read or by the update with the likelihoods (pf_numba.PredictedState)
        An: Any = _fast().Prediction(A, dt, (l11, l21, l22), d, rng)
    else:
        An = np.empty_like(A)
        pos, vel = An[:2], An[2:]
        np.multiply(A[2:], dt, out=pos)
        pos += A[:2]
        if config.q > 0:
            # NCV noise per axis from the 2×2 Cholesky factor of Q (block structure):
            # w_pos = l11 z1, w_vel = l21 z1 + l22 z2, rows of Z = [z1x, z1y, z2x, z2y].
            Z = np.empty((4, A.shape[1]))
            if config.noise == "float32":
                normals_f32(rng, Z)
            else:
                rng.standard_normal(out=Z)
            np.multiply(Z[:2], l21, out=vel)
            Z[2:] *= l22
            vel += Z[2:]
            vel += A[2:]
            Z[:2] *= l11
            pos += Z[:2]
        else:
            vel[...] = A[2:]
        if d[0] != 0.0 or d[1] != 0.0:
            pos -= (dt * d)[:, None]
            vel -= d[:, None]
    move = config.variant == "resample-move"
    new = (_fast().PredictedState if lazy else PFState)(
        step=state.step + 1, particles=An if lazy else An.T, log_weights=state.log_weights,
        freq_mean=state.freq_mean, freq_var=state.freq_var, ess=state.ess,
        parent=state.particles if move else None, parent_dv=d.copy() if move else None,
        kernel=config.kernel)
    return _with_weights(new, state.weights) if "weights" in state.__dict__ else new


def update(state: PFState, measurements: Sequence[Measurement], rng: np.random.Generator,
           config: PFConfig) -> PFState:
    """Weight the cloud by the measurements of this step, then resample if ESS is low.

    Pings (``Measurement.ping``) are assimilated after the other measurements, one at a time,
    by progressive correction: a 50 m ping against a cloud spread over kilometres would leave
    one particle standing, so its likelihood is split into stages ``L = Π L^{α_i}`` with
    Gaussian stage precisions ``α_i/σ²`` growing geometrically (stage std shrinking by 2) from
    about half the cloud's RMS range offset from the measurement, with resampling and
    regularisation between stages (Oudjane & Musso's progressive correction). The stage
    precisions sum to ``1/σ²``, so the posterior is unchanged in expectation.

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
        tell what happened (in the last stage).
    """
    for m in measurements:
        check_measurement(m)
    state = _assimilate(state, [m for m in measurements if not m.ping], rng, config)
    for m in measurements:
        if m.ping and not gated(state, m, config.ping_gate):
            r = range_of(state.particles)
            # spread of the cloud about the measurement (a confident but wrong cloud is wide)
            spread = float(np.sqrt(max(float(state.weights @ (r - float(m.value)) ** 2), 0.0)))
            total = 1.0 / float(m.sigma) ** 2
            p = 1.0 / max(spread / 2.0, float(m.sigma)) ** 2
            precisions: list[float] = []
            while sum(precisions) + p < total:
                precisions.append(p)
                p *= 4.0  # stage std halves
            precisions.append(total - sum(precisions))
            for prec in precisions:
                stage = Measurement(kind="range", value=m.value, sigma=float(1.0 / np.sqrt(prec)))
                state = _assimilate(state, [stage], rng, config)
    return state


def _assimilate(state: PFState, measurements: Sequence[Measurement], rng: np.random.Generator,
                config: PFConfig) -> PFState:
    """Bayes update by all ``measurements`` at once (the body of :func:`update`)."""
    if not measurements:
        return dataclasses.replace(state, resampled=False, degenerate=False)
    fast = config.kernel == "numba"
    move = (config.variant == "resample-move" and state.parent is not None and config.q > 0
            and config.move_steps > 0 and all(m.kind != "frequency" for m in measurements))
    ll: np.ndarray | None = None
    ll_keep: np.ndarray | None = None
    parts: Any = None
    fm, fv = state.freq_mean, state.freq_var
    if fast:  # the same log-weights, one compiled pass for bearings and ranges
        lw, mx, fm, fv, ll_keep, parts = _fast().log_weights(state, measurements, config,
                                                             move, _fast().pending(state))
    X = state.particles
    if not fast:
        for m in measurements:  # validated by update (check_measurement)
            if m.kind in ("bearing", "range"):
                c = measurement_ll(X, m, config.bearing_clutter)
            elif m.kind == "frequency":
                c, fm, fv = frequency_update(X, m, fm, fv)
            else:
                raise ArgumentError("measurement.kind", "'bearing', 'range' or 'frequency'",
                                    m.kind)
            ll = np.asarray(c, dtype=float) if ll is None else ll + c
        assert ll is not None
        ll_keep = ll.copy() if move else None
        lw = ll
        lw += state.log_weights
        mx = lw.max()
    degenerate = False
    if not np.isfinite(mx):  # NaN somewhere or all −inf / +inf
        finite = np.isfinite(lw)
        if not finite.any():
            degenerate = True
            lw = np.zeros_like(lw)
        else:
            lw = np.where(finite, lw, -np.inf)
        mx, parts = lw.max(), None
    if fast:
        w, ess = _fast().normalise(lw, parts)
    else:  # Normalise with one exp (max-shifted, in place), no logsumexp overhead.
        w = np.subtract(lw, mx)
        np.exp(w, out=w)
        tot = w.sum()
        w *= 1.0 / tot
        lw -= mx + np.log(tot)
        ess = float(1.0 / np.dot(w, w))
    if ess < config.degeneracy_ess:
        degenerate = True
    resampled = False
    n = X.shape[0]
    if degenerate:
        warnings.warn(
            f"particle filter degenerate at step {state.step} (ESS = {ess:.2f}); "
            "recovering by resampling and roughening", DegeneracyWarning, stacklevel=2)
        # Roughening with the spread of the *predicted* cloud (before weighting).
        A = particle_rows(X)
        spread = np.std(A, axis=1)
        idx = systematic_indices(w, rng)
        A = np.take(A, idx, axis=1)
        A += rng.standard_normal(A.shape) * (config.roughening * spread)[:, None]
        X = A.T
        if fm is not None and fv is not None:
            fm, fv = fm[idx], fv[idx]
        lw = np.full(n, -np.log(n))
        resampled = True
    elif ess < config.ess_threshold * n or config.ess_threshold >= 1.0:
        A = particle_rows(X)
        if fast and config.variant != "regularised":  # indices and gather in one launch
            idx, A = _fast().resample(w, rng.random(), A)
        else:
            idx = _fast().systematic(w, rng.random()) if fast else systematic_indices(w, rng)
        if config.variant == "regularised":
            d = A.shape[0]
            h = config.bandwidth_scale * (4.0 / (n * (d + 2))) ** (1.0 / (d + 4))
            if fast:  # gather and jitter in one pass (Philox normals)
                A = _fast().gather(A, idx, h * safe_cholesky(_fast().moments(A, w)[1]), rng)
            else:
                Lc = h * safe_cholesky(weighted_cov(A, w))
                A = np.take(A, idx, axis=1)
                # A += Lc Z row by row (Lc lower triangular; no thin BLAS product).
                Z = rng.standard_normal(A.shape)
                tmp = np.empty(n)
                for i in range(d):
                    for j in range(i + 1):
                        if Lc[i, j] != 0.0:
                            np.multiply(Z[j], Lc[i, j], out=tmp)
                            A[i] += tmp
        else:
            A = A if fast else np.take(A, idx, axis=1)  # fast: gathered with the indices
            if move and ll_keep is not None and state.parent is not None:
                A = mh_move(A, np.take(particle_rows(state.parent), idx, axis=1), state.parent_dv,
                             ll_keep[idx], measurements, rng, config)
        X = A.T
        if fm is not None and fv is not None:
            fm, fv = fm[idx], fv[idx]
        lw = _fast().full(n, -np.log(n)) if fast else np.full(n, -np.log(n))
        resampled = True
    new = PFState(step=state.step, particles=X, log_weights=lw, freq_mean=fm, freq_var=fv,
                  ess=ess, resampled=resampled, degenerate=degenerate, kernel=config.kernel)
    if fast:
        return _with_weights(new, _fast().full(n, 1.0 / n) if resampled else w)
    return new


# --------------------------------------------------------------------------------------------
# Convenience wrapper
# --------------------------------------------------------------------------------------------


class ParticleFilter:
    """A :class:`PFConfig` with initialisers and bound :func:`predict` / :func:`update`;
    implements :class:`tmaplan.estimators.filter.Filter`.

    Parameters
    ----------
    config : PFConfig
    """

    name: ClassVar[str] = "pf"
    #: Sensor kinds it assimilates.
    applies_to: ClassVar[frozenset[str]] = frozenset({"bearing", "range", "frequency"})

    def __init__(self, config: PFConfig) -> None:
        self.config = config

    def init(self, scenario: Scenario, rng: np.random.Generator) -> PFState:
        """N particles from the scenario's prior (:meth:`from_prior`)."""
        return self.from_prior(scenario, rng)

    def diagnostic(self, state: PFState) -> float:
        """Effective sample size after the last update."""
        return float(state.ess)

    def from_particles(self, particles: np.ndarray, *, step: int = 0,
                       log_weights: np.ndarray | None = None) -> PFState:
        """State from given relative particles, shape (N, 4) (equal weights by default)."""
        X = np.array(particles, dtype=float, copy=True, order="F")  # column-major layout
        if X.ndim != 2 or X.shape[1] != 4 or X.shape[0] < 1 or not np.isfinite(X).all():
            raise ArgumentError("particles", "a finite (N, 4) array, N >= 1",
                                getattr(X, "shape", X))
        n = X.shape[0]
        if log_weights is None:
            lw = np.full(n, -np.log(n))
        else:
            lw = np.asarray(log_weights, float)
            if (lw.shape != (n,) or np.isnan(lw).any() or np.isposinf(lw).any()
                    or not np.isfinite(lw).any()):
                raise ArgumentError("log_weights", f"shape ({n},), no NaN or +inf, not all "
                                    "-inf", lw.shape if lw.shape != (n,) else lw)
            lw = lw - logsumexp(lw)
        return PFState(step=step, particles=X, log_weights=lw, ess=effective_sample_size(lw),
                       kernel=self.config.kernel)

    def from_prior(self, scenario: Scenario, rng: np.random.Generator, *,
                   observer_state0: np.ndarray | None = None) -> PFState:
        """Draw N particles from the scenario's prior (relative to the observer at step 0).

        Uses :func:`tmaplan.models.prior.relative_prior_samples`; never the true state
        (beyond what the prior itself is defined from).
        """
        X = relative_prior_samples(scenario, self.config.n_particles, rng, observer_state0)
        return self.from_particles(X, step=0)

    def from_gaussian(self, mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator, *,
                      step: int = 0) -> PFState:
        """Draw N particles from N(mean, cov) (relative state)."""
        m, C = np.asarray(mean, float), np.asarray(cov, float)
        if m.shape != (4,) or not np.isfinite(m).all():
            raise ArgumentError("mean", "a finite relative state of shape (4,)", mean)
        if C.shape != (4, 4) or not np.isfinite(C).all() or (np.diag(C) < 0).any():
            raise ArgumentError("cov", "a finite (4, 4) covariance", cov)
        L = safe_cholesky(C)
        Z = rng.standard_normal((4, self.config.n_particles))
        A = m[:, None] + L @ Z
        return self.from_particles(A.T, step=step)

    def predict(self, state: PFState, dv: np.ndarray | None, rng: np.random.Generator
                ) -> PFState:
        """See :func:`predict`."""
        return predict(state, dv, rng, self.config)

    def update(self, state: PFState, measurements: Sequence[Measurement],
               rng: np.random.Generator) -> PFState:
        """See :func:`update`."""
        return update(state, measurements, rng, self.config)
