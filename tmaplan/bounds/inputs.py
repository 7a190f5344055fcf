"""Inputs shared by every PCRB (Monte Carlo, closed form, truth-conditional) and the planners.

Everything a PCRB needs from a :class:`~tmaplan.scenario.Scenario` is resolved here once:
the observer track and its velocity increments (``c_t = −H Δv_t``, docs/conventions.md), the
bearing and range information per step (:func:`information_rates`, the one per-step
sensor-information function), the ping weights per step, and the prior of the relative
initial state (moments and the LPC information ``J₀`` of brehard2005 eq. 56,
:func:`lpc_prior_information`, the one J₀).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.special import ndtr

from tmaplan.errors import (
    ArgumentError,
    ObservabilityError,
    ScenarioError,
    finite_real,
    is_integer,
)
from tmaplan.geometry import cart_to_lpc, wrap_angle
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import (
    relative_prior_covariance,
    relative_prior_samples,
    true_initial_state,
)
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import (
    BearingSensor,
    FrequencySensor,
    RangeSensor,
    Scenario,
    TimeGrid,
    measurement_steps,
)
from tmaplan.scenario.prior_checks import zero_prior_stds

__all__ = ["MIN_PRIOR_RANGE", "PCRBInputs", "check_ping_steps", "information_rates",
           "lpc_prior_information", "prepare", "range_reach_terms", "reached_range_weight",
           "resolve_ping_steps"]

#: Prior samples closer than this to the observer count as "mass at zero range" [m].
MIN_PRIOR_RANGE = 1.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class PCRBInputs:
    """Resolved inputs of a PCRB computation (K transitions, K + 1 instants).

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    dt : float
        [s].
    A, Q : ndarray, shape (4, 4)
        NCV transition and process-noise covariance (``q·Σ⊗I₂``) [m², m²/s, m²/s²].
    observer : ObserverTrack
    c : ndarray, shape (K, 4)
        ``c_t = −H Δv_t`` [m, m, m/s, m/s]: ``X_{t+1} = A X_t + c_t + w_t``.
    bearing_info : ndarray, shape (K + 1,)
        Σ 1/σ_β² over the bearing sensors measuring at each step [rad⁻²].
    ambiguity : {"none", "pi"}
        "pi" if any bearing sensor is π-ambiguous (brehard2005 eq. 4).
    ping_steps : ndarray of int
        Steps with a range ping (active range sensors or an explicit list).
    ping_weight : ndarray, shape (K + 1,)
        Σ 1/σ_r² of the range measurements at each step [m⁻²]: the pings and the passive
        range sensors (0 where there is none).
    range_sigma : float or None
        σ_r of a ping [m] (:func:`resolve_ping_steps`).
    range_reach : tuple of (float, ndarray of shape (K + 1,))
        The parts of ``ping_weight`` [m⁻²] read by range sensors with a ``max_range`` [m],
        one per reach (:func:`range_reach_terms`): at step k such a reading counts only where
        the range is within its reach (:func:`reached_range_weight`). Empty: every reading
        counts (no ``max_range``).
    frequency_sensors : tuple of (FrequencySensor, ndarray)
        Each frequency sensor with its steps.
    prior_samples : int
        Number of prior samples behind ``m0, S0, cov_lpc0, cov_cart0``.
    m0 : ndarray, shape (4,)
        Mean of the relative initial state [m, m, m/s, m/s].
    S0 : ndarray, shape (4, 4)
        Raw second moment ``E X₀X₀ᵀ``.
    cov_cart0 : ndarray, shape (4, 4)
        Covariance of X₀ (:func:`tmaplan.models.prior.relative_prior_covariance`: exact for a
        gaussian prior, else of the samples, normalised by n as ``cov_lpc0``).
    cov_lpc0 : ndarray, shape (4, 4), or None
        Covariance of the LPC initial state (brehard2005 eq. 56, bearing centred on its circular
        mean).
    prior_subsample : ndarray, shape (n_sub, 4)
        The first ≤ 500 prior samples of X₀ (for the side-assumption diagnostic).
    """

    times: np.ndarray
    dt: float
    A: np.ndarray
    Q: np.ndarray
    observer: ObserverTrack
    c: np.ndarray
    bearing_info: np.ndarray
    ambiguity: str
    ping_steps: np.ndarray
    ping_weight: np.ndarray
    range_sigma: float | None
    range_reach: tuple[tuple[float, np.ndarray], ...] = ()
    frequency_sensors: tuple[tuple[FrequencySensor, np.ndarray], ...]
    prior_samples: int
    m0: np.ndarray
    S0: np.ndarray
    cov_cart0: np.ndarray
    cov_lpc0: np.ndarray | None
    prior_subsample: np.ndarray

    @property
    def n_steps(self) -> int:
        """K."""
        return self.times.shape[0] - 1


def check_ping_steps(steps: Sequence[int] | np.ndarray, n_steps: int, *, field: str = "ping_steps",
                     source: str | None = None) -> np.ndarray:
    """Ping steps checked against a grid of ``n_steps`` + 1 instants.

    Parameters
    ----------
    steps : sequence of int
        Ping steps (indices on the grid, step 0 at its first instant).
    n_steps : int
        Last step K of the grid (the horizon in steps).
    field : str
        Name of the argument, for the error message.
    source : str, optional
        Scenario name, for the error message.

    Returns
    -------
    ndarray of int, shape (n,)
        The steps, each in [0, K], in the given order.

    Raises
    ------
    ArgumentError
        Naming ``field``, the valid range and the received steps, if a step is outside it
        (a step past the horizon or before its start is refused, never dropped) or is not an
        integer (a bool, a float, a string: never truncated or parsed).
    """
    expected = f"integer steps in [0, {int(n_steps)}]"
    if isinstance(steps, str | bytes) or not hasattr(steps, "__iter__"):
        raise ArgumentError(field, f"a sequence of {expected}", steps, source=source)
    raw = np.asarray(list(steps), dtype=object).reshape(-1)
    if not all(is_integer(x, 0) and x <= n_steps for x in raw):
        raise ArgumentError(field, expected, raw.tolist(), source=source)
    return raw.astype(int)


def resolve_ping_steps(scenario: Scenario, ping_steps: Sequence[int] | None,
                       ) -> tuple[np.ndarray, np.ndarray, float | None]:
    """Ping steps and per-step range weights Σ 1/σ_r² [m⁻²].

    The passive range sensors (``active = false``: continuous range measurements, not pings)
    always count at their own steps. ``ping_steps=None``: the active range sensors ping at
    their own steps (each with its own σ). An explicit list replaces the active sensors'
    steps and pings with the σ of the first active range sensor (of the first range sensor
    if none is active); a non-empty list without a range sensor raises
    :class:`ScenarioError`. The returned steps are those of the pings (not of the passive
    range measurements); the returned σ is that of a ping.
    """
    K = scenario.time.n_steps
    sensors = [s for s in scenario.sensors if isinstance(s, RangeSensor)]
    active = [s for s in sensors if s.active]
    sigma = float((active or sensors)[0].sigma) if sensors else None
    weight = information_rates(scenario, sensors=[s for s in sensors if not s.active])[1]
    if ping_steps is None:
        pings = information_rates(scenario, sensors=active)[1]
        return np.flatnonzero(pings > 0), weight + pings, sigma
    steps = check_ping_steps(ping_steps, K, source=scenario.name)
    if steps.size and sigma is None:
        raise ScenarioError("sensors", "a range sensor (kind = 'range') to ping with",
                            "no range sensor", source=scenario.name)
    steps = np.unique(steps)
    if sigma is not None:
        weight[steps] += 1.0 / sigma**2
    return steps, weight, sigma


def range_reach_terms(scenario: Scenario, ping_steps: Sequence[int] | None = None,
                      ) -> tuple[tuple[float, np.ndarray], ...]:
    """The range information per step limited by a reach: one term per ``max_range``.

    The readings of :func:`resolve_ping_steps` (same rules: passive range sensors at their own
    steps; ``ping_steps=None``, the active sensors at theirs; an explicit list, the pinging
    sensor at those steps) whose sensor has a ``max_range``, grouped by reach. A reading is
    the range of the contact only where its range is at most the reach (the echo exists,
    :func:`tmaplan.simulate.simulate`); :func:`reached_range_weight` applies the terms.

    Parameters
    ----------
    scenario : Scenario
    ping_steps : sequence of int, optional
        As :func:`resolve_ping_steps` (checked there).

    Returns
    -------
    tuple of (float, ndarray of shape (K + 1,))
        ``(max_range [m], Σ 1/σ_r² [m⁻²] per step)`` for each reach with a reading, sorted by
        reach; a part of :func:`resolve_ping_steps`' weight. Empty without a ``max_range``.
    """
    K = scenario.time.n_steps
    sensors = [s for s in scenario.sensors if isinstance(s, RangeSensor)]
    pinger = next(iter([s for s in sensors if s.active] or sensors), None)
    terms: dict[float, np.ndarray] = {}
    for s in sensors:
        if s.max_range is None:
            continue
        w = np.zeros(K + 1)
        if not s.active or ping_steps is None:
            w += information_rates(scenario, sensors=[s])[1]
        if ping_steps is not None and s is pinger:
            w[np.unique(np.asarray(list(ping_steps), int))] += 1.0 / float(s.sigma) ** 2
        if w.any():
            terms[float(s.max_range)] = terms.get(float(s.max_range), 0.0) + w
    return tuple(sorted(terms.items()))


def reached_range_weight(weight: np.ndarray, reach: Sequence[tuple[float, np.ndarray]],
                         ranges: np.ndarray, step: int | None = None) -> np.ndarray:
    """Range information Σ 1/σ_r² [m⁻²] of the readings that reach the contact.

    ``weight − Σ_terms w_term·1[r > max_range]``: a reading whose sensor has a ``max_range``
    counts only where the range ``r`` is within it (:func:`range_reach_terms`); the others
    always count. Without a reach (``reach`` empty), or where every range is within it, the
    result is ``weight`` itself, bit for bit.

    Parameters
    ----------
    weight : ndarray, shape (..., K + 1)
        Range information per step of all the readings [m⁻²] (``PCRBInputs.ping_weight``).
    reach : sequence of (float, ndarray of shape (..., K + 1))
        ``(max_range [m], weight of its readings per step [m⁻²])``.
    ranges : ndarray
        Ranges [m]: shape (..., K + 1) (every step), or any shape (samples at ``step``).
    step : int, optional
        Only this step: ``weight`` and the terms are taken at ``step``.

    Returns
    -------
    ndarray
        The broadcast shape of ``ranges`` and ``weight`` (at ``step``) [m⁻²].
    """
    r = np.asarray(ranges, float)
    w = np.asarray(weight, float)
    out = np.broadcast_to(w if step is None else w[..., step], np.broadcast_shapes(
        r.shape, w.shape if step is None else w.shape[:-1])).copy()
    for max_range, wt in reach:
        part = np.asarray(wt, float) if step is None else np.asarray(wt, float)[..., step]
        out -= np.where(r > max_range, part, 0.0)
    return np.maximum(out, 0.0, out=out)  # no negative round-off where none reaches


def _check_prior_range_support(scenario: Scenario) -> None:
    p = scenario.prior
    if p is None or p.kind != "polar":
        return
    if p.range_min > 0.0:
        return
    bad = p.range_distribution in ("uniform", "log-uniform")
    if p.range_distribution == "normal" and p.range_std:
        rel = true_initial_state(scenario)[:2] - np.asarray(scenario.observer.position, float)
        mean = p.range_mean if p.range_mean is not None else float(np.hypot(*rel))
        bad = bad or ndtr(-mean / p.range_std) > 1e-12  # P(range < 0)
    if bad:
        raise ScenarioError(
            "prior.range_min",
            "> 0: the range prior puts mass at zero range, where ln r and the rates "
            "β̇, ṙ/r (∝ 1/r) are undefined, so the LPC prior information J₀ does not exist",
            p.range_min, source=scenario.name)


def information_rates(scenario: Scenario, *, t_start: float | None = None,
                      n_steps: int | None = None, include_start: bool = True,
                      sensors: Sequence[Any] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Bearing [rad⁻²] and range [m⁻²] information Σ 1/σ² per step k = 0..K, shape (K + 1,).

    The one per-step sensor-information function of the bounds and the planners (one bearing:
    1/σ_β², brehard2005 eq. 47; a range ping on ln r: ``E r²/σ_r²``, eq. 51). Step 0 is at
    ``t_start`` (default ``scenario.time.t0``; the grid is extended past the horizon if a plan
    needs it), K = ``n_steps`` (default the scenario's); ``include_start=False`` leaves step 0
    empty (a planner's belief at ``t_start`` already holds that measurement); ``sensors``
    counts only these of the scenario's sensors (default all; e.g. the passive range sensors).
    A non-finite ``t_start`` or an ``n_steps`` that is not an integer >= 0 is an
    :class:`ArgumentError`.
    """
    grid = scenario.time
    if t_start is not None:
        finite_real("t_start", t_start, "a finite time [s]", source=scenario.name)
    if n_steps is not None and not is_integer(n_steps, 0):
        raise ArgumentError("n_steps", "an integer >= 0", n_steps, source=scenario.name)
    k0 = 0 if t_start is None else round((float(t_start) - grid.t0) / grid.dt)
    K = grid.n_steps if n_steps is None else int(n_steps)
    if k0 + K > grid.n_steps:
        grid = TimeGrid(dt=grid.dt, horizon=grid.dt * max(k0 + K, 1), t0=grid.t0)
    info = {"bearing": np.zeros(K + 1), "range": np.zeros(K + 1)}
    for s in scenario.sensors if sensors is None else sensors:
        if isinstance(s, BearingSensor | RangeSensor):
            st = measurement_steps(s, grid) - k0
            st = st[(st >= (0 if include_start else 1)) & (st <= K)]
            np.add.at(info[s.kind], st, 1.0 / float(s.sigma) ** 2)
    return info["bearing"], info["range"]


