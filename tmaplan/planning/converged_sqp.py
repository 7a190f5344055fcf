"""Converged re-plans by a condensed quasi-Newton SQP over the turn rates (issue 42).

:class:`ConvergedSQP` solves the heading OCP of a "direct" :class:`HeadingPlanner` to a
Karush-Kuhn-Tucker tolerance, as IPOPT does, but in the condensed space of the real-time
iteration (:mod:`tmaplan.planning.rti`): the turn rates ``u`` (n values in [−1, 1]) are the
only variables, the shooting states are re-simulated from them exactly, and every step is a
dense quadratic programme over ``u`` with the keep-out constraint linearised:

1. start: the previous plan's turn rates shifted to ``belief.t`` and re-simulated, the
   objective divided by its value there (as :meth:`HeadingPlanner.solve` does);
2. Hessian: the real-time iteration's model at the offline plan (:class:`RTIModel`, computed
   once per campaign) condensed to ``u`` and rescaled to this objective scale, then updated
   by damped BFGS (Powell) from the Lagrangian gradients of the accepted steps;
3. the step's QP (``daqp``, or another :data:`tmaplan.planning.rti.QP_SOLVERS` entry) gives
   the step ``d`` and multipliers; its optimality condition ``B d + ∇F + Aᵀλ + λ_u = 0`` makes
   ``‖B d‖∞`` the stationarity residual of the multipliers at the current point, so the
   solve stops when ``‖B d‖∞ ≤ tol`` and the keep-out holds (``constraint_tol``): IPOPT's
   ``tol`` on the same scaled problem;
4. line search: Armijo on the ℓ1 merit ``F + μ·violation`` (μ above the largest
   multiplier), step lengths 1, ½, … . The full step is evaluated with the gradient and the
   constraint Jacobian (:meth:`RealTimeIteration.evaluate`): accepted, as most are, that
   evaluation is the next step's, so an accepted full step costs one casadi call instead of
   two (the objective alone, then again with its gradient); shorter steps evaluate the merit
   function alone.

A solve that does not converge within ``max_iter`` steps, whose QP fails or whose line search
finds no decrease raises :class:`tmaplan.errors.SolverError` (or returns ``success=False``),
so a receding controller falls back exactly as after a failed IPOPT solve.
"""

from __future__ import annotations

import copy
import dataclasses
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from tmaplan.errors import ArgumentError, SolverError, is_integer
from tmaplan.planning.casadi_eval import NumpyFunction
from tmaplan.planning.rti import RealTimeIteration, RTIModel, constraint_violation

if TYPE_CHECKING:
    from tmaplan.planning.belief import Belief
    from tmaplan.planning.heading import HeadingPlan, HeadingPlanner

__all__ = ["ConvergedSQP"]


