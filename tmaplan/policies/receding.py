"""Receding-horizon re-planning on the particle filter's posterior (:class:`Receding`)."""

from __future__ import annotations

import dataclasses
import time
from concurrent.futures import BrokenExecutor, CancelledError, Executor, Future
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.errors import (
    ArgumentError,
    InfeasibleError,
    PlanningError,
    ScenarioError,
    SolverError,
    as_real,
    finite_real,
    is_integer,
    is_whole_count,
    whole_steps_text,
)
from tmaplan.models.observer import ObserverTrack
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.converged_sqp import ConvergedSQP
from tmaplan.planning.rti import QP_SOLVERS, RealTimeIteration, reference_model
from tmaplan.policies.base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    log,
    turn_limits,
)
from tmaplan.policies.manoeuvres import TurnRatePlayback, offline_plan, remember_offline_plan

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["RECEDING_SOLVERS", "Receding", "multi_start_replan", "prefetch_receding_model"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Receding:
    """Receding-horizon re-planning on the particle filter's posterior.

    Every ``replan_interval`` [s] the heading OCP is re-solved from the current own-ship state
    over ``horizon`` [s] with the filter's particles as the belief; its first segment is flown
    until the next re-plan. If its solve does not converge, the re-plan falls back to the
    multi-start's other starts (``fallback_starts``), and if none converges either, the
    previous plan is kept. The controller's ``log`` has one entry per re-plan (``t`` [s],
    ``status``, ``success``: a converged plan; ``fell_back``: a fallback used;
    ``infeasible``: no plan, as no plan satisfies the constraints; ``seconds``; ``solver``;
    ``start``: the start of a multi-start or fallback plan), which a campaign counts
    (:mod:`tmaplan.evaluation.replans`).

    How a re-plan is solved (``solver``):

    * ``"sqp"`` (default since issue 42): every re-plan solved to IPOPT's tolerance
      (``full_tol``) by a condensed quasi-Newton SQP over the turn rates
      (:class:`tmaplan.planning.converged_sqp.ConvergedSQP`: the real-time iteration's
      Hessian model, BFGS updates carried from re-plan to re-plan, ``qpsol`` QPs) on the
      compiled objective, warm-started as ``"ipopt"``; a solve that does not converge is
      solved by IPOPT from the same warm start (what ``"ipopt"`` would have flown), then falls
      back as IPOPT's does (``fallback_starts``). 44 ms CPU median per re-plan on harvested
      re-plans against 213 ms for ``"ipopt"`` before issue 42 and 137 ms on the compiled
      objective; no later than ``"ipopt"`` in a check fixed before its runs
      (docs/results/fast-replans.md). CLI names ``receding``, ``receding-sqp``.
    * ``"ipopt"``: one IPOPT solve at every re-plan (at ``full_tol``), warm-started
      from the previous plan, the first one from the offline plan from the prior (bit for bit
      the former ``Receding(solver="real-time", full_solves=tuple(range(64)))``, the
      ``receding-full`` of docs/results/receding-ipopt.md). It replaced the real-time
      iteration as the default because, solved to convergence, the re-plans localise sooner
      on ``bow-closing``:
      −0.26 [−0.40, −0.11] min against the real-time iteration on 3000 paired runs (seed 17;
      81.4 % of the runs localised by the horizon against 76.5 %), and −0.20 [−0.34, −0.06]
      min against ``planned`` on 4000 runs fixed before the run (seed 18), where the
      real-time iteration had tied with it; no later on ``default``
      and ``contact-astern`` (−0.22 [−1.17, +0.74] and −0.85 [−1.86, +0.17] min, 200 runs,
      seed 17), at 0.2–0.4 s (``bow-closing``) to 1 s (``default``) per re-plan instead of
      0.08 s (docs/results/receding-ipopt.md). The default until issue 42; CLI name
      ``receding-ipopt``.
    * ``"real-time"``: one warm-started SQP step
      (:class:`tmaplan.planning.rti.RealTimeIteration`, milliseconds) from the previous plan,
      the first one from the offline plan from the prior, with a full IPOPT solve as the
      fallback (``full_above``, ``full_solves``, ``multi_start``); CLI name
      ``receding-realtime`` (the default before; the ``receding`` numbers of docs/results/ up
      to the seed-17 campaign were flown with it), ``receding-rti`` without the ``full_above``
      fallback.
    * ``"multi-start"``: the first re-plan by IPOPT warm-started from the offline plan from
      the prior; every later one by IPOPT from five starts — the previous plan shifted to the
      re-plan time, its mirror image (the same manoeuvre to the other side), straight and
      the turn-early guesses to both sides — keeping the best (the log's ``start`` names
      it); CLI name ``receding-multistart``. A warm-started solve stays on the side the
      previous plan turned to, while the posterior may favour the other. At 6–10 times the
      planning time, it did not localise reliably sooner: on ``bow-closing``, against
      ``planned``, −0.95 [−1.59, −0.30] min on runs 100–399 of seed 10 (five-start re-plans
      up to the sixth), +0.74 [+0.07, +1.40] min on 300 runs of seed 12 and −0.20 [−0.76,
      +0.37] min on 300 runs of seed 15; pooled −0.15 [−0.51, +0.20] min, although it
      localised 5–10 percentage points more runs by the horizon on each (docs/results/
      value-of-information.md).

    Attributes
    ----------
    replan_interval : float, optional
        [s], a whole number (>= 1) of steps of dt; default (None):
        ``scenario.planning.replan_interval``.
    horizon : float, optional
        Look-ahead [s], finite and > 0; default: the planner's.
    objective : str
        Planning objective (default :data:`CLOSED_LOOP_OBJECTIVE`).
    max_particles : int
        Particles passed to the planner as belief samples (>= 5): a systematic subsample
        when the filter has more, else all of them with their weights
        (:meth:`tmaplan.planning.Belief.from_particles`).
    solver : {"ipopt", "real-time", "multi-start", "sqp"}
        How the re-plans are solved (above).
    qpsol : str
        With ``solver="real-time"`` or ``"sqp"``: QP solver of the real-time iteration or
        of the SQP (:data:`tmaplan.planning.rti.QP_SOLVERS`).
    rti_steps : int
        With ``solver="real-time"``: SQP steps per re-plan of the real-time iteration, >= 1.
    full_solves : tuple of int
        With ``solver="real-time"``: re-plans (0 = the first) always solved by a full IPOPT
        solve warm-started from the previous plan (default none). The fields that only the
        real-time iteration uses (``qpsol``, ``rti_steps``, ``full_solves``, ``full_above``,
        ``rti``) are refused with another solver, rather than ignored.
    full_above : float
        With ``solver="real-time"``: when a real-time iteration step lowers the objective by
        more than this fraction of its value at the shifted previous plan, the optimum has
        moved far and a full IPOPT solve warm-started from the previous plan replaces the
        step; ``inf``: never (``receding-rti``). On ``default`` (tuning seeds 1000, 28
        re-plans of 3 runs, ``benchmarks/closed_loop.py --gaps``) the start was 100–320
        objective units (10–30 %) from the IPOPT optimum at 5 re-plans, where the step
        lowered the objective by 1.2–15 %, and at most 10 units at the others, where it
        lowered it by at most 0.4 %: the default 1 % separates them.
    full_tol : float, optional
        IPOPT's tolerance for the re-plans' IPOPT solves (every solver's)
        (``tol`` of :meth:`tmaplan.planning.HeadingPlanner.solve`; None: the planner's 1e-7).
        Default 1e-4: on ``default`` (runs 0–23 of seed 0, the two settings interleaved in
        one process) a full solve took 1.00 s instead of 1.24 s, and over 100 paired runs
        the closed loop did not change (time to accuracy +1.4 s [−64.3, +67.0], final range
        error +5.6 m [−38.6, +49.8] against 1e-7; docs/findings.md).
    until_end : bool
        Count only the plan steps up to the scenario's end (``HeadingPlanner(until_end=True)``):
        a re-plan at time t optimises the time the mission has left instead of a full
        horizon that runs past the end, where the metrics stop counting. Off by default: on
        ``bow-closing`` (30 min, 400 paired runs, seed 6) it changed the mean time to
        accuracy by +0.6 s [−13.2, +14.4] against the real-time iteration
        (docs/results/receding-realtime.md).
    multi_start : tuple of int
        With ``solver="real-time"`` or ``"ipopt"``: re-plans (0 = the first) solved from the
        five starts of ``"multi-start"`` instead (default none).
    rti : RTIModel, optional
        With ``solver="real-time"`` or ``"sqp"``: the offline plan and the Hessian model of
        the real-time iteration (:func:`tmaplan.planning.rti.reference_model`); computed once
        per scenario if not given (:meth:`resolve` computes it once per campaign, so that
        workers receive it).
    first_plan : HeadingPlan, optional
        With ``solver="ipopt"`` or ``"multi-start"``: the offline plan from the prior that
        the first re-plan starts from; computed once per scenario if not given (by
        :meth:`resolve`, once per campaign).
    replan_on_alarm : bool
        Re-plan at once from the (recovered) posterior when the consistency monitor raised an
        alarm since the last step (:attr:`BeliefView.alarms`), not only every
        ``replan_interval``; a run without alarms is unchanged.
    fallback_starts : bool
        When a re-plan's solve does not converge (:class:`~tmaplan.errors.SolverError`) or
        its problem is reported infeasible (:class:`~tmaplan.errors.InfeasibleError`),
        solve it again from the other starts of ``"multi-start"`` (the mirror image of the
        previous plan, straight, turn-early to both sides; IPOPT at ``full_tol``) and fly the
        best that converged; the previous plan is kept only if none did. Off: keep it at
        once. A warm-started solve can stall on a plateau of the objective (every belief draw
        far from localised along the previous plan; IPOPT's limited-memory Hessian then
        takes tiny steps) where a turn-early start converges in a few dozen iterations.
    compiled : bool, optional
        Whether the re-plans' IPOPT and SQP solves evaluate the objective by its compiled
        kernel (``HeadingPlanner(compiled=True)``, :mod:`tmaplan.planning.compiled_objective`:
        the same values and gradients to rounding, 1.8 times faster IPOPT re-plans on
        ``default``). Default (None): yes, except with ``solver="real-time"``, whose model
        needs second derivatives (True is refused there). False: the casadi graph, the path
        before issue 42 (kept for the paired checks and the speed ratios).
    """

    replan_interval: float | None = None
    horizon: float | None = None
    objective: str | None = CLOSED_LOOP_OBJECTIVE
    max_particles: int = 2000
    solver: str = "sqp"
    qpsol: str = "daqp"
    rti_steps: int = 1
    full_solves: tuple[int, ...] = ()
    full_above: float = 0.01
    full_tol: float | None = 1e-4
    until_end: bool = False
    multi_start: tuple[int, ...] = ()
    rti: Any = dataclasses.field(default=None, compare=False, repr=False)
    first_plan: Any = dataclasses.field(default=None, compare=False, repr=False)
    replan_on_alarm: bool = True
    fallback_starts: bool = True
    compiled: bool | None = None
    name: str = "receding"

    @property
    def uses_compiled(self) -> bool:
        """Whether the re-plans evaluate the objective by its compiled kernel
        (``compiled``, its default resolved)."""
        return self.solver != "real-time" if self.compiled is None else bool(self.compiled)

    def controller(self, scenario: Scenario) -> Controller:
        """A controller owning a planner built once for the whole run."""
        return _RecedingController(self, scenario)

    @property
    def needs_offline_plan(self) -> bool:
        """Whether :meth:`resolve` will compute the offline plan from the prior
        (:func:`~tmaplan.policies.manoeuvres.offline_plan`): the start of the real-time
        iteration's model or the first re-plan's start, unless given or of another horizon.
        A campaign solves it first, its starts on the workers."""
        return self.horizon is None and (
            (self.solver in _MODEL_SOLVERS and self.rti is None)
            or (self.solver not in _MODEL_SOLVERS and self.first_plan is None))

    def resolve(self, scenario: Scenario) -> Receding:
        """The same policy with what its re-plans start from computed (once per campaign):
        the real-time iteration's model, or the plan the first re-plan starts from."""
        _check_receding(self, scenario)
        if self.solver in _MODEL_SOLVERS and self.rti is None:
            return dataclasses.replace(self, rti=_rti_model(scenario, self.objective,
                                                            self.horizon, self.until_end))
        if self.solver not in _MODEL_SOLVERS and self.first_plan is None:
            return dataclasses.replace(self, first_plan=_first_plan(
                scenario, self.objective, self.horizon, self.until_end))
        return self

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The offline plan from the prior: the receding controller's first plan."""
        return offline_plan(scenario, self.objective).observer


#: How :class:`Receding` solves its re-plans.
RECEDING_SOLVERS = ("ipopt", "real-time", "multi-start", "sqp")
#: The solvers that use the real-time iteration's model (``rti``, ``qpsol``).
_MODEL_SOLVERS = ("real-time", "sqp")

#: Heading planners (casadi problems built once) by (scenario, objective, horizon, until_end),
#: the 16 most recently used.
_PLANNER_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool, bool], Any] = (
    LRUCache(16))


