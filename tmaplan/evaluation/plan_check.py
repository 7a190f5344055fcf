"""Does the plan pay? Paired Monte Carlo of the offline plan against what an operator flies.

The checks of "does the plan pay?" (docs/findings.md, docs/results/plan-pays.md):

* :func:`tune_single_turn`: the single course change chosen *by Monte Carlo* — a grid of
  single turns (times × course changes to both sides) flown in closed loop on seeds of their
  own (``seed`` different from the evaluation's), the one with the smallest mean censored
  time to accuracy kept. It is the strongest simple baseline a user could tune, and it never
  sees the evaluation seeds;
* :func:`select_plan`: the planner's own use of Monte Carlo — among the distinct local
  optima of the multi-started OCP (:func:`tmaplan.policies.plan_starts.plan_candidates`),
  the one whose closed-loop mean time to accuracy on the *planner's* seeds is smallest (the
  cost ranks broad families of manoeuvres well but not its own nearby local optima);
* :func:`plan_campaign`: one paired campaign (common random numbers, truths from the prior)
  of ``planned`` against ``straight``, the single turn the planning cost itself picks as best
  (:func:`tmaplan.policies.best_single_turn`), every practitioner tactic
  (:mod:`tmaplan.policies.tactics`), the Monte Carlo tuned turn and optionally ``receding``;
* :func:`planned_differences`: the paired mean differences ``planned − X`` of the time to
  accuracy (censored at the horizon + dt, as ``compare``) with t intervals (negative:
  ``planned`` localises sooner).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.errors import ArgumentError, as_real, is_integer
from tmaplan.evaluation.campaigns import CampaignResult, CampaignSpec, run_campaign
from tmaplan.evaluation.metrics import PairedDifference, censor_time, paired_difference
from tmaplan.policies import (
    Combined,
    LeadLag,
    LegTurnLeg,
    Planned,
    Policy,
    Receding,
    SingleTurn,
    Straight,
    best_single_turn,
)
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.scenario import Scenario

__all__ = ["PLAN_BASELINES", "TUNE_ANGLES", "TUNE_FRACTIONS", "plan_campaign",
           "planned_differences", "select_plan", "tune_single_turn"]

#: The baselines :func:`plan_campaign` flies by name (``baselines``).
PLAN_BASELINES = ("straight", "single-turn", "leg-turn-leg", "lead-lag")
#: Course changes of the Monte Carlo tuning grid [deg] (both sides).
TUNE_ANGLES = (60.0, 90.0, 120.0, 150.0)
#: Turn times of the tuning grid, as fractions of the horizon.
TUNE_FRACTIONS = (0.125, 0.25, 0.375, 0.5)


def tune_single_turn(scenario: Scenario, *, runs: int = 16, seed: int = 1000,
                     n_particles: int = 3000, accuracy: float = 0.1,
                     angles: Sequence[float] = TUNE_ANGLES,
                     fractions: Sequence[float] = TUNE_FRACTIONS, workers: int = 1,
                     out_dir: str | Path | None = None) -> tuple[SingleTurn, dict[str, float]]:
    """The single turn of the grid with the smallest Monte Carlo mean time to accuracy.

    Parameters
    ----------
    scenario : Scenario
    runs : int
        Paired runs per grid point (truths from the prior).
    seed : int
        Root seed of the tuning runs; keep it apart from the evaluation's seed.
    n_particles, accuracy :
        As for :class:`tmaplan.experiments.CampaignSpec`.
    angles : sequence of float
        Course changes [deg], each flown to both sides; non-empty, finite.
    fractions : sequence of float
        Turn times as fractions of the horizon, in (0, 1); non-empty.
    workers, out_dir :
        As for :func:`tmaplan.experiments.run_campaign` (resumable).

    Returns
    -------
    turn : SingleTurn
        The best turn, named ``tuned-turn``.
    scores : dict
        Grid point name -> mean censored time to accuracy [s].
    """
    if not is_integer(runs, 1):
        raise ArgumentError("runs", "an integer >= 1", runs)
    if isinstance(angles, str) or not len(angles) or not all(
            np.isfinite(as_real(a)) for a in angles):
        raise ArgumentError("angles", "a non-empty sequence of finite course changes [deg]",
                            angles)
    if isinstance(fractions, str) or not len(fractions) or not all(
            0.0 < as_real(f) < 1.0 for f in fractions):
        raise ArgumentError("fractions", "a non-empty sequence of values in (0, 1)", fractions)
    t0, H = scenario.time.t0, scenario.time.horizon
    grid: dict[str, SingleTurn] = {}
    for f in fractions:
        for a in angles:
            for s in (1.0, -1.0):
                grid[f"turn:{s * a:+g}deg@{f * H:g}s"] = SingleTurn(
                    angle=s * np.radians(a), time=t0 + float(f) * H, name="tuned-turn")
    spec = CampaignSpec(scenario=scenario, policies=tuple(grid), runs=int(runs), seed=seed,
                        n_particles=n_particles, accuracy=accuracy)
    camp = run_campaign(spec, out_dir=out_dir, workers=workers,
                        policies={k: Combined(manoeuvre=v) for k, v in grid.items()})
    c = censor_time(scenario.times)
    scores = {k: float(np.mean(np.where(np.isfinite(t := camp.summary[k]
                                                    ["time_to_accuracy_runs"]), t, c)))
              for k in grid}
    best = min(scores, key=lambda k: scores[k])
    return grid[best], scores


def select_plan(scenario: Scenario, plans: Mapping[str, Any], *, runs: int = 24,
                seed: int = 2000, n_particles: int = 3000, accuracy: float = 0.1,
                workers: int = 1) -> tuple[str, Any, dict[str, float]]:
    """The plan of ``plans`` with the smallest mean censored time to accuracy in closed loop.

    Parameters
    ----------
    scenario : Scenario
    plans : mapping
        Name -> ``HeadingPlan`` (e.g. :func:`tmaplan.policies.plan_starts.plan_candidates`).
    runs : int
        Paired runs (truths from the prior) on the planner's seeds.
    seed : int
        Root seed of the selection runs; keep it apart from the evaluation's and the tuning's.
    n_particles, accuracy, workers :
        As for :func:`tmaplan.experiments.run_campaign`.

    Returns
    -------
    name : str
    plan : HeadingPlan
    scores : dict
        Name -> mean censored time to accuracy [s].
    """
    if not plans:
        raise ArgumentError("plans", "at least one plan", 0)
    if not is_integer(runs, 1):
        raise ArgumentError("runs", "an integer >= 1", runs)
    if len(plans) == 1:
        (name, plan), = plans.items()
        return name, plan, {}
    pols = {f"plan:{k}": Combined(manoeuvre=Planned(plan=v)) for k, v in plans.items()}
    spec = CampaignSpec(scenario=scenario, policies=tuple(pols), runs=int(runs), seed=seed,
                        n_particles=n_particles, accuracy=accuracy)
    camp = run_campaign(spec, workers=workers, policies=pols)
    c = censor_time(scenario.times)
    scores = {}
    for k in plans:
        t = camp.summary[f"plan:{k}"]["time_to_accuracy_runs"]
        scores[k] = float(np.mean(np.where(np.isfinite(t), t, c)))
    best = min(scores, key=lambda k: scores[k])
    return best, plans[best], scores


def plan_campaign(scenario: Scenario, *, runs: int = 100, seed: int = 0,
                  n_particles: int = 3000, accuracy: float = 0.1,
                  tuned: SingleTurn | None = None, receding: bool = False,
                  objective: str | None = None, selected: Any = None, workers: int = 1,
                  out_dir: str | Path | None = None,
                  baselines: bool | Sequence[str] = True) -> CampaignResult:
    """Paired campaign of ``planned`` against the baselines (see the module docstring).

    Policies: ``planned`` (the multi-started offline plan of ``objective``, default the
    scenario's), ``straight``, ``single-turn`` (the best single turn by the planning cost),
    ``leg-turn-leg``, ``lead-lag``, ``tuned-turn`` (if ``tuned`` is given), ``planned-mc``
    (the plan ``selected`` by :func:`select_plan`, if given) and ``receding`` (if
    ``receding``). ``baselines=False`` flies only ``planned`` and what is asked for beyond
    the baselines (e.g. ``receding − planned`` alone), a sequence of baseline names flies
    those only: every policy re-creates run ``i``'s generators from the same seeds, so its
    runs are those of the full campaign.
    """
    if not is_integer(runs, 1):  # before the offline plan, which takes seconds
        raise ArgumentError("runs", "an integer >= 1", runs)
    make: dict[str, Callable[[], Any]] = {
        "straight": Straight, "single-turn": lambda: best_single_turn(scenario),
        "leg-turn-leg": LegTurnLeg, "lead-lag": LeadLag}
    wanted = (PLAN_BASELINES if baselines is True else () if baselines is False
              else (baselines,) if isinstance(baselines, str) else tuple(baselines))
    for k in wanted:
        if k not in PLAN_BASELINES:
            raise ArgumentError("baselines", f"True, False or names among {PLAN_BASELINES}", k)
    obj = objective if objective is not None else (
        scenario.planning.objective if scenario.planning is not None else None)
    pols: dict[str, Policy] = {
        "planned": Combined(manoeuvre=Planned(objective=obj,
                                              plan=offline_plan(scenario, obj)))}
    pols |= {k: Combined(manoeuvre=make[k]()) for k in wanted}
    if tuned is not None:
        pols["tuned-turn"] = Combined(manoeuvre=tuned)
    if selected is not None:
        pols["planned-mc"] = Combined(manoeuvre=Planned(objective=obj, plan=selected,
                                                        name="planned-mc"))
    if receding:
        pols["receding"] = Combined(manoeuvre=Receding(objective=obj))
    spec = CampaignSpec(scenario=scenario, policies=tuple(pols), runs=int(runs), seed=seed,
                        n_particles=n_particles, accuracy=accuracy)
    return run_campaign(spec, out_dir=out_dir, workers=workers, policies=pols)


def planned_differences(camp: CampaignResult, reference: str = "planned", *,
                        level: float = 0.95) -> dict[str, PairedDifference]:
    """``reference − X`` of the mean time to accuracy for every other policy X [s].

    Times never reached are censored at the horizon + dt; the interval is the paired t
    interval of :func:`tmaplan.evaluation.metrics.paired_difference`.
    """
    if reference not in camp.policies:
        raise ArgumentError("reference", f"one of {', '.join(camp.policies)}", reference)
    censor = censor_time(camp.times)
    tta: Mapping[str, Any] = {k: camp.summary[k]["time_to_accuracy_runs"]
                              for k in camp.policies}
    return {k: paired_difference(tta, reference, k, "time_to_accuracy", level=level,
                                 censor=censor)
            for k in camp.policies if k != reference}
