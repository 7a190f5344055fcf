"""The offline heading plan from the prior, multi-started from the manoeuvres it must beat.

The heading OCP (:class:`tmaplan.planning.HeadingPlanner`) is non-convex: from its built-in
initial guesses IPOPT can stop in a local optimum worse than a manoeuvre an operator flies by
rule. :func:`plan_from_prior` therefore starts it from every manoeuvre it is compared with —
straight, the practitioner tactics (:class:`~tmaplan.policies.LegTurnLeg`,
:class:`~tmaplan.policies.LeadLag`, each also mirrored to the other side) and the best single
turns of the baseline grid by the planning cost itself — plus the planner's own guesses, and
keeps the solution with the smallest cost. A solution started from a manoeuvre is a local
improvement of it, so the plan's cost is never worse than the cost of any of those
manoeuvres (up to the solver's tolerance).
"""

from __future__ import annotations

import dataclasses
import uuid
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.errors import ArgumentError, PlanningError, SolverError, is_integer
from tmaplan.models.observer import ObserverTrack
from tmaplan.parallel import closing_pool, process_pool
from tmaplan.planning.baselines import evaluate_baselines, straight_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.feasibility import check_keep_out
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner
from tmaplan.policies.tactics import LeadLag, LegTurnLeg

if TYPE_CHECKING:
    from concurrent.futures import Executor

    from tmaplan.scenario import Scenario

__all__ = ["plan_candidates", "plan_from_prior", "start_programs", "turn_program"]


def turn_program(track: ObserverTrack, planner: HeadingPlanner) -> np.ndarray:
    """Turn-rate program ``u_j/u_max`` (n,) of ``track`` on the planner's control grid: the mean
    turn rate over each control interval of ``Tc`` (the heading change across it / Tc),
    clipped to [−1, 1]; a shorter track continues straight."""
    hd = np.unwrap(np.asarray(track.heading, float))
    nodes = np.arange(planner.n + 1) * planner.m
    nodes = np.minimum(nodes, hd.size - 1)
    u = np.diff(hd[nodes]) / (planner.Tc * max(planner.u_max, 1e-12))
    return np.clip(u, -1.0, 1.0)


def start_programs(scenario: Scenario, planner: HeadingPlanner, *, n_turns: int = 3,
                   ) -> dict[str, np.ndarray]:
    """Named initial guesses (turn-rate programs, :func:`turn_program`) for the multi-start.

    ``straight``; ``leg-turn-leg`` and ``lead-lag`` (their nominal tracks from the prior mean,
    :mod:`tmaplan.policies.tactics`) and their mirror images (``…:mirrored``, the turn to the
    other side); the ``n_turns`` best single turns of the baseline grid
    (:func:`tmaplan.planning.evaluate_baselines`) by the planner's own objective; the
    planner's built-in guesses (``guess:i``).
    """
    out: dict[str, np.ndarray] = {"straight": turn_program(straight_track(scenario), planner)}
    for tactic in (LegTurnLeg(), LeadLag()):
        try:
            u = turn_program(tactic.nominal_track(scenario), planner)
        except (PlanningError, ValueError):  # a horizon too short for the rule
            continue
        out[tactic.name] = u
        out[f"{tactic.name}:mirrored"] = -u
    # ranked by the planner's own objective (its turn-rate normaliser, samples, step weights)
    base = evaluate_baselines(scenario, planner.objective,
                              evaluator=planner.evaluator(Belief.from_prior(scenario)))
    for i, b in enumerate(base["single-turn"][: max(int(n_turns), 0)]):
        out[f"single-turn:{i}"] = turn_program(b.track, planner)
    j = np.arange(planner.n)
    n = planner.n
    guesses = [np.where(j < n / 3, 1.0, -1.0), np.where(j < n / 3, -1.0, 1.0),
               np.where(j < n / 4, 1.0, 0.0), np.where(j < n / 4, -1.0, 0.0)]
    for i, u in enumerate(guesses):
        out[f"guess:{i}"] = u
    return out