def _planner(scenario: Scenario, objective: str | None, horizon: float | None,
             until_end: bool = False, compiled: bool = False) -> Any:
    key = (scenario, objective, horizon, until_end, compiled)
    if key not in _PLANNER_CACHE:
        kw: dict[str, Any] = {"until_end": until_end, "compiled": compiled}
        if objective is not None:
            kw["objective"] = objective
        if horizon is not None:
            kw["horizon"] = horizon
        _PLANNER_CACHE[key] = HeadingPlanner(scenario, **kw)
    return _PLANNER_CACHE[key]


#: Real-time-iteration models (or their pending futures), keyed as the planners.
_RTI_MODEL_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool], Any] = LRUCache(16)
#: Real-time iterations (each holds its planner and QP), the 16 most recently used.
_RTI_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool, str, int, bool], Any] = (
    LRUCache(16))


def _rti_model(scenario: Scenario, objective: str | None, horizon: float | None,
               until_end: bool = False) -> Any:
    """The real-time iteration's model at the offline plan from the prior (cached)."""
    key = (scenario, objective, horizon, until_end)
    if key not in _RTI_MODEL_CACHE:
        planner = _planner(scenario, objective, horizon, until_end)
        plan = _first_plan(scenario, objective, horizon, until_end)
        _RTI_MODEL_CACHE[key] = reference_model(planner, plan, Belief.from_prior(scenario))
    model = _RTI_MODEL_CACHE[key]
    if isinstance(model, Future):  # computed on a worker (prefetch_receding_model)
        try:
            model = model.result()
        except (CancelledError, BrokenExecutor):  # the pool went away first: compute here
            del _RTI_MODEL_CACHE[key]
            return _rti_model(scenario, objective, horizon, until_end)
        except BaseException:
            del _RTI_MODEL_CACHE[key]  # reported, and not kept: a later call tries again
            raise
        _RTI_MODEL_CACHE[key] = model
    return model


