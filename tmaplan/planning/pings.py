"""Active-ping scheduling under a budget with the closed-form PCRB (file 000 §5, NOTES_000 §4.2).

Choose at most ``budget`` ping steps on a fixed observer track to minimise a closed-form PCRB
objective. Structure used (NOTES_000 §4.2): the moments, the D-terms and ``E r_k²`` do not
depend on the schedule; a ping at step k adds ``u_k·E r_k²/σ_r²`` to ``J_k[ln r, ln r]``
(file 000 eq. 51); the Riccati map is matrix-monotone, so adding a ping never increases any
objective below (range bound ``sqrt(E r_k²·[J_k⁻¹]_{ln r})``, position bound
``sqrt(tr P_pos)``), which makes "all remaining candidates pinged" a valid lower bound for
branch and bound.

Methods
    ``exact``: exhaustive enumeration on the batched evaluator when the number of schedules is
    at most ``max_enumerate`` (proven optimum), else best-first branch and bound with the
    monotone lower bound, a time limit and the reported gap.
    ``relaxed``: u_k ∈ [0, 1] NLP (casadi + IPOPT, exact gradients through the recursion,
    Σu ≤ K, Σ_{window} u ≤ 1 for the spacing), then rounding (largest u first, spacing
    respected) and local swaps. For terminal objectives the relaxed problem is convex
    (``[J⁻¹]_{ln r}`` is convex and decreasing in J, J_T concave in u), so its optimum is a proven
    lower bound.
    ``greedy``: add the best ping one at a time (then the same local swaps).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.bounds.closed_form_engine import ClosedFormEngine, lpc_position_bound_graph
from tmaplan.errors import PlanningError, ScenarioError
from tmaplan.models.observer import ObserverTrack, observer_track

# The search methods (feasibility, exact, relaxed, greedy, local swaps) and the evenly spaced
# reference schedule live in their own module.
from tmaplan.planning._ping_search import (
    _exact,
    _greedy,
    _local_swaps,
    _max_pings,
    _relaxed,
    _round,
    ping_candidates,
    uniform_ping_steps,
)
from tmaplan.planning.belief import Belief
from tmaplan.planning.objectives import (
    PING_OBJECTIVES,
    PingObjectiveName,
    ping_sigma,
    plan_bearing_information,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["PING_OBJECTIVES", "PingEvaluator", "PingSchedule", "ping_candidates",
           "schedule_pings", "uniform_ping_steps"]

_OK = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}


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
        Proven lower bound on the optimum [m] (nan if none is known).
    gap : float
        ``objective − reference`` [m]: to the exact optimum when it was computed, else to
        ``lower_bound`` (nan if neither).
    gap_reference : str
        "exact", "lower-bound", "relaxation (not proven)" or "none".
    bound : ndarray, shape (K + 1,)
        Range bound per step with the schedule [m].
    status : str
        "optimal", "gap", solver status, ...
    seconds : float
    method : str
    objective_name : str
    budget : int
    uniform_steps : ndarray of int
        The evenly spaced reference schedule (:func:`uniform_ping_steps`), the one the
        ``uniform`` ping policy flies.
    """

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
            raise ScenarioError("objective", f"one of {', '.join(PING_OBJECTIVES)}", objective)
        self.objective = objective
        sig = ping_sigma(scenario)
        if sig is None:
            raise PlanningError(f"{scenario.name}: no range sensor to ping with (add a "
                                "[[sensors]] kind = 'range' or planning.ping_sigma)")
        K = observer.position.shape[0] - 1
        self.engine = ClosedFormEngine.from_belief(
            belief, observer, dt=float(scenario.time.dt), q=float(scenario.target.q),
            bearing_info=plan_bearing_information(scenario, belief.t, K), ping_sigma=sig)
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
        """0/1 matrix (S, K+1) of ping-step sets."""
        U = np.zeros((len(sets), self.K + 1))
        for i, st in enumerate(sets):
            U[i, list(st)] = 1.0
        return U

    def value(self, steps: Sequence[int]) -> float:
        """Objective of one schedule."""
        return float(self.evaluate(self.schedules([steps]))[0])

    def casadi_objective(self, u: Any) -> Any:
        """casadi expression of the objective of relaxed weights ``u`` ((K+1)×1 MX).

        For ``terminal-range-bound`` it is ``[J_K⁻¹]_{ln r}·E r_K²`` (the square of the range
        bound: same minimiser, and convex in u).
        """
        import casadi as ca

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
                   max_relaxed: int = 200,
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
        ``exact``: enumerate when C(n, K) is at most this, else branch and bound.
    time_limit : float
        Branch-and-bound time limit [s] (the gap is reported when it is hit).
    max_relaxed : int
        ``relaxed``: at most this many candidates (every stride-th) enter the NLP; rounding
        and local swaps then use every candidate. The relaxation is then a lower bound of the
        coarse problem only (so no proven lower bound is reported).
    gap_reference : {"auto", "exact", "none"}
        ``relaxed``/``greedy``: compute the exact optimum to report the gap ("auto": when
        enumeration is cheap, C(n, K) ≤ 20 000).

    Raises
    ------
    PlanningError
        Budget larger than the candidate steps (or than the spacing allows), no range sensor.
    SolverError
        The relaxed NLP did not converge.
    """
    from tmaplan.errors import SolverError

    t_start = time.perf_counter()
    budget = int(budget)
    if budget < 0:
        raise PlanningError(f"budget: expected >= 0 pings, received {budget}")
    if method not in ("exact", "relaxed", "greedy"):
        raise PlanningError(f"method: expected 'exact', 'relaxed' or 'greedy', received "
                            f"{method!r}")
    obs = observer if observer is not None else observer_track(scenario.observer,
                                                               scenario.time)
    bel = belief if belief is not None else Belief.from_prior(scenario)
    ev = PingEvaluator(scenario, obs, bel, objective)
    cand, gap, spacing = ping_candidates(scenario, ev.times, candidate_steps=candidate_steps,
                                         forbidden=forbidden, min_spacing=min_spacing)
    if budget > cand.size:
        raise PlanningError(f"budget K = {budget} pings is larger than the {cand.size} "
                            f"candidate ping steps in the horizon ({ev.K} steps)")
    if budget > _max_pings(cand, gap):
        raise PlanningError(f"budget K = {budget} pings cannot be met with min_spacing "
                            f"{spacing:g} s: at most {_max_pings(cand, gap)} fit")
    no_ping = float(ev.evaluate(np.zeros((1, ev.K + 1)))[0])
    uni = uniform_ping_steps(ev.times, budget, candidates=cand, gap=gap)
    uniform = float(ev.value(uni))
    lb, ref, status = float("nan"), "none", "ok"
    if budget == 0:
        steps, val, status = [], no_ping, "optimal"
        lb, ref = val, "exact"
    elif method == "greedy":
        steps = _greedy(ev, cand, budget, gap)
        steps, val = _local_swaps(ev, steps, cand, gap)
    elif method == "relaxed":
        # Relax on at most max_relaxed candidates (every stride-th one); the local swaps
        # then work on the full candidate set with radii up to the stride.
        stride = max(1, math.ceil(cand.size / max_relaxed))
        coarse = cand[::stride]
        if coarse.size < budget:
            coarse = cand
        u, fr, st = _relaxed(ev, coarse, budget, gap)
        if st not in _OK:
            raise SolverError("ipopt", st, "relaxed ping scheduling NLP")
        radius = sorted({1, 2, 4} | {max(1, stride // 2), stride})
        rounded = _round(u, coarse, budget, gap)
        rv = ev.evaluate(ev.schedules(rounded))
        steps, val = _local_swaps(ev, rounded[int(np.argmin(rv))], cand, gap, radius=radius)
        status = st
        if objective == "terminal-range-bound" and stride == 1:
            lb, ref = math.sqrt(max(fr, 0.0)), "lower-bound"
        else:
            lb, ref = fr, "relaxation (not proven)"
    else:
        g0 = _greedy(ev, cand, budget, gap) if math.comb(cand.size, budget) > max_enumerate \
            else []
        v0 = ev.value(g0) if g0 else float("inf")
        steps, val, lb, status = _exact(ev, cand, budget, gap, g0, v0, max_enumerate,
                                        time_limit)
        ref = "exact" if status == "optimal" else "lower-bound"
    if method != "exact" and budget and (gap_reference == "exact" or (
            gap_reference == "auto" and math.comb(cand.size, budget) <= 20_000)):
        _, ex_val, _, _ = _exact(ev, cand, budget, gap, [], float("inf"), 20_000 if
                                 gap_reference == "auto" else max_enumerate, time_limit)
        lb, ref = ex_val, "exact"
    steps_a = np.asarray(sorted(steps), int)
    bound = ev.per_step(ev.schedules([steps_a.tolist()]))[0]
    return PingSchedule(steps=steps_a, times=ev.times[steps_a], objective=val,
                        no_ping_objective=no_ping, uniform_objective=uniform,
                        lower_bound=lb, gap=val - lb if np.isfinite(lb) else float("nan"),
                        gap_reference=ref, bound=bound, status=status,
                        seconds=time.perf_counter() - t_start, method=method,
                        objective_name=objective, budget=budget,
                        uniform_steps=np.asarray(uni, dtype=int))