def lpc_prior_information(samples: np.ndarray, weights: np.ndarray | None = None,
                          ) -> tuple[np.ndarray, np.ndarray]:
    """LPC covariance (4, 4) of weighted samples (n, 4) of X₀ and its inverse J₀ (eq. 56).

    The one prior information of the closed-form PCRB (brehard2005 eq. 56), for a scenario's
    prior and a planner's belief alike. Eq. 56 is printed as a scalar ``(Y−EY)ᵀ(Y−EY)``; it is
    the outer product about the mean (docs/errata.md), normalised by Σw (n for equal weights,
    as :attr:`Belief.cov`). The bearing is centred on its circular mean first (a prior
    straddling β = ±π is handled). Samples [m, m/s] must be at non-zero range; raises
    :class:`ObservabilityError` if the covariance is not positive definite,
    :class:`ArgumentError` for weights that are not finite, >= 0, of shape (n,) with Σw > 0.
    """
    Y = cart_to_lpc(np.asarray(samples, float))
    w = None if weights is None else np.asarray(weights, float)
    if w is not None and not (w.shape == Y.shape[:1] and np.all(np.isfinite(w))
                              and np.all(w >= 0.0) and w.sum() > 0.0):
        raise ArgumentError("weights", f"finite weights >= 0 of shape ({Y.shape[0]},) with a "
                            "positive sum", w)
    z = np.exp(1j * Y[:, 0])
    bm = np.angle(np.mean(z) if w is None else np.sum(w * z))
    Y[:, 0] = wrap_angle(Y[:, 0] - bm) + bm
    cov = np.cov(Y, rowvar=False, aweights=w, bias=True)
    var = np.diag(cov)
    msg = ("prior information J0 (inverse LPC prior covariance, brehard2005 eq. 56) is not "
           f"positive definite: LPC prior variances {var.tolist()} (a zero std in the prior?)")
    # a degenerate prior component leaves only round-off variance: judge on the correlation
    if not np.all(np.isfinite(cov)) or np.any(var <= 1e-24):
        raise ObservabilityError(msg)
    d = np.sqrt(var)
    if np.linalg.eigvalsh(cov / np.outer(d, d)).min() < 1e-10:
        raise ObservabilityError(msg)
    try:
        J0 = np.linalg.inv(cov)
        np.linalg.cholesky(J0)
    except np.linalg.LinAlgError as exc:
        raise ObservabilityError(msg) from exc
    return cov, 0.5 * (J0 + J0.T)