def _first_plan(scenario: Scenario, objective: str | None, horizon: float | None,
                until_end: bool = False) -> Any:
    """The plan from the prior that a receding controller's first re-plan starts from: the
    offline plan (:func:`~tmaplan.policies.manoeuvres.offline_plan`, cached), or with another
    horizon the planner's solve from the prior (cached)."""
    if horizon is None:
        return offline_plan(scenario, objective)
    key = (scenario, objective, horizon, until_end)
    if key not in _FIRST_PLAN_CACHE:
        _FIRST_PLAN_CACHE[key] = _planner(scenario, objective, horizon, until_end).solve(
            Belief.from_prior(scenario))
    return _FIRST_PLAN_CACHE[key]


#: The first plans of another horizon than the offline plan's, keyed as the planners.
_FIRST_PLAN_CACHE: LRUCache[tuple[Scenario, str | None, float | None, bool], Any] = (
    LRUCache(16))


def prefetch_receding_model(scenario: Scenario, objective: str | None, pool: Executor) -> None:
    """Start computing the real-time iteration's model of ``Receding(objective=objective)``
    (its SQP's; ``receding-realtime``'s too; the Hessian at the offline plan, about 5 s on
    ``default``) on a worker of ``pool``, so that the main process can meanwhile do other
    work (``tmaplan demo``: the ping schedule);
    :meth:`Receding.resolve` then waits for it. The same model, bit for bit, as computed in
    this process. Needs the offline plan
    (:func:`~tmaplan.policies.manoeuvres.offline_plan`), which the worker receives."""
    key = (scenario, objective, None, False)
    if key not in _RTI_MODEL_CACHE:
        _RTI_MODEL_CACHE[key] = pool.submit(_rti_model_on_worker, scenario, objective,
                                            offline_plan(scenario, objective))


