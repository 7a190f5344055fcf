"""Running one estimator on one set of measurements: the estimator interface and :func:`run`.

An estimator (:class:`Estimator`) declares its ``name``, the sensor kinds it ``applies_to`` and
the ``bound`` it is judged against, and ``estimate`` s a :class:`Track` from a scenario, its
measurements and the observer track. Implementations: :class:`FilterEstimator` (a recursive
:class:`tmaplan.estimators.filter.Filter` driven by :func:`tmaplan.estimators.filter.drive`:
the particle filter from the prior or from bearings only, the range-only filter) and
:class:`MLEEstimator`. :func:`run` accepts a name of :data:`ESTIMATORS`, an estimator or a
filter / MLE configuration; the Monte Carlo evaluation is
:func:`tmaplan.evaluation.tracking.monte_carlo`.

Priors. The papers centre their priors on the truth; following Ristic et al. (ristic2004, ch. 6)
the *centre* of the prior is itself random per run: :func:`run_prior` draws the prior bearing
(the measured bearing at step 0 when there is one, which the filter then does not assimilate
a second time), range, speed / velocity means from the prior around the truth, and the
filter's particles are drawn around that centre. The estimator never sees the true state.
"""

from __future__ import annotations

import dataclasses
import time as _time
import warnings
from collections.abc import Callable, Sequence
from typing import (
    Any,
    ClassVar,
    Literal,
    Protocol,
    get_args,
    runtime_checkable,
)

import numpy as np

from tmaplan.bounds.batch_fim import tma_data
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, ScenarioError
from tmaplan.estimators.applicability import APPLICABILITY, Applicability
from tmaplan.estimators.filter import Filter, drive
from tmaplan.estimators.init_bearings import initialise_from_bearings
from tmaplan.estimators.mle import MLEConfig, mle, state_track
from tmaplan.estimators.particle_filter import DegeneracyWarning, ParticleFilter, PFConfig
from tmaplan.estimators.range_only import RangeOnlyConfig, RangeOnlyFilter
from tmaplan.geometry import bearing_of, range_of
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import true_initial_state
from tmaplan.scenario import Scenario
from tmaplan.simulate import Measurement, MeasurementSet, Simulation, measurement_batches

__all__ = [
    "ESTIMATORS",
    "Estimator",
    "FilterEstimator",
    "MLEEstimator",
    "Track",
    "estimator_for",
    "run",
    "run_prior",
    "seed_bearings",
]

