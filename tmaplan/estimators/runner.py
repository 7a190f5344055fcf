"""Common runner of the estimators and their Monte Carlo evaluation against a bound.

``run(estimator, scenario, measurements) -> Track`` runs one estimator on one set of
measurements; ``monte_carlo(scenario, estimator, runs=..., seed=...)`` repeats it over runs
seeded from one ``numpy.random.SeedSequence(seed)`` (one child per run) and compares the RMSE
with the bound: for the filters the PCRB along the runs' true trajectories, averaged over the
runs (:func:`tmaplan.estimators.truth_bound.truth_pcrb`, BENCHMARK_SCENARIOS §B2; option
``bound="prior"``: the prior-averaged PCRB of ``tmaplan.bounds.pcrb.monte_carlo_pcrb``,
see :func:`_pcrb_position`), the CRLB of the batch estimate for the MLE.

Priors. The papers centre their priors on the truth; following Ristic et al. (BENCHMARK B2)
the *centre* of the prior is itself random per run: :func:`run_prior` draws the prior bearing
(the measured bearing at step 0 when there is one), range, speed / velocity means from the
prior around the truth, and the filter's particles are drawn around that centre. The estimator
never sees the true state.
"""

from __future__ import annotations

import dataclasses
import time as _time
import warnings
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.errors import ScenarioError
from tmaplan.estimators.init_bearings import initialise_from_bearings
from tmaplan.estimators.mle import MLEConfig, mle, state_track, tma_data
from tmaplan.estimators.particle_filter import (
    DegeneracyWarning,
    Measurement,
    ParticleFilter,
    PFConfig,
)
from tmaplan.estimators.range_only import (
    RangeOnlyConfig,
    RangeOnlyState,
    range_only_predict,
    range_only_update,
)
from tmaplan.estimators.range_only_gm import (
    RangeOnlyMixture,
    mixture_from_gaussian,
    mixture_predict,
    mixture_update,
)
from tmaplan.estimators.truth_bound import truth_bounds
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import prior_relative_moments, relative_prior_samples
from tmaplan.simulate import MeasurementSet, Simulation, simulate

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "ESTIMATORS",
    "MonteCarloResult",
    "Track",
    "measurement_batches",
    "monte_carlo",
    "run",
    "run_prior",
]