class ConvergedSQP:
    """Heading re-plans solved to a KKT tolerance by a condensed SQP (module docstring).

    Parameters
    ----------
    planner : HeadingPlanner
        A "direct" planner at constant speed.
    model : RTIModel
        Hessian model at the offline plan (:func:`tmaplan.planning.rti.reference_model`).
    qpsol : str
        casadi QP solver of the steps (:data:`tmaplan.planning.rti.QP_SOLVERS`).
    max_iter : int
        SQP steps before the solve is reported as not converged, >= 1.
    constraint_tol : float
        Keep-out violation treated as satisfied [dimensionless: (range/keep-out)² − 1].
    carry_hessian : bool
        Start from the quasi-Newton Hessian the warm-start plan's solve ended with (kept in
        its ``warm["hessian"]``, of the objective divided by ``warm["hessian_scale"]``),
        shifted with the plan by the elapsed control intervals, the intervals it does not
        cover from the model; False: from the model at every solve.
    rti : RealTimeIteration, optional
        A real-time iteration of the same planner whose compiled functions (objective,
        gradient, constraint Jacobian) and QP are reused instead of built again.
    """

    def __init__(self, planner: HeadingPlanner, model: RTIModel, *, qpsol: str = "daqp",
                 max_iter: int = 50, constraint_tol: float = 1e-6,
                 carry_hessian: bool = True, rti: RealTimeIteration | None = None) -> None:
        import casadi as ca  # deferred: casadi is slow to import

        if not is_integer(max_iter, 1):
            raise ArgumentError("max_iter", "an integer >= 1", max_iter)
        if rti is not None and (rti.planner is not planner or rti.qpsol != qpsol):
            raise ArgumentError("rti", f"a real-time iteration of this planner with qpsol "
                                f"{qpsol!r}", f"qpsol {rti.qpsol!r}")
        self._rti = (rti.with_model(model) if rti is not None else
                     RealTimeIteration(planner, model, qpsol=qpsol))
        self.planner, self.model, self.qpsol = planner, model, qpsol
        self.max_iter = int(max_iter)
        self.constraint_tol = float(constraint_tol)
        self.carry_hessian = bool(carry_hessian)
        nlp = planner.nlp
        self._merit_eval = NumpyFunction(ca.Function("sqp_merit", [nlp["x"], nlp["p"]],
                                                     [nlp["f"], nlp["g"]]))

    def with_model(self, model: RTIModel) -> ConvergedSQP:
        """The same solver (same compiled functions) with another model."""
        if model is self.model:
            return self
        out = copy.copy(self)
        out._rti = self._rti.with_model(model)
        out.model = model
        return out

    def solve(self, belief: Belief, *, warm_start: HeadingPlan | None = None,
              heading0: float | None = None, position0: np.ndarray | None = None,
              speed0: float | None = None, ping_steps: Sequence[int] = (),
              tol: float | None = None, raise_on_failure: bool = True) -> HeadingPlan:
        """Solve the re-plan for ``belief`` from ``warm_start`` (default the model's plan)
        shifted to ``belief.t``, as :meth:`HeadingPlanner.solve` with a warm start.

        Parameters
        ----------
        belief : Belief
        warm_start : HeadingPlan, optional
        heading0, speed0, position0, ping_steps
            The start state and the pings, as for
            :meth:`tmaplan.planning.rti.RealTimeIteration.solve`.
        tol : float, optional
            Stationarity tolerance on the scaled objective (default 1e-7, as IPOPT's).
        raise_on_failure : bool
            If False, a solve that did not converge is returned with ``success=False``.

        Returns
        -------
        HeadingPlan
            ``solver`` ``"sqp-<qpsol>"``; ``iterations`` the SQP steps.

        Raises
        ------
        PlanningError
            The estimate inside the keep-out range (before any step).
        SolverError
            Not converged (iteration limit, failed QP, no decrease along the step).
        """
        pl = self.planner
        pl.check_tolerance(tol)
        t_start = time.perf_counter()
        tol = 1e-7 if tol is None else float(tol)
        prev = warm_start if warm_start is not None else self.model.plan
        start = self._rti.replan_start(belief, prev, heading0=heading0, speed0=speed0,
                                       position0=position0, ping_steps=ping_steps)
        heading0, speed0, p0, u, x = (start.heading0, start.speed0, start.position0, start.u,
                                      start.x)
        P = np.concatenate([start.parameters, [heading0, speed0, 1.0, 1.0]])
        lbw, ubw, lbg, ubg = start.bounds
        f_start = self._merit_eval(x, P)[0].item()
        scale = max(abs(f_start), 1e-3) if np.isfinite(f_start) else 1.0
        P[-2] = scale
        B: np.ndarray | None = None
        # the last accepted step and the Lagrangian gradient before it (multipliers lam)
        step: np.ndarray | None = None
        grad_l, lam = np.zeros(0), np.zeros(0)
        mu, status, iters, converged = 1.0, "Maximum_Iterations_Exceeded", 0, False
        evaluated: tuple[np.ndarray, ...] | None = None  # evaluate(x, P) of the full step
        while iters < self.max_iter:
            iters += 1
            f0, g0, qp = self._rti.condensed(x, P, lbw, ubw, lbg, ubg, evaluated,
                                             hessian=B is None)
            if not np.isfinite(f0):
                status = "objective not finite"
                break
            A = qp["a"]
            if B is None:
                B = 0.5 * (qp["h"] + qp["h"].T) * (self.model.scale / scale)
                if self.carry_hessian:
                    B = _shifted_hessian(B, prev, belief.t, pl.Tc, scale)
            elif step is not None:
                B = _bfgs(B, step, qp["g"] + A.T @ lam - grad_l)
            qp["h"] = B
            d, lam, stats = self._rti.solve_qp(qp)  # an interrupt raises, never a failure
            if not bool(stats.get("success", False)):
                status = f"QP: {stats.get('return_status', 'failed')}"
                break
            v0 = constraint_violation(g0, lbg, ubg)
            if np.max(np.abs(B @ d), initial=0.0) <= tol and v0 <= self.constraint_tol:
                converged, status = True, "Solve_Succeeded"
                break
            mu = max(mu, 1.1 * float(np.max(np.abs(lam), initial=0.0)))
            phi0 = f0 + mu * v0
            slope = float(qp["g"] @ d) - mu * v0
            alpha, accepted = 1.0, False
            for trial in range(30):
                u1 = np.clip(u + alpha * d, -1, 1)
                x1 = pl.decision_vector(u1, heading0, speed0)
                if trial == 0:
                    evaluated = self._rti.evaluate(x1, P)
                    f1, g1 = evaluated[0], evaluated[2]
                else:
                    evaluated = None
                    f1, g1 = self._merit_eval(x1, P)
                phi1 = f1.item() + mu * constraint_violation(g1.reshape(-1), lbg, ubg)
                if np.isfinite(phi1) and phi1 <= phi0 + 1e-4 * alpha * min(slope, 0.0):
                    accepted = True
                    break
                alpha *= 0.5
            if not accepted:
                status = "no decrease of the merit function along the step"
                break
            grad_l, step = qp["g"] + A.T @ lam, u1 - u
            u, x = u1, x1
        seconds = time.perf_counter() - t_start
        if not converged and raise_on_failure:
            raise SolverError(f"sqp-{self.qpsol}", status, f"heading re-plan (condensed SQP) "
                              f"did not converge in {iters} step(s)")
        warm = {"x": x, "lam_x": np.zeros_like(x), "lam_g": np.zeros(lbg.size), "sign": 1.0,
                "shape": ("direct", pl.n, pl.n_arcs), "scale": scale,
                "hessian": B, "hessian_scale": scale}
        plan = pl.make_plan(x, P, belief.t, p0, speed0, status, converged, iters, seconds,
                             warm, status)
        return dataclasses.replace(plan, solver=f"sqp-{self.qpsol}")