def _rti_model_on_worker(scenario: Scenario, objective: str | None, plan: Any) -> Any:
    remember_offline_plan(scenario, objective, plan)
    return _rti_model(scenario, objective, None)


def _rti(policy: Receding, scenario: Scenario) -> Any:
    """The policy's real-time iteration (casadi functions built once per process)."""
    model = policy.rti if policy.rti is not None else _rti_model(
        scenario, policy.objective, policy.horizon, policy.until_end)
    key = (scenario, policy.objective, policy.horizon, policy.until_end, policy.qpsol,
           policy.rti_steps, policy.uses_compiled)
    planner = _planner(scenario, policy.objective, policy.horizon, policy.until_end,
                       policy.uses_compiled)
    if key not in _RTI_CACHE or _RTI_CACHE[key].planner is not planner:  # (planner evicted)
        _RTI_CACHE[key] = RealTimeIteration(planner, model, qpsol=policy.qpsol,
                                            steps=policy.rti_steps)
    return _RTI_CACHE[key].with_model(model)


def _sqp(planner: Any, rti: Any) -> Any:
    """The converged SQP of a planner (casadi functions built once per process)."""
    key = (planner, rti.qpsol)
    if key not in _SQP_CACHE:
        _SQP_CACHE[key] = ConvergedSQP(planner, rti.model, qpsol=rti.qpsol, rti=rti)
    return _SQP_CACHE[key].with_model(rti.model)


