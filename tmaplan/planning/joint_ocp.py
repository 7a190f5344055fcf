"""Joint heading and ping plan as one optimal control problem (casadi), certified on its pings.

The heading OCP of :class:`tmaplan.planning.heading.HeadingPlanner` (direct multiple shooting,
closed-form PCRB objective) gets the ping weights as decision variables: a ping at step k adds
``w_k·E r_k²/σ_r²`` to ``J_k[ln r, ln r]`` of the closed-form recursion (brehard2005, eq. 51),
exactly as in the scheduler (:mod:`tmaplan.planning.pings`). Over the candidate steps c_i
(the allowed steps, outside the forbidden windows, a multiple of ``ping_stride`` after
the first one) the NLP is::

    minimise   f(ω, w)   (the closed-form objective, e.g. the mean range bound [m])
    subject to the heading dynamics, |ω| ≤ ω_max, keep-out range (the heading OCP),
               Σ_i w_i = K,   Σ_{c_i ∈ [c, c + gap)} w_i ≤ 1 for every candidate c (spacing),
               w_i ∈ {0, 1} (``mode="bonmin"``) or w_i ∈ [0, 1] (``mode="relaxed"``).

Modes
    ``"relaxed"``: the continuous relaxation by IPOPT (or casadi's ``sqpmethod``, see below);
    then (``binarize``) a continuation in μ of the penalty μ·Σ w(1 − w), which drives the
    weights to {0, 1} while the headings adapt (the relaxation alone spreads the weights thinly
    over many steps, and headings tuned to such fractional pings are poor for K real ones);
    rounded (largest weights first, respecting the spacing) and polished: heading re-solve
    with the rounded pings fixed, then a :func:`~tmaplan.planning.pings.schedule_pings` pass
    on the resulting track (all allowed steps, not only the stride), repeated while the pair
    improves (at most ``polish_rounds``); polishing never ends above its start.
    ``"bonmin"``: the mixed-integer NLP by bonmin (B-BB, casadi's build); the NLP is not convex
    in the headings, so bonmin's branch and bound is a heuristic here, not a global optimum.
    Use a small case (a few candidates, ``ping_stride``); its pings are polished the same way.

Starts: the pingless heading plan (the alternating method's first block) with the weights
spread evenly, and with the pings scheduled along it (``init="both"``, the default, keeps the
better polished pair; with the even start alone the result was 5 % worse than the alternating
method's at K = 3 on `default`, see ``benchmarks/planning.py --joint``).

Certificate (ping part): for the returned track, the cvxpy relaxation of
:mod:`tmaplan.planning.ping_relaxation` lower-bounds every ping schedule on that track, so
``lower_bound ≤ objective`` and ``gap = (objective − lower_bound)/objective`` says how far, at
most, the returned pings are from the best pings for the returned headings. It does not bound
the joint (heading) problem, which is non-convex.

QP solvers (issue 14, item 5). The QPs of this module are the subproblems of an SQP solve of
the relaxed OCP: ``nlp_solver="sqp-osqp"`` runs casadi's ``sqpmethod`` with OSQP as the QP
solver (damped BFGS Hessian, so every QP is convex as OSQP requires), ``"sqp-qrqp"`` with
casadi's active-set qrqp, ``"ipopt"`` (default) the interior-point method. Measured with
``python benchmarks/planning.py --joint`` (`default`, 45 min, 22 control intervals of 120 s,
ping stride 4, K = 2, relaxation without the binarising continuation; 2 shared cores)::

    solver     NLP time    iterations  relaxed objective
    ipopt       1.62 s         64      101.6551 m
    sqp-osqp   11.48 s        144      101.6551 m   (7.1 x ipopt)
    sqp-qrqp   39.46 s        142      101.6551 m   (24.4 x ipopt)

(times include the pingless heading solve that starts every method, ≈ 0.5 s). With the exact
Hessian instead of BFGS, sqpmethod + OSQP made 100 iterations in 65 s without converging
(``convexify_strategy="regularize"``) or failed at the first QP (``"eigen-reflect"``). So OSQP
is the better QP solver of the two for this SQP (3.4 x faster than qrqp over as many
iterations; each QP has 135 variables, a dense BFGS Hessian and 289 constraints, 176 of them
keep-out inequalities), but for this one-shot solve the SQP itself is not the right method:
IPOPT converges in fewer, cheaper iterations and stays the default. ``"sqp-osqp"`` is kept as
an option (tested) for setups where one QP per solve is what is wanted, e.g. warm-started
re-planning; that use is not measured here.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import time
from collections.abc import Iterator, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.errors import PlanningError, is_integer
from tmaplan.geometry import course_speed
from tmaplan.interrupts import solver_call
from tmaplan.models.sensors import default_ping_budget
from tmaplan.models.target import initial_velocity
from tmaplan.planning.belief import Belief
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner
from tmaplan.planning.joint import JOINT_PING_OBJECTIVE
from tmaplan.planning.objectives import belief_bearing_information
from tmaplan.planning.ping_search import max_pings, ping_candidates, round_weights, spacing_ok
from tmaplan.planning.pings import (
    OPTIMAL_GAP,
    TIGHT_BOUND_TOLERANCE,
    PingEvaluator,
    PingSchedule,
    schedule_pings,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "JOINT_MODES",
    "JOINT_NLP_SOLVERS",
    "JointOCPResult",
    "plan_joint_ocp",
    "with_own_pings",
]

JOINT_MODES = ("relaxed", "bonmin")
JOINT_NLP_SOLVERS = ("ipopt", "sqp-osqp", "sqp-qrqp")
_OK = {"Solve_Succeeded", "Solved_To_Acceptable_Level", "SUCCESS", "Solve_Succeeded (MINLP)"}

#: Continuation weights μ of the binarising penalty μ·Σ w(1 − w) (objective scaled to ≈ 1).
_BINARIZE_MU = (0.01, 0.03, 0.1, 0.3, 1.0)

@dataclasses.dataclass(frozen=True, kw_only=True)
class JointOCPResult:
    """A joint heading + ping plan from one OCP, certified on its pings.

    Attributes
    ----------
    heading : HeadingPlan
        Final heading plan; its ``objective`` is with the pings it was solved with (the
        polished ones), never below ``objective`` when the certificate found better pings.
    pings : PingSchedule
        Final pings on the final track, with the certificate of the ping part.
    objective : float
        Objective of the pair [m].
    lower_bound : float
        Certified lower bound on every ping schedule along the final track [m].
    gap : float
        ``(objective − lower_bound)/objective`` (relative).
    relaxed_objective : float
        Optimum of the joint NLP as solved (``relaxed``: fractional weights; ``bonmin``: the
        binary solution) [m].
    weights : ndarray, shape (n_candidates,)
        Ping weights of the joint NLP solution on ``candidate_steps``.
    candidate_steps : ndarray of int
        Candidate ping steps of the joint NLP (the stride).
    rounded_steps : ndarray of int
        Pings after rounding ``weights``, before polishing.
    rounded_objective : float
        Objective of the NLP's headings with ``rounded_steps`` [m] (polishing starts there
        and never ends above it when the NLP succeeded; after a failed NLP, whose point may
        violate the heading constraints, any polished pair replaces it).
    mode : str
        "relaxed" or "bonmin".
    nlp_solver : str
        "ipopt", "sqp-osqp", "sqp-qrqp" or "bonmin".
    status : str
        Return status of the joint NLP solver.
    success : bool
        Whether the joint NLP solver reported success.
    iterations : int
        Joint NLP iterations (bonmin: 0, not reported by casadi).
    seconds : float
        Wall time of the whole plan [s].
    nlp_seconds : float
        Of ``seconds``, in the joint NLP [s].
    polish_seconds : float
        Of ``seconds``, in rounding, polishing and certifying [s].
    """

    heading: HeadingPlan
    pings: PingSchedule
    objective: float
    lower_bound: float
    gap: float
    relaxed_objective: float
    weights: np.ndarray
    candidate_steps: np.ndarray
    rounded_steps: np.ndarray
    rounded_objective: float
    mode: str
    nlp_solver: str
    status: str
    success: bool
    iterations: int
    seconds: float
    nlp_seconds: float
    polish_seconds: float

    def payload(self) -> dict[str, Any]:
        """JSON fields in the scheduler's layout (``objective``, ``lower_bound``, ``gap``,
        ``solver`` {``status``, ``seconds``})."""
        return {
            "objective": self.objective, "lower_bound": self.lower_bound, "gap": self.gap,
            "gap_reference": self.pings.gap_reference,
            "relaxed_objective": self.relaxed_objective,
            "rounded_objective": self.rounded_objective,
            "ping_steps": self.pings.steps, "ping_times": self.pings.times,
            "rounded_steps": self.rounded_steps, "budget": self.pings.budget,
            "solver": {"status": self.status, "seconds": self.seconds, "success": self.success,
                       "mode": self.mode, "nlp_solver": self.nlp_solver,
                       "nlp_seconds": self.nlp_seconds, "iterations": self.iterations,
                       "ping_status": self.pings.status},
        }


def _check_int(name: str, value: Any, low: int) -> int:
    if not is_integer(value, low):
        raise PlanningError(f"{name}: expected an integer >= {low}, received {value!r}")
    return int(value)


def with_own_pings(cert: PingSchedule, ev: PingEvaluator, steps: Sequence[int],
                    ) -> PingSchedule:
    """``cert`` (the scheduler's certified pings on the final track), or the pair's own pings
    ``steps`` with ``cert``'s lower bound when they are better.

    The bound is checked as :func:`~tmaplan.planning.pings.schedule_pings` checks it: above
    the own pings' objective by more than the solver's tolerance it is an invalid certificate
    (:class:`PlanningError`), a NaN bound gives no gap ("no bound") — both were reported as a
    zero gap and "optimal".
    """
    v_own = ev.value(list(steps))
    if not v_own < cert.objective:
        return cert
    own = np.asarray(sorted(steps), int)
    lb = float(cert.lower_bound)
    if np.isfinite(lb) and v_own < lb <= v_own * (1 + TIGHT_BOUND_TOLERANCE):
        lb = v_own  # tight relaxation, equal up to the solver's tolerance
    if np.isfinite(lb) and lb > v_own:
        raise PlanningError(f"lower bound {lb:.6g} above the objective {v_own:.6g} of the "
                            f"joint plan's pings ({cert.gap_reference}): certificate invalid")
    g_rel = (v_own - lb) / v_own if np.isfinite(lb) and v_own > 0 else float("nan")
    status = ("no bound" if not np.isfinite(g_rel) else
              "optimal" if g_rel <= OPTIMAL_GAP else "feasible")
    return dataclasses.replace(cert, steps=own, times=ev.times[own], objective=v_own,
                               lower_bound=lb, gap=g_rel, status=status,
                               bound=ev.per_step(ev.schedules([own.tolist()]))[0])


def _spacing_matrix(cand: np.ndarray, gap: int) -> np.ndarray:
    """Rows of the linear spacing constraints A w ≤ 1 (one per window of ``gap`` steps)."""
    rows = []
    if gap > 1:
        for c in cand:
            win = np.flatnonzero((cand >= c) & (cand < c + gap))
            if win.size > 1:
                rows.append(win)
    A = np.zeros((len(rows), cand.size))
    for r, win in enumerate(rows):
        A[r, win] = 1.0
    return A


@contextlib.contextmanager
def _quiet_stdout(on: bool) -> Iterator[None]:
    """Silence the C-level standard output (bonmin prints its node log whatever its
    ``nlp_log_level``)."""
    if not on:
        yield
        return
    sys.stdout.flush()
    fd = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(fd, 1)
        os.close(fd)


def _nlp_solver(name: str, nlp: dict[str, Any], mode: str, n_heading: int, n_cand: int,
                options: dict[str, Any]) -> Any:
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    if mode == "bonmin":
        opts: dict[str, Any] = {
            "print_time": False, "discrete": [False] * n_heading + [True] * n_cand,
            "bonmin": {"print_level": 0, "bb_log_level": 0, "nlp_log_level": 0,
                       "hessian_approximation": "limited-memory", "max_iter": 500,
                       "time_limit": 120.0, **options}}
        return ca.nlpsol("joint_bonmin", "bonmin", nlp, opts)
    if name == "ipopt":
        ipopt = {"print_level": 0, "sb": "yes", "max_iter": 500, "tol": 1e-7,
                 "acceptable_tol": 1e-5, "hessian_approximation": "limited-memory",
                 "limited_memory_max_history": 20, **options}
        return ca.nlpsol("joint_ipopt", "ipopt", nlp, {"print_time": False, "ipopt": ipopt})
    qp = name.split("-", 1)[1]
    qp_opts: dict[str, Any] = {"error_on_fail": False}
    if qp == "osqp":
        qp_opts["osqp"] = {"verbose": False, "eps_abs": 1e-9, "eps_rel": 1e-9,
                           "max_iter": 20_000, "polish": True}
    else:
        qp_opts.update({"print_iter": False, "print_header": False, "print_info": False})
    sqp = {"print_time": False, "qpsol": qp, "qpsol_options": qp_opts,
           "hessian_approximation": "limited-memory", "max_iter": 300, "print_header": False,
           "print_iteration": False, "print_status": False, "error_on_fail": False,
           "tol_pr": 1e-7, "tol_du": 1e-5, **options}
    return ca.nlpsol(f"joint_sqp_{qp}", "sqpmethod", nlp, sqp)


def _solve_nlp(solver: Any, x: np.ndarray, P: np.ndarray, mus: Sequence[float],
               bounds: dict[str, np.ndarray], nh: int, quiet: bool) -> dict[str, Any]:
    """μ = 0: the relaxation (or bonmin's MINLP); then a continuation in μ of the penalty
    μ·Σ w(1 − w) pushing the weights to {0, 1} while the headings adapt. Status, success and
    objective are the μ = 0 solve's; ``x`` the last successful continuation step's, else the
    μ = 0 solve's (successful or not: ``ok`` says)."""
    out: dict[str, Any] = {"iters": 0}
    for k, m in enumerate(mus):
        with _quiet_stdout(quiet), solver_call():  # an interrupt raises, never a failure
            sol = solver(x0=x, p=np.concatenate([P, [m]]), **bounds)
        try:
            stats = solver.stats()
        except RuntimeError:  # casadi's sqpmethod has no status after some QP failures
            stats = {"return_status": "unknown (no solver status)", "success": False}
        st = str(stats.get("return_status", "unknown"))
        good = bool(stats.get("success", st in _OK))
        out["iters"] += int(stats.get("iter_count", 0) or 0)
        if k == 0:
            out.update(status=st, ok=good, f=float(sol["f"]))
        elif not good:  # keep the last successful continuation step
            break
        x = np.asarray(sol["x"]).reshape(-1)
        out.update(x=x, lam_x=np.asarray(sol["lam_x"]).reshape(-1),
                   lam_g=np.asarray(sol["lam_g"]).reshape(-1))
        if np.max(np.minimum(x[nh:], 1 - x[nh:]), initial=0.0) < 1e-3:
            break
    return out


def plan_joint_ocp(scenario: Scenario, *, budget: int | None = None,
                   objective: Literal["range-bound", "mean-range-bound",
                                      "mean-position-bound"] = "mean-range-bound",
                   mode: Literal["relaxed", "bonmin"] = "relaxed",
                   nlp_solver: Literal["ipopt", "sqp-osqp", "sqp-qrqp"] = "ipopt",
                   ping_stride: int = 1, belief: Belief | None = None,
                   min_spacing: float | None = None,
                   forbidden: Sequence[tuple[float, float]] = (), polish_rounds: int = 3,
                   solver_options: dict[str, Any] | None = None,
                   init: Literal["even", "schedule", "both"] = "both", binarize: bool = True,
                   **planner_kw: Any) -> JointOCPResult:
    """Plan headings and ``budget`` pings (default ``planning.ping_budget``) as one OCP.

    Parameters
    ----------
    scenario : Scenario
        Needs ``observer.turn_rate_max`` and a range sensor (or ``planning.ping_sigma``).
    budget : int, optional
        Number of pings K ≥ 1.
    objective : {"mean-range-bound", "range-bound", "mean-position-bound"}
        Heading objective; the pings are scheduled and certified for the same quantity.
    mode : {"relaxed", "bonmin"}
        Continuous relaxation + rounding + polishing, or binary pings by bonmin.
    nlp_solver : {"ipopt", "sqp-osqp", "sqp-qrqp"}
        NLP solver of the relaxed mode (bonmin has its own).
    ping_stride : int
        Candidate ping steps are the allowed steps a multiple of it after the first allowed
        step (≥ 1).
    belief : Belief, optional
        Default the prior.
    min_spacing : float, optional
        Minimum time between pings [s] (default ``planning.ping_min_spacing``).
    forbidden : sequence of (start, end)
        Time windows without pings [s], added to ``planning.ping_forbidden``.
    polish_rounds : int
        Heading re-solve / ping schedule rounds after rounding (≥ 1).
    solver_options : dict, optional
        Extra options of the joint NLP solver (IPOPT, sqpmethod or bonmin).
    init : {"both", "even", "schedule"}
        Start of the NLP: the pingless heading plan with the weights spread evenly, or on the
        pings scheduled along it; "both" solves from each and keeps the better polished pair.
    binarize : bool
        Relaxed mode: after the relaxation, the continuation in μ of the penalty
        μ·Σ w(1 − w) (weights to {0, 1}) before rounding.
    **planner_kw
        Passed to :class:`HeadingPlanner` (``horizon``, ``control_interval``, ``n_starts``).

    Raises
    ------
    PlanningError
        Invalid ``budget``, ``ping_stride``, ``mode``, ``nlp_solver``, ``init`` or
        ``objective``; more pings than the strided candidates or the spacing allow; no range
        sensor.
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    t_start = time.perf_counter()
    if objective not in JOINT_PING_OBJECTIVE:
        raise PlanningError(f"objective: expected one of {sorted(JOINT_PING_OBJECTIVE)}, "
                            f"received {objective!r}")
    if mode not in JOINT_MODES:
        raise PlanningError(f"mode: expected one of {JOINT_MODES}, received {mode!r}")
    if init not in ("both", "even", "schedule"):
        raise PlanningError(f"init: expected 'both', 'even' or 'schedule', received {init!r}")
    if nlp_solver not in JOINT_NLP_SOLVERS:
        raise PlanningError(f"nlp_solver: expected one of {JOINT_NLP_SOLVERS}, received "
                            f"{nlp_solver!r}")
    if budget is None:
        budget = default_ping_budget(scenario)
    K = _check_int("budget", budget, 1)
    stride = _check_int("ping_stride", ping_stride, 1)
    rounds = _check_int("polish_rounds", polish_rounds, 1)
    if mode == "bonmin" and not ca.has_nlpsol("bonmin"):
        raise PlanningError("mode: 'bonmin' is not available in this casadi build")
    bel = belief if belief is not None else Belief.from_prior(scenario)
    planner = HeadingPlanner(scenario, objective=objective, **planner_kw)
    if planner.ping_scale == 0.0:
        raise PlanningError(f"{scenario.name}: no range sensor to ping with (add a "
                            "[[sensors]] kind = 'range' or planning.ping_sigma)")
    times = bel.t + planner.times
    allowed, gap, spacing = ping_candidates(scenario, times, forbidden=forbidden,
                                            min_spacing=min_spacing)
    cand = allowed[(allowed - allowed[:1].sum()) % stride == 0]
    if K > cand.size or K > max_pings(cand, gap):
        raise PlanningError(f"budget: expected at most {min(cand.size, max_pings(cand, gap))} "
                            f"pings on the {cand.size} candidate steps of ping_stride {stride} "
                            f"(min_spacing {spacing:g} s), received {K}")

    pair = JOINT_PING_OBJECTIVE[objective]
    # ------------------------------------------------------------------ the joint NLP
    # The heading OCP's NLP (x: headings/positions/turn rates; p: belief, sensors, heading0,
    # speed0, objective scale, sign) with its ping slice replaced by the weights S·w.
    nlp_h = planner.nlp
    xh, Ph = nlp_h["x"], nlp_h["p"]
    nh, ng = int(xh.size1()), int(nlp_h["g"].size1())
    sl = planner.layout.slices()["ping"]
    w = ca.MX.sym("w", cand.size)
    q = ca.MX.sym("q", Ph.size1())
    Sel = np.zeros((planner.K + 1, cand.size))
    Sel[cand, np.arange(cand.size)] = 1.0
    p_expr = ca.vertcat(q[:sl.start], ca.mtimes(ca.DM(Sel), w), q[sl.stop:])
    f, g = ca.substitute([nlp_h["f"], nlp_h["g"]], [Ph], [p_expr])  # inlined, no call node
    A = _spacing_matrix(cand, gap)
    g_all = ca.vertcat(g, ca.sum1(w), *([ca.mtimes(ca.DM(A), w)] if A.size else []))
    mu = ca.MX.sym("mu")  # weight of the binarising penalty Σ w(1 − w) (0: the relaxation)
    nlp = {"x": ca.vertcat(xh, w), "p": ca.vertcat(q, mu), "g": g_all,
           "f": f + mu * ca.sum1(w * (1 - w))}
    solver = _nlp_solver(nlp_solver, nlp, mode, nh, cand.size, dict(solver_options or {}))

    obs = scenario.observer
    heading0 = float(course_speed(initial_velocity(obs))[0])
    speed0 = planner.speed0
    planner.check_start(bel, heading0, speed0)
    pvec = planner.layout.vector(bel, belief_bearing_information(scenario, bel, planner.K))
    lbh, ubh, lbgh, ubgh = planner.bounds(heading0)
    bounds = {"lbx": np.concatenate([lbh, np.zeros(cand.size)]),
              "ubx": np.concatenate([ubh, np.ones(cand.size)]),
              "lbg": np.concatenate([lbgh, [K], np.full(A.shape[0], -np.inf)]),
              "ubg": np.concatenate([ubgh, [K], np.ones(A.shape[0])])}
    # starts: the pingless heading plan (the alternating method's first block) with the
    # weights spread evenly ("even") or on the pings scheduled along it ("schedule")
    t_nlp = time.perf_counter()
    plan0 = planner.solve(bel, heading0=heading0, speed0=speed0)
    assert plan0.warm is not None
    sgn = float(plan0.warm["sign"])
    P = np.concatenate([pvec, [heading0, speed0, 1.0, sgn]])
    f0 = float(ca.Function("joint_f", [nlp["x"], q], [f])(
        np.concatenate([plan0.warm["x"], np.full(cand.size, K / cand.size)]), P))
    P[-2] = max(abs(f0), 1e-3) if np.isfinite(f0) else 1.0  # objective scale
    starts: dict[str, np.ndarray] = {}
    if init in ("even", "both"):
        starts["even"] = np.full(cand.size, K / cand.size)
    if init in ("schedule", "both"):
        s0 = schedule_pings(scenario, budget=K, objective=pair,  # type: ignore[arg-type]
                            observer=plan0.observer, belief=bel, min_spacing=min_spacing,
                            forbidden=forbidden, candidate_steps=cand, gap_reference="none")
        starts["schedule"] = np.isin(cand, s0.steps).astype(float)
    nlp_seconds = time.perf_counter() - t_nlp
    mus = [0.0] + (list(_BINARIZE_MU) if mode == "relaxed" and binarize else [])
    tried = []
    for w0 in starts.values():
        t1 = time.perf_counter()
        run = _solve_nlp(solver, np.concatenate([plan0.warm["x"], w0]), P, mus, bounds, nh,
                         quiet=mode == "bonmin")
        nlp_seconds += time.perf_counter() - t1
        x = run["x"]
        u = np.clip(x[nh:], 0.0, 1.0)
        # round: bonmin's binaries, else the largest weights respecting the spacing
        rounded = sorted(int(c) for c in cand[u > 0.5]) if mode == "bonmin" else []
        if len(rounded) != K or not spacing_ok(rounded, gap):
            rounded = round_weights(u, cand, K, gap)[0]
        # the NLP's headings with the rounded pings: the point polishing starts from
        P_fix = P.copy()
        P_fix[sl] = Sel @ np.isin(cand, rounded).astype(float)
        warm = {"x": x[:nh], "lam_x": run["lam_x"][:nh], "lam_g": run["lam_g"][:ng],
                "sign": sgn, "shape": (planner.transcription, planner.n, planner.n_arcs)}
        plan = planner.make_plan(x[:nh], np.concatenate([P_fix[:-2], [1.0, sgn]]), bel.t,
                                 np.asarray(obs.position, float), speed0, run["status"],
                                 run["ok"], run["iters"], nlp_seconds, warm, run["status"])
        r_obj = PingEvaluator(scenario, plan.observer, bel, pair).value(rounded)
        # (a failed NLP's point may violate the heading constraints: any polished pair wins)
        best: tuple[float, HeadingPlan, list[int]] = (
            r_obj if run["ok"] else float("inf"), plan, list(rounded))
        for _ in range(rounds):
            # headings with the pings fixed, then the pings along the new track; each block
            # is kept only if it lowers the objective of the pair
            plan = planner.solve(bel, warm_start=best[1], ping_steps=best[2],
                                 raise_on_failure=False)
            if plan.success:
                v = PingEvaluator(scenario, plan.observer, bel, pair).value(best[2])
                if v < best[0] * (1 - 1e-9):
                    best = (v, plan, best[2])
            sched = schedule_pings(scenario, budget=K, objective=pair,  # type: ignore[arg-type]
                                   observer=best[1].observer, belief=bel,
                                   min_spacing=min_spacing, forbidden=forbidden,
                                   gap_reference="none")
            if not sched.objective < best[0] * (1 - 1e-9):
                break
            best = (sched.objective, best[1], sched.steps.tolist())
        tried.append((0 if run["ok"] else 1, best[0], best, run, u, rounded, r_obj))
    _, _, (_, plan, steps), run, u, rounded, rounded_objective = min(
        tried, key=lambda t: (t[0], t[1]))
    status, okf, iters = run["status"], run["ok"], sum(t[3]["iters"] for t in tried)
    relaxed_objective = run["f"] * P[-2]
    # certificate of the ping part on the final track (and the scheduler's pings if better)
    cert = schedule_pings(scenario, budget=K, objective=pair,  # type: ignore[arg-type]
                          observer=plan.observer, belief=bel, min_spacing=min_spacing,
                          forbidden=forbidden, gap_reference="auto")
    final = with_own_pings(cert, PingEvaluator(scenario, plan.observer, bel, pair), steps)
    return JointOCPResult(
        heading=plan, pings=final, objective=float(final.objective),
        lower_bound=float(final.lower_bound), gap=float(final.gap),
        relaxed_objective=relaxed_objective, weights=u, candidate_steps=cand,
        rounded_steps=np.asarray(rounded, int), rounded_objective=float(rounded_objective),
        mode=mode,
        nlp_solver="bonmin" if mode == "bonmin" else nlp_solver, status=status,
        success=bool(okf), iterations=iters, seconds=time.perf_counter() - t_start,
        nlp_seconds=nlp_seconds, polish_seconds=time.perf_counter() - t_start - nlp_seconds)