#: Estimator names (CLI ``track --estimator``); each is built by :data:`_NAMED` below, where a
#: new filter is named.
EstimatorName = Literal["pf", "pf-bearings", "mle", "range-only"]
ESTIMATORS: tuple[str, ...] = get_args(EstimatorName)


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
        Filters: :meth:`~tmaplan.estimators.filter.Filter.diagnostic` per step (particle
        filter: effective sample size; range-only filter: number of mixture components).
    seconds : float
        Wall time [s].
    status : str
        "ok", "recovered" (a degeneracy was recovered by roughening), "rejected" (MLE failed
        the acceptance test), "unobservable" (MLE whose range the data do not determine,
        :attr:`tmaplan.estimators.mle.MLEResult.relative_range_std`), "failed".
    message : str
    first_step : int
        First step with an estimate.
    details : Any
        Estimator-specific result: MLEResult, BearingsInit (``pf-bearings``) or the filter's
        last state.
    """

    __repr__ = short_repr

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
# Priors
# --------------------------------------------------------------------------------------------


def run_prior(scenario: Scenario, rng: np.random.Generator,
              measurements: Sequence[MeasurementSet] | None = None) -> Scenario:
    """The scenario with its prior *centre* drawn for this run (Ristic-style, B2).

    Fields of the polar prior that default to the truth (``bearing_mean``, ``range_mean``,
    ``speed_mean``, ``velocity_mean``) are replaced by a draw around the truth with the
    prior's own std; the bearing mean is the measured bearing at step 0 when there is one
    (:func:`seed_bearings`; the estimators then do not assimilate that bearing again).
    Gaussian priors with ``mean = None`` get ``mean = truth + std·N(0, 1)``. Every mean being
    given then, the drawn prior has ``centred_on_truth`` off (a prior refuses it then).
    """
    p = scenario.prior
    if p is None:
        raise ScenarioError("prior", "a [prior] table for this estimator", None,
                            source=scenario.name)
    truth = true_initial_state(scenario)
    if p.kind == "gaussian":
        if p.mean is not None:
            return scenario
        mean = truth + np.asarray(p.std, float) * rng.standard_normal(4)
        m0, m1, m2, m3 = (float(x) for x in mean)
        return scenario.replace(prior=dataclasses.replace(p, mean=(m0, m1, m2, m3),
                                                          centred_on_truth=False))
    rel = truth[:2] - np.asarray(scenario.observer.position, float)
    changes: dict[str, Any] = {}
    if p.bearing_mean is None:
        seed = seed_bearings(scenario, measurements)
        z0 = (float(seed.values[0]) if seed is not None
              else float(bearing_of(rel) + p.bearing_std * rng.standard_normal()))
        changes["bearing_mean"] = z0
    if p.range_mean is None:
        r = float(range_of(rel)) + float(p.range_std or 0.0) * rng.standard_normal()
        lo = max(p.range_min, 1e-3)
        hi = p.range_max if p.range_max is not None else np.inf
        if p.range_distribution == "normal":  # drawn anyway: the run's random stream stays
            changes["range_mean"] = float(np.clip(r, lo, hi))
    v = truth[2:]
    if p.velocity_distribution == "normal" and p.velocity_mean is None:
        changes["velocity_mean"] = tuple(float(x) for x in v + p.velocity_std
                                         * rng.standard_normal(2))
    if p.velocity_distribution == "speed-course" and p.speed_distribution == "normal" \
            and p.speed_mean is None:
        s = float(range_of(v)) + p.speed_std * rng.standard_normal()
        s_hi = p.speed_max if p.speed_max is not None else np.inf
        # within [speed_min, speed_max] as the range mean: a draw far outside would leave
        # the truncated normal no mass (refused by models.prior.check_truncated_normal)
        changes["speed_mean"] = float(np.clip(s, p.speed_min, s_hi))
    # every mean is given now: the truth opt-in goes (a prior refuses it then)
    return scenario.replace(prior=dataclasses.replace(p, **changes, centred_on_truth=False))


def seed_bearings(scenario: Scenario, measurements: Sequence[MeasurementSet] | None
                  ) -> MeasurementSet | None:
    """The bearing set whose step-0 bearing centres the prior in :func:`run_prior`, or None.

    The first set of a sensor without ambiguity (a bearing known modulo π does not give the
    side) with a bearing at step 0, when the scenario's polar prior leaves ``bearing_mean`` to
    the run. As in ristic2004 (ch. 6) that bearing *seeds* the prior: a filter started from
    the prior must not assimilate it again (its information would count twice).
    """
    p = scenario.prior
    if p is None or p.kind != "polar" or p.bearing_mean is not None:
        return None
    for ms in measurements or ():
        if ms.kind == "bearing" and ms.steps.size and ms.steps[0] == 0 \
                and getattr(scenario.sensors[ms.sensor], "ambiguity", "none") == "none":
            return ms
    return None


def _observer_of(scenario: Scenario, measurements: Any, observer: ObserverTrack | None
                 ) -> tuple[Sequence[MeasurementSet], ObserverTrack]:
    if isinstance(measurements, Simulation):
        return measurements.measurements, observer or measurements.observer
    return measurements, observer or observer_track(scenario.observer, scenario.time)


# --------------------------------------------------------------------------------------------
# Estimators
# --------------------------------------------------------------------------------------------


@runtime_checkable
class Estimator(Protocol):
    """What :func:`run` and the Monte Carlo evaluation need of an estimator."""

    #: The bound it is compared with: "pcrb" (filters) or "crlb" (batch estimates).
    bound: ClassVar[Literal["pcrb", "crlb"]]

    @property
    def name(self) -> str:
        """Name in :data:`ESTIMATORS` (CLI ``--estimator``)."""

    @property
    def applies_to(self) -> frozenset[str]:
        """Sensor kinds the estimator uses; the scenario needs at least one of them."""

    def estimate(self, scenario: Scenario, measurements: Sequence[MeasurementSet],
                 observer: ObserverTrack, rng: np.random.Generator) -> Track:
        """One estimate of the relative track."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilterEstimator:
    """A recursive filter run over the time grid (:func:`tmaplan.estimators.filter.drive`).

    Attributes
    ----------
    filter : Filter
        :class:`~tmaplan.estimators.particle_filter.ParticleFilter` or
        :class:`~tmaplan.estimators.range_only.RangeOnlyFilter`.
    init : {"prior", "bearings"}
        "prior": from the run's prior (:func:`run_prior`); "bearings": the particle filter from
        the bearings-only batch initialisation (brehard2004) of the first bearing sensor.
    r_min, r_max : float
        Range interval of the bearings-only initialisation [m] (brehard2004).
    """

    filter: Filter[Any]
    init: Literal["prior", "bearings"] = "prior"
    r_min: float = 1000.0
    r_max: float = 40000.0
    bound: ClassVar[Literal["pcrb", "crlb"]] = "pcrb"

    def __post_init__(self) -> None:
        if not isinstance(self.init, str) or self.init not in ("prior", "bearings"):
            raise ArgumentError("init", "'prior' or 'bearings'", self.init)

    @property
    def name(self) -> str:
        """"pf", "pf-bearings" or "range-only"."""
        return f"{self.filter.name}-bearings" if self.init == "bearings" else self.filter.name

    @property
    def applies_to(self) -> frozenset[str]:
        """The filter's sensor kinds; bearings for the bearings-only start."""
        return frozenset({"bearing"}) if self.init == "bearings" else self.filter.applies_to

    @property
    def applicability(self) -> Applicability | None:
        """What it applies to (:mod:`tmaplan.estimators.applicability`)."""
        return APPLICABILITY.get(self.name)

    def estimate(self, scenario: Scenario, measurements: Sequence[MeasurementSet],
                 observer: ObserverTrack, rng: np.random.Generator) -> Track:
        """Filter the run; NaN before the first estimate.

        From bearings, the filter starts at the batch centre (with the other sensors'
        measurements there) and skips the batch's own bearings up to its end; measurements
        before the centre are not used. Only :class:`DegeneracyWarning` s are counted (status
        "recovered"); other warnings reach the caller.
        """
        batches = measurement_batches(scenario, measurements, observer)
        dv = observer.velocity_increments
        details: Any = None
        k_end = 0
        # Up to the end of the initialisation batch, the measurements not in it.
        rest = batches
        with warnings.catch_warnings(record=True) as wlist:
            warnings.simplefilter("always", DegeneracyWarning)
            if self.init == "bearings":
                state, k_end, details, used = self._from_bearings(scenario, measurements, dv,
                                                                  rng)
                rest = measurement_batches(
                    scenario, [ms for ms in measurements if ms is not used], observer)
                # The batch holds the bearings of its centre, not the other sensors' there.
                if rest.get(int(state.step)):
                    state = self.filter.update(state, rest[int(state.step)], rng)
            else:
                state = self.filter.init(run_prior(scenario, rng, measurements), rng)
                seed = seed_bearings(scenario, measurements)  # in the prior: not again
                at0 = batches if seed is None else measurement_batches(
                    scenario, [ms for ms in measurements if ms is not seed], observer)
                state = self.filter.update(state, at0.get(0, []), rng)

            def step(k: int, _: Any) -> tuple[np.ndarray, list[Measurement]]:
                # Up to the end of the initialisation batch its bearings are already in.
                return dv[k], (batches if k >= k_end else rest).get(k + 1, [])

            first = int(state.step)
            fr = drive(self.filter, state, scenario.n_steps, step, rng)
        # Count the degeneracy recoveries; hand every other warning on to the caller.
        n_warn = 0
        for w in wlist:
            if issubclass(w.category, DegeneracyWarning):
                n_warn += 1
            else:
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno,
                                       source=w.source)
        ok = bool(np.isfinite(fr.estimates[first:]).all())
        return Track(estimator=self.name, times=scenario.times, estimates=fr.estimates,
                     covariances=fr.covariances, ess=fr.diagnostics, seconds=0.0,
                     status="failed" if not ok else ("recovered" if n_warn else "ok"),
                     message="non-finite estimate" if not ok else
                     f"{n_warn} degeneracy recoveries" if n_warn else "",
                     first_step=first, details=details if details is not None else fr.state)

    def _from_bearings(self, scenario: Scenario, meas: Sequence[MeasurementSet],
                       dv: np.ndarray, rng: np.random.Generator
                       ) -> tuple[Any, int, Any, MeasurementSet]:
        """Particle cloud of the bearings-only initialisation, its batch end, details and the
        bearing set the batch is taken from."""
        if not isinstance(self.filter, ParticleFilter):
            raise ArgumentError("init", "'prior' for a filter other than the particle filter",
                                self.init)
        b = [m for m in meas if m.kind == "bearing"]
        if not b:
            raise ArgumentError("measurements", "a bearing measurement set for the "
                                "bearings-only initialisation", sorted({m.kind for m in meas}))
        steps, z = b[0].steps, b[0].values
        config = self.filter.config
        # The batch must not straddle an observer manoeuvre (eq. 13 assumes none).
        moving = np.nonzero(np.any(np.abs(dv) > 1e-9, axis=1))[0]
        first_man = int(moving[0]) if moving.size else scenario.n_steps
        n_ok = int(np.searchsorted(steps, first_man, side="right"))
        res = initialise_from_bearings(
            scenario.times[steps[:n_ok]], z[:n_ok], float(b[0].sigma), r_min=self.r_min,
            r_max=self.r_max, n_particles=config.n_particles, rng=rng, q=config.q,
            dt=config.dt * float(np.median(np.diff(steps))) if steps.size > 1 else None,
            ambiguity=getattr(scenario.sensors[b[0].sensor], "ambiguity", "none"))
        state = self.filter.from_particles(res.particles, step=int(steps[res.centre_index]))
        return state, int(steps[res.end_index]), res, b[0]


