"""Consistency monitoring and track recovery around any recursive filter.

:class:`MonitoredFilter` wraps a :class:`tmaplan.estimators.filter.Filter` and, before each
update, forms the innovation of every bearing and range measurement against the predicted
state: ``ν = z − ẑ`` with variance ``S = σ² + var(ẑ)`` (over the particles for a particle
filter, by linearisation ``H P Hᵀ`` otherwise), and the normalised innovation squared
``ε = ν²/S``, which is χ²₁ when the filter is consistent (Bar-Shalom, Li & Kirubarajan 2001,
§5.4; ristic2004 ch. 6 uses the same Gaussian innovation picture). Three tests, each at the
false-alarm probability ``alpha`` per test:

* **bearings, sliding window**: alarm when the sum of the last ``window`` bearing NIS exceeds
  its (1 − α) quantile. A bearing whose own NIS exceeds the χ²₁ (1 − α) quantile c is an
  *outlier* (a wild bearing, clutter): it is left out of the window
  and the CUSUM, and ``outliers`` of them in a row raise the alarm (a lost track gives nothing
  but outliers; 5 % independent wild bearings give three in a row with probability 1.25e-4);
  outliers are also kept from the filter (``withhold_outliers``: innovation gating, so a plain
  Gaussian likelihood survives wild bearings too);
  the window therefore sums χ²₁ variables truncated to [0, c], and its threshold is the
  (1 − α) quantile of that sum (computed by numerical convolution), so the window test's
  false-alarm probability is α;
* **ranges, one at a time**: a ping is rare and decisive; alarm when its NIS exceeds the χ²₁
  quantile (a confident cloud that lost the contact is told so by the next ping);
* **manoeuvres, CUSUM**: the signed normalised bearing innovations ``ν/√S`` drift one way after
  an unmodelled course change, long before the window sum grows; a two-sided CUSUM
  ``g⁺ ← max(0, g⁺ + ν/√S − κ)``, ``g⁻ ← max(0, g⁻ − ν/√S − κ)`` alarms at ``g > h``
  (Page 1954), with ``h`` set from α by Siegmund's approximation of the in-control run length
  ``ARL₀ ≈ (e^{2κh'} − 2κh' − 1)/(2κ²)``, ``h' = h + 1.166`` so that ``1/ARL₀ ≈ α``;
* **manoeuvres, GLR** (``glr_window`` > 0): the sliding-window velocity-jump likelihood-ratio
  test of :mod:`tmaplan.estimators.manoeuvre_glr` on the stored measurements, at false-alarm
  probability ``glr_alpha`` per step; its change point is the onset of the recovery.

On an alarm the filter **recovers** (when the inner filter is a particle filter): it goes back
to a posterior it stored, rejuvenates that cloud and filters the stored observer increments
and measurements again up to now, with the process noise widened by ``q_boost`` for the
re-filtered span and ``holdoff`` steps after it. Two kinds of recovery:

* after a bearing alarm (a manoeuvre, or a burst of outliers), it goes back to the change
  point estimated by the CUSUM (the last step its statistic was 0; ``lookback`` steps for the
  other bearing tests), keeps the positions and gives a fraction ``velocity_fraction`` of the
  particles a new course (uniform on the circle) at a speed scaled by a log-normal factor of
  std ``speed_spread``: the bearings since the change decide between them;
* after a ping alarm (the track is lost), it goes back ``lookback`` steps and gives a
  fraction of the particles new target velocities from the scenario prior, another fraction
  new ranges along their own bearing from the prior's range support (the contact may be
  elsewhere on the line of sight, as in the bearings-only initialisation of
  :mod:`tmaplan.estimators.init_bearings`, brehard2004 eq. 30); the recent bearings and the
  ping decide.

The rejuvenated particles get a total prior weight ``rejuvenation_weight`` (the cloud is an
importance sample of the mixture "as it was" / "new hypotheses"), so hypotheses the
measurements cannot refute — the range rate of a contact seen on bearings only — do not take
over after a false alarm, while a real manoeuvre or a lost track, whose measurements refute the
old cloud by many orders of likelihood, hands over to them. Each recovery is logged
(:attr:`MonitoredState.log`) and counted (:attr:`MonitoredState.recoveries`); the closed loop
reports it per run.

The closed loop's :class:`tmaplan.evaluation.filter_options.FilterOptions` bundles the robust
measurement models of the particle filter (:class:`tmaplan.estimators.particle_filter.PFConfig`
``bearing_clutter`` and ``ping_gate``) with this monitor and the closed loop's answer to its
alarms.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np
from scipy import optimize

from tmaplan.errors import ArgumentError
from tmaplan.estimators.manoeuvre_glr import glr_threshold, velocity_jump_glr
from tmaplan.estimators.particle_filter import ParticleFilter
from tmaplan.estimators.pf_kernels import particle_rows
from tmaplan.geometry import wrap_angle, wrap_half_angle
from tmaplan.models.target import initial_velocity
from tmaplan.scenario import Scenario
from tmaplan.simulate import Measurement

__all__ = [
    "MonitorConfig",
    "MonitoredFilter",
    "MonitoredState",
    "cusum_threshold",
    "innovation",
]


@functools.cache
def _truncated_sum_quantile(n: int, alpha: float, step: float = 0.005) -> float:
    """(1 − α) quantile of the sum of n iid χ²₁ truncated to [0, χ²₁ (1 − α) quantile],
    by convolving the binned distribution (bin probabilities from the CDF, so the x^{-1/2}
    singularity at 0 costs nothing); error below ``n·step/2``."""
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    cap = float(stats.chi2.isf(alpha, 1))
    edges = np.arange(0.0, cap + step, step)
    edges[-1] = cap
    p = np.diff(stats.chi2.cdf(edges, 1))
    p /= p.sum()
    size = n * p.size
    f = np.fft.rfft(p, size) ** n
    pmf = np.clip(np.fft.irfft(f, size), 0.0, None)
    tail = np.cumsum(pmf[::-1])[::-1] / pmf.sum()
    centre = (np.arange(size) + 0.5 * n) * step  # n bin centres summed
    return float(centre[np.nonzero(tail > alpha)[0][-1]])


def cusum_threshold(alpha: float, kappa: float) -> float:
    """CUSUM threshold h whose one-sided in-control average run length is ``1/alpha`` steps
    (Siegmund's approximation, see the module docstring), for unit-variance increments and
    reference value ``kappa``."""
    def arl(h: float) -> float:
        b = 2.0 * kappa * (h + 1.166)
        return (math.exp(b) - b - 1.0) / (2.0 * kappa**2)

    if arl(0.0) >= 1.0 / alpha:  # a large κ: any positive statistic is already rare enough
        return 0.0
    return float(optimize.brentq(lambda h: math.log(arl(h)) + math.log(alpha), 0.0, 100.0))


@dataclasses.dataclass(frozen=True, kw_only=True)
class MonitorConfig:
    """Settings of the consistency monitor.

    Attributes
    ----------
    window : int
        Bearings in the sliding NIS window.
    alpha : float
        False-alarm probability per test, in (0, 0.5).
    kappa : float
        CUSUM reference value [innovation σ] (the drift detected fastest is 2κ).
    cusum_alpha : float, optional
        False-alarm rate per step of the CUSUM (default ``alpha``).
    cusum : bool
        Run the manoeuvre CUSUM.
    outliers : int
        Consecutive outlier bearings that raise the alarm.
    withhold_outliers : bool
        Keep outlier bearings from the filter (innovation gating at the χ²₁ (1 − α) quantile).
    lookback : int
        Steps re-filtered on recovery (at most, after a CUSUM alarm).
    velocity_fraction, range_fraction : float
        Fractions of the rejuvenated cloud with new velocities / new ranges.
    speed_spread : float
        Std of the log speed factor of a manoeuvre recovery.
    rejuvenation_weight : float
        Total prior weight of the rejuvenated particles, in (0, 1): the recovery is a mixture
        "track as it was" / "new hypotheses" that the re-filtered measurements weigh, so a
        false alarm costs little.
    q_boost : float
        Process-noise multiplier while re-filtering and for ``holdoff`` steps after.
    holdoff : int
        Steps after a recovery without tests (the statistics restart).
    recover : bool
        Recover on alarms (False: only count them).
    glr_window : int
        Steps of the velocity-jump GLR window (0: no GLR test); its candidate onsets are the
        last ``lookback`` steps.
    glr_alpha : float, optional
        False-alarm probability per step of the GLR test (default ``alpha``).
    """

    window: int = 8
    alpha: float = 1e-3
    kappa: float = 0.5
    cusum_alpha: float | None = None
    cusum: bool = True
    outliers: int = 3
    withhold_outliers: bool = True
    lookback: int = 16
    velocity_fraction: float = 0.5
    range_fraction: float = 0.25
    speed_spread: float = 0.25
    rejuvenation_weight: float = 0.1
    q_boost: float = 1000.0
    holdoff: int = 16
    recover: bool = True
    glr_window: int = 0
    glr_alpha: float | None = None

    def __post_init__(self) -> None:
        for name in ("window", "lookback", "holdoff", "outliers"):
            v = getattr(self, name)
            if type(v) is not int or v < (0 if name == "holdoff" else 1):  # no bool
                raise ArgumentError(f"monitor.{name}", "an integer >= 1 (holdoff >= 0)", v)
        if not 0.0 < self.alpha < 0.5:
            raise ArgumentError("monitor.alpha", "a probability in (0, 0.5)", self.alpha)
        for name in ("cusum_alpha", "glr_alpha"):
            v = getattr(self, name)
            if v is not None and not 0.0 < v < 0.5:
                raise ArgumentError(f"monitor.{name}", "a probability in (0, 0.5)", v)
        if (not isinstance(self.glr_window, int) or isinstance(self.glr_window, bool)
                or not (self.glr_window == 0 or self.glr_window >= self.lookback)):
            raise ArgumentError("monitor.glr_window", "0 (off) or an integer >= lookback",
                                self.glr_window)
        if not self.kappa > 0:
            raise ArgumentError("monitor.kappa", "> 0", self.kappa)
        if not (0 <= self.velocity_fraction and 0 <= self.range_fraction
                and self.velocity_fraction + self.range_fraction <= 1):
            raise ArgumentError("monitor.velocity_fraction",
                                "fractions >= 0 with velocity + range fractions <= 1",
                                (self.velocity_fraction, self.range_fraction))
        if not 0.0 < self.rejuvenation_weight < 1.0:
            raise ArgumentError("monitor.rejuvenation_weight", "in (0, 1)",
                                self.rejuvenation_weight)
        for name, lo in (("q_boost", 1.0), ("speed_spread", 0.0)):  # finite (q·q_boost, e^…)
            if not lo <= getattr(self, name) < math.inf:
                raise ArgumentError(f"monitor.{name}", f"finite, >= {lo:g}", getattr(self, name))

    @property
    def bearing_threshold(self) -> float:
        """(1 − α) quantile of a sum of ``window`` χ²₁ variables truncated to
        [0, :attr:`range_threshold`] (the inlier NIS, module docstring)."""
        return _truncated_sum_quantile(self.window, self.alpha)

    @property
    def range_threshold(self) -> float:
        """χ²₁ (1 − α) quantile."""
        from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

        return float(stats.chi2.isf(self.alpha, 1))

    @property
    def cusum_threshold(self) -> float:
        """CUSUM threshold h for a one-sided run length 2/α (two sides: 1/α)."""
        a = self.alpha if self.cusum_alpha is None else self.cusum_alpha
        return cusum_threshold(a / 2.0, self.kappa)


def innovation(state: Any, m: Measurement) -> tuple[float, float]:
    """Innovation ``ν = z − ẑ`` and its variance ``S = σ² + var(ẑ)`` of a bearing or range.

    Parameters
    ----------
    state : FilterState
        Predicted state; a particle state (``particles``, ``weights``) gives the moments over
        the cloud (for the compiled kernels' clouds, a bearing's in one compiled pass,
        :func:`tmaplan.estimators.pf_moments.bearing_moments`, equal to rounding), any other
        its mean and covariance by linearisation.
    m : Measurement
        Bearing [rad] (innovation wrapped; modulo π if π-ambiguous) or range [m].

    Returns
    -------
    nu, S : float
        [rad] / [rad²] or [m] / [m²].
    """
    sigma2 = float(m.sigma) ** 2
    wrap = wrap_half_angle if m.kind == "bearing" and m.ambiguity == "pi" else wrap_angle
    if hasattr(state, "particles"):
        X, w = state.particles, state.weights
        if (m.kind == "bearing" and wrap is wrap_angle
                and getattr(state, "kernel", "numpy") == "numba"):  # one compiled pass
            from tmaplan.estimators.pf_moments import bearing_moments  # deferred: numba

            nu, var = bearing_moments(particle_rows(X), w, float(m.value))
            if math.isfinite(nu) and math.isfinite(var):  # else numpy's formula (below)
                return nu, sigma2 + var
        if m.kind == "bearing":
            d = wrap(float(m.value) - np.arctan2(X[:, 0], X[:, 1]))
        else:
            d = float(m.value) - np.hypot(X[:, 0], X[:, 1])
        nu = float(w @ d)
        return nu, sigma2 + float(w @ (d - nu) ** 2)
    x, P = np.asarray(state.mean, float), np.asarray(state.cov, float)
    r2 = float(x[0] ** 2 + x[1] ** 2)
    if m.kind == "bearing":
        H = np.array([x[1], -x[0], 0.0, 0.0]) / r2
        nu = float(wrap(float(m.value) - math.atan2(x[0], x[1])))
    else:
        H = np.array([x[0], x[1], 0.0, 0.0]) / math.sqrt(r2)
        nu = float(m.value) - math.sqrt(r2)
    return nu, sigma2 + float(H @ P @ H)


@dataclasses.dataclass(frozen=True, kw_only=True)
class MonitoredState:
    """A wrapped filter state with the monitor's statistics.

    Attributes
    ----------
    inner : FilterState
        The wrapped filter's state.
    nis : tuple of float
        Bearing NIS of the current window (newest last), outliers left out.
    streak : int
        Consecutive outlier bearings.
    outliers : int
        Outlier bearings so far.
    cusum : tuple of float
        (g⁺, g⁻).
    age : tuple of int
        Steps since g⁺ and g⁻ were last 0 (the change point of a CUSUM alarm).
    history : tuple
        Up to ``lookback`` entries ``(posterior at i, Δv_i, v̄_i, measurements at i + 1)``.
    pending : tuple or None
        ``(posterior, Δv, v̄)`` between :meth:`MonitoredFilter.predict` and ``update``.
    velocity : ndarray, shape (2,)
        Observer mean velocity v̄ at ``step`` [m/s].
    recoveries : int
        Recoveries so far.
    log : tuple of dict
        One entry per alarm: step, test, statistic, threshold, recovered.
    quiet : int
        Steps left without tests after a recovery.
    prior : Prior or None
        The scenario's prior (:meth:`MonitoredFilter.init`): the support of rejuvenation.
    """

    inner: Any
    nis: tuple[float, ...] = ()
    streak: int = 0
    outliers: int = 0
    cusum: tuple[float, float] = (0.0, 0.0)
    age: tuple[int, int] = (0, 0)
    history: tuple[Any, ...] = ()
    pending: Any = None
    velocity: np.ndarray
    recoveries: int = 0
    log: tuple[dict[str, Any], ...] = ()
    quiet: int = 0
    prior: Any = None

    def evolve(self, **changes: Any) -> MonitoredState:
        """``dataclasses.replace(self, **changes)`` for the filter's own fields, at a tenth of
        its cost (every step makes two): the fields copied, then ``changes``."""
        new = object.__new__(MonitoredState)
        new.__dict__.update(self.__dict__, **changes)
        return new

    @property
    def step(self) -> int:
        """Grid step of the inner state."""
        return int(self.inner.step)

    @property
    def mean(self) -> np.ndarray:
        """Posterior mean, shape (4,)."""
        return np.asarray(self.inner.mean)

    @property
    def cov(self) -> np.ndarray:
        """Posterior covariance, shape (4, 4)."""
        return np.asarray(self.inner.cov)

    @property
    def particles(self) -> np.ndarray:
        """The inner particle cloud (particle filters only), shape (N, 4)."""
        return np.asarray(self.inner.particles)

    @property
    def weights(self) -> np.ndarray:
        """The inner weights (particle filters only), shape (N,)."""
        return np.asarray(self.inner.weights)


class MonitoredFilter:
    """A filter with consistency monitoring and recovery (module docstring); implements
    :class:`tmaplan.estimators.filter.Filter`.

    Parameters
    ----------
    inner : Filter
        The wrapped filter (recovery needs a :class:`ParticleFilter`).
    config : MonitorConfig
    """

    name: ClassVar[str] = "monitored"
    applies_to: ClassVar[frozenset[str]] = frozenset({"bearing", "range", "frequency"})

    def __init__(self, inner: Any, config: MonitorConfig | None = None) -> None:
        self.inner = inner
        self.config = config or MonitorConfig()
        self._thresholds = (self.config.bearing_threshold, self.config.range_threshold,
                            self.config.cusum_threshold)
        self._boosted = inner
        if isinstance(inner, ParticleFilter):
            self._boosted = ParticleFilter(dataclasses.replace(
                inner.config, q=inner.config.q * self.config.q_boost))

    def init(self, scenario: Scenario, rng: np.random.Generator) -> MonitoredState:
        """The inner filter's initial state, the observer's initial velocity."""
        return MonitoredState(inner=self.inner.init(scenario, rng), prior=scenario.prior,
                              velocity=np.asarray(initial_velocity(scenario.observer), float))

    def wrap(self, inner_state: Any, observer_velocity: np.ndarray) -> MonitoredState:
        """Monitor from a given inner state and observer mean velocity [m/s]."""
        return MonitoredState(inner=inner_state, velocity=np.asarray(observer_velocity, float))

    def diagnostic(self, state: MonitoredState) -> float:
        """The inner filter's diagnostic."""
        return float(self.inner.diagnostic(state.inner))

    def predict(self, state: MonitoredState, dv: np.ndarray | None,
                rng: np.random.Generator) -> MonitoredState:
        """Inner prediction (boosted process noise during a hold-off)."""
        d = np.zeros(2) if dv is None else np.asarray(dv, float).reshape(2)
        filt = self._boosted if state.quiet > 0 else self.inner
        return state.evolve(inner=filt.predict(state.inner, d, rng),
                            pending=(state.inner, d, state.velocity),
                            velocity=state.velocity + d)

    def update(self, state: MonitoredState, measurements: Sequence[Measurement],
               rng: np.random.Generator) -> MonitoredState:
        """Test the innovations, update the inner filter, recover on an alarm."""
        cfg = self.config
        t_b, t_r, t_c = self._thresholds
        nis, (gp, gm), streak = list(state.nis), state.cusum, state.streak
        ap, am = state.age  # steps, not bearings: a step may hold 0 (a fade) or ≥ 2 of them
        n_out, zp, zm = state.outliers, False, False  # zp/zm: g± was 0 within this step
        alarm: dict[str, Any] | None = None
        kept: list[Measurement] = []
        for m in measurements:
            kept.append(m)
            if m.kind not in ("bearing", "range") or getattr(m, "ambiguity", "none") == "pi":
                continue
            nu, S = innovation(state.inner, m)
            e = nu * nu / S
            if m.kind == "range":
                if e > t_r and alarm is None:
                    alarm = {"test": "range", "statistic": e, "threshold": t_r}
                continue
            if e > t_r:  # an outlier: out of the window and the CUSUM (and the filter)
                streak += 1
                n_out += 1
                if cfg.withhold_outliers:
                    kept.pop()
                if alarm is None and streak >= cfg.outliers:
                    alarm = {"test": "outliers", "statistic": float(streak),
                             "threshold": float(cfg.outliers)}
                continue
            streak = 0
            nis = ([*nis, e])[-cfg.window:]
            u = nu / math.sqrt(S)
            gp, gm = max(0.0, gp + u - cfg.kappa), max(0.0, gm - u - cfg.kappa)
            zp, zm = zp or gp == 0.0, zm or gm == 0.0
            if alarm is None and len(nis) == cfg.window and sum(nis) > t_b:
                alarm = {"test": "bearing-window", "statistic": sum(nis), "threshold": t_b}
            if alarm is None and cfg.cusum and max(gp, gm) > t_c:
                alarm = {"test": "cusum", "statistic": max(gp, gm), "threshold": t_c,
                         "onset": (1 if zp else ap + 1) if gp > gm else (1 if zm else am + 1)}
        ap, am = (0 if gp == 0 else 1 if zp else ap + 1), (0 if gm == 0 else 1 if zm else am + 1)
        history = state.history
        if state.pending is not None:
            history = ((*history, (*state.pending, tuple(kept))))[-max(cfg.lookback,
                                                                       cfg.glr_window):]
        if alarm is None and cfg.glr_window and state.quiet == 0:
            alarm = self._glr(history)
        filt = self._boosted if state.quiet > 0 else self.inner
        new = state.evolve(inner=filt.update(state.inner, kept, rng),
                           nis=tuple(nis), cusum=(gp, gm), age=(ap, am), streak=streak,
                           outliers=n_out, history=history,
                           pending=None, quiet=max(state.quiet - 1, 0))
        if state.quiet > 0 or alarm is None:
            return new
        alarm["step"] = new.step
        can = cfg.recover and isinstance(self.inner, ParticleFilter) and bool(history)
        alarm["recovered"] = can
        if can:
            new = self._recover(new, rng, alarm.get("onset"), lost=alarm["test"] == "range")
        return dataclasses.replace(new, log=(*new.log, alarm),
                                   recoveries=new.recoveries + int(can))

    def _glr(self, history: tuple[Any, ...]) -> dict[str, Any] | None:
        """The velocity-jump GLR alarm on the last ``glr_window`` steps, or None."""
        cfg, dt = self.config, getattr(getattr(self.inner, "config", None), "dt", None)
        test = None if dt is None else velocity_jump_glr(history[-cfg.glr_window:], float(dt),
                                                         max_back=cfg.lookback)
        if test is None:
            return None
        h = glr_threshold(cfg.alpha if cfg.glr_alpha is None else cfg.glr_alpha,
                          test.candidates)
        if test.statistic <= h:
            return None
        return {"test": "glr", "statistic": test.statistic, "threshold": h,
                "onset": test.back, "dv": test.dv.tolist()}

    # -- recovery ------------------------------------------------------------------------------
    def _rejuvenate(self, inner: Any, vbar: np.ndarray, rng: np.random.Generator,
                    lost: bool, prior: Any) -> Any:
        """Resampled cloud in which a fraction of particles, of total weight
        ``rejuvenation_weight``, carries new velocities (and, if ``lost``, new ranges)."""
        cfg, pf = self.config, self.inner
        n = inner.particles.shape[0]
        idx = rng.choice(n, size=n, p=inner.weights / inner.weights.sum())
        X = np.array(inner.particles[idx], float)
        u = rng.random(n)
        nv = u < cfg.velocity_fraction
        nr = ((u >= cfg.velocity_fraction) & (u < cfg.velocity_fraction + cfg.range_fraction)
              if lost else np.zeros(n, bool))
        if lost:  # velocities from the prior, ranges on the line of sight
            speed_max, r_lo, r_hi = self._support(X, prior)
            sp = speed_max * np.sqrt(rng.random(nv.sum()))  # uniform on the speed disc
            b = np.arctan2(X[nr, 0], X[nr, 1])
            r = rng.uniform(r_lo, r_hi, nr.sum())
            X[nr, 0], X[nr, 1] = r * np.sin(b), r * np.cos(b)
        else:  # a manoeuvre: same place, new course, similar speed
            vt = X[nv, 2:] + vbar
            sp = np.hypot(vt[:, 0], vt[:, 1]) * np.exp(cfg.speed_spread
                                                       * rng.standard_normal(nv.sum()))
        co = rng.uniform(-np.pi, np.pi, nv.sum())
        X[nv, 2] = sp * np.sin(co) - vbar[0]
        X[nv, 3] = sp * np.cos(co) - vbar[1]
        new = nv | nr
        k = int(new.sum())
        lw = np.where(new, np.log(cfg.rejuvenation_weight / max(k, 1)),
                      np.log((1.0 - cfg.rejuvenation_weight) / max(n - k, 1)))
        return pf.from_particles(X, step=int(inner.step), log_weights=lw)

    def _support(self, X: np.ndarray, p: Any) -> tuple[float, float, float]:
        """Target speed bound [m/s] and range support [m] for rejuvenation: the prior's if it
        gives them, else from the cloud."""
        r = np.hypot(X[:, 0], X[:, 1])
        speed_max = (p.speed_max if p is not None and p.speed_max is not None
                     else 2.0 * float(np.median(np.hypot(X[:, 2], X[:, 3]))) + 5.0)
        r_med = float(np.median(r))
        lo = p.range_min if p is not None and p.range_max is not None else r_med / 3.0
        hi = p.range_max if p is not None and p.range_max is not None else 3.0 * r_med
        return float(speed_max), float(max(lo, 1.0)), float(hi)

    def _recover(self, state: MonitoredState, rng: np.random.Generator,
                 onset: int | None, lost: bool) -> MonitoredState:
        """Rejuvenate a stored posterior (the CUSUM's change point, else ``lookback`` steps
        back) and filter forward again with boosted process noise."""
        k = self.config.lookback
        hist = state.history[-(k if onset is None else min(max(int(onset), 1), k)):]
        post, _, vbar, _ = hist[0]
        inner = self._rejuvenate(post, vbar, rng, lost=lost, prior=state.prior)
        for _, dv, _, meas in hist:
            inner = self._boosted.predict(inner, dv, rng)
            inner = self._boosted.update(inner, meas, rng)
        return dataclasses.replace(state, inner=inner, nis=(), cusum=(0.0, 0.0), age=(0, 0),
                                   streak=0, history=(), quiet=self.config.holdoff)