ESTIMATORS = ("pf", "pf-bearings", "mle", "range-only")
EstimatorName = Literal["pf", "pf-bearings", "mle", "range-only"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Track:
    """Output of one estimator run.

    Attributes
    ----------
    estimator : str
    times : ndarray, shape (K + 1,)
        [s].
    estimates : ndarray, shape (K + 1, 4)
        Relative state estimates ``[r_x, r_y, v_x, v_y]`` [m, m/s]; NaN before the estimator
        has one (e.g. before the bearings-only initialisation).
    covariances : ndarray, shape (K + 1, 4, 4)
        Posterior (filters) or delta-method CRLB-at-estimate (MLE) covariances.
    ess : ndarray or None, shape (K + 1,)
        Particle filter: effective sample size after each update; range-only mixture: the
        number of mixture components after each scan.
    seconds : float
        Wall time [s].
    status : str
        "ok", "recovered" (a degeneracy was recovered by roughening), "rejected" (MLE failed
        the acceptance test), "failed".
    message : str
    first_step : int
        First step with an estimate.
    details : Any
        Estimator-specific result (MLEResult, BearingsInit) or None.
    """

    estimator: str
    times: np.ndarray
    estimates: np.ndarray
    covariances: np.ndarray
    ess: np.ndarray | None
    seconds: float
    status: str
    message: str = ""
    first_step: int = 0
    details: Any = None


# --------------------------------------------------------------------------------------------
# Measurements and priors
# --------------------------------------------------------------------------------------------


def measurement_batches(scenario: Scenario, measurements: Sequence[MeasurementSet],
                        observer: ObserverTrack) -> dict[int, list[Measurement]]:
    """Group measurement sets into per-step :class:`Measurement` lists for the filters."""
    out: dict[int, list[Measurement]] = {}
    offset = observer.velocity - observer.mean_velocity
    for ms in measurements:
        sensor = scenario.sensors[ms.sensor]
        for i, k in enumerate(np.asarray(ms.steps, int)):
            if ms.kind == "bearing":
                m = Measurement(kind="bearing", value=float(ms.values[i]),
                                sigma=float(ms.sigma), ambiguity=sensor.ambiguity)
            elif ms.kind == "range":
                m = Measurement(kind="range", value=float(ms.values[i]), sigma=float(ms.sigma))
            else:
                m = Measurement(kind="frequency", value=np.asarray(ms.values[i], float),
                                sigma=np.asarray(ms.sigma, float), c=float(sensor.c),
                                velocity_offset=offset[k])
            out.setdefault(int(k), []).append(m)
    return out


def run_prior(scenario: Scenario, rng: np.random.Generator,
              measurements: Sequence[MeasurementSet] | None = None) -> Scenario:
    """The scenario with its prior *centre* drawn for this run (Ristic-style, B2).

    Fields of the polar prior that default to the truth (``bearing_mean``, ``range_mean``,
    ``speed_mean``, ``velocity_mean``) are replaced by a draw around the truth with the
    prior's own std; the bearing mean is the measured bearing at step 0 when there is one.
    Gaussian priors with ``mean = None`` get ``mean = truth + std·N(0, 1)``.
    """
    from tmaplan.models.prior import true_initial_state

    p = scenario.prior
    if p is None:
        raise ScenarioError("prior", "a [prior] table for this estimator", None,
                            source=scenario.name)
    truth = true_initial_state(scenario)
    if p.kind == "gaussian":
        if p.mean is not None:
            return scenario
        mean = truth + np.asarray(p.std, float) * rng.standard_normal(4)
        return scenario.replace(prior=dataclasses.replace(p, mean=tuple(float(x) for x in mean)))
    rel = truth[:2] - np.asarray(scenario.observer.position, float)
    changes: dict[str, Any] = {}
    if p.bearing_mean is None:
        z0 = None
        for ms in measurements or ():
            if ms.kind == "bearing" and ms.steps.size and ms.steps[0] == 0:
                z0 = float(ms.values[0])
        if z0 is None:
            z0 = float(np.arctan2(rel[0], rel[1]) + p.bearing_std * rng.standard_normal())
        changes["bearing_mean"] = z0
    if p.range_mean is None:
        r = float(np.hypot(*rel)) + float(p.range_std or 0.0) * rng.standard_normal()
        lo = max(p.range_min, 1e-3)
        hi = p.range_max if p.range_max is not None else np.inf
        changes["range_mean"] = float(np.clip(r, lo, hi))
    v = truth[2:]
    if p.velocity_distribution == "normal" and p.velocity_mean is None:
        changes["velocity_mean"] = tuple(float(x) for x in v + p.velocity_std
                                         * rng.standard_normal(2))
    if p.velocity_distribution == "speed-course" and p.speed_distribution == "normal" \
            and p.speed_mean is None:
        s = float(np.hypot(*v)) + p.speed_std * rng.standard_normal()
        changes["speed_mean"] = float(max(s, p.speed_min))
    return scenario.replace(prior=dataclasses.replace(p, **changes))


def _observer_of(scenario: Scenario, measurements: Any, observer: ObserverTrack | None
                 ) -> tuple[Sequence[MeasurementSet], ObserverTrack]:
    if isinstance(measurements, Simulation):
        return measurements.measurements, observer or measurements.observer
    return measurements, observer or observer_track(scenario.observer, scenario.time)


# --------------------------------------------------------------------------------------------
# Runners
# --------------------------------------------------------------------------------------------


def _run_pf(scenario: Scenario, meas: Sequence[MeasurementSet], obs: ObserverTrack,
            rng: np.random.Generator, config: PFConfig, init: str,
            r_min: float, r_max: float) -> Track:
    K = scenario.n_steps
    pf = ParticleFilter(config)
    batches = measurement_batches(scenario, meas, obs)
    dv = obs.velocity_increments
    est = np.full((K + 1, 4), np.nan)
    cov = np.full((K + 1, 4, 4), np.nan)
    ess = np.full(K + 1, np.nan)
    details = None
    recovered = False
    if init == "bearings":
        b = [m for m in meas if m.kind == "bearing"]
        if not b:
            raise ScenarioError("sensors", "a bearing sensor for the bearings-only "
                                "initialisation", None, source=scenario.name)
        steps, z = b[0].steps, b[0].values
        sensor = scenario.sensors[b[0].sensor]
        # The batch must not straddle an observer manoeuvre (eq. 13 assumes none).
        moving = np.nonzero(np.any(np.abs(dv) > 1e-9, axis=1))[0]
        first_man = int(moving[0]) if moving.size else K
        n_ok = int(np.searchsorted(steps, first_man, side="right"))
        init_res = initialise_from_bearings(
            scenario.times[steps[:n_ok]], z[:n_ok], float(b[0].sigma), r_min=r_min,
            r_max=r_max, n_particles=config.n_particles, rng=rng, q=config.q,
            dt=config.dt * float(np.median(np.diff(steps))) if steps.size > 1 else None,
            ambiguity=sensor.ambiguity)
        details = init_res
        k_c, k_e = int(steps[init_res.centre_index]), int(steps[init_res.end_index])
        state = pf.from_particles(init_res.particles, step=k_c)
        est[k_c], cov[k_c], ess[k_c] = state.mean, state.cov, state.ess
        # Catch up to the batch end without re-assimilating bearings already in the batch.
        for k in range(k_c, k_e):
            state = pf.predict(state, dv[k], rng)
            extra = [m for m in batches.get(k + 1, []) if m.kind != "bearing"]
            if extra:
                state = pf.update(state, extra, rng)
            est[k + 1], cov[k + 1], ess[k + 1] = state.mean, state.cov, state.ess
        start = k_e
        first = k_c
    else:
        sc = run_prior(scenario, rng, meas)
        state = pf.from_particles(relative_prior_samples(sc, config.n_particles, rng), step=0)
        with warnings.catch_warnings(record=True) as wlist:
            warnings.simplefilter("always", DegeneracyWarning)
            state = pf.update(state, batches.get(0, []), rng)
        recovered |= bool(wlist)
        est[0], cov[0], ess[0] = state.mean, state.cov, state.ess
        start = 0
        first = 0
    with warnings.catch_warnings(record=True) as wlist:
        warnings.simplefilter("always", DegeneracyWarning)
        for k in range(start, K):
            state = pf.predict(state, dv[k], rng)
            state = pf.update(state, batches.get(k + 1, []), rng)
            est[k + 1], cov[k + 1], ess[k + 1] = state.mean, state.cov, state.ess
    recovered |= bool(wlist)
    if not np.isfinite(est[first:]).all():
        return Track(estimator="pf", times=scenario.times, estimates=est, covariances=cov,
                     ess=ess, seconds=0.0, status="failed", message="non-finite estimate",
                     first_step=first, details=details)
    return Track(estimator="pf-bearings" if init == "bearings" else "pf", times=scenario.times,
                 estimates=est, covariances=cov, ess=ess, seconds=0.0,
                 status="recovered" if recovered else "ok",
                 message=f"{len(wlist)} degeneracy recoveries" if recovered else "",
                 first_step=first, details=details)


def _run_range_only(scenario: Scenario, meas: Sequence[MeasurementSet], obs: ObserverTrack,
                    rng: np.random.Generator, config: RangeOnlyConfig) -> Track:
    K = scenario.n_steps
    sc = run_prior(scenario, rng, meas)
    mean, P = prior_relative_moments(sc, 20_000, rng)
    ranges: dict[int, tuple[float, float]] = {}
    for ms in meas:
        if ms.kind == "range":
            for i, k in enumerate(ms.steps):
                ranges[int(k)] = (float(ms.values[i]), float(ms.sigma))
    dv = obs.velocity_increments
    est = np.full((K + 1, 4), np.nan)
    cov = np.full((K + 1, 4, 4), np.nan)
    mixture = config.mode == "mixture"
    n_comp = np.zeros(K + 1)
    if mixture:
        mcfg = config.mixture()
        gm: RangeOnlyMixture = mixture_from_gaussian(mean, P)
        for k in range(K + 1):
            if k > 0:
                gm = mixture_predict(gm, dv[k - 1], mcfg)
            if k in ranges:
                gm = mixture_update(gm, *ranges[k], mcfg)
            est[k], cov[k], n_comp[k] = gm.mean, gm.cov, gm.n_components
        final: Any = gm
    else:
        st = RangeOnlyState(step=0, mean=mean, cov=P)
        for k in range(K + 1):
            if k > 0:
                st = range_only_predict(st, dv[k - 1], config)
            if k in ranges:
                st = range_only_update(st, *ranges[k], config)
            est[k], cov[k] = st.mean, st.cov
        final = st
    ok = np.isfinite(est).all()
    return Track(estimator="range-only", times=scenario.times, estimates=est, covariances=cov,
                 ess=n_comp if mixture else None, seconds=0.0,
                 status="ok" if ok else "failed",
                 message=f"mode {config.mode}", details=final)


def _run_mle(scenario: Scenario, meas: Sequence[MeasurementSet], obs: ObserverTrack,
             config: MLEConfig) -> Track:
    model = None if config.model == "auto" else config.model
    data = tma_data(scenario, meas, obs, model=model, frequencies=config.frequencies)
    res = mle(data, config)
    S, C = state_track(data, res.params, res.covariance, scenario.times)
    rel = S - obs.state
    status = "ok" if res.success else ("rejected" if res.status == "converged" else "failed")
    return Track(estimator="mle", times=scenario.times, estimates=rel,
                 covariances=C if C is not None else np.full((rel.shape[0], 4, 4), np.nan),
                 ess=None, seconds=0.0, status=status,
                 message=f"{res.status}; cost {res.cost:.1f} vs threshold {res.threshold:.1f}",
                 first_step=0, details=res)


def run(estimator: EstimatorName | PFConfig | MLEConfig | RangeOnlyConfig, scenario: Scenario,
        measurements: Simulation | Sequence[MeasurementSet], *,
        rng: np.random.Generator | None = None, observer: ObserverTrack | None = None,
        n_particles: int = 10_000, q: float | None = None, r_min: float = 1000.0,
        r_max: float = 40000.0) -> Track:
    """Run one estimator on one set of measurements.

    Parameters
    ----------
    estimator : {"pf", "pf-bearings", "mle", "range-only"} or a config
        "pf": particle filter from the prior; "pf-bearings": from bearings only (file 001).
        A :class:`PFConfig` runs the prior-initialised PF with it.
    scenario : Scenario
    measurements : Simulation or sequence of MeasurementSet
    rng : numpy.random.Generator, optional
        Needed by the filters (default: a fresh unseeded generator).
    observer : ObserverTrack, optional
        Default: from the Simulation, else the scenario's scripted observer.
    n_particles : int
        PF only (when ``estimator`` is a name).
    q : float, optional
        Filter process noise [m²/s³] (default: the scenario target's q).
    r_min, r_max : float
        Range interval of the bearings-only initialisation [m] (file 001 L291).

    Returns
    -------
    Track
    """
    meas, obs = _observer_of(scenario, measurements, observer)
    rng = rng if rng is not None else np.random.default_rng()
    qf = float(scenario.target.q if q is None else q)
    t0 = _time.perf_counter()
    if isinstance(estimator, PFConfig):
        tr = _run_pf(scenario, meas, obs, rng, estimator, "prior", r_min, r_max)
    elif isinstance(estimator, MLEConfig):
        tr = _run_mle(scenario, meas, obs, estimator)
    elif isinstance(estimator, RangeOnlyConfig):
        tr = _run_range_only(scenario, meas, obs, rng, estimator)
    elif estimator in ("pf", "pf-bearings"):
        cfg = PFConfig(n_particles=n_particles, dt=scenario.time.dt, q=qf)
        tr = _run_pf(scenario, meas, obs, rng, cfg,
                     "bearings" if estimator == "pf-bearings" else "prior", r_min, r_max)
    elif estimator == "mle":
        tr = _run_mle(scenario, meas, obs, MLEConfig())
    elif estimator == "range-only":
        tr = _run_range_only(scenario, meas, obs, rng,
                             RangeOnlyConfig(dt=scenario.time.dt, q=qf))
    else:
        raise ScenarioError("estimator", f"one of {', '.join(ESTIMATORS)}", estimator)
    return dataclasses.replace(tr, seconds=_time.perf_counter() - t0)


# --------------------------------------------------------------------------------------------
# Bounds
# --------------------------------------------------------------------------------------------


def _pcrb_position(scenario: Scenario, rng: np.random.Generator, samples: int) -> np.ndarray:
    """Prior-averaged Cartesian PCRB position std (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`)."""
    from tmaplan.bounds.pcrb import monte_carlo_pcrb

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # side-assumption notes concern the LPC bound only
        res = monte_carlo_pcrb(scenario, samples=samples, rng=rng, coords="cartesian")
    return np.asarray(res.position_std, float)


def _crlb_bounds(scenario: Scenario, config: MLEConfig) -> tuple[np.ndarray, np.ndarray]:
    """Position and range std of the batch CRLB at the truth, per step [m]."""
    from tmaplan.estimators.mle import fisher_information

    sim = simulate(scenario, None)
    model = None if config.model == "auto" else config.model
    data = tma_data(scenario, sim.measurements, sim.observer, model=model,
                    frequencies=config.frequencies)
    t = scenario.target
    if data.model == "constant-turn":
        geom = np.array([*t.centre, t.radius, t.phase, t.omega], float)
    else:
        # cv / multi-leg: truth = initial position and one velocity per leg
        vel = [sim.target[0, 2:]] + [sim.target[np.searchsorted(scenario.times, s), 2:]
                                     for s in data.leg_starts]
        geom = np.concatenate([sim.target[0, :2], *vel])
    f0 = []
    if data.n_lines:
        fs = next(s for s in scenario.sensors if s.kind == "frequency")
        f0 = list(fs.f0[: data.n_lines])
    p = np.concatenate([geom, f0])
    C = np.linalg.inv(fisher_information(data, p))
    S, Cs = state_track(data, p, C, scenario.times)
    assert Cs is not None
    rel = S[:, :2] - sim.observer.position
    u = rel / np.hypot(rel[:, 0], rel[:, 1])[:, None]
    return (np.sqrt(np.trace(Cs[:, :2, :2], axis1=1, axis2=2)),
            np.sqrt(np.einsum("ki,kij,kj->k", u, Cs[:, :2, :2], u)))


# --------------------------------------------------------------------------------------------
# Monte Carlo
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class MonteCarloResult:
    """Monte Carlo evaluation of an estimator (DESIGN §4 ``track`` fields).

    Attributes
    ----------
    problem, estimator : str
    runs, seed : int
    times : ndarray, shape (K + 1,)
        [s].
    rmse_position, rmse_range : ndarray, shape (K + 1,)
        Over the runs that were not rejected or failed [m]; NaN where no estimate.
    bound_position : ndarray, shape (K + 1,)
        PCRB (filters: along the runs' truths, or prior-averaged, see ``bound_kind``) or CRLB
        (MLE) position std [m].
    bound_range : ndarray, shape (K + 1,)
        Range std of the same bound (delta method along the true line of sight) [m]; NaN for
        the prior-averaged bound.
    bound_kind : str
        "truth", "prior", "crlb" or "none".
    divergence_rate : float
        Fraction of runs rejected, failed, or ending with a position error > 5× the bound.
    nees : ndarray, shape (K + 1,)
        Average normalised estimation error squared (4-D) over the used runs.
    position_errors : ndarray, shape (runs, K + 1)
        [m].
    statuses : tuple of str
    seconds : float
        Total wall time [s].
    ambiguous_runs : int
        MLE: runs whose estimate has a statistically indistinguishable distinct alternative
        (:attr:`tmaplan.estimators.mle.MLEResult.alternatives`); 0 for the filters.
    """

    problem: str
    estimator: str
    runs: int
    seed: int
    times: np.ndarray
    rmse_position: np.ndarray
    rmse_range: np.ndarray
    bound_position: np.ndarray
    bound_range: np.ndarray
    bound_kind: str
    divergence_rate: float
    nees: np.ndarray
    position_errors: np.ndarray
    statuses: tuple[str, ...]
    seconds: float
    ambiguous_runs: int = 0

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (SI units)."""
        return {"problem": self.problem, "estimator": self.estimator, "runs": self.runs,
                "seed": self.seed, "times": self.times, "rmse_position": self.rmse_position,
                "rmse_range": self.rmse_range, "bound_position": self.bound_position,
                "bound_range": self.bound_range,
                "bound_kind": self.bound_kind, "divergence_rate": self.divergence_rate,
                "nees": self.nees,
                "rejected": sum(s in ("rejected", "failed") for s in self.statuses),
                "ambiguous_runs": self.ambiguous_runs,
                "seconds": self.seconds}


def monte_carlo(scenario: Scenario, estimator: EstimatorName | PFConfig | MLEConfig
                | RangeOnlyConfig, *, runs: int, seed: int = 0, n_particles: int = 10_000,
                bound: bool | Literal["truth", "prior"] = True, bound_samples: int = 2000,
                progress: Callable[[int, int], None] | None = None,
                **run_kwargs: Any) -> MonteCarloResult:
    """Monte Carlo runs of one estimator: truth + measurements + estimate per run.

    Parameters
    ----------
    scenario : Scenario
    estimator : str or config
        As for :func:`run`.
    runs : int
    seed : int
        Root of ``numpy.random.SeedSequence(seed)``; child i seeds run i (simulation and
        estimator share the child's generator, in that order).
    n_particles : int
    bound : bool or {"truth", "prior"}
        Compute the bound (False: NaN). Filters: True / "truth" is the PCRB along each run's
        true trajectory with ``J_0 = P_0⁻¹`` (prior centred on the truth), averaged over the
        runs (BENCHMARK §B2, Ristic's bound); "prior" is the PCRB averaged over trajectories
        drawn from the prior (optimistic before an unobservable geometry becomes observable).
        The MLE always uses the CRLB at the truth.
    bound_samples : int
        Monte Carlo samples of the prior-averaged PCRB.
    progress : callable(done, total), optional
    **run_kwargs
        Passed to :func:`run`.

    Returns
    -------
    MonteCarloResult
    """
    if runs < 1:
        raise ScenarioError("runs", ">= 1", runs)
    t0 = _time.perf_counter()
    K = scenario.n_steps
    err_pos = np.full((runs, K + 1), np.nan)
    err_rng = np.full((runs, K + 1), np.nan)
    nees = np.full((runs, K + 1), np.nan)
    statuses = []
    ambiguous = 0
    truths = np.zeros((runs, K + 1, 4))
    children = np.random.SeedSequence(seed).spawn(runs + 1)
    for i in range(runs):
        rng = np.random.default_rng(children[i])
        sim = simulate(scenario, rng)
        truths[i] = sim.relative
        tr = run(estimator, scenario, sim, rng=rng, n_particles=n_particles, **run_kwargs)
        statuses.append(tr.status)
        ambiguous += bool(getattr(tr.details, "ambiguous", False))
        e = tr.estimates - sim.relative
        err_pos[i] = np.hypot(e[:, 0], e[:, 1])
        err_rng[i] = np.hypot(tr.estimates[:, 0], tr.estimates[:, 1]) - np.hypot(
            sim.relative[:, 0], sim.relative[:, 1])
        with np.errstate(invalid="ignore"):
            try:
                sol = np.linalg.solve(tr.covariances, e[..., None])[..., 0]
                nees[i] = np.einsum("ki,ki->k", e, sol)
            except (np.linalg.LinAlgError, ValueError):
                pass
        if progress is not None:
            progress(i + 1, runs)
    name = estimator if isinstance(estimator, str) else type(estimator).__name__
    kind = "none"
    if bound:
        brng = np.random.default_rng(children[runs])
        if name == "mle" or isinstance(estimator, MLEConfig):
            cfg = estimator if isinstance(estimator, MLEConfig) else MLEConfig()
            (b, br), kind = _crlb_bounds(scenario, cfg), "crlb"
        elif bound == "prior":
            b, kind = _pcrb_position(scenario, brng, bound_samples), "prior"
            br = np.full(K + 1, np.nan)
        elif bound is True or bound == "truth":
            (b, br), kind = truth_bounds(scenario, truths), "truth"
        else:
            raise ScenarioError("bound", "True, False, 'truth' or 'prior'", bound)
    else:
        b = br = np.full(K + 1, np.nan)
    used = np.array([s not in ("rejected", "failed") for s in statuses])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rmse_p = np.sqrt(np.nanmean(err_pos[used] ** 2, axis=0)) if used.any() \
            else np.full(K + 1, np.nan)
        rmse_r = np.sqrt(np.nanmean(err_rng[used] ** 2, axis=0)) if used.any() \
            else np.full(K + 1, np.nan)
        mean_nees = np.nanmean(nees[used], axis=0) if used.any() else np.full(K + 1, np.nan)
    final_bad = ~used | ~(err_pos[:, -1] <= 5.0 * b[-1]) if bound else ~used
    return MonteCarloResult(problem=scenario.name, estimator=str(name), runs=runs, seed=seed,
                            times=scenario.times, rmse_position=rmse_p, rmse_range=rmse_r,
                            bound_position=b, bound_range=br, bound_kind=kind,
                            divergence_rate=float(np.mean(final_bad)),
                            nees=mean_nees, position_errors=err_pos, statuses=tuple(statuses),
                            seconds=_time.perf_counter() - t0, ambiguous_runs=ambiguous)