@dataclasses.dataclass(frozen=True, kw_only=True)
class MLEEstimator:
    """The batch maximum-likelihood estimate (:func:`tmaplan.estimators.mle.mle`)."""

    config: MLEConfig = dataclasses.field(default_factory=MLEConfig)
    bound: ClassVar[Literal["pcrb", "crlb"]] = "crlb"

    @property
    def name(self) -> str:
        """"mle"."""
        return "mle"

    @property
    def applies_to(self) -> frozenset[str]:
        """Bearings (frequency lines are optional)."""
        return frozenset({"bearing"})

    @property
    def applicability(self) -> Applicability:
        """What it applies to (:mod:`tmaplan.estimators.applicability`)."""
        return APPLICABILITY["mle"]

    def estimate(self, scenario: Scenario, meas: Sequence[MeasurementSet], obs: ObserverTrack,
                 rng: np.random.Generator) -> Track:
        """The MLE and its track, with the delta-method CRLB-at-estimate covariances."""
        config = self.config
        model = None if config.model == "auto" else config.model
        data = tma_data(scenario, meas, obs, model=model, frequencies=config.frequencies)
        res = mle(data, config)
        S, C = state_track(data, res.params, res.covariance, scenario.times)
        rel = S - obs.state
        status = "ok" if res.success else ("rejected" if res.status == "converged" else
                                           "unobservable" if res.status == "unobservable"
                                           else "failed")
        return Track(estimator="mle", times=scenario.times, estimates=rel,
                     covariances=C if C is not None else np.full((rel.shape[0], 4, 4), np.nan),
                     ess=None, seconds=0.0, status=status,
                     message=f"{res.status}; cost {res.cost:.1f} vs threshold {res.threshold:.1f}"
                     + (f"; {res.message}" if res.status == "unobservable" else ""),
                     first_step=0, details=res)


