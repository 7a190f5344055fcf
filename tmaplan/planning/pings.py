"""Active-ping scheduling under a budget with the closed-form PCRB (file 000 §5, NOTES_000 §4.2).

Choose at most ``budget`` ping steps on a fixed observer track to minimise a closed-form PCRB
objective. Structure used (NOTES_000 §4.2): the moments, the D-terms and ``E r_k²`` do not
depend on the schedule; a ping at step k adds ``u_k·E r_k²/σ_r²`` to ``J_k[ln r, ln r]``
(file 000 eq. 51); the Riccati map is matrix-monotone, so adding a ping never increases any
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
import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.bounds._lpc_terms import (
    SYM_INDEX,
    aux_to_dterms,
    basis,
    inverse_diagonal,
    step_functions,
    tichavsky_step,
)
from tmaplan.errors import PlanningError, ScenarioError
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.target import ncv_matrices

# The search methods (feasibility, exact, relaxed, greedy, local swaps) live in their own
# module; ``_uniform_steps`` is re-exported here for the plots.
from tmaplan.planning._ping_search import (
    _candidates,
    _exact,
    _greedy,
    _local_swaps,
    _max_pings,
    _round,
    _spacing_ok,
    _uniform_steps,
)
from tmaplan.planning.belief import Belief
from tmaplan.planning.objectives import bearing_information, ping_sigma

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["PING_OBJECTIVES", "PingEvaluator", "PingSchedule", "schedule_pings"]

PING_OBJECTIVES = ("mean-range-bound", "terminal-range-bound", "mean-position-bound")
#: Certified relative gap below which a schedule is reported "optimal".
OPTIMAL_GAP = 1e-3
#: A relaxation bound above a schedule's objective by at most this relative amount is the
#: relaxation being tight (its optimum is integral) up to the conic solver's tolerance
#: (Clarabel's relative gap tolerance here is 1e-8); anything larger is an error.
_TIGHT = 1e-6


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
        Without pings, and with ``budget`` evenly spaced pings [m].
    lower_bound : float
        Certified lower bound on the optimum [m] (nan if none was computed).
    gap : float
        Relative gap ``(objective − lower_bound)/objective`` (nan without a bound).
    gap_reference : str
        Where ``lower_bound`` comes from: "relaxation (clarabel|scs)", "enumeration",
        "enumeration (time limit)", "fallback: all candidates pinged (...)" (the relaxation
        failed; its reasons), or "none".
    bound : ndarray, shape (K + 1,)
        Range bound per step with the schedule [m].
    status : str
        "optimal" (certified gap ≤ 1e-3), "feasible" (heuristic, larger gap), "time limit"
        (``exact`` stopped with the incumbent), "no bound" (``gap_reference="none"``).
    seconds : float
    method : str
    objective_name : str
    budget : int
    bound_seconds : float
        Of ``seconds``, spent on the certificate [s].
    relaxed_weights : ndarray, shape (n_candidates,)
        Optimal weights of the relaxation (empty when it was not solved).
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
    bound_seconds: float = 0.0
    relaxed_weights: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))


class PingEvaluator:
    """Batched closed-form PCRB objective of ping schedules on a fixed observer track.

    The recursion is :func:`tmaplan.bounds._lpc_terms.tichavsky_step` (the one implementation
    of the closed form) on entries of shape (S,), one entry per schedule.

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
        self.sigma = sig
        self.scale = 1.0 / sig**2
        dt = float(scenario.time.dt)
        K = observer.position.shape[0] - 1
        self.K, self.dt = K, dt
        self.times = observer.times
        A, Q = ncv_matrices(dt, float(scenario.target.q))
        moment_fn, riccati_fn = step_functions(A, Q)
        self._riccati = riccati_fn
        dv = observer.velocity_increments
        c = -np.hstack([dt * dv, dv])
        S0 = belief.second_moment
        x0 = np.concatenate([belief.mean, [S0[i, j] for i, j in SYM_INDEX]])
        xs, aux = (np.asarray(o) for o in moment_fn.mapaccum(K)(x0, c.T))
        self.aux = aux
        self.moments = np.hstack([x0[:, None], xs])
        self.er2 = self.moments[4] + self.moments[8]
        self.J0 = belief.lpc_information()
        self.bearing = bearing_information(scenario, belief.t, K)
        self._pw = self.scale * self.er2
        self._dterms = [aux_to_dterms(aux[:, k].tolist()) for k in range(K)]
        if objective == "mean-position-bound":
            E = basis()[:, :2, :]
            T = np.einsum("kai,laj->klij", E, E)
            Sk = np.zeros((K + 1, 4, 4))
            for n, (i, j) in enumerate(SYM_INDEX):
                Sk[:, i, j] = Sk[:, j, i] = self.moments[4 + n]
            self._W = np.einsum("nkl,klij->nij", Sk, T)

    # ------------------------------------------------------------------------ numeric
    def per_step(self, U: np.ndarray) -> np.ndarray:
        """Bound per step (S, K+1) [m]: range bound, or sqrt(tr P_pos) (position objective)."""
        U = np.atleast_2d(np.asarray(U, float))
        S, K = U.shape[0], self.K
        if U.shape[1] != K + 1:
            raise ScenarioError("u", f"shape (S, {K + 1})", U.shape)
        J = [[float(x) + np.zeros(S) for x in row] for row in self.J0.tolist()]
        J[1][1] = J[1][1] + U[:, 0] * self._pw[0]
        out = np.empty((S, K + 1))
        pos = self.objective == "mean-position-bound"
        pw = U * self._pw[None, :]
        b = self.bearing.tolist()
        for k in range(K + 1):  # loop over time steps; schedules are batched
            if k > 0:
                D11, D12, D22 = self._dterms[k - 1]
                J, piv = tichavsky_step(J, D11, D12, D22, b[k], pw[:, k])
                if np.any(piv[3] <= 0):
                    raise PlanningError("closed-form PCRB: J_t + D11 is not positive definite")
            if pos:
                M = np.stack([np.stack(r, axis=-1) for r in J], axis=-2)
                P = np.linalg.inv(M)
                out[:, k] = np.sqrt(np.maximum(np.einsum("ij,sij->s", self._W[k], P), 0))
            else:
                var, _ = inverse_diagonal(J)
                out[:, k] = np.sqrt(self.er2[k] * var[1])
        return out

    def _evaluate_compiled(self, U: np.ndarray) -> np.ndarray | None:
        """Range objectives through the compiled C schedule kernel of
        :mod:`tmaplan.bounds._jit` (same generic step; None if no compiler)."""
        from tmaplan.bounds._jit import schedule_kernel
        from tmaplan.bounds._lpc_terms import SYM_INDEX

        if self.objective == "mean-position-bound":
            return None
        kernel = schedule_kernel()
        if kernel is None:
            return None
        K, S = self.K, U.shape[0]
        u = np.ascontiguousarray(U, dtype=float)
        J = [[float(x) + np.zeros(S) for x in row] for row in self.J0.tolist()]
        J[1][1] = J[1][1] + u[:, 0] * self._pw[0]
        var0, _ = inverse_diagonal(J)
        val0 = np.sqrt(self.er2[0] * var0[1])
        acc = np.array(np.broadcast_to(0.0 + val0, (S,)))
        last = acc.copy()
        j0 = np.empty((10, S))
        for n, (i, k) in enumerate(SYM_INDEX):
            j0[n] = J[i][k]
        if "_aux_rows" not in self.__dict__:
            self._aux_rows = np.ascontiguousarray(self.aux.T, dtype=float)
        b = np.ascontiguousarray(self.bearing[1:], float)
        pw = np.ascontiguousarray(self._pw[1:], float)
        er2 = np.ascontiguousarray(self.er2[1:], float)
        kernel(K, S, j0.ctypes.data, self._aux_rows.ctypes.data, b.ctypes.data, pw.ctypes.data,
               er2.ctypes.data, u.ctypes.data, K + 1, acc.ctypes.data, last.ctypes.data, None)
        if not (np.all(np.isfinite(acc)) and np.all(np.isfinite(last))):
            return None  # let the reference path raise its clear error
        return (last if K > 0 else acc) if self.objective == "terminal-range-bound" \
            else acc / (K + 1)

    def evaluate(self, U: np.ndarray, chunk: int = 4096) -> np.ndarray:
        """Objective (S,) [m] of schedules U (S, K+1) (weights in [0, 1])."""
        U = np.atleast_2d(np.asarray(U, float))
        if U.shape[0] and U.shape[1] == self.K + 1:
            fast = self._evaluate_compiled(U)
            if fast is not None:
                return fast
        res = []
        for s in range(0, U.shape[0], chunk):
            pb = self.per_step(U[s:s + chunk])
            res.append(pb[:, -1] if self.objective == "terminal-range-bound"
                       else pb.mean(axis=1))
        return np.concatenate(res) if res else np.zeros(0)

    def schedules(self, sets: Sequence[Sequence[int]]) -> np.ndarray:
        """0/1 matrix (S, K+1) of ping-step sets."""
        U = np.zeros((len(sets), self.K + 1))
        for i, st in enumerate(sets):
            U[i, list(st)] = 1.0
        return U

    def value(self, steps: Sequence[int]) -> float:
        """Objective of one schedule."""
        return float(self.evaluate(self.schedules([steps]))[0])

    # ---------------------------------------------------------------------- symbolic
    def casadi_objective(self, u: Any) -> Any:
        """casadi expression of the objective of relaxed weights ``u`` ((K+1)×1 MX).

        For ``terminal-range-bound`` it is ``[J_K⁻¹]_{ln r}·E r_K²`` (the square of the range
        bound: same minimiser, and convex in u).
        """
        import casadi as ca

        K = self.K
        J0 = [[ca.MX(float(x)) for x in row] for row in self.J0.tolist()]
        J0[1][1] = J0[1][1] + u[0] * float(self._pw[0])
        j0 = ca.vertcat(*[J0[i][j] for i, j in SYM_INDEX])
        acc = self._riccati.mapaccum("ping_riccati", K)
        jn, varn, _ = acc(j0, ca.DM(self.aux), ca.DM(self.bearing[1:][None, :]),
                          (u[1:] * self.scale).T)
        var0, _ = inverse_diagonal(J0)
        if self.objective == "terminal-range-bound":
            return varn[1, -1] * float(self.er2[-1])
        if self.objective == "mean-range-bound":
            rb = ca.sqrt(ca.DM(self.er2[1:]).T * varn[1, :])
            return (ca.sum2(rb) + ca.sqrt(var0[1] * float(self.er2[0]))) / (K + 1)
        j = ca.SX.sym("j", 10)
        w = ca.SX.sym("w", 4, 4)
        Jm = ca.SX(4, 4)
        for n, (a, b_) in enumerate(SYM_INDEX):
            Jm[a, b_] = j[n]
            Jm[b_, a] = j[n]
        f = ca.Function("posw", [j, w], [ca.sqrt(ca.sum1(ca.sum2(w * ca.inv(Jm))))])
        Wk = ca.DM(np.hstack([self._W[k] for k in range(K + 1)]))
        vals = f.map(K + 1)(ca.horzcat(j0, jn), Wk)
        return ca.sum2(vals) / (K + 1)


