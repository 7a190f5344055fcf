"""Active-ping scheduling under a budget with the closed-form PCRB (brehard2005 §5, docs/errata.md).

Choose at most ``budget`` ping steps on a fixed observer track to minimise a closed-form PCRB
objective. Structure used (docs/errata.md): the moments, the D-terms and ``E r_k²`` do not
depend on the schedule; a ping at step k adds ``u_k·E r_k²/σ_r²`` to ``J_k[ln r, ln r]``
(brehard2005 eq. 51); the Riccati map is matrix-monotone, so adding a ping never increases any
objective below (range bound ``sqrt(E r_k²·[J_k⁻¹]_{ln r})``, position bound
``sqrt(tr P_pos)``), which makes "all remaining candidates pinged" a valid lower bound for
branch and bound.

Methods (every one reports a certified ``lower_bound`` and the relative ``gap``)
    ``relaxed`` (default): the convex SDP relaxation of
    :mod:`tmaplan.planning.ping_relaxation` (cvxpy + Clarabel) gives the certified lower bound
    and fractional weights; their roundings, the greedy schedule and the evenly spaced one are
    polished by moves of any ping to any candidate over the whole horizon, and the best is kept
    (never worse than ``greedy``).
    ``greedy``: add the best ping one at a time, then local swaps; same certificate.
    ``exact``: tree enumeration with prefix reuse and valid pruning on all cores
    (:mod:`tmaplan.planning.ping_exact`), started from the ``relaxed`` schedule. Status
    ``optimal`` only when the certified relative gap is ≤ 1e-3, else ``time limit``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.bounds.closed_form import require_process_noise
from tmaplan.bounds.closed_form_engine import ClosedFormEngine, lpc_position_bound_graph
from tmaplan.bounds.inputs import check_ping_steps
from tmaplan.display import seconds_text, short_repr
from tmaplan.errors import ArgumentError, PlanningError, is_integer
from tmaplan.memory import check_steps
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.objectives import (
    PING_OBJECTIVES,
    PingObjectiveName,
    belief_bearing_information,
    ping_sigma,
)
from tmaplan.planning.ping_exact import tree_search
from tmaplan.planning.ping_relaxation import relaxation_bound
from tmaplan.planning.ping_search import (
    exact_search,
    greedy_schedule,
    local_swaps,
    max_pings,
    ping_candidates,
    round_weights,
    spacing_ok,
    uniform_ping_steps,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["PING_OBJECTIVES", "PingEvaluator", "PingSchedule", "certified_schedule",
           "ping_candidates", "schedule_pings", "uniform_ping_steps"]

#: Certified relative gap below which a schedule is reported "optimal".
OPTIMAL_GAP = 1e-3
#: A relaxation bound above a schedule's objective by at most this relative amount is the
#: relaxation being tight (its optimum is integral) up to the conic solver's tolerance
#: (Clarabel's relative gap tolerance here is 1e-8); anything larger is an error.
TIGHT_BOUND_TOLERANCE = 1e-6


@dataclasses.dataclass(frozen=True, kw_only=True)
class PingSchedule:
    """A ping schedule and its quality.

    Attributes
    ----------
    steps : ndarray of int, shape (n_pings,)
        Ping steps on the observer track's grid.
    times : ndarray, shape (n_pings,)
        [s].
    objective : float
        Objective with these pings [m].
    no_ping_objective, uniform_objective : float
        Without pings, and with the ``budget`` evenly spaced pings ``uniform_steps`` [m].
    lower_bound : float
        Certified lower bound on the optimum [m] (nan if none was computed).
    gap : float
        Relative gap ``(objective − lower_bound)/objective`` (nan without a bound).
    gap_reference : str
        Where ``lower_bound`` comes from: "relaxation (clarabel)", "relaxation (clarabel,
        reduced accuracy)" (Clarabel's "AlmostSolved", its reduced gap removed), "relaxation
        (scs)", "enumeration", "enumeration (time limit)", "fallback: all candidates
        pinged (...)" (the relaxation failed; its reasons), or "none".
    bound : ndarray, shape (K + 1,)
        Range bound per step with the schedule [m].
    status : str
        "optimal" (certified gap ≤ 1e-3), "feasible" (heuristic, larger gap), "time limit"
        (``exact`` stopped with the incumbent), "no bound" (``gap_reference="none"``).
    seconds : float
    method : str
    objective_name : str
    budget : int
    uniform_steps : ndarray of int
        The evenly spaced reference schedule (:func:`uniform_ping_steps`), the one the
        ``uniform`` ping policy flies.
    bound_seconds : float
        Of ``seconds``, spent on the certificate [s].
    relaxed_weights : ndarray, shape (n_candidates,)
        Optimal weights of the relaxation (empty when it was not solved).
    """

    __repr__ = short_repr

    steps: np.ndarray
    times: np.ndarray
    objective: float
    no_ping_objective: float
    uniform_objective: float
    lower_bound: float
    gap: float
    gap_reference: str
    bound: np.ndarray
    status: str
    seconds: float
    method: str
    objective_name: str
    budget: int
    uniform_steps: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=int))
    bound_seconds: float = 0.0
    relaxed_weights: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        # read-only copies: the relaxed weights were the cached relaxation's own array, so
        # writing into one result changed the weights (and roundings) of later calls
        for name in ("steps", "times", "bound", "uniform_steps", "relaxed_weights"):
            a = np.array(getattr(self, name), copy=True)
            a.flags.writeable = False
            object.__setattr__(self, name, a)


class PingEvaluator:
    """A ping-scheduling objective on a fixed observer track: the closed-form engine
    (:class:`tmaplan.bounds.closed_form_engine.ClosedFormEngine`) of the belief and track,
    reduced to one number per schedule.

    Parameters
    ----------
    scenario : Scenario
    observer : ObserverTrack
    belief : Belief
        Relative state at the track's first instant.
    objective : str
        One of :data:`PING_OBJECTIVES`.
    """

    def __init__(self, scenario: Scenario, observer: ObserverTrack, belief: Belief,
                 objective: str = "mean-range-bound") -> None:
        if objective not in PING_OBJECTIVES:
            raise ArgumentError("objective", f"one of {', '.join(PING_OBJECTIVES)}", objective)
        self.objective = objective
        sig = ping_sigma(scenario)
        if sig is None:
            raise PlanningError(f"{scenario.name}: no range sensor to ping with (add a "
                                "[[sensors]] kind = 'range' or planning.ping_sigma)")
        require_process_noise(scenario)
        K = observer.position.shape[0] - 1
        self.engine = ClosedFormEngine.from_belief(
            belief, observer, dt=float(scenario.time.dt), q=float(scenario.target.q),
            bearing_info=belief_bearing_information(scenario, belief, K), ping_sigma=sig)
        self.K, self.dt, self.times = K, float(scenario.time.dt), observer.times
        self._quantity = "position" if objective == "mean-position-bound" else "range"
        self._reduce = "terminal" if objective == "terminal-range-bound" else "mean"

    def per_step(self, U: np.ndarray) -> np.ndarray:
        """Bound per step (S, K+1) [m]: range bound, or sqrt(tr P_pos) (position objective)."""
        return self.engine.evaluate_schedules(U, quantity=self._quantity)

    def evaluate(self, U: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """Objective (S,) [m] of schedules U (S, K+1) (weights in [0, 1]), ``chunk`` at a time."""
        U = np.atleast_2d(np.asarray(U, float))
        return np.concatenate([np.zeros(0)] + [
            self.engine.evaluate_schedules(U[s:s + chunk], reduce=self._reduce,
                                           quantity=self._quantity)
            for s in range(0, U.shape[0], chunk)])

    def schedules(self, sets: Sequence[Sequence[int]]) -> np.ndarray:
        """0/1 matrix (S, K+1) of ping-step sets (each step in [0, K], else
        :class:`ArgumentError` naming ``ping_steps``)."""
        U = np.zeros((len(sets), self.K + 1))
        for i, st in enumerate(sets):
            U[i, check_ping_steps(st, self.K)] = 1.0
        return U

    def value(self, steps: Sequence[int]) -> float:
        """Objective of one schedule."""
        return float(self.evaluate(self.schedules([steps]))[0])

    def casadi_objective(self, u: Any) -> Any:
        """casadi expression of the objective of relaxed weights ``u`` ((K+1)×1 MX).

        For ``terminal-range-bound`` it is ``[J_K⁻¹]_{ln r}·E r_K²`` (the square of the range
        bound: same minimiser, and convex in u).
        """
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        g = self.engine.schedule_graph(u)
        if self.objective == "terminal-range-bound":
            return g["var"][-1, 1] * g["er2"][-1]
        pb = g["range_bound"] if self._quantity == "range" else lpc_position_bound_graph(g)
        return ca.sum1(pb) / (self.K + 1)


def schedule_pings(scenario: Scenario, *, budget: int,
                   method: Literal["exact", "relaxed", "greedy"] = "relaxed",
                   objective: PingObjectiveName = "mean-range-bound",
                   observer: ObserverTrack | None = None, belief: Belief | None = None,
                   min_spacing: float | None = None,
                   forbidden: Sequence[tuple[float, float]] = (),
                   candidate_steps: Sequence[int] | None = None,
                   max_enumerate: int = 50_000, time_limit: float = 30.0,
                   workers: int | None = None,
                   gap_reference: Literal["auto", "exact", "none"] = "auto") -> PingSchedule:
    """Choose at most ``budget`` ping steps (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
        Needs a prior (or ``belief``) and a range sensor (or ``planning.ping_sigma``).
    budget : int
        Maximum number of pings K.
    method : {"exact", "relaxed", "greedy"}
    objective : {"mean-range-bound", "terminal-range-bound", "mean-position-bound"}
    observer : ObserverTrack, optional
        Default the scenario's scripted track.
    belief : Belief, optional
        Default the prior.
    min_spacing : float, optional
        Minimum time between pings [s] (default ``planning.ping_min_spacing``).
    forbidden : sequence of (start, end)
        Time windows [s] without pings (counter-detection), added to
        ``planning.ping_forbidden``.
    candidate_steps : sequence of int, optional
        Allowed steps (default 1..K).
    max_enumerate : int
        ``exact`` with ``mean-position-bound`` (no compiled kernel): plain enumeration when
        C(n, K) is at most this, else best-first branch and bound.
    time_limit : float
        ``exact``: time limit of the enumeration [s] (the certified gap is reported).
    workers : int, optional
        ``exact``: processes (default: the available cores, at most 2).
    gap_reference : {"auto", "exact", "none"}
        "auto": certify with the convex relaxation; "exact": ``relaxed``/``greedy`` also run
        the exact enumeration for their bound; "none": no certificate (fast inner loops,
        e.g. the alternating joint plan), status "no bound".

    Raises
    ------
    ArgumentError
        ``budget``, ``max_enumerate`` or ``workers`` not an integer in range (a bool or a float
        was truncated), ``time_limit`` NaN or negative (NaN never stopped the enumeration);
        ``candidate_steps``, ``forbidden``, ``min_spacing`` invalid (:func:`ping_candidates`).
    PlanningError
        Budget larger than the candidate steps (or than the spacing allows), no range sensor.
    ScenarioError
        ``time.horizon`` with more steps than fit in the memory available
        (:func:`tmaplan.memory.check_steps`), before anything is built.
    """
    t_start = time.perf_counter()
    if not is_integer(budget, 0):
        raise ArgumentError("budget", "an integer >= 0 (pings)", budget)
    budget = int(budget)
    if not is_integer(max_enumerate, 0):
        raise ArgumentError("max_enumerate", "an integer >= 0", max_enumerate)
    if workers is not None and not is_integer(workers, 1):
        raise ArgumentError("workers", "an integer >= 1 (None: the available cores)", workers)
    if isinstance(time_limit, bool) or not isinstance(time_limit, (int, float, np.number)) \
            or not float(time_limit) >= 0:
        raise ArgumentError("time_limit", "a time >= 0 s (inf: none)", time_limit)
    if method not in ("exact", "relaxed", "greedy"):
        raise PlanningError(f"method: expected 'exact', 'relaxed' or 'greedy', received "
                            f"{method!r}")
    if gap_reference not in ("auto", "exact", "none"):
        raise PlanningError(f"gap_reference: expected 'auto', 'exact' or 'none', received "
                            f"{gap_reference!r}")
    obs = observer if observer is not None else observer_track(scenario.observer,
                                                               scenario.time)
    check_steps(len(obs.times) - 1, (("schedule", 1),), field="time.horizon",
                dt=scenario.time.dt, received=seconds_text(scenario.time.horizon),
                source=scenario.name)  # before any graph is built
    bel = belief if belief is not None else Belief.from_prior(scenario)
    ev = PingEvaluator(scenario, obs, bel, objective)
    cand, gap, spacing = ping_candidates(scenario, ev.times, candidate_steps=candidate_steps,
                                         forbidden=forbidden, min_spacing=min_spacing)
    if budget > cand.size:
        raise PlanningError(f"budget K = {budget} pings is larger than the {cand.size} "
                            f"candidate ping steps in the horizon ({ev.K} steps)")
    if budget > max_pings(cand, gap):
        raise PlanningError(f"budget K = {budget} pings cannot be met with min_spacing "
                            f"{spacing:g} s: at most {max_pings(cand, gap)} fit")
    return certified_schedule(ev, cand, gap, budget, method=method, objective=objective,
                              gap_reference=gap_reference, max_enumerate=max_enumerate,
                              time_limit=time_limit, workers=workers, t_start=t_start)


def certified_schedule(ev: Any, cand: np.ndarray, gap: int, budget: int, *, method: str,
                       objective: str, gap_reference: str, max_enumerate: int,
                       time_limit: float, workers: int | None,
                       t_start: float) -> PingSchedule:
    """The search and certificate of :func:`schedule_pings` on an evaluator ``ev``
    (:class:`PingEvaluator`, or several contacts' evaluator of
    :mod:`tmaplan.planning.ping_contacts`, which has ``parts``), candidate steps ``cand``,
    spacing ``gap`` [steps] and ``budget`` (checked by the caller); ``t_start`` is the
    caller's start time (``time.perf_counter()``) for ``seconds``.

    Several contacts: ``exact`` enumerates with :func:`_exact` (plain enumeration, or
    best-first branch and bound with the all-remaining-pinged bound: monotone for a sum of
    contacts) and solves the relaxation only when the enumeration stopped at its time limit
    (the stronger bound is kept); ``gap_reference="exact"`` enumerates only when the
    relaxation has not already certified a gap ≤ 1e-3.
    """

    several = getattr(ev, "parts", None) is not None
    no_ping = float(ev.evaluate(np.zeros((1, ev.K + 1)))[0])
    uni = uniform_ping_steps(ev.times, budget, candidates=cand, gap=gap)
    uniform = float(ev.value(uni))
    lb, ref, bound_s = float("nan"), "none", 0.0
    u_rel = np.zeros(0)
    steps: list[int]
    if budget == 0:
        steps, val, lb, ref = [], no_ping, no_ping, "enumeration"
    else:
        # several contacts, exact: the enumeration certifies; the relaxation (a large cvxpy
        # build) only strengthens the bound of an enumeration stopped by the time limit
        late = several and method == "exact"
        certify = gap_reference != "none" or method == "exact"
        if certify and not late:
            rr = relaxation_bound(ev, cand, budget, gap)
            lb, ref, bound_s, u_rel = rr.lower_bound, _source(rr.status), rr.seconds, rr.u
        # greedy + local swaps: the greedy method, and a start of the others
        g = greedy_schedule(ev, cand, budget, gap)
        steps, val = local_swaps(ev, g, cand, gap)
        if method != "greedy":
            starts = [steps, uni]
            if u_rel.size and np.all(np.isfinite(u_rel)):
                starts += round_weights(u_rel, cand, budget, gap)
            whole = range(1, cand.size)  # moves of any ping to any candidate
            for st in starts:
                if len(st) != budget or not spacing_ok(st, gap):
                    continue
                s2, v2 = local_swaps(ev, list(st), cand, gap, max_rounds=4 * budget + 4,
                                      radius=whole)
                if v2 < val:
                    steps, val = s2, v2
        done_relaxed = several and np.isfinite(lb) and val > 0 and \
            (val - lb) / val <= OPTIMAL_GAP
        if (method == "exact" or gap_reference == "exact") and not done_relaxed:
            t0 = time.perf_counter()
            if objective == "mean-position-bound" or several:
                st, v, elb, status_e = exact_search(ev, cand, budget, gap, steps, val,
                                              max_enumerate, time_limit)
                done = status_e == "optimal"
            else:
                er = tree_search(ev, cand, budget, gap, tuple(steps), val, time_limit,
                                 workers=workers)
                st, elb, done = list(er.steps), er.lower_bound, er.complete
                v = ev.value(st)
            if v < val:
                steps, val = st, v
            elb = min(elb, val)
            if done:
                lb, ref = val, "enumeration"
            elif not (elb <= lb):  # the stronger of two valid bounds (nan-safe)
                lb, ref = elb, "enumeration (time limit)"
            if late and not done:
                rr = relaxation_bound(ev, cand, budget, gap)
                if rr.lower_bound > lb:
                    lb, ref, u_rel = rr.lower_bound, _source(rr.status), rr.u
            bound_s += time.perf_counter() - t0
    if np.isfinite(lb) and val < lb <= val * (1 + TIGHT_BOUND_TOLERANCE):
        lb = val  # tight relaxation (integral optimum): equal up to the solver's tolerance
    rel_gap = (val - lb) / val if np.isfinite(lb) and val > 0 else float("nan")
    if np.isfinite(rel_gap) and rel_gap < 0:
        # a certified bound above an evaluated schedule is a defect: never report it
        raise PlanningError(f"lower bound {lb:.6g} above the objective {val:.6g} "
                            f"({ref}): certificate invalid")
    if not np.isfinite(rel_gap):
        status = "no bound" if budget else "optimal"
    elif rel_gap <= OPTIMAL_GAP:
        status = "optimal"
    else:
        status = "time limit" if method == "exact" else "feasible"
    steps_a = np.asarray(sorted(steps), int)
    bound = ev.per_step(ev.schedules([steps_a.tolist()]))[0]
    return PingSchedule(steps=steps_a, times=ev.times[steps_a], objective=float(val),
                        no_ping_objective=no_ping, uniform_objective=uniform,
                        lower_bound=float(lb), gap=float(rel_gap), gap_reference=ref,
                        bound=bound, status=status, seconds=time.perf_counter() - t_start,
                        method=method, objective_name=objective, budget=budget,
                        bound_seconds=bound_s, relaxed_weights=np.asarray(u_rel, float),
                        uniform_steps=np.asarray(uni, dtype=int))


def _source(status: str) -> str:
    """gap_reference label of a relaxation status."""
    if status.startswith("certified ("):
        return "relaxation " + status[len("certified "):]
    return status
