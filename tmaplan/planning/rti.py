"""Real-time iteration: a heading re-plan as one warm-started SQP step (milliseconds).

A receding-horizon controller re-solves :class:`tmaplan.planning.HeadingPlanner`'s OCP for a
belief that changed little since the last plan. Instead of a full IPOPT solve (≈ 1 s on
``default``), :class:`RealTimeIteration` takes *one* sequential-quadratic-programming step from
the previous plan shifted to the current time (the real-time iteration of nonlinear model
predictive control):

1. start ``x₀``: the previous turn-rate sequence shifted by the elapsed control intervals and
   re-simulated from the current heading (so the shooting constraints hold exactly);
2. the objective's gradient, the constraints and their Jacobian at ``x₀`` (one casadi
   function, built once per planner: the planner's own NLP, so any
   :class:`tmaplan.planning.objectives.Objective` the planner uses);
3. the quadratic programme ``min ½ dᵀ H d + ∇fᵀ d`` subject to the linearised constraints and
   the bounds, solved by casadi's ``qrqp`` (default) or ``osqp``;
4. the turn rates ``u₀ + α d_u`` re-simulated (α = 1, ½, ¼), accepted when the objective
   does not increase and the keep-out constraint holds (to ``constraint_tol``) or its
   violation decreases; a re-plan is returned only if its last accepted step satisfies the
   constraint: a step from a start inside the keep-out range (the estimate moved close) that
   only reduces the violation may be followed by more steps (``steps``), but is never
   returned as a plan. Otherwise (no step accepted, or the constraint still violated) a full
   warm-started IPOPT solve is the fallback, whose failure raises.

``H`` is the Hessian of the Lagrangian at the offline plan from the prior (exact, by casadi's
automatic differentiation, forward over reverse column by column, once per campaign:
:func:`reference_model`) made positive definite
by taking the absolute values of its eigenvalues (floored at ``eigen_floor`` times the largest).
The exact Hessian at every re-plan costs ≈ 4.7 s on ``default`` (the ``expected-time-to-accuracy``
objective, 183 variables; measured by ``benchmarks/closed_loop.py --step``), more than the
IPOPT solve it replaces (≈ 1 s), while the objective, its gradient and the constraint Jacobian
cost ≈ 13 ms and the condensed QP (45 turn rates) 2 ms with ``daqp`` (``osqp`` 9 ms, ``qrqp``
117 ms). A whole re-plan, belief parameters and track included, takes ≈ 20 ms: the trial point
is evaluated once, for the merit test and for the plan, and the casadi functions are called
through numpy buffers (:class:`tmaplan.planning.casadi_eval.NumpyFunction`); before both, it
took ≈ 43 ms (same values, bit for bit).

``osqp`` is selectable (``qpsol="osqp"``) but not the default: its workspace is reused across
calls, so repeated steps may differ in the last digits (≈ 1e−15), while ``qrqp`` is bit
reproducible, which the campaigns' identical-results guarantee needs.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from tmaplan.errors import ArgumentError, PlanningError, SolverError, is_integer
from tmaplan.planning.belief import Belief
from tmaplan.planning.casadi_eval import NumpyFunction
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner

__all__ = ["QP_SOLVERS", "RTIModel", "RealTimeIteration", "ReplanStart", "constraint_violation",
           "hessian_columns", "reference_model"]

#: QP solvers of the step (casadi ``conic`` plugins).
QP_SOLVERS = ("daqp", "qrqp", "osqp")


@dataclasses.dataclass(frozen=True, kw_only=True)
class RTIModel:
    """What a real-time iteration needs besides the planner, computed once per campaign.

    Attributes
    ----------
    hessian : ndarray, shape (n_w, n_w)
        Positive-definite model of the Hessian of the scaled Lagrangian (dimensionless per
        decision variable).
    scale : float
        Objective scale the Hessian belongs to (the objective is divided by it) [objective
        units].
    plan : HeadingPlan
        The reference plan (the offline plan from the prior): the first re-plan's start.
    """

    hessian: np.ndarray
    scale: float
    plan: Any


@dataclasses.dataclass(frozen=True, kw_only=True)
class ReplanStart:
    """The start of a warm-started heading re-plan (:meth:`RealTimeIteration.replan_start`).

    Attributes
    ----------
    heading0 : float
        Start heading [rad].
    speed0 : float
        Start speed [m/s].
    position0 : ndarray, shape (2,)
        Start position [m].
    parameters : ndarray, shape (n_p,)
        The objective's parameters (:meth:`HeadingPlanner.parameter_vector`, the head of the
        NLP's ``P``).
    bounds : tuple of ndarray
        ``(lbw, ubw, lbg, ubg)`` of the decision vector and the constraints for a start at
        ``heading0`` (:meth:`HeadingPlanner.bounds`).
    u : ndarray, shape (m,)
        The previous plan's turn rates shifted to the belief's time, fractions of ``u_max``
        clipped to [−1, 1].
    x : ndarray, shape (n_w,)
        The NLP's decision vector of ``u`` flown from ``heading0`` at ``speed0``
        (:meth:`HeadingPlanner.decision_vector`).
    """

    heading0: float
    speed0: float
    position0: np.ndarray
    parameters: np.ndarray
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    u: np.ndarray
    x: np.ndarray


def constraint_violation(g: np.ndarray, lbg: np.ndarray, ubg: np.ndarray) -> float:
    """The largest violation of the bounds ``lbg <= g <= ubg`` (0 when all hold).

    Parameters
    ----------
    g, lbg, ubg : ndarray, shape (n_g,)
        Constraint values and their lower and upper bounds [dimensionless for the keep-out
        rows: (range/keep-out)² − 1].

    Returns
    -------
    float
        ``max(max(lbg − g), max(g − ubg), 0)``.
    """
    return float(max(np.max(lbg - g, initial=0.0), np.max(g - ubg, initial=0.0)))


def reference_model(planner: HeadingPlanner, plan: HeadingPlan, belief: Belief, *,
                    heading0: float | None = None, speed0: float | None = None,
                    eigen_floor: float = 1e-3) -> RTIModel:
    """The Hessian model of a real-time iteration at a solved plan (exact, then convexified).

    Parameters
    ----------
    planner : HeadingPlanner
        A "direct" planner.
    plan : HeadingPlan
        An IPOPT solution of ``planner`` for ``belief`` (its primal and dual values are used).
    belief : Belief
    heading0, speed0 : float, optional
        The start state ``plan`` was solved from (default the scenario's).
    eigen_floor : float
        Eigenvalues of the Hessian are replaced by their absolute values, floored at this
        fraction of the largest.
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    _check_planner(planner)
    if plan.warm is None or "scale" not in plan.warm:
        raise PlanningError("reference_model: plan has no solver state (expected an IPOPT "
                            "plan of this planner)")
    if not 0 < eigen_floor < 1:
        raise ArgumentError("eigen_floor", "in (0, 1)", eigen_floor)
    h0, s0, _ = planner.start_state(heading0, speed0, None)
    scale = float(plan.warm["scale"])
    P = np.concatenate([planner.parameter_vector(belief, ()), [h0, s0, scale, 1.0]])
    nlp = planner.nlp
    lam = ca.MX.sym("lam", nlp["g"].shape[0])
    grad = ca.Function("rti_lagrangian_gradient", [nlp["x"], nlp["p"], lam],
                       [ca.gradient(nlp["f"] + ca.dot(lam, nlp["g"]), nlp["x"])])
    H = hessian_columns(grad, np.asarray(plan.warm["x"], float), P,
                        np.asarray(plan.warm["lam_g"], float))
    vals, vecs = np.linalg.eigh(0.5 * (H + H.T))
    mag = np.abs(vals)
    mag = np.maximum(mag, eigen_floor * max(float(mag.max()), 1e-12))
    return RTIModel(hessian=(vecs * mag) @ vecs.T, scale=scale, plan=plan)


def hessian_columns(grad: Any, x: np.ndarray, *args: Any, threads: int | None = None
                    ) -> np.ndarray:
    """The Jacobian of a gradient function (a Hessian), one forward derivative per column.

    Parameters
    ----------
    grad : casadi.Function
        ``grad(x, *args)`` -> gradient, shape (n,).
    x : ndarray, shape (n,)
    *args
        The function's other inputs (fixed).
    threads : int, optional
        casadi threads the n columns are shared among (default: the CPUs this process may
        use). Each column is computed the same way whatever the count, so the result is
        bit-identical; on ``default`` (183 columns) 2 threads take ≈ 0.65× the time of 1.

    Returns
    -------
    ndarray, shape (n, n)
        Exact (automatic differentiation, forward over reverse): one forward derivative of
        ``grad`` mapped over the n unit directions. Building ``casadi.hessian`` of the 16-sample
        objective on ``default`` took about a minute and a forward derivative in n directions
        at once as long; the one-direction derivative builds in about 0.1 s.
    """
    n = x.size
    if threads is None:
        threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    if not is_integer(threads, 1):
        raise ArgumentError("threads", "an integer >= 1", threads)
    g0 = grad(x, *args)
    fwd = grad.forward(1)
    zeros = [np.zeros((np.asarray(a).size, n)) for a in args]
    mapped = fwd.map(n, "thread", int(min(threads, n))) if threads > 1 else fwd.map(n)
    return np.asarray(mapped(x, *args, g0, np.eye(n), *zeros))


def _check_planner(planner: HeadingPlanner) -> None:
    if planner.transcription != "direct" or planner.speed_choice:
        raise PlanningError("real-time iteration: needs a 'direct' heading planner at "
                            f"constant speed, received transcription {planner.transcription!r}"
                            f"{' with speed choice' if planner.speed_choice else ''}")


class RealTimeIteration:
    """One-SQP-step re-plans of a heading planner (see the module docstring).

    Parameters
    ----------
    planner : HeadingPlanner
        A "direct" planner at constant speed (its NLP and objective are used as they are).
    model : RTIModel
        Hessian model and reference plan (:func:`reference_model`).
    qpsol : {"daqp", "qrqp", "osqp"}
        casadi QP solver of the condensed step (default ``daqp``, a dense active-set solver:
        the fastest of the three on ``default`` and bit reproducible).
    backtracks : int
        Step lengths tried: 1, ½, … (``backtracks + 1`` of them) before the fallback.
    constraint_tol : float
        Constraint violation treated as satisfied [dimensionless: (range/keep-out)² − 1].
    steps : int
        SQP steps per re-plan (1: the real-time iteration; more steps stop at the first
        rejected one; the fallback applies when the first is rejected or the last accepted
        one leaves the constraints violated).
    rescale : bool
        Divide the objective by its value at the start of each re-plan (the model Hessian was
        computed for the objective divided by its value at the reference plan), so that the
        step keeps its length as the objective shrinks along the run; False (default: it
        localised sooner in paired closed-loop runs on ``default``): the reference scale
        throughout.
    """

    def __init__(self, planner: HeadingPlanner, model: RTIModel, *, qpsol: str = "daqp",
                 backtracks: int = 2, constraint_tol: float = 1e-6, steps: int = 1,
                 rescale: bool = False) -> None:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        _check_planner(planner)
        if qpsol not in QP_SOLVERS:
            raise ArgumentError("qpsol", f"one of {', '.join(QP_SOLVERS)}", qpsol)
        nlp = planner.nlp
        n_w = nlp["x"].shape[0]
        if model.hessian.shape != (n_w, n_w):
            raise ArgumentError("model.hessian", f"shape ({n_w}, {n_w})", model.hessian.shape)
        self.planner, self.model, self.qpsol = planner, model, qpsol
        self.backtracks = max(0, int(backtracks))
        self.constraint_tol = float(constraint_tol)
        if int(steps) < 1:
            raise ArgumentError("steps", ">= 1", steps)
        self.steps = int(steps)
        self.rescale = bool(rescale)
        w, P, f, g = nlp["x"], nlp["p"], nlp["f"], nlp["g"]
        self._eval = NumpyFunction(ca.Function("rti_eval", [w, P],
                                               [f, ca.gradient(f, w), g, ca.jacobian(g, w)]))
        # condensing: the shooting equalities fix the states (ψ, p) given the turn rates u, so
        # the QP is over u only (n variables instead of 4n + 3)
        m = planner.n
        self._u = np.arange(3 * (m + 1), 4 * m + 3)
        self._x = np.arange(3 * (m + 1))
        lbg, ubg = planner.bounds(0.0)[2:]
        self._eq = lbg == ubg  # the shooting constraints
        # bounded states (heading limits) become general constraint rows
        self._xb = np.arange(m + 1) if planner.heading_limits is not None else np.arange(0)
        n_rows = int(np.count_nonzero(~self._eq)) + self._xb.size
        opts: dict[str, Any] = {"error_on_fail": False}
        if qpsol == "qrqp":
            opts.update(print_iter=False, print_header=False, print_info=False)
        elif qpsol == "osqp":
            opts.update(osqp={"verbose": False, "eps_abs": 1e-9, "eps_rel": 1e-9,
                              "max_iter": 20000, "polish": True})
        self._qp = ca.conic("rti_qp", qpsol, {"h": ca.Sparsity.dense(m, m),
                                              "a": ca.Sparsity.dense(n_rows, m)}, opts)
        self._qp_buffer = NumpyFunction(self._qp)

    def with_model(self, model: RTIModel) -> RealTimeIteration:
        """The same iteration (same compiled functions) with another model."""
        if model is self.model:
            return self
        n_w = self.model.hessian.shape[0]
        if model.hessian.shape != (n_w, n_w):
            raise ArgumentError("model.hessian", f"shape ({n_w}, {n_w})", model.hessian.shape)
        out = copy.copy(self)
        out.model = model
        return out

    @property
    def turn_rate_index(self) -> np.ndarray:
        """Indices (m,) of the turn-rate controls ``u_j/u_max`` in the NLP's decision vector."""
        return self._u

    @property
    def qp(self) -> Any:
        """The condensed QP's casadi ``conic`` solver (built once), which :meth:`solve_qp`
        calls through numpy buffers with the dict :meth:`condensed` returns."""
        return self._qp

    def solve_qp(self, qp: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
        """Solve the condensed QP (the dict :meth:`condensed` returns) through numpy buffers:
        the same solve as :attr:`qp` called with the dict, without converting each array to
        a casadi matrix (half the time of a call at 45 turn rates).

        Returns
        -------
        x : ndarray, shape (m,)
            The turn-rate step.
        lam_a : ndarray, shape (n_rows,)
            The multipliers of the general constraints.
        stats : dict
            The solver's statistics of this solve (``success``, ``return_status``).
        """
        fn = self._qp
        args = [qp[name] if name in qp else np.asarray(fn.default_in(i)) *
                np.ones(fn.nnz_in(i)) for i, name in enumerate(fn.name_in())]
        out = dict(zip(fn.name_out(), self._qp_buffer(*args), strict=True))
        return (out["x"].reshape(-1), out["lam_a"].reshape(-1),
                self._qp_buffer.stats())

    def evaluate(self, x: np.ndarray, P: np.ndarray) -> tuple[np.ndarray, ...]:
        """The NLP's objective (1, 1), its gradient (n_w, 1), the constraints (n_g, 1) and
        their Jacobian (n_g, n_w) at the decision vector ``x`` for the parameters ``P`` (one
        casadi call; the gradient by one reverse sweep, ``casadi.gradient``)."""
        return self._eval(x, P)

    def condensed(self, x0: np.ndarray, P: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
                  lbg: np.ndarray, ubg: np.ndarray,
                  evaluated: tuple[np.ndarray, ...] | None = None, *, hessian: bool = True
                  ) -> tuple[float, np.ndarray, dict[str, Any]]:
        """Objective and constraints at x0, and the QP over the turn-rate step d_u.

        ``x0`` is the NLP's decision vector, ``P`` its parameters, ``lbw``…``ubg`` its bounds
        (:meth:`HeadingPlanner.bounds`); ``evaluated``: :meth:`evaluate` ``(x0, P)`` if
        already computed (not evaluated again); ``hessian`` False: ``qp["h"]`` is left
        to the caller (zeros; a quasi-Newton SQP supplies its own). Returns ``(f0, g0, qp)``:
        the objective, the constraints at ``x0`` and the arguments of :attr:`qp`.

        Linearised equalities ``J_s d_s + J_u d_u = −g_E`` give ``d = Z d_u + z₀`` with
        ``Z = [−J_s⁻¹ J_u; I]``; the QP has the reduced Hessian ``Zᵀ H Z`` and gradient
        ``Zᵀ(∇f + H z₀)``.
        """
        f0, grad, g0, J = self.evaluate(x0, P) if evaluated is None else evaluated
        g0 = g0.reshape(-1)
        eq, xs, xu = self._eq, self._x, self._u
        Js = J[np.ix_(eq, xs)]
        rhs = np.linalg.solve(Js, np.column_stack([J[np.ix_(eq, xu)], g0[eq]]))
        Z = np.zeros((x0.size, xu.size))
        Z[xs] = -rhs[:, :-1]
        Z[xu] = np.eye(xu.size)
        z0 = np.zeros(x0.size)
        z0[xs] = -rhs[:, -1]
        H = self.model.hessian
        JI = J[~eq]
        lin = g0[~eq] + JI @ z0
        qp = {"h": Z.T @ H @ Z if hessian else np.zeros((xu.size, xu.size)),
              "g": Z.T @ (np.asarray(grad).reshape(-1) + H @ z0),
              "a": np.vstack([JI @ Z, Z[self._xb]]),
              "lba": np.concatenate([lbg[~eq] - lin, (lbw - x0 - z0)[self._xb]]),
              "uba": np.concatenate([ubg[~eq] - lin, (ubw - x0 - z0)[self._xb]]),
              "lbx": (lbw - x0)[xu], "ubx": (ubw - x0)[xu]}
        return f0.item(), g0, qp

    def replan_start(self, belief: Belief, previous: HeadingPlan, *, heading0: float | None,
                     speed0: float | None, position0: np.ndarray | None,
                     ping_steps: Sequence[int]) -> ReplanStart:
        """The start of a re-plan for ``belief``: ``previous`` shifted to ``belief.t``, flown
        from the start state (the real-time iteration's and
        :class:`tmaplan.planning.converged_sqp.ConvergedSQP`'s first step).

        Parameters
        ----------
        belief : Belief
        previous : HeadingPlan
            The plan to start from.
        heading0, speed0 : float or None
            Current heading [rad] and speed [m/s] (None: the scenario's).
        position0 : ndarray, shape (2,), or None
            Current position [m] (None: the scenario's).
        ping_steps : sequence of int
            Plan steps with a range ping.

        Returns
        -------
        ReplanStart

        Raises
        ------
        PlanningError
            The estimate inside the keep-out range (:meth:`HeadingPlanner.check_start`).
        """
        pl = self.planner
        heading0, speed0, p0 = pl.start_state(heading0, speed0, position0)
        pl.check_start(belief, heading0, speed0)
        pvec = pl.parameter_vector(belief, ping_steps)
        bounds = pl.bounds(heading0)
        x_prev, _ = pl.shifted_start(previous, belief.t, heading0, speed0)
        u = np.clip(np.asarray(x_prev)[self._u], -1, 1)
        return ReplanStart(heading0=heading0, speed0=speed0, position0=p0, parameters=pvec,
                           bounds=bounds, u=u, x=pl.decision_vector(u, heading0, speed0))

    def solve(self, belief: Belief, *, previous: HeadingPlan | None = None,
              heading0: float | None = None, position0: np.ndarray | None = None,
              speed0: float | None = None, ping_steps: Sequence[int] = (),
              fallback: bool = True) -> HeadingPlan:
        """A re-plan for ``belief``: one SQP step from ``previous`` (default the model's plan)
        shifted to ``belief.t``, or a warm IPOPT solve if the step is rejected.

        Parameters
        ----------
        belief : Belief
        previous : HeadingPlan, optional
        heading0, speed0 : float, optional
            Current heading [rad] and speed [m/s] (default the scenario's).
        position0 : ndarray, shape (2,), optional
            Current position [m] (places the returned track).
        ping_steps : sequence of int
            Plan steps with a range ping.
        fallback : bool
            If False, a rejected step (or one that leaves the keep-out constraint violated)
            raises :class:`tmaplan.errors.SolverError` instead of falling back to IPOPT.

        Returns
        -------
        HeadingPlan
            ``solver`` is ``"rti-daqp"`` / ``"rti-qrqp"`` / ``"rti-osqp"`` for an accepted
            step (``warm["start_objective"]``: the objective at the shifted start),
            ``"ipopt"`` for the fallback.

        Raises
        ------
        PlanningError
            The estimate inside the keep-out range; the IPOPT fallback infeasible.
        SolverError
            The fallback did not converge, or (``fallback=False``) the step was rejected.
        """
        t_start = time.perf_counter()
        pl = self.planner
        prev = previous if previous is not None else self.model.plan
        start = self.replan_start(belief, prev, heading0=heading0, speed0=speed0,
                                  position0=position0, ping_steps=ping_steps)
        heading0, speed0, p0, x0 = start.heading0, start.speed0, start.position0, start.x
        P = np.concatenate([start.parameters, [heading0, speed0, self.model.scale, 1.0]])
        lbw, ubw, lbg, ubg = start.bounds
        if self.rescale:
            # the model Hessian belongs to the objective divided by its value at the
            # reference; divide by the value at the start instead (curvature relative to value)
            f_start = self._merit(x0, np.concatenate([P[:-2], [1.0, 1.0]]))[0]
            if np.isfinite(f_start) and abs(f_start) > 0:
                P[-2] = abs(f_start)
        accepted, reason, f_start = self._step(x0, P, lbw, ubw, lbg, ubg)
        for _ in range(self.steps - 1):
            if accepted is None:
                break
            more, _, _ = self._step(accepted[0], P, lbw, ubw, lbg, ubg)
            if more is None:
                break
            accepted = more
        if accepted is not None and accepted[2] is not None:
            # a step from an infeasible start may only have reduced the violation: that
            # is no plan (the stationary step has no outputs: its start is feasible)
            v = constraint_violation(np.asarray(accepted[2][-1]).reshape(-1), lbg, ubg)
            if v > self.constraint_tol:
                accepted, reason = None, (f"constraints (keep-out) still violated after the step "
                                          f"({v:.2e} > constraint_tol "
                                          f"{self.constraint_tol:g})")
        if accepted is not None:
            x1, status, evaluated = accepted
            warm = {"x": x1, "lam_x": np.zeros_like(x1), "lam_g": np.zeros(lbg.size),
                    "sign": 1.0, "shape": ("direct", pl.n, pl.n_arcs),
                    "scale": float(P[-2]), "start_objective": f_start * float(P[-2])}
            plan = pl.make_plan(x1, P, belief.t, p0, speed0, status, True, 1,
                                time.perf_counter() - t_start, warm, status, evaluated)
            return dataclasses.replace(plan, solver=f"rti-{self.qpsol}")
        if not fallback:
            raise SolverError(f"rti-{self.qpsol}", reason, "real-time iteration step rejected")
        plan = pl.solve(belief, heading0=heading0, position0=p0, speed0=speed0,
                        warm_start=prev, ping_steps=ping_steps)
        return dataclasses.replace(plan, seconds=time.perf_counter() - t_start,
                                   message=f"RTI step rejected ({reason}); {plan.message}")

    def _merit(self, x: np.ndarray, P: np.ndarray) -> tuple[float, np.ndarray, Any]:
        """The NLP's objective (divided by the scale ``P[-2]``, as the NLP's) and constraints
        at x, and the planner's plan outputs there (one evaluation of the plan function)."""
        outs = self.planner.plan_function(x, P)
        return outs[0].item() / float(P[-2]), outs[-1].reshape(-1), outs

    def _step(self, x0: np.ndarray, P: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lbg: np.ndarray, ubg: np.ndarray
              ) -> tuple[tuple[np.ndarray, str, Any] | None, str, float]:
        """One SQP step from x0: ((x, status, plan outputs at x or None), "", f0) if accepted,
        (None, reason, f0) if not; f0 is the scaled objective at x0."""
        pl = self.planner
        f0, g0, qp = self.condensed(x0, P, lbw, ubw, lbg, ubg)
        if not np.isfinite(f0):
            return None, "objective not finite at the start", f0
        v0 = constraint_violation(g0, lbg, ubg)
        # (the buffers' call runs in solver_call: qrqp turns Ctrl-C into a failed QP, an
        # interrupt raises)
        d, _, stats = self.solve_qp(qp)
        if not bool(stats.get("success", False)):
            return None, f"QP: {stats.get('return_status', 'failed')}", f0
        if np.max(np.abs(d), initial=0.0) <= 1e-6 and v0 <= self.constraint_tol:
            # below 1e-6 of the maximum turn rate: x0 is stationary to what is flown (the
            # merit test would only compare round-off)
            return (x0, "RTI step: stationary", None), "", f0
        alpha = 1.0
        for _ in range(self.backtracks + 1):
            u = np.clip(x0[self._u] + alpha * d, -1, 1)
            x1 = pl.decision_vector(u, float(P[-4]), float(P[-3]))
            f1, g1, outs = self._merit(x1, P)
            v1 = constraint_violation(g1, lbg, ubg)
            feasible = v1 <= self.constraint_tol or v1 < v0
            if np.isfinite(f1) and feasible and f1 <= f0 + 1e-12 * abs(f0):
                return (x1, f"RTI step alpha={alpha:g}", outs), "", f0
            alpha *= 0.5
        return None, (f"no decrease (objective {f0:.6g} -> {f1:.6g}, violation {v0:.2e} -> "
                      f"{v1:.2e})"), f0