def prepare(scenario: Scenario, *, ping_steps: Sequence[int] | None = None,
            observer: ObserverTrack | None = None, prior_samples: int | None = None,
            rng: np.random.Generator | None = None, lpc: bool = True) -> PCRBInputs:
    """Resolve a scenario into :class:`PCRBInputs`.

    Parameters
    ----------
    scenario : Scenario
        Needs a ``prior`` and an NCV target (the PCRB's dynamics).
    ping_steps : sequence of int, optional
        See :func:`resolve_ping_steps`.
    observer : ObserverTrack, optional
        Default: the scenario's scripted observer.
    prior_samples : int, optional
        Default ``scenario.prior.samples``.
    rng : numpy.random.Generator, optional
        For the prior samples; default ``default_rng(scenario.prior.seed)`` (reproducible).
    lpc : bool
        Form the LPC prior (eq. 56) and check the prior for mass at zero range; a Cartesian
        PCRB does not need either (``cov_lpc0`` is then None).
    """
    if scenario.prior is None:
        raise ScenarioError("prior", "a [prior] table (the PCRB needs a prior)", None,
                            source=scenario.name)
    if scenario.target.model == "constant-turn":
        raise ScenarioError("target.model", "'ncv' or 'multi-leg' (the PCRB uses NCV dynamics)",
                            scenario.target.model, source=scenario.name)
    grid = scenario.time
    K = grid.n_steps
    obs = observer if observer is not None else observer_track(scenario.observer, grid)
    if obs.position.shape[0] != K + 1:
        raise ArgumentError("observer", f"a track with {K + 1} steps",
                            f"{obs.position.shape[0]} steps", source=scenario.name)
    A, Q = ncv_matrices(grid.dt, float(scenario.target.q))
    dv = obs.velocity_increments
    c = -np.hstack([grid.dt * dv, dv])

    bearing_info = information_rates(scenario)[0]
    freq: list[tuple[Any, np.ndarray]] = []
    ambiguity = "none"
    for s in scenario.sensors:
        st = measurement_steps(s, grid)
        if isinstance(s, BearingSensor) and s.ambiguity == "pi":
            ambiguity = "pi"
        elif isinstance(s, FrequencySensor):
            freq.append((s, st[st <= K]))
    steps, weight, sigma = resolve_ping_steps(scenario, ping_steps)

    if lpc:
        _check_prior_range_support(scenario)
    if prior_samples is not None and not is_integer(prior_samples, 10):
        raise ArgumentError("prior_samples", "an integer >= 10", prior_samples,
                            source=scenario.name)
    n = int(prior_samples) if prior_samples is not None else scenario.prior.samples
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise ArgumentError("rng", "a numpy.random.Generator", type(rng).__name__,
                            source=scenario.name)
    rng = np.random.default_rng(scenario.prior.seed) if rng is None else rng
    X0 = relative_prior_samples(scenario, n, rng, obs.state[0])
    cov_lpc = None
    if lpc:
        r = np.hypot(X0[:, 0], X0[:, 1])
        if r.min() < MIN_PRIOR_RANGE:
            raise ScenarioError("prior", f"no prior mass within {MIN_PRIOR_RANGE} m of the "
                                "observer (ln r and 1/r diverge at zero range)",
                                f"a sample at range {r.min():.3g} m", source=scenario.name)
        try:
            cov_lpc = lpc_prior_information(X0)[0]
        except ObservabilityError as exc:
            if not (zero := zero_prior_stds(scenario.prior)):
                raise
            raise ScenarioError(zero[0], "a std > 0 (the closed-form bound's prior information "
                                "J0, brehard2005 eq. 56, is not positive definite for a prior "
                                f"without a density; zero stds: {', '.join(zero)})", 0.0,
                                source=scenario.name) from exc
    m0 = X0.mean(axis=0)
    S0 = X0.T @ X0 / n
    return PCRBInputs(
        times=np.asarray(grid.times), dt=float(grid.dt), A=A, Q=Q, observer=obs, c=c,
        bearing_info=bearing_info, ambiguity=ambiguity,
        ping_steps=steps, ping_weight=weight, range_sigma=sigma,
        range_reach=range_reach_terms(scenario, ping_steps), frequency_sensors=tuple(freq),
        prior_samples=n, m0=m0, S0=S0, cov_cart0=relative_prior_covariance(scenario, X0),
        cov_lpc0=cov_lpc,
        prior_subsample=X0[:500].copy())