#: Converged SQPs by (planner, QP solver).
_SQP_CACHE: LRUCache[tuple[Any, str], Any] = LRUCache(16)


def _check_receding(policy: Receding, scenario: Scenario) -> None:
    """ArgumentError naming the first invalid field of ``policy`` (before anything is
    computed from it)."""
    for field in ("replan_interval", "horizon"):
        v = getattr(policy, field)
        if v is not None:
            finite_real(f"receding.{field}", v, "> 0 s", lower=0.0, strict=True)
    v, dt = policy.replan_interval, scenario.time.dt
    if v is not None and not is_whole_count(float(v) / dt):
        # the controller acts on the grid: another interval would silently be rounded up
        raise ArgumentError("receding.replan_interval", whole_steps_text(dt), v)
    n = policy.rti_steps
    if not is_integer(n, 1):
        raise ArgumentError("receding.rti_steps", "an integer >= 1", n)
    if not isinstance(policy.solver, str) or policy.solver not in RECEDING_SOLVERS:
        raise ArgumentError("receding.solver", f"one of {', '.join(RECEDING_SOLVERS)}",
                            policy.solver)
    for field in ("full_solves", "multi_start"):
        idx = getattr(policy, field)
        if not all(is_integer(i, 0) for i in idx):
            raise ArgumentError(f"receding.{field}", "re-plan indices >= 0", idx)
    mp = policy.max_particles
    if not is_integer(mp, 5):
        raise ArgumentError("receding.max_particles", "an integer >= 5", mp)
    if not as_real(policy.full_above) > 0:  # (NaN, a bool or a string fail)
        raise ArgumentError("receding.full_above", "> 0 (inf: never)", policy.full_above)
    HeadingPlanner.check_tolerance(policy.full_tol, "receding.full_tol")
    if not (policy.compiled is None or isinstance(policy.compiled, bool)) or (
            policy.compiled is True and policy.solver == "real-time"):
        raise ArgumentError("receding.compiled", "None or False with solver='real-time' (its "
                            "model needs second derivatives), else None, True or False",
                            policy.compiled)
    if policy.solver in _MODEL_SOLVERS and policy.qpsol not in QP_SOLVERS:
        raise ArgumentError("receding.qpsol", f"one of {', '.join(QP_SOLVERS)}", policy.qpsol)
    if policy.solver != "real-time":  # what only the real-time iteration uses, not ignored
        defaults = {f.name: f.default for f in dataclasses.fields(Receding)}
        for field in _REAL_TIME_ONLY[2 if policy.solver == "sqp" else 0:]:
            value, default = getattr(policy, field), defaults[field]
            if value is not default and value != default:
                raise ArgumentError(f"receding.{field}", f"{default!r} with solver="
                                    f"{policy.solver!r} (it serves solver='real-time' only)",
                                    value)


#: The fields that only ``solver="real-time"`` uses (refused off their defaults otherwise;
#: ``"sqp"`` uses the first two).
_REAL_TIME_ONLY = ("qpsol", "rti", "rti_steps", "full_solves", "full_above")