def _shifted_hessian(B: np.ndarray, prev: HeadingPlan, t: float, Tc: float,
                     scale: float) -> np.ndarray:
    """``B`` with its leading block replaced by the Hessian of ``prev``'s solve (if it has
    one) shifted by the control intervals elapsed since it, rescaled to ``scale``: block
    diagonal, so positive definite when both blocks are."""
    warm = prev.warm or {}
    old = warm.get("hessian")
    if old is None or np.shape(old) != B.shape:
        return B
    k = max(round((t - float(prev.times[0])) / Tc), 0)
    n = B.shape[0]
    if k >= n:
        return B
    out = B.copy()
    out[: n - k, :] = 0.0
    out[:, : n - k] = 0.0
    out[: n - k, : n - k] = np.asarray(old)[k:, k:] * (float(warm["hessian_scale"]) / scale)
    return out


def _bfgs(B: np.ndarray, s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Damped BFGS update (Powell): B stays positive definite."""
    Bs = B @ s
    sBs = float(s @ Bs)
    if sBs <= 1e-16:
        return B
    sy = float(s @ y)
    theta = 1.0 if sy >= 0.2 * sBs else 0.8 * sBs / (sBs - sy)
    r = theta * y + (1 - theta) * Bs
    return B - np.outer(Bs, Bs) / sBs + np.outer(r, r) / float(s @ r)
