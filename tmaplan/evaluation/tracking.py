"""Monte Carlo evaluation of an estimator against its bound (the `track` verb).

``monte_carlo(scenario, estimator, runs=..., seed=...)`` repeats :func:`tmaplan.estimators.run`
over runs seeded from one ``numpy.random.SeedSequence(seed)`` (one child per run,
:func:`tmaplan.evaluation.seeding.run_seeds`) and compares
the RMSE with the estimator's bound (:attr:`tmaplan.estimators.runner.Estimator.bound`): for the
filters the PCRB along the runs' true trajectories, averaged over the runs
(:func:`tmaplan.bounds.truth_bound.truth_pcrb`, ristic2004, ch. 6; option
``bound="prior"``: the prior-averaged PCRB of ``tmaplan.bounds.pcrb.monte_carlo_pcrb``, see
:func:`_pcrb_position`), the CRLB of the batch estimate for the MLE (:func:`_crlb_bounds`).
"""

from __future__ import annotations

import dataclasses
import time as _time
import warnings
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from tmaplan.bounds.batch_fim import tma_data, true_parameters
from tmaplan.bounds.crlb import information_covariance
from tmaplan.bounds.pcrb import monte_carlo_pcrb
from tmaplan.bounds.truth_bound import truth_bounds
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, is_integer
from tmaplan.estimators.applicability import check_applicable
from tmaplan.estimators.mle import MLEConfig, state_track
from tmaplan.estimators.particle_filter import PFConfig
from tmaplan.estimators.range_only import RangeOnlyConfig
from tmaplan.estimators.runner import Estimator, EstimatorName, estimator_for, run
from tmaplan.evaluation.seeding import run_seeds
from tmaplan.geometry import range_of
from tmaplan.scenario import Scenario
from tmaplan.simulate import simulate

__all__ = ["NOT_USED", "MonteCarloResult", "monte_carlo"]


# --------------------------------------------------------------------------------------------
# Bounds
# --------------------------------------------------------------------------------------------


def _pcrb_position(scenario: Scenario, rng: np.random.Generator, samples: int) -> np.ndarray:
    """Prior-averaged Cartesian PCRB position std (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # side-assumption notes concern the LPC bound only
        res = monte_carlo_pcrb(scenario, samples=samples, rng=rng, coords="cartesian")
    return np.asarray(res.position_std, float)


def _crlb_bounds(scenario: Scenario, config: MLEConfig) -> tuple[np.ndarray, np.ndarray]:
    """Position and range std of the batch CRLB at the truth, per step [m]."""
    sim = simulate(scenario, None)
    model = None if config.model == "auto" else config.model
    data = tma_data(scenario, sim.measurements, sim.observer, model=model,
                    frequencies=config.frequencies)
    p = true_parameters(scenario, data.track, data.n_lines)
    C = information_covariance(data, p)  # ObservabilityError when singular, as `crlb` says
    S, Cs = state_track(data, p, C, scenario.times)
    assert Cs is not None
    rel = S[:, :2] - sim.observer.position
    u = rel / range_of(rel)[:, None]
    return (np.sqrt(np.trace(Cs[:, :2, :2], axis1=1, axis2=2)),
            np.sqrt(np.einsum("ki,kij,kj->k", u, Cs[:, :2, :2], u)))


# --------------------------------------------------------------------------------------------
# Monte Carlo
# --------------------------------------------------------------------------------------------


#: Run statuses left out of the RMSE and NEES and counted as divergent: the MLE's "rejected"
#: (acceptance test) and "unobservable" (range not determined by the data, see
#: :class:`tmaplan.estimators.mle.MLEConfig`), and "failed".
NOT_USED = ("rejected", "failed", "unobservable")


@dataclasses.dataclass(frozen=True, kw_only=True)
class MonteCarloResult:
    """Monte Carlo evaluation of an estimator (docs/cli.md ``track`` fields).

    Attributes
    ----------
    problem, estimator : str
    runs, seed : int
    times : ndarray, shape (K + 1,)
        [s].
    rmse_position, rmse_range : ndarray, shape (K + 1,)
        Over the runs that were not rejected, failed or unobservable (:data:`NOT_USED`) [m];
        NaN where no estimate.
    bound_position : ndarray, shape (K + 1,)
        PCRB (filters: along the runs' truths, or prior-averaged, see ``bound_kind``) or CRLB
        (MLE) position std [m].
    bound_range : ndarray, shape (K + 1,)
        Range std of the same bound (delta method along the true line of sight) [m]; NaN for
        the prior-averaged bound.
    bound_kind : str
        "truth", "prior", "crlb" or "none".
    divergence_rate : float
        Fraction of runs rejected, failed, unobservable, or ending with a position error > 5×
        the bound.
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

    __repr__ = short_repr

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
                "unobservable": self.statuses.count("unobservable"),
                "ambiguous_runs": self.ambiguous_runs,
                "seconds": self.seconds}