class _RecedingController:
    def __init__(self, policy: Receding, scenario: Scenario) -> None:
        _check_receding(policy, scenario)
        pl = scenario.planning
        interval = policy.replan_interval if policy.replan_interval is not None else (
            pl.replan_interval if pl else None)
        if interval is None:
            raise ScenarioError("planning.replan_interval", "a re-planning interval for the "
                                "receding policy", None, source=scenario.name)
        self.interval = float(interval)
        self.policy = policy
        self.scenario = scenario
        self.planner = _planner(scenario, policy.objective, policy.horizon, policy.until_end,
                                policy.uses_compiled)
        self.rti = _rti(policy, scenario) if policy.solver in _MODEL_SOLVERS else None
        self.sqp = _sqp(self.planner, self.rti) if policy.solver == "sqp" else None
        # what the first re-plan starts from (None: a cold start)
        self.first: Any = None
        if self.rti is not None:
            self.first = self.rti.model.plan
        else:
            self.first = policy.first_plan if policy.first_plan is not None else _first_plan(
                scenario, policy.objective, policy.horizon, policy.until_end)
        self.u_max, self.dt = turn_limits(scenario)
        self.plan: Any = None
        self.playback: TurnRatePlayback | None = None
        self.next_replan = scenario.time.t0
        self.log: list[dict[str, Any]] = []
        self.alarms = 0

    def act(self, belief: BeliefView, t: float) -> Action:
        alarmed = self.policy.replan_on_alarm and belief.alarms > self.alarms
        self.alarms = belief.alarms
        if alarmed or t + 1e-9 >= self.next_replan:
            self._replan(belief, t)
            self.next_replan = t + self.interval
        rate = self.playback.rate_at(t) if self.playback is not None else 0.0
        return Action(turn_rate=rate)

    def _replan(self, belief: BeliefView, t: float) -> None:
        t0 = time.perf_counter()
        # the filter's posterior at step k has assimilated the measurements at k (it predicts
        # and updates to k before the controller acts at k; at step 0 it has updated with the
        # measurements of step 0, if any): the plan counts the sensors from the next step
        b = Belief.from_particles(belief.particles, belief.weights, t=t,
                                  max_samples=self.policy.max_particles, assimilated=True)
        entry: dict[str, Any] = {"t": t}
        pol, n = self.policy, len(self.log)
        kw: dict[str, Any] = {"heading0": belief.heading, "position0": belief.position}
        try:
            if (pol.solver == "multi-start" and n > 0) or n in pol.multi_start:
                plan = self.multi_start(b, **kw)
                entry["start"] = plan.message
                fell_back = False
            else:
                try:
                    plan, fell_back = self._solve(b, n, **kw)
                except (SolverError, InfeasibleError) as exc:  # (not a bad request)
                    if not pol.fallback_starts:
                        raise
                    # the first solve did not converge: the other starts of the multi-start
                    plan, fell_back = self._fall_back(b, exc, **kw), True
                    entry["start"] = plan.message
            entry.update(status=plan.status, success=True, solver=plan.solver,
                         fell_back=fell_back)
            self.plan = plan
            self.playback = TurnRatePlayback(plan, self.scenario)
        except PlanningError as exc:  # keep flying the previous plan
            # no plan satisfies the constraints (infeasible), or not converged (the others)
            entry.update(status=str(exc), success=False, fell_back=True,
                         infeasible=isinstance(exc, InfeasibleError))
            log.info("re-plan at t=%.0f s failed (%s); keeping the previous plan", t, exc)
        entry["seconds"] = time.perf_counter() - t0
        self.log.append(entry)

    def _solve(self, b: Any, n: int, *, heading0: float,
               position0: np.ndarray) -> tuple[Any, bool]:
        """Re-plan ``n`` by the policy's solver: (the plan, whether the real-time iteration's
        step was rejected, or the SQP did not converge, and IPOPT from the same warm start
        gave the plan)."""
        pol = self.policy
        full = {"heading0": heading0, "position0": position0,
                "warm_start": self.plan or self.first, "tol": pol.full_tol}
        if self.sqp is not None:
            try:
                return self.sqp.solve(b, **full), False
            except SolverError:  # IPOPT's re-plan, as "ipopt" would solve it (then the starts)
                return self.planner.solve(b, **full), True
        if self.rti is None or n in pol.full_solves:  # "ipopt", or a full solve asked
            return self.planner.solve(b, **full), False
        plan = self.rti.solve(b, previous=self.plan, heading0=heading0, position0=position0)
        if plan.solver == "ipopt":  # the step was rejected (RealTimeIteration.solve)
            return plan, True
        start = (plan.warm or {}).get("start_objective")
        if start is not None and start - plan.objective > pol.full_above * abs(start):
            plan = self.planner.solve(b, **full)
        return plan, False

    def _fall_back(self, b: Any, error: PlanningError, *, heading0: float,
                   position0: np.ndarray) -> Any:
        """The best converged solve from the multi-start's other starts (:meth:`multi_start`
        without the warm start) after the first solve failed with ``error``. If none
        converged: an error naming both failures, an :class:`InfeasibleError` if the fallback
        found the problem infeasible."""
        try:
            return self.multi_start(b, heading0=heading0, position0=position0, warm=False)
        except PlanningError as again:
            if str(again) == str(error):  # refused before any solve (the same check)
                raise
            cls = InfeasibleError if isinstance(again, InfeasibleError) else PlanningError
            raise cls(f"{error}; then from the fallback starts: {again}") from error

    def multi_start(self, b: Any, *, heading0: float | None,
                    position0: np.ndarray | None, warm: bool = True) -> Any:
        """:func:`multi_start_replan` from the previous plan (or the first), at the
        policy's ``full_tol``."""
        return multi_start_replan(self.planner, b, self.plan or self.first, heading0=heading0,
                                  position0=position0, tol=self.policy.full_tol, warm=warm)