#: Estimator per name, given the scenario, the PF size, the filter's q and the range
#: interval of the bearings-only initialisation.
_NAMED: dict[str, Callable[[Scenario, int, float, float, float], Estimator]] = {
    "pf": lambda sc, n, q, lo, hi: FilterEstimator(
        filter=ParticleFilter(PFConfig(n_particles=n, dt=sc.time.dt, q=q))),
    "pf-bearings": lambda sc, n, q, lo, hi: FilterEstimator(
        filter=ParticleFilter(PFConfig(n_particles=n, dt=sc.time.dt, q=q)), init="bearings",
        r_min=lo, r_max=hi),
    "mle": lambda sc, n, q, lo, hi: MLEEstimator(),
    "range-only": lambda sc, n, q, lo, hi: FilterEstimator(
        filter=RangeOnlyFilter(RangeOnlyConfig(dt=sc.time.dt, q=q))),
}
#: Estimator of a configuration, by the configuration's type.
_CONFIGURED: dict[type, Callable[[Any], Estimator]] = {
    PFConfig: lambda c: FilterEstimator(filter=ParticleFilter(c)),
    RangeOnlyConfig: lambda c: FilterEstimator(filter=RangeOnlyFilter(c)),
    MLEConfig: lambda c: MLEEstimator(config=c),
}


