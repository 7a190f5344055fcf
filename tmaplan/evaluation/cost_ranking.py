"""Cost fidelity: how well does each cost functional rank manoeuvres the way the filter does?

A planning cost is only worth optimising if a manoeuvre that it calls better also localises the
contact sooner in closed loop. :func:`rank_costs` measures that:

1. a family of candidate manoeuvres (:func:`candidate_manoeuvres`): straight; single course
   changes on a grid of times × angles to both sides; zig-zags; the practitioner tactics
   (:mod:`tmaplan.policies.tactics`); the offline plan of every planning objective;
2. every cost functional (:func:`cost_functionals`) on every candidate's nominal track (the
   track it flies when the belief is the prior mean): every name of
   :data:`tmaplan.planning.objectives.OBJECTIVE_NAMES` (so a new planning objective is ranked
   as soon as it is registered), the prior-averaged Cartesian PCRB
   (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`: the bound of the *averaged* information) and
   the expected CRLB (the average over prior draws of each draw's *own* bound,
   :func:`tmaplan.bounds.truth_bound.truth_bounds`), each terminal and averaged over the
   horizon;
3. every candidate flown in closed loop with common random numbers, truths from the prior (the
   paired, resumable campaign of :func:`tmaplan.evaluation.campaigns.run_campaign`);
4. per cost, the Spearman ρ and Kendall τ between the cost and the Monte Carlo metrics (mean
   time to accuracy, censored at the horizon + dt as in ``compare``; final range RMSE), with
   bootstrap percentile 95 % intervals (:func:`scipy.stats.bootstrap`, resampling the Monte
   Carlo runs and the candidates independently, so the interval covers both the Monte Carlo
   noise of the metric and the choice of candidates).

Every cost and metric is "smaller is better", so a cost that predicts well has ρ near +1.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.bounds.pcrb import monte_carlo_pcrb
from tmaplan.bounds.truth_bound import truth_bounds
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, PlanningError, as_real, is_integer
from tmaplan.evaluation.campaigns import CampaignResult, CampaignSpec, run_campaign
from tmaplan.evaluation.metrics import censor_time
from tmaplan.evaluation.seeding import root_rng, run_seeds
from tmaplan.models.observer import ObserverTrack, turn_rate_track
from tmaplan.planning import HeadingPlanner
from tmaplan.planning.baselines import SINGLE_TURN_ANGLES, SINGLE_TURN_FRACTIONS, ZIGZAG_GRID
from tmaplan.planning.belief import Belief
from tmaplan.planning.objectives import (
    OBJECTIVE_NAMES,
    ObjectiveEvaluator,
    make_objective,
)
from tmaplan.policies import (
    CLOSED_LOOP_OBJECTIVE,
    Combined,
    LeadLag,
    LegTurnLeg,
    ManoeuvrePolicy,
    Planned,
    SingleTurn,
    Straight,
    Zigzag,
)
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.scenario import Scenario
from tmaplan.simulate import draw_truth

__all__ = ["Candidate", "CostCorrelation", "CostRankingResult", "candidate_manoeuvres",
           "cost_functionals", "default_objective", "evaluate_costs", "rank_correlations",
           "rank_costs"]

#: Monte Carlo metrics the costs are ranked against (``time_to_accuracy``: mean over runs,
#: censored; ``final_range_rmse``: RMS over runs of the final range error) [s], [m].
METRICS = ("time_to_accuracy", "final_range_rmse")


@dataclasses.dataclass(frozen=True, kw_only=True)
class Candidate:
    """One candidate manoeuvre.

    Attributes
    ----------
    name : str
        Unique name (the campaign's policy name), e.g. ``single-turn:+60deg@675s``.
    family : str
        ``straight``, ``single-turn``, ``zigzag``, ``tactic`` or ``planned``.
    policy : ManoeuvrePolicy
        What is flown in closed loop (offline plans precomputed).
    """

    name: str
    family: str
    policy: ManoeuvrePolicy


def default_objective(scenario: Scenario) -> str:
    """Name of the objective that ``tmaplan plan`` optimises by default on ``scenario`` (read
    from :class:`tmaplan.planning.HeadingPlanner`, never restated here)."""
    return str(HeadingPlanner(scenario).objective.name)


def _grid(scenario: Scenario) -> list[Candidate]:
    t0, H = scenario.time.t0, scenario.time.horizon
    out = []
    for f in SINGLE_TURN_FRACTIONS:
        for a in SINGLE_TURN_ANGLES:
            for s in (1.0, -1.0):
                out.append(Candidate(
                    name=f"single-turn:{s * a:+g}deg@{f * H:g}s", family="single-turn",
                    policy=SingleTurn(angle=s * np.radians(a), time=t0 + f * H)))
    for f, a in ZIGZAG_GRID:
        for s in (1.0, -1.0):
            out.append(Candidate(
                name=f"zigzag:{s * a:+g}deg,leg{f * H:g}s", family="zigzag",
                policy=Zigzag(leg_duration=f * H, angle=0.5 * s * np.radians(a), start=t0)))
    return out


def candidate_manoeuvres(scenario: Scenario, n: int = 40, *,
                         plan_objectives: Sequence[str] | None = None,
                         ) -> tuple[tuple[Candidate, ...], dict[str, str]]:
    """The candidate family, ``n`` manoeuvres at most.

    Always: straight, the two practitioner tactics (:class:`~tmaplan.policies.LegTurnLeg`,
    :class:`~tmaplan.policies.LeadLag`) and the offline plan of each objective of
    ``plan_objectives`` (default: every name of ``OBJECTIVE_NAMES``; aliases that give the
    same objective are planned once), in that order of priority; the rest are single turns
    (``SINGLE_TURN_FRACTIONS`` × ``SINGLE_TURN_ANGLES`` × both sides) and zig-zags
    (``ZIGZAG_GRID`` × both sides of :mod:`tmaplan.planning.baselines`), evenly spread over
    that grid.

    Returns
    -------
    candidates : tuple of Candidate
    skipped : dict
        Objective name -> why its plan is not a candidate (solver failure, alias).
    """
    if not is_integer(n, 3):
        raise ArgumentError("candidates", "an integer >= 3 (a rank correlation needs three)", n)
    fixed = [Candidate(name="straight", family="straight", policy=Straight()),
             Candidate(name="leg-turn-leg", family="tactic", policy=LegTurnLeg()),
             Candidate(name="lead-lag", family="tactic", policy=LeadLag())]
    skipped: dict[str, str] = {}
    names = OBJECTIVE_NAMES if plan_objectives is None else tuple(plan_objectives)
    for obj in names:  # every name, also those beyond the n candidates
        if obj not in OBJECTIVE_NAMES:
            raise ArgumentError("plan_objectives", f"names of {', '.join(OBJECTIVE_NAMES)}",
                                obj)
    seen: dict[str, str] = {}
    for obj in names:
        if len(fixed) >= n:
            break
        canon = make_objective(obj).name
        if canon in seen:
            skipped[obj] = f"same objective as {seen[canon]}"
            continue
        seen[canon] = obj
        try:
            plan = offline_plan(scenario, obj)
        except PlanningError as exc:
            skipped[obj] = f"plan failed: {exc}"
            continue
        fixed.append(Candidate(name=f"planned:{obj}", family="planned",
                               policy=Planned(objective=obj, plan=plan)))
    grid = _grid(scenario)
    m = max(int(n) - len(fixed), 0)
    idx = np.unique(np.round(np.linspace(0, len(grid) - 1, min(m, len(grid)))).astype(int)) \
        if m else np.zeros(0, int)
    return tuple(fixed[:n]) + tuple(grid[i] for i in idx), skipped


# --------------------------------------------------------------------------------------------
# cost functionals on a fixed track
# --------------------------------------------------------------------------------------------
CostFn = Callable[[ObserverTrack], float]


def _full_track(scenario: Scenario, track: ObserverTrack) -> ObserverTrack:
    """The track on the scenario's whole grid (a shorter plan continues straight)."""
    K = scenario.n_steps
    if track.position.shape[0] == K + 1:
        return track
    u = np.zeros(K)
    rates = np.diff(np.unwrap(track.heading)) / scenario.time.dt
    u[:min(K, rates.size)] = rates[:K]
    return turn_rate_track(track.position[0], float(track.heading[0]), float(track.speed[0]),
                           u, scenario.time.dt, scenario.time.t0)


def _track_key(tr: ObserverTrack) -> bytes:
    """Content key of a track (terminal and mean costs share one bound computation)."""
    return np.ascontiguousarray(tr.state).tobytes()


def _objective_cost(ev: Any) -> CostFn:
    def cost(tr: ObserverTrack) -> float:
        return float(ev(tr)[0])

    return cost


def cost_functionals(scenario: Scenario, *, samples: int = 1000, seed: int = 0
                     ) -> tuple[dict[str, CostFn], dict[str, str]]:
    """Every cost functional that can be evaluated on a fixed own-ship track (minimised).

    * each name of ``OBJECTIVE_NAMES`` (:class:`tmaplan.planning.objectives.ObjectiveEvaluator`
      with the prior as belief); names whose values coincide with an earlier one are
      dropped by :func:`evaluate_costs`;
    * ``pcrb-cartesian-range`` / ``mean-pcrb-cartesian-range``: range bound of the
      prior-averaged Cartesian PCRB (:func:`tmaplan.bounds.pcrb.monte_carlo_pcrb`, ``samples``
      propagated draws), terminal / mean over the horizon [m];
    * ``expected-crlb-range`` / ``mean-expected-crlb-range``: the expected CRLB, the average
      over ``samples // 10`` prior draws of each draw's own (truth-conditioned) range bound,
      ``sqrt(mean_draws uᵀ[J_k⁻¹]u)`` (:func:`tmaplan.bounds.truth_bound.truth_bounds`),
      terminal / mean [m].

    The random draws come from ``seed`` and are the same for every track (common random
    numbers), so the costs of two tracks differ only by the tracks.

    Returns
    -------
    costs : dict
        Name -> function of an :class:`ObserverTrack` on the scenario's grid.
    skipped : dict
        Name -> why it cannot be evaluated on ``scenario``.
    """
    costs: dict[str, CostFn] = {}
    skipped: dict[str, str] = {}
    belief = Belief.from_prior(scenario)
    for name in OBJECTIVE_NAMES:
        try:
            ev = ObjectiveEvaluator(scenario, name, belief=belief)
        except (PlanningError, ArgumentError, NotImplementedError) as exc:
            skipped[name] = str(exc)
            continue
        costs[name] = _objective_cost(ev)

    pcrb_cache: dict[bytes, np.ndarray] = {}

    def pcrb(tr: ObserverTrack) -> np.ndarray:
        key = _track_key(tr)
        if key not in pcrb_cache:
            pcrb_cache[key] = monte_carlo_pcrb(
                scenario, samples=int(samples), rng=root_rng(seed),
                coords="cartesian", observer=tr).range_std
        return pcrb_cache[key]

    costs["pcrb-cartesian-range"] = lambda tr: float(pcrb(tr)[-1])
    costs["mean-pcrb-cartesian-range"] = lambda tr: float(np.mean(pcrb(tr)))
    n_draws = max(int(samples) // 10, 2)
    targets = np.stack([draw_truth(scenario, np.random.default_rng(s), from_prior=True)
                        for s in run_seeds(seed, n_draws)])
    ecrlb_cache: dict[bytes, np.ndarray] = {}

    def ecrlb(tr: ObserverTrack) -> np.ndarray:
        key = _track_key(tr)
        if key not in ecrlb_cache:
            ecrlb_cache[key] = truth_bounds(scenario, targets - tr.state[None])[1]
        return ecrlb_cache[key]

    costs["expected-crlb-range"] = lambda tr: float(ecrlb(tr)[-1])
    costs["mean-expected-crlb-range"] = lambda tr: float(np.mean(ecrlb(tr)))
    return costs, skipped


def evaluate_costs(scenario: Scenario, tracks: Mapping[str, ObserverTrack],
                   costs: Mapping[str, CostFn]) -> tuple[dict[str, np.ndarray],
                                                         dict[str, str]]:
    """Every cost on every track (tracks extended to the scenario's grid).

    Returns
    -------
    values : dict
        Cost name -> values (n_tracks,), in the order of ``tracks``; a cost whose values equal
        an earlier cost's on every track (an alias, e.g. ``terminal-range-bound``) is left out.
    aliases : dict
        Left-out name -> the name it duplicates.
    """
    full = [_full_track(scenario, tr) for tr in tracks.values()]
    values: dict[str, np.ndarray] = {}
    aliases: dict[str, str] = {}
    for name, fn in costs.items():
        v = np.array([fn(tr) for tr in full], float)
        same = [k for k, w in values.items() if np.array_equal(v, w)]
        if same:
            aliases[name] = same[0]
        else:
            values[name] = v
    return values, aliases


# --------------------------------------------------------------------------------------------
# rank correlations
# --------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, kw_only=True)
class CostCorrelation:
    """Rank agreement of one cost with the Monte Carlo metrics over the candidates.

    Attributes
    ----------
    name : str
    values : ndarray, shape (C,)
        The cost of each candidate (NaN: undefined there; ±inf: ranked as the extremes).
    spearman, kendall : float
        Spearman ρ and Kendall τ (τ-b) with the mean time to accuracy over the candidates of
        non-NaN cost (NaN for a constant cost or fewer than three such).
    spearman_ci, kendall_ci : tuple of float
        Bootstrap percentile 95 % intervals.
    spearman_rmse, kendall_rmse : float
        The same with the final range RMSE.
    spearman_rmse_ci : tuple of float
    excluded : int
        Candidates left out of the correlations and intervals for a NaN cost.
    """

    name: str
    values: np.ndarray
    spearman: float
    spearman_ci: tuple[float, float]
    kendall: float
    kendall_ci: tuple[float, float]
    spearman_rmse: float
    spearman_rmse_ci: tuple[float, float]
    kendall_rmse: float
    excluded: int = 0


def _metrics(tta: np.ndarray, fre: np.ndarray, censor: float) -> tuple[np.ndarray, np.ndarray]:
    """Per candidate: mean censored time to accuracy [s], final range RMSE [m]."""
    t = np.where(np.isfinite(tta), tta, censor)
    return t.mean(axis=-1), np.sqrt(np.mean(fre**2, axis=-1))


def _rho(cost: np.ndarray, metric: np.ndarray) -> tuple[float, float]:
    if cost.size < 3 or np.all(cost == cost[0]) or np.all(metric == metric[0]):
        return float("nan"), float("nan")
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    return (float(stats.spearmanr(cost, metric).statistic),
            float(stats.kendalltau(cost, metric).statistic))


def rank_correlations(costs: Mapping[str, np.ndarray], tta: np.ndarray, fre: np.ndarray, *,
                      censor: float, n_resamples: int = 999, seed: int = 0,
                      level: float = 0.95) -> tuple[CostCorrelation, ...]:
    """Spearman ρ and Kendall τ of each cost against the Monte Carlo metrics.

    Parameters
    ----------
    costs : mapping
        Cost name -> values (C,); a candidate of NaN cost is left out (``excluded``, a warning).
    tta : ndarray, shape (C, R)
        Time to accuracy of each candidate in each run [s] (+inf: never; NaN refused).
    fre : ndarray, shape (C, R)
        Final range error of each candidate in each run [m] (finite).
    censor : float
        Value of a time to accuracy that is never reached [s] (horizon + dt); finite and not
        below any finite time.
    n_resamples : int
        Bootstrap resamples, >= 0 (0: no intervals); runs and candidates are resampled
        independently (:func:`scipy.stats.bootstrap`, ``paired=False``, percentile
        intervals).
    seed : int
        Seed of the bootstrap, >= 0.
    level : float
        Confidence level, in (0, 1).

    Returns
    -------
    tuple of CostCorrelation
        In the order of ``costs``.

    Raises
    ------
    ArgumentError
        Fewer than three candidates, arrays of mismatched shapes, a NaN time or a non-finite
        final error (named by candidate and run), a censor below a finite time, a level
        outside (0, 1), a negative or non-integer ``n_resamples`` or ``seed``.
    """
    tta = np.asarray(tta, float)
    fre = np.asarray(fre, float)
    if tta.ndim != 2 or tta.shape[1] < 1:
        raise ArgumentError("tta", "an array of shape (candidates, runs)", tta.shape)
    C, R = tta.shape
    if C < 3:
        raise ArgumentError("candidates", ">= 3 (a rank correlation needs three)", C)
    if fre.shape != tta.shape:
        raise ArgumentError("fre", f"the shape of tta {tta.shape}", fre.shape)
    for field, x, what in (("tta", tta, "finite values or +inf (never reached)"),
                           ("fre", fre, "finite values")):
        bad = np.argwhere(~(np.isfinite(x) | (np.isposinf(x) if field == "tta" else False)))
        if bad.size:
            raise ArgumentError(field, what, f"{x[tuple(bad[0])]} at (candidate, run) "
                                f"{tuple(bad[0].tolist())}, {len(bad)} in all")
    top = float(np.max(tta, initial=-np.inf, where=np.isfinite(tta)))
    if not np.isfinite(as_real(censor)) or censor < top:
        raise ArgumentError("censor", f"a finite number >= the largest finite time ({top:g} s), "
                            "e.g. the horizon + dt", censor)
    for name, v in costs.items():
        if np.shape(v) != (C,):
            raise ArgumentError(f"costs[{name!r}]", f"shape ({C},), one per candidate", np.shape(v))
    if not 0 < as_real(level) < 1:
        raise ArgumentError("level", "a confidence level in (0, 1), e.g. 0.95", level)
    for field, value in (("n_resamples", n_resamples), ("seed", seed)):
        if not is_integer(value, 0):
            raise ArgumentError(field, "an integer >= 0", value)
    m_tta, m_fre = _metrics(tta, fre, censor)
    out = []
    for name, v in costs.items():
        v = np.asarray(v, float)
        ok = np.flatnonzero(~np.isnan(v))  # NaN: undefined there, the others are ranked
        if ok.size < C:
            warnings.warn(f"cost {name!r}: {C - ok.size} of {C} candidates have a NaN cost, "
                          "left out of its rank correlations", RuntimeWarning, stacklevel=2)
        s, k = _rho(v[ok], m_tta[ok])
        s2, k2 = _rho(v[ok], m_fre[ok])

        def stat(runs: np.ndarray, cand: np.ndarray, v: np.ndarray = v) -> np.ndarray:
            runs, cand = runs.astype(int), cand.astype(int)
            a, b = _metrics(tta[np.ix_(cand, runs)], fre[np.ix_(cand, runs)], censor)
            return np.array([*_rho(v[cand], a), _rho(v[cand], b)[0]])

        cis = [(float("nan"), float("nan"))] * 3
        if (np.isfinite(s) or np.isfinite(s2)) and R >= 2 and n_resamples > 0:
            from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")  # degenerate resamples (constant cost)
                bs = stats.bootstrap((np.arange(R), ok), stat, paired=False,
                                     vectorized=False, n_resamples=int(n_resamples),
                                     confidence_level=level, method="percentile",
                                     random_state=root_rng(seed))
            a = 100.0 * (1.0 - level) / 2.0  # percentiles of the resamples where defined
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # all NaN: interval NaN
                lo, hi = np.nanpercentile(bs.bootstrap_distribution, [a, 100.0 - a], axis=-1)
            cis = [(float(lo[i]), float(hi[i])) for i in range(3)]
        out.append(CostCorrelation(name=name, values=v, excluded=C - ok.size, spearman=s,
                                   spearman_ci=cis[0], kendall=k, kendall_ci=cis[1],
                                   spearman_rmse=s2, spearman_rmse_ci=cis[2], kendall_rmse=k2))
    return tuple(out)


# --------------------------------------------------------------------------------------------
# the whole measurement
# --------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, kw_only=True)
class CostRankingResult:
    """Result of :func:`rank_costs`.

    Attributes
    ----------
    problem : str
    candidates : tuple of str
        Candidate names (C).
    families : tuple of str
        Family of each candidate.
    costs : tuple of CostCorrelation
        Sorted by decreasing Spearman ρ with the time to accuracy (NaN last).
    time_to_accuracy : ndarray, shape (C,)
        Mean time to accuracy over the runs, censored at ``censor`` [s].
    final_range_rmse : ndarray, shape (C,)
        [m].
    censor : float
        [s].
    default_objective : str
        Objective of ``tmaplan plan`` by default on this problem.
    closed_loop_objective : str
        Objective of the ``planned`` / ``receding`` policies.
    skipped : dict
        Costs or plans left out, and why; aliases.
    campaign : CampaignResult
    seconds : float
    """

    __repr__ = short_repr

    problem: str
    candidates: tuple[str, ...]
    families: tuple[str, ...]
    costs: tuple[CostCorrelation, ...]
    time_to_accuracy: np.ndarray
    final_range_rmse: np.ndarray
    censor: float
    default_objective: str
    closed_loop_objective: str
    skipped: dict[str, str]
    campaign: CampaignResult
    seconds: float

    def to_json(self) -> dict[str, Any]:
        """The ``tmaplan rank-costs`` payload (SI units)."""
        spec = self.campaign.spec
        return {
            "problem": self.problem,
            "candidates": len(self.candidates),
            "default_objective": self.default_objective,
            "closed_loop_objective": self.closed_loop_objective,
            "costs": [{"name": c.name, "spearman": c.spearman,
                       "spearman_ci": list(c.spearman_ci), "kendall": c.kendall,
                       "kendall_ci": list(c.kendall_ci), "spearman_rmse": c.spearman_rmse,
                       "spearman_rmse_ci": list(c.spearman_rmse_ci),
                       "kendall_rmse": c.kendall_rmse, "excluded": c.excluded,
                       "values": c.values.tolist()}
                      for c in self.costs],
            "candidate_names": list(self.candidates),
            "families": list(self.families),
            "time_to_accuracy": self.time_to_accuracy.tolist(),
            "final_range_rmse": self.final_range_rmse.tolist(),
            "censor": self.censor,
            "runs": spec.runs, "seed": spec.seed, "particles": spec.n_particles,
            "accuracy": spec.accuracy,
            "skipped": dict(self.skipped),
            "directory": None if self.campaign.directory is None
            else str(self.campaign.directory),
            "computed_runs": len(self.campaign.computed_runs),
            "loaded_runs": len(self.campaign.loaded_runs),
            "seconds": self.seconds,
        }


def rank_costs(scenario: Scenario, *, candidates: int | Sequence[Candidate] = 40,
               runs: int = 50, seed: int = 0, n_particles: int = 3000, accuracy: float = 0.1,
               plan_objectives: Sequence[str] | None = None, cost_samples: int = 1000,
               n_resamples: int = 999, workers: int = 1, scheduler: str | None = None,
               out_dir: str | Path | None = None, progress: bool = False,
               extra_costs: Mapping[str, CostFn] | None = None) -> CostRankingResult:
    """Rank every cost functional against closed-loop Monte Carlo (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
    candidates : int or sequence of Candidate
        How many candidates of :func:`candidate_manoeuvres`, or the candidates themselves.
    runs, seed, n_particles, accuracy :
        The paired campaign (:class:`tmaplan.experiments.CampaignSpec`); runs are stored under
        ``out_dir`` keyed on the scenario, candidates, settings and code version, and resumed.
    plan_objectives : sequence of str, optional
        Objectives whose offline plans are candidates (default all; ``()`` none).
    cost_samples : int
        Draws behind the Monte Carlo costs (:func:`cost_functionals`).
    n_resamples : int
        Bootstrap resamples of the intervals.
    workers, scheduler, progress :
        As for :func:`tmaplan.experiments.run_campaign`.
    out_dir : path, optional
    extra_costs : mapping, optional
        More cost functionals (name -> function of a track) to rank.

    Returns
    -------
    CostRankingResult
    """
    t_start = time.perf_counter()
    if isinstance(candidates, int | np.integer):
        cands, skipped = candidate_manoeuvres(scenario, int(candidates),
                                              plan_objectives=plan_objectives)
    else:
        cands, skipped = tuple(candidates), {}
    if len(cands) < 3:
        raise ArgumentError("candidates", ">= 3 (a rank correlation needs three)", len(cands))
    names = [c.name for c in cands]
    if len(set(names)) != len(names):
        raise PlanningError("candidate names must be unique")
    spec = CampaignSpec(scenario=scenario, policies=tuple(names), runs=runs, seed=seed,
                        n_particles=n_particles, accuracy=accuracy)
    pols = {c.name: Combined(manoeuvre=c.policy) for c in cands}
    camp = run_campaign(spec, out_dir=out_dir, workers=workers, scheduler=scheduler,
                        progress=progress, policies=pols)
    fns, sk = cost_functionals(scenario, samples=cost_samples, seed=seed)
    fns.update(extra_costs or {})
    skipped.update({f"cost {k}": v for k, v in sk.items()})
    values, aliases = evaluate_costs(
        scenario, {c.name: c.policy.nominal_track(scenario) for c in cands}, fns)
    skipped.update({f"cost {k}": f"alias of {v}" for k, v in aliases.items()})
    censor = censor_time(scenario.times)
    tta = np.stack([camp.summary[n]["time_to_accuracy_runs"] for n in names])
    fre = np.stack([camp.summary[n]["final_range_error_runs"] for n in names]).astype(float)
    cors = rank_correlations(values, tta, fre, censor=censor, n_resamples=n_resamples,
                             seed=seed)
    skipped.update({f"cost {c.name}": f"{c.excluded} of {len(names)} candidates with a NaN "
                    "cost left out of its correlations" for c in cors if c.excluded})
    cors = tuple(sorted(cors, key=lambda c: -c.spearman if np.isfinite(c.spearman) else np.inf))
    m_tta, m_fre = _metrics(tta, fre, censor)
    return CostRankingResult(
        problem=scenario.name, candidates=tuple(names),
        families=tuple(c.family for c in cands), costs=cors, time_to_accuracy=m_tta,
        final_range_rmse=m_fre, censor=censor, default_objective=default_objective(scenario),
        closed_loop_objective=CLOSED_LOOP_OBJECTIVE, skipped=skipped, campaign=camp,
        seconds=time.perf_counter() - t_start)