def multi_start_replan(planner: Any, b: Any, prev: Any, *, heading0: float | None,
                       position0: np.ndarray | None, tol: float | None,
                       warm: bool = True) -> Any:
    """Full IPOPT re-plan from several starts, the best kept (its ``message`` names the
    start): the previous plan shifted to ``b.t`` (warm), its mirror image (the same
    manoeuvre to the other side), straight and the turn-early guesses to both sides.

    Parameters
    ----------
    planner : HeadingPlanner
        The planner re-solved (for several contacts: the joint planner,
        :attr:`tmaplan.planning.contacts.ContactsPlanner.joint`).
    b : Belief or ContactBeliefs
        The belief(s) to plan against, at ``b.t`` [s].
    prev : HeadingPlan, optional
        The plan flown so far (None: no warm start, no mirror image).
    heading0 : float, optional
        Own-ship heading [rad] (None: the scenario's initial course).
    position0 : ndarray, shape (2,), optional
        Own-ship position [m].
    tol : float, optional
        IPOPT's tolerance (None: the planner's).
    warm : bool
        Include the warm start; False (the fallback after it failed): the other starts,
        the mirror image only if there is a previous plan.

    Returns
    -------
    HeadingPlan
        The best of the converged solves.

    Raises
    ------
    SolverError
        If no start converged (a start stopped at the iteration limit or failed).
    InfeasibleError
        If every start reported the problem infeasible, or it is (the estimate inside
        the keep-out range).
    """
    if prev is None and warm:
        raise PlanningError("multi-start re-plan: no previous plan to start from")
    pl = planner
    kw = {"heading0": heading0, "position0": position0, "tol": tol,
          "raise_on_failure": False}
    j = np.arange(pl.n)
    starts = {"straight": np.zeros(pl.n), "early-port": np.where(j < pl.n / 4, -1.0, 0.0),
              "early-starboard": np.where(j < pl.n / 4, 1.0, 0.0)}
    plans = {}
    if prev is not None:
        k = max(round((b.t - float(prev.times[0])) / pl.Tc), 0)
        u = np.clip(prev.turn_rate / max(pl.u_max, 1e-12), -1.0, 1.0)
        u = np.concatenate([u[k:], np.full(min(k, pl.n), u[-1] if u.size else 0.0)])
        u = np.resize(u, pl.n) if u.size != pl.n else u
        starts = {"mirrored": -u, **starts}
        if warm:
            plans["warm"] = pl.solve(b, warm_start=prev, **kw)
    for name, s in starts.items():
        plans[name] = pl.solve(b, starts=[s], **kw)
    ok = {n: p for n, p in plans.items() if p.success and np.isfinite(p.objective)}
    if not ok:
        statuses = sorted({p.status for p in plans.values()})
        what = f"multi-start re-plan at t={b.t:.0f} s from {len(plans)} start(s)"
        if all("Infeasible" in st for st in statuses):
            raise InfeasibleError(f"{what}: infeasible from every start (IPOPT: "
                                  f"{', '.join(statuses)})")
        raise SolverError("ipopt", ", ".join(statuses), f"{what}: no start converged")
    name = min(ok, key=lambda n: ok[n].objective)
    return dataclasses.replace(ok[name], message=f"multi-start: {name}")