def estimator_for(estimator: EstimatorName | Estimator | PFConfig | MLEConfig
                  | RangeOnlyConfig, scenario: Scenario, *, n_particles: int = 10_000,
                  q: float | None = None, r_min: float = 1000.0, r_max: float = 40000.0
                  ) -> Estimator:
    """The :class:`Estimator` for a name of :data:`ESTIMATORS`, a configuration or itself.

    Raises
    ------
    ArgumentError
        Unknown name, or a filter whose ``dt`` is not the scenario's time step
        (:class:`~tmaplan.errors.ScenarioError`: a scenario without a sensor the estimator
        applies to).
    """
    qf = float(scenario.target.q if q is None else q)
    if isinstance(estimator, str):
        if estimator not in _NAMED:
            raise ArgumentError("estimator", f"one of {', '.join(ESTIMATORS)}", estimator)
        est = _NAMED[estimator](scenario, n_particles, qf, r_min, r_max)
    elif type(estimator) in _CONFIGURED:
        est = _CONFIGURED[type(estimator)](estimator)
    elif isinstance(estimator, Estimator):
        est = estimator
    else:
        raise ArgumentError("estimator", f"one of {', '.join(ESTIMATORS)}, a configuration "
                            "or an Estimator", type(estimator).__name__)
    if not any(s.kind in est.applies_to for s in scenario.sensors):
        raise ScenarioError("sensors", f"a {' or '.join(sorted(est.applies_to))} sensor for "
                            f"the {est.name} estimator", None, source=scenario.name)
    # A filter predicts one grid step with its own dt: another step is a wrong motion model.
    dt = getattr(getattr(getattr(est, "filter", None), "config", None), "dt", None)
    if dt is not None and not np.isclose(float(dt), scenario.time.dt, rtol=1e-9, atol=0.0):
        raise ArgumentError("estimator.dt", f"the scenario's time step {scenario.time.dt:g} s "
                            "(the filter predicts one grid step at a time)", dt)
    return est


def run(estimator: EstimatorName | Estimator | PFConfig | MLEConfig | RangeOnlyConfig,
        scenario: Scenario,
        measurements: Simulation | Sequence[MeasurementSet], *,
        rng: np.random.Generator | None = None, observer: ObserverTrack | None = None,
        n_particles: int = 10_000, q: float | None = None, r_min: float = 1000.0,
        r_max: float = 40000.0) -> Track:
    """Run one estimator on one set of measurements.

    Parameters
    ----------
    estimator : {"pf", "pf-bearings", "mle", "range-only"}, an Estimator or a config
        "pf": particle filter from the prior; "pf-bearings": from bearings only (brehard2004).
        A :class:`PFConfig` runs the prior-initialised PF with it (:func:`estimator_for`).
    scenario : Scenario
    measurements : Simulation or sequence of MeasurementSet
    rng : numpy.random.Generator, optional
        Needed by the filters (default: a fresh unseeded generator).
    observer : ObserverTrack, optional
        Default: from the Simulation, else the scenario's scripted observer.
    n_particles : int
        PF only (when ``estimator`` is a name).
    q : float, optional
        Filter process noise [m²/s³] (default: the scenario target's q) when ``estimator`` is
        a name (a configuration carries its own).
    r_min, r_max : float
        Range interval of the bearings-only initialisation [m] (brehard2004).

    Returns
    -------
    Track

    Raises
    ------
    ArgumentError
        An unknown estimator, a filter whose ``dt`` is not the scenario's time step, or
        ``rng`` neither a Generator nor None.
    """
    if rng is not None and not isinstance(rng, np.random.Generator):
        raise ArgumentError("rng", "a numpy.random.Generator or None", type(rng).__name__)
    meas, obs = _observer_of(scenario, measurements, observer)
    est = estimator_for(estimator, scenario, n_particles=n_particles, q=q, r_min=r_min,
                        r_max=r_max)
    t0 = _time.perf_counter()
    tr = est.estimate(scenario, meas, obs, rng if rng is not None else np.random.default_rng())
    return dataclasses.replace(tr, seconds=_time.perf_counter() - t0)