def schedule_pings(scenario: Scenario, *, budget: int,
                   method: Literal["exact", "relaxed", "greedy"] = "relaxed",
                   objective: Literal["mean-range-bound", "terminal-range-bound",
                                      "mean-position-bound"] = "mean-range-bound",
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
    PlanningError
        Budget larger than the candidate steps (or than the spacing allows), no range sensor.
    """
    from tmaplan.planning.ping_exact import tree_search
    from tmaplan.planning.ping_relaxation import relaxation_bound

    t_start = time.perf_counter()
    budget = int(budget)
    if budget < 0:
        raise PlanningError(f"budget: expected >= 0 pings, received {budget}")
    if method not in ("exact", "relaxed", "greedy"):
        raise PlanningError(f"method: expected 'exact', 'relaxed' or 'greedy', received "
                            f"{method!r}")
    if gap_reference not in ("auto", "exact", "none"):
        raise PlanningError(f"gap_reference: expected 'auto', 'exact' or 'none', received "
                            f"{gap_reference!r}")
    obs = observer if observer is not None else observer_track(scenario.observer,
                                                               scenario.time)
    bel = belief if belief is not None else Belief.from_prior(scenario)
    ev = PingEvaluator(scenario, obs, bel, objective)
    pl = scenario.planning
    spacing = float(min_spacing if min_spacing is not None else
                    (pl.ping_min_spacing if pl is not None else 0.0))
    gap = max(1, math.ceil(spacing / ev.dt - 1e-9))
    windows = list(forbidden) + (list(pl.ping_forbidden) if pl is not None else [])
    cand = _candidates(ev, candidate_steps, windows)
    if budget > cand.size:
        raise PlanningError(f"budget K = {budget} pings is larger than the {cand.size} "
                            f"candidate ping steps in the horizon ({ev.K} steps)")
    if budget > _max_pings(cand, gap):
        raise PlanningError(f"budget K = {budget} pings cannot be met with min_spacing "
                            f"{spacing:g} s: at most {_max_pings(cand, gap)} fit")
    no_ping = float(ev.evaluate(np.zeros((1, ev.K + 1)))[0])
    uni = _uniform_steps(cand, budget, ev.K) if budget else []
    uniform = float(ev.value(uni))
    lb, ref, bound_s = float("nan"), "none", 0.0
    u_rel = np.zeros(0)
    if budget == 0:
        steps, val, lb, ref = [], no_ping, no_ping, "enumeration"
    else:
        certify = gap_reference != "none" or method == "exact"
        if certify:
            rr = relaxation_bound(ev, cand, budget, gap)
            lb, ref, bound_s, u_rel = rr.lower_bound, _source(rr.status), rr.seconds, rr.u
        # greedy + local swaps: the greedy method, and a start of the others
        g = _greedy(ev, cand, budget, gap)
        steps, val = _local_swaps(ev, g, cand, gap)
        if method != "greedy":
            starts = [steps, uni]
            if u_rel.size and np.all(np.isfinite(u_rel)):
                starts += _round(u_rel, cand, budget, gap)
            whole = range(1, cand.size)  # moves of any ping to any candidate
            for st in starts:
                if len(st) != budget or not _spacing_ok(st, gap):
                    continue
                s2, v2 = _local_swaps(ev, list(st), cand, gap, max_rounds=4 * budget + 4,
                                      radius=whole)
                if v2 < val:
                    steps, val = s2, v2
        if method == "exact" or gap_reference == "exact":
            t0 = time.perf_counter()
            if objective == "mean-position-bound":
                st, v, elb, status_e = _exact(ev, cand, budget, gap, steps, val,
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
            bound_s += time.perf_counter() - t0
    if np.isfinite(lb) and val < lb <= val * (1 + _TIGHT):
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
                        bound_seconds=bound_s, relaxed_weights=np.asarray(u_rel, float))


def _source(status: str) -> str:
    """gap_reference label of a relaxation status."""
    if status.startswith("certified ("):
        return "relaxation " + status[len("certified "):]
    return status