def plan_from_prior(scenario: Scenario, objective: Any = None, *, n_turns: int = 3,
                    planner: HeadingPlanner | None = None, workers: int = 1,
                    pool: Executor | None = None, **planner_kw: Any) -> HeadingPlan:
    """Heading plan from the prior, multi-started (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
    objective : str or Objective, optional
        Default: the scenario's ``planning.objective``.
    n_turns : int
        Best single turns of the baseline grid used as starts.
    planner : HeadingPlanner, optional
        A planner to reuse (``objective`` and ``planner_kw`` are then ignored).
    workers : int
        Processes the starts are solved on (each builds its own planner; the same plans as
        one process, bit for bit). Only without ``planner`` and with ``objective`` a name
        (an :class:`~tmaplan.planning.objectives.Objective` object is solved in this
        process).
    pool : concurrent.futures.Executor, optional
        Worker processes to solve the starts on instead (:func:`tmaplan.parallel.
        process_pool`, e.g. a campaign's; same conditions as ``workers``).
    **planner_kw
        Further arguments of :class:`tmaplan.planning.HeadingPlanner`.

    Returns
    -------
    HeadingPlan
        The best solution over the starts; its ``message`` names the start it came from.

    Raises
    ------
    SolverError
        If IPOPT converged from none of the starts.
    """
    plans = plan_candidates(scenario, objective, n_turns=n_turns, planner=planner,
                            workers=workers, pool=pool, **planner_kw)
    name = min(plans, key=lambda k: plans[k].objective)
    return dataclasses.replace(
        plans[name], iterations=sum(p.iterations for p in plans.values()),
        seconds=sum(p.seconds for p in plans.values()),
        message=f"best of the multi-start: {name}")


def plan_candidates(scenario: Scenario, objective: Any = None, *, n_turns: int = 3,
                    planner: HeadingPlanner | None = None, tol: float = 1e-4,
                    workers: int = 1, pool: Executor | None = None, **planner_kw: Any
                    ) -> dict[str, HeadingPlan]:
    """Every distinct local optimum of the multi-start (start name -> plan), best cost first.

    Solutions whose costs agree within ``tol`` (relative) are one optimum, kept under the
    first start that reached it. Arguments as :func:`plan_from_prior`.

    Raises
    ------
    ScenarioError
        A keep-out range that the prior or the truth starts inside
        (:func:`tmaplan.planning.feasibility.check_keep_out`).
    SolverError
        If IPOPT converged from none of the starts.
    """
    if not is_integer(workers, 1):
        raise ArgumentError("workers", "an integer >= 1", workers)
    parallel = (workers > 1 or pool is not None) and planner is None and (
        objective is None or isinstance(objective, str))
    belief = Belief.from_prior(scenario)
    # a keep-out range the prior starts inside fails every start (each start's PlanningError
    # is taken as "did not converge"): refused before the planner is built, naming the field
    given = planner.keep_out if planner is not None else planner_kw.get("keep_out_range")
    check_keep_out(scenario, belief=belief, keep_out=given,
                   field="planning.keep_out_range" if given is None else "keep_out_range")
    if planner is None:
        planner = _build_planner(scenario, objective, planner_kw)
    starts = start_programs(scenario, planner, n_turns=n_turns)
    if parallel:
        own = None
        if pool is None:
            pool = own = process_pool(min(int(workers), len(starts)), warm_up=(__name__,))
        with closing_pool(own):  # (stopped at once by an interrupt)
            # the planner's inputs travel with each start (a few kB); each worker builds the
            # planner once per multi-start (the token; _solve_in_worker's cache)
            key = (uuid.uuid4().hex, scenario, objective, planner_kw)
            plans = list(pool.map(_solve_in_worker, [key] * len(starts), starts.values()))
    else:
        plans = [_solve_start(planner, belief, u) for u in starts.values()]
    found = [(name, plan) for name, plan in zip(starts, plans) if plan is not None]
    if not found:
        raise SolverError("ipopt", "no start converged",
                          f"heading OCP from the prior ({scenario.name})")
    found.sort(key=lambda np_: np_[1].objective)
    out: dict[str, HeadingPlan] = {}
    for name, plan in found:
        if all(abs(plan.objective - q.objective) > tol * max(abs(q.objective), 1e-12)
               for q in out.values()):
            out[name] = plan
    return out


def _build_planner(scenario: Scenario, objective: Any, planner_kw: dict[str, Any]
                   ) -> HeadingPlanner:
    kw = dict(planner_kw)
    if objective is not None:
        kw["objective"] = objective
    return HeadingPlanner(scenario, **kw)


def _solve_start(planner: HeadingPlanner, belief: Any, u: np.ndarray) -> HeadingPlan | None:
    """IPOPT from one start; None if it failed or did not converge."""
    try:
        plan = planner.solve(belief, starts=[u], raise_on_failure=False)
    except PlanningError:
        return None
    return plan if plan.success and np.isfinite(plan.objective) else None


_WORKER: dict[str, Any] = {}


def _solve_in_worker(key: tuple[Any, ...], u: np.ndarray) -> HeadingPlan | None:
    """One start on a worker process. ``key``: (token, scenario, objective, planner
    arguments); the planner and the prior belief are built once per worker and token."""
    token, scenario, objective, planner_kw = key
    if _WORKER.get("token") != token:
        _WORKER.update(token=token, planner=_build_planner(scenario, objective, planner_kw),
                       belief=Belief.from_prior(scenario))
    return _solve_start(_WORKER["planner"], _WORKER["belief"], u)