def monte_carlo(scenario: Scenario, estimator: EstimatorName | Estimator | PFConfig | MLEConfig
                | RangeOnlyConfig, *, runs: int, seed: int = 0, n_particles: int = 10_000,
                bound: bool | Literal["truth", "prior"] = True, bound_samples: int = 2000,
                progress: Callable[[int, int], None] | None = None,
                **run_kwargs: Any) -> MonteCarloResult:
    """Monte Carlo runs of one estimator: truth + measurements + estimate per run.

    Parameters
    ----------
    scenario : Scenario
    estimator : str, Estimator or config
        As for :func:`tmaplan.estimators.run`.
    runs : int
    seed : int
        Root of ``numpy.random.SeedSequence(seed)``; child i seeds run i (simulation and
        estimator share the child's generator, in that order).
    n_particles : int
    bound : bool or {"truth", "prior"}
        Compute the bound (False: NaN). Filters: True / "truth" is the PCRB along each run's
        true trajectory with ``J_0 = P_0⁻¹`` (prior centred on the truth), averaged over the
        runs (ristic2004, ch. 6); "prior" is the PCRB averaged over trajectories
        drawn from the prior (optimistic before an unobservable geometry becomes observable).
        The MLE always uses the CRLB at the truth ("prior" is refused for it).
    bound_samples : int
        Monte Carlo samples of the prior-averaged PCRB.
    progress : callable(done, total), optional
    **run_kwargs
        Passed to :func:`tmaplan.estimators.run` (``q``, ``r_min``, ``r_max``, ``observer``).

    Returns
    -------
    MonteCarloResult

    Raises
    ------
    ArgumentError
        ``runs`` not an integer >= 1, ``seed`` not an integer >= 0, another ``bound``, or
        ``bound_samples`` < 2 with ``bound="prior"`` (before any run is computed).
    ScenarioError
        An estimator / bound that cannot give a number on this scenario
        (:func:`tmaplan.estimators.applicability.check_applicable`).
    ObservabilityError
        The MLE's bound (the batch CRLB at the truth) is singular: the scenario's track is
        not observable (before any run is computed).
    """
    if not is_integer(runs, 1):
        raise ArgumentError("runs", "an integer >= 1", runs)
    if not is_integer(seed, 0):
        raise ArgumentError("seed", "an integer >= 0", seed)
    if not (isinstance(bound, bool) or bound in ("truth", "prior")):
        raise ArgumentError("bound", "True, False, 'truth' or 'prior'", bound)
    if bound == "prior" and not is_integer(bound_samples, 2):  # checked before the runs
        raise ArgumentError("bound_samples", "an integer >= 2", bound_samples)
    est = estimator_for(estimator, scenario, n_particles=n_particles,
                        **{k: v for k, v in run_kwargs.items() if k in ("q", "r_min", "r_max")})
    check_applicable(est, scenario, bound=bound)
    t0 = _time.perf_counter()
    # the batch CRLB depends on the scenario only: before the runs, so that an unobservable
    # scenario is refused at once (ObservabilityError, as `tmaplan crlb` refuses it)
    crlb_bounds = (_crlb_bounds(scenario, getattr(est, "config", MLEConfig()))
                   if bound and est.bound == "crlb" else None)
    K = scenario.n_steps
    err_pos = np.full((runs, K + 1), np.nan)
    err_rng = np.full((runs, K + 1), np.nan)
    nees = np.full((runs, K + 1), np.nan)
    statuses = []
    ambiguous = 0
    truths = np.zeros((runs, K + 1, 4))
    children = run_seeds(seed, runs + 1)  # the last one: the bound's draws
    for i in range(runs):
        rng = np.random.default_rng(children[i])
        sim = simulate(scenario, rng)
        truths[i] = sim.relative
        tr = run(est, scenario, sim, rng=rng, **run_kwargs)
        statuses.append(tr.status)
        ambiguous += bool(getattr(tr.details, "ambiguous", False))
        e = tr.estimates - sim.relative
        err_pos[i] = range_of(e)
        err_rng[i] = range_of(tr.estimates) - range_of(sim.relative)
        with np.errstate(invalid="ignore"):
            try:
                sol = np.linalg.solve(tr.covariances, e[..., None])[..., 0]
                nees[i] = np.einsum("ki,ki->k", e, sol)
            except (np.linalg.LinAlgError, ValueError):
                pass
        if progress is not None:
            progress(i + 1, runs)
    kind = "none"
    if bound:
        brng = np.random.default_rng(children[runs])
        if crlb_bounds is not None:
            (b, br), kind = crlb_bounds, "crlb"
        elif bound == "prior":
            b, kind = _pcrb_position(scenario, brng, bound_samples), "prior"
            br = np.full(K + 1, np.nan)
        elif bound is True or bound == "truth":
            (b, br), kind = truth_bounds(scenario, truths), "truth"
        else:
            raise ArgumentError("bound", "True, False, 'truth' or 'prior'", bound)
    else:
        b = br = np.full(K + 1, np.nan)
    used = np.array([s not in NOT_USED for s in statuses])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rmse_p = np.sqrt(np.nanmean(err_pos[used] ** 2, axis=0)) if used.any() \
            else np.full(K + 1, np.nan)
        rmse_r = np.sqrt(np.nanmean(err_rng[used] ** 2, axis=0)) if used.any() \
            else np.full(K + 1, np.nan)
        mean_nees = np.nanmean(nees[used], axis=0) if used.any() else np.full(K + 1, np.nan)
    final_bad = ~used | ~(err_pos[:, -1] <= 5.0 * b[-1]) if bound else ~used
    return MonteCarloResult(problem=scenario.name, estimator=est.name, runs=runs, seed=seed,
                            times=scenario.times, rmse_position=rmse_p, rmse_range=rmse_r,
                            bound_position=b, bound_range=br, bound_kind=kind,
                            divergence_rate=float(np.mean(final_bad)),
                            nees=mean_nees, position_errors=err_pos, statuses=tuple(statuses),
                            seconds=_time.perf_counter() - t0, ambiguous_runs=ambiguous)
