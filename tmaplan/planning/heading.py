"""Heading optimal-control problem (casadi + IPOPT): direct multiple shooting and bang-bang.

Own ship at speed V (constant, or chosen per control interval), heading ψ clockwise from North,
turn rate ω ∈ [−ω_max, ω_max]; constraints: keep-out range from the target *estimate* (the
belief mean propagated at constant velocity), optional heading limits. The objective is any
:class:`tmaplan.planning.objectives.Objective` (minimised).

Transcriptions
    ``"direct"``: multiple shooting on the control grid (interval ``control_interval``): states
    (ψ_j, p_j) at the nodes, piecewise-constant ω_j, continuity constraints; inside an interval
    the grid steps are integrated exactly with :func:`arc_displacement_casadi`.
    ``"bang-bang"``: switching-time parametrisation: a fixed sequence of arcs with
    ω ∈ {+ω_max, 0, −ω_max} (lecadre1997 §VII / Le Cadre & Laurent-Michel: bounded controls give
    bang-bang optima) whose *durations* are the variables; positions on the dt grid are exact
    sums of arcs clipped at the grid instants, so the switch times are exact.

The NLP is built once (belief, initial heading and speed, bearing and ping information and the
objective scale are casadi parameters): :meth:`HeadingPlanner.solve` re-solves a new belief
with a warm start. The decision vector's layout is :mod:`tmaplan.planning.heading_transcription`'s;
the real-time iteration and the joint OCP solve the same NLP through the planner's public hooks.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.bounds.closed_form import require_process_noise
from tmaplan.bounds.inputs import check_ping_steps
from tmaplan.errors import ArgumentError, InfeasibleError, PlanningError, SolverError
from tmaplan.geometry import course_speed, velocity_from_course, wrap_angle
from tmaplan.interrupts import solver_call
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import initial_velocity, ncv_matrices
from tmaplan.planning.arcs import arc_displacement_casadi, safe_sinc
from tmaplan.planning.belief import Belief
from tmaplan.planning.casadi_eval import NumpyFunction
from tmaplan.planning.feasibility import (
    check_plan_inputs,
    check_planning_horizon,
    check_start_keep_out,
)
from tmaplan.planning.heading_plan import HeadingPlan
from tmaplan.planning.heading_transcription import (
    bang_bang_guesses,
    bang_bang_transcription,
    direct_decision_vector,
    direct_guesses,
    direct_transcription,
    plan_switch_times,
    shifted_durations,
    with_epigraph,
)
from tmaplan.planning.objectives import (
    DEFAULT_OBJECTIVE,
    Objective,
    ObjectiveEvaluator,
    PlanContext,
    belief_bearing_information,
    closed_form_graph,
    make_objective,
    ping_sigma,
    until_end_weights,
)

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["BUILT_IN_STARTS", "HeadingPlan", "HeadingPlanner", "arc_displacement_casadi",
           "check_planning_horizon", "plan_heading", "safe_sinc"]

#: Built-in initial guesses of a cold solve per transcription: ``n_starts`` takes at most
#: this many (the direct transcription's straight, two turn-reverse, two zig-zag and two
#: turn-early patterns; the bang-bang one's equal and front-loaded arcs to both sides).
BUILT_IN_STARTS = {"direct": 7, "bang-bang": 4}

_OK = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}


class HeadingPlanner:
    """Heading OCP built once, solved many times (see module docstring).

    Parameters
    ----------
    scenario : Scenario
    objective : str or Objective
        Default ``scenario.planning.objective`` or :data:`DEFAULT_OBJECTIVE`.
    horizon : float, optional
        [s]; default ``planning.horizon`` (warned past the end) or the scenario's; whole intervals.
    control_interval : float, optional
        [s]; default ``planning.control_interval`` or dt. Rounded to whole dt steps.
    transcription : {"direct", "bang-bang"}
    n_starts : int
        Initial guesses tried on a cold solve (best successful one is kept); at most
        :data:`BUILT_IN_STARTS` of the transcription are used.
    solver_options : dict, optional
        Extra IPOPT options (``{"max_iter": 500}``, ``{"hessian_approximation": "exact"}``).
    turn_rate_max, keep_out_range : float, optional
        Override the scenario's limits [rad/s], [m].
    speed_choice : bool
        Speed per interval in [speed_min, speed_max] ("direct" only).
    n_arcs : int
        Arcs of the bang-bang sequence (+, 0, −, 0, +, ...).
    logdet_samples : int
        Belief samples averaged by the ``logdet`` objective (1 = the mean).
    until_end : bool
        Count only the plan steps up to the scenario's end in the objectives that sum or
        average over the steps, and in ``logdet``'s information (step weights 0 after it,
        :class:`ParamLayout`): a re-plan at time t then optimises the time the mission has
        left, not a full horizon beyond it. The terminal objectives (the value at the
        horizon's last step) do not read the step weights.
    compiled : bool
        The objective's compiled kernel where it has one (:class:`PlanContext`): re-plans.

    Attributes
    ----------
    n, m, K : int
        Control intervals, grid steps per interval, grid steps of the horizon (K = n m).
    dt, Tc : float
        Grid step and control interval [s].
    times : ndarray, shape (K + 1,)
        Plan grid relative to the plan's start [s].
    u_max : float
        Maximum turn rate [rad/s].
    speed0 : float
        The scenario's initial speed [m/s].
    layout : ParamLayout
        Layout of the objective's parameters (belief, sensors, step weights).
    ping_scale : float
        Information scale 1/σ_r² of a range ping [1/m²]; 0 without a range sensor.
    nlp : dict
        The casadi NLP ``{"x": w, "p": P, "f": f/scale, "g": g}``: ``w`` the decision vector
        (:mod:`tmaplan.planning.heading_transcription`), ``P = [parameter_vector(...),
        heading0 (rad), speed0 (m/s), scale, sign]`` (scale: the objective's divisor; sign:
        the bang-bang orientation, 1 for "direct"), ``g`` the constraints
        (:meth:`bounds`).
    plan_function : NumpyFunction
        ``(w, P) -> (f, range_bound, position, mean_velocity, heading, turn_rate, g)`` on
        numpy arrays: the unscaled objective, the closed-form range bound [m] (K + 1,), the
        track relative to the start [m] (K + 1, 2), mean velocities [m/s] (K + 1, 2),
        headings [rad] (K + 1,), turn rates [rad/s] (K,) and the constraints (what
        :meth:`make_plan` reads).

    Raises
    ------
    ScenarioError or ArgumentError
        Before any graph is built (:mod:`tmaplan.planning.feasibility`): a planning horizon
        of no whole number of control intervals (an argument ``horizon`` shorter than one),
        more steps than fit in the memory available.

    """

    def __init__(self, scenario: Scenario, *, objective: str | Objective | None = None,
                 horizon: float | None = None, control_interval: float | None = None,
                 transcription: Literal["direct", "bang-bang"] = "direct", n_starts: int = 4,
                 solver_options: dict[str, Any] | None = None,
                 turn_rate_max: float | None = None, keep_out_range: float | None = None,
                 speed_choice: bool = False, n_arcs: int = 5, logdet_samples: int = 1,
                 until_end: bool = False, compiled: bool = False) -> None:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        pl = scenario.planning
        obs = scenario.observer
        self.scenario = scenario
        if objective is None:
            objective = pl.objective if pl is not None else DEFAULT_OBJECTIVE
        self.objective = make_objective(objective, samples=logdet_samples,
                                        accuracy=scenario.required_accuracy)
        if transcription not in ("direct", "bang-bang"):
            raise PlanningError(f"transcription: expected 'direct' or 'bang-bang', received "
                                f"{transcription!r}")
        self.transcription = transcription
        self.n_starts = max(1, int(n_starts))
        self.until_end = bool(until_end)
        dt = float(scenario.time.dt)
        H = horizon if horizon is not None else (pl.horizon if pl and pl.horizon else
                                                 scenario.time.horizon)
        Tc = control_interval if control_interval is not None else (
            pl.control_interval if pl and pl.control_interval else dt)
        self.m = max(1, round(float(Tc) / dt))
        if horizon is None and control_interval is None:
            check_planning_horizon(scenario)
        elif float(H) < self.m * dt * (1 - 1e-9):  # nothing to plan: refused, not rounded up
            field = "horizon" if horizon is not None else "control_interval"
            raise ArgumentError(field, f"a horizon of at least one control interval ({H:g} s "
                                f">= {self.m * dt:g} s)", horizon if horizon is not None
                                else control_interval, source=scenario.name)
        self.n = max(1, round(float(H) / (self.m * dt)))
        # refused before any graph is built (a 30-day horizon exhausted the memory)
        check_plan_inputs(scenario, self.n * self.m, horizon=horizon)
        self.dt, self.Tc = dt, self.m * dt
        self.K = self.n * self.m
        umax = turn_rate_max if turn_rate_max is not None else obs.turn_rate_max
        if umax is None:
            raise PlanningError(f"{scenario.name}: observer.turn_rate_max is needed to plan "
                                "headings (bounded turn rate)")
        self.u_max = float(umax)
        self.keep_out = float(keep_out_range if keep_out_range is not None else
                              (pl.keep_out_range if pl is not None else 0.0))
        v0 = initial_velocity(obs)
        self.speed0 = float(course_speed(v0)[1])
        self.speed_bounds = (float(obs.speed_min), float(obs.speed_max or self.speed0))
        self.speed_choice = bool(speed_choice) and transcription == "direct" and (
            self.speed_bounds[1] > self.speed_bounds[0])
        lim = (obs.heading_min, obs.heading_max)
        self.heading_limits = None if lim[0] is None or lim[1] is None else (
            float(lim[0]), float(lim[1]))
        self.n_arcs = max(1, int(n_arcs))
        require_process_noise(scenario)
        A, Q = ncv_matrices(dt, float(scenario.target.q))
        self.layout = self.objective.param_layout(self.K)
        sig = ping_sigma(scenario)
        self.ping_scale = 0.0 if sig is None else 1.0 / sig**2
        self.times = dt * np.arange(self.K + 1)

        # ---------------------------------------------------------------- parameters
        p_obj = ca.MX.sym("p_obj", self.layout.size)
        hd0 = ca.MX.sym("heading0")
        spd0 = ca.MX.sym("speed0")
        scale = ca.MX.sym("scale")
        sgn = ca.MX.sym("sign")  # bang-bang orientation
        P = ca.vertcat(p_obj, hd0, spd0, scale, sgn)
        self._np = self.layout.size

        if transcription == "direct":
            w, lbw, ubw, g, lbg, ubg, traj = direct_transcription(
                hd0, spd0, n=self.n, m=self.m, dt=dt, u_max=self.u_max,
                speed_bounds=self.speed_bounds if self.speed_choice else None)
        else:
            w, lbw, ubw, g, lbg, ubg, traj = bang_bang_transcription(
                hd0, spd0, sgn, K=self.K, dt=dt, u_max=self.u_max, n_arcs=self.n_arcs,
                heading_limits=self.heading_limits is not None)
        pos, vbar, head, urate = traj
        ctx = PlanContext(dt=dt, times=self.times, A=A, Q=Q, v_obs=vbar, disp=pos,
                          turn_rate=urate, p=p_obj, layout=self.layout, compiled=compiled,
                          ping_scale=self.ping_scale, turn_rate_max=max(self.u_max, 1e-9))
        self._callbacks = ctx.cache.setdefault("callbacks", [])  # live as long as the solvers
        f = self.objective.expression(ctx)  # (a compiled one's, and its epigraph terms', too)
        self._n_w = w.shape[0]
        w, f, lbw, ubw, g, lbg, ubg, self._epi_guess = with_epigraph(
            self.objective.epigraph_terms(ctx), scale, w, P, f, lbw, ubw, g, lbg, ubg)
        rb = closed_form_graph(ctx)["range_bound"]
        # keep-out from each target estimate: E X_0 propagated at constant velocity
        for o in (self.layout.mean_offsets() if self.keep_out > 0 else ()):
            m0 = p_obj[o:o + 4]
            t = ca.DM(self.times.reshape(-1, 1))
            v_o0 = vbar[0, :]
            tx = m0[0] + t * (m0[2] + v_o0[0]) - pos[:, 0]
            ty = m0[1] + t * (m0[3] + v_o0[1]) - pos[:, 1]
            g.append(((tx * tx + ty * ty) / self.keep_out**2)[1:])
            lbg.append(np.ones(self.K))
            ubg.append(np.full(self.K, np.inf))
        G = ca.vertcat(*g)
        self._lbg, self._ubg = np.concatenate(lbg), np.concatenate(ubg)
        self._lbw, self._ubw = lbw, ubw
        self.nlp = {"x": w, "p": P, "f": f / scale, "g": G}
        # the plan's outputs and the constraints (the real-time iteration's trial point is
        # tested and, if accepted, becomes the plan from one evaluation)
        self.plan_function = NumpyFunction(ca.Function("plan_eval", [w, P],
                                                       [f, rb, pos, vbar, head, urate, G]))
        self._opts = solver_options or {}
        self._solvers: dict[tuple[bool, float | None], Any] = {}

    # ------------------------------------------------------------------------- solve
    @staticmethod
    def check_tolerance(tol: Any, field: str = "tol") -> None:
        """Raise :class:`ArgumentError` naming ``field`` unless ``tol`` is a number in (0, 1)
        or None (an IPOPT ``tol`` for :meth:`solve`)."""
        if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float))
                                or not 0 < tol < 1):
            raise ArgumentError(field, "a number in (0, 1) or None", tol)

    def _solver(self, warm: bool, tol: float | None = None) -> Any:
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        key = (warm, tol)
        if key not in self._solvers:
            ipopt: dict[str, Any] = {
                "print_level": 0, "sb": "yes", "max_iter": 300, "tol": 1e-7,
                "acceptable_tol": 1e-5, "hessian_approximation": "limited-memory",
                "limited_memory_max_history": 20}
            if warm:
                ipopt.update({"warm_start_init_point": "yes", "warm_start_bound_push": 1e-6,
                              "warm_start_mult_bound_push": 1e-6, "mu_init": 1e-4})
            ipopt.update(self._opts)
            if tol is not None:
                ipopt.update({"tol": float(tol), "acceptable_tol": 10 * float(tol)})
            self._solvers[key] = ca.nlpsol(f"heading_{len(self._solvers)}", "ipopt", self.nlp,
                                           {"print_time": False, "ipopt": ipopt,
                                            "calc_lam_p": False})  # unused; no ∂/∂p in a kernel
        return self._solvers[key]

    def bounds(self, heading0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Bounds ``(lbw, ubw, lbg, ubg)`` of the decision vector and the constraints of
        :attr:`nlp` for a start at ``heading0`` [rad] (fresh arrays).

        The heading limits, if any, are placed in the 2π turn of ``heading0``; the shooting
        and duration constraints are equalities (``lbg == ubg``), the keep-out ones
        inequalities.
        """
        lbw, ubw = self._lbw.copy(), self._ubw.copy()
        lbg, ubg = self._lbg.copy(), self._ubg.copy()
        if self.heading_limits is not None:
            lo, hi = self.heading_limits
            shift = 2 * np.pi * np.round((heading0 - 0.5 * (lo + hi)) / (2 * np.pi))
            lo, hi = lo + shift, hi + shift
            if self.transcription == "direct":
                lbw[: self.n + 1], ubw[: self.n + 1] = lo, hi
            else:
                na = self.n_arcs
                lbg[1:na + 2], ubg[1:na + 2] = lo, hi
        return lbw, ubw, lbg, ubg

    def _guesses(self, heading0: float, speed0: float) -> list[tuple[np.ndarray, float]]:
        """Initial guesses (w, sign) for the multi-start."""
        if self.transcription == "bang-bang":
            return bang_bang_guesses(self.n_arcs)[: self.n_starts]
        return [(self.decision_vector(u, heading0, speed0), 1.0)
                for u in self.start_programs()[: self.n_starts]]

    def start_programs(self) -> list[np.ndarray]:
        """The direct transcription's built-in starts, turn-rate programs ``u_j/u_max`` (n,)
        in [−1, 1] in the order a cold solve tries them (:data:`BUILT_IN_STARTS`)."""
        return direct_guesses(self.n)

    def decision_vector(self, u: np.ndarray, heading0: float, speed0: float) -> np.ndarray:
        """The "direct" decision vector of :attr:`nlp` for a turn-rate program ``u`` (fractions
        of :attr:`u_max` per control interval, shape (n,)) flown from ``heading0`` [rad] at
        ``speed0`` [m/s] (:func:`~tmaplan.planning.heading_transcription.direct_decision_vector`:
        the shooting constraints hold)."""
        return direct_decision_vector(u, heading0, speed0, m=self.m, dt=self.dt,
                                      u_max=self.u_max, speed_choice=self.speed_choice)

    def shifted_start(self, plan: HeadingPlan, t: float, heading0: float,
                      speed0: float) -> tuple[np.ndarray, dict[str, Any] | None]:
        """Primal warm start from ``plan`` (its ``warm`` state, or its turn rates) shifted to
        the time ``t`` [s], flown from ``heading0`` [rad] at ``speed0`` [m/s].

        Returns
        -------
        x0 : ndarray
            Decision vector of :attr:`nlp`: the plan's turn rates shifted by the elapsed
            control intervals (the last one repeated) and re-simulated from ``heading0``
            ("direct"), or its arc durations cut at ``t`` ("bang-bang").
        duals : dict or None
            The plan's solver state when it is unshifted and of this shape (its
            ``lam_x``, ``lam_g`` warm-start IPOPT), else None.
        """
        warm = plan.warm or {}
        k = round((t - plan.times[0]) / self.Tc)
        same = warm.get("shape") == (self.transcription, self.n, self.n_arcs)
        if same and k == 0:
            return warm["x"], warm
        if self.transcription == "bang-bang":
            if same:
                return shifted_durations(np.asarray(warm["x"])[: self._n_w], self.K, self.dt,
                                         t - plan.times[0]), None
            return self._guesses(heading0, speed0)[0][0], None
        u = plan.turn_rate / max(self.u_max, 1e-12)
        u = np.clip(np.concatenate([u[k:], np.full(max(k, 0), u[-1] if u.size else 0.0)]),
                    -1, 1)
        u = np.resize(u, self.n) if u.size != self.n else u
        return self.decision_vector(u, heading0, speed0), None

    def solve(self, belief: Belief, *, heading0: float | None = None,
              position0: np.ndarray | None = None, speed0: float | None = None,
              warm_start: HeadingPlan | None = None, ping_steps: Sequence[int] = (),
              raise_on_failure: bool = True,
              starts: Sequence[np.ndarray] | None = None,
              tol: float | None = None) -> HeadingPlan:
        """Solve the heading OCP for a belief (relative to the observer state at ``belief.t``).

        Parameters
        ----------
        belief : Belief
            Relative state ``target − [position0, velocity(heading0, speed0)]`` at t.
        heading0 : float, optional
            Current heading [rad] (default the scenario's initial course).
        position0 : ndarray, shape (2,), optional
            Current position [m] (default the scenario's initial position); only places the
            returned track.
        speed0 : float, optional
            Current speed [m/s] (default the scenario's).
        warm_start : HeadingPlan, optional
            Previous plan: shifted to ``belief.t`` and used as the only initial guess.
        ping_steps : sequence of int
            Plan steps with a range ping (enter the closed-form objectives), each in [0, K]
            (K = :attr:`K`, step 0 at ``belief.t``); others raise :class:`ArgumentError`.
        raise_on_failure : bool
            If False, a failed solve is returned with ``success=False`` instead of raising.
        starts : sequence of ndarray, optional
            Initial guesses replacing the built-in ones ("direct" only): turn-rate programs
            ``u_j/u_max`` in [−1, 1], one value per control interval, shape (n,).
        tol : float, optional
            IPOPT ``tol`` of this solve (``acceptable_tol`` 10× it; default 1e-7).

        Raises
        ------
        InfeasibleError
            Infeasible request (e.g. the estimate inside the keep-out range), or IPOPT found
            the problem infeasible (a :class:`PlanningError`).
        SolverError
            IPOPT did not converge from any start.
        """
        t_start = time.perf_counter()
        self.check_tolerance(tol)
        heading0, speed0, p0 = self.start_state(heading0, speed0, position0)
        self.check_start(belief, heading0, speed0)
        pvec = self.parameter_vector(belief, ping_steps)
        lbw, ubw, lbg, ubg = self.bounds(heading0)
        guesses: list[tuple[np.ndarray, float]]
        duals: dict[str, Any] | None
        if warm_start is not None:
            x0, duals = self.shifted_start(warm_start, belief.t, heading0, speed0)
            sgn = float(warm_start.warm.get("sign", 1.0)) if warm_start.warm else 1.0
            guesses = [(x0, sgn)]
        elif starts is not None and self.transcription == "direct":
            progs = [np.clip(np.asarray(u, float).reshape(-1), -1, 1) for u in starts]
            if not progs or any(u.shape != (self.n,) for u in progs):
                raise PlanningError(f"starts: expected turn-rate programs of shape "
                                    f"({self.n},), received {[u.shape for u in progs]}")
            duals, guesses = None, [(self.decision_vector(u, heading0, speed0), 1.0)
                                    for u in progs]
        else:
            duals, guesses = None, self._guesses(heading0, speed0)
        P0 = np.concatenate([pvec, [heading0, speed0, 1.0, guesses[0][1]]])
        f0 = self.plan_function(self.with_epigraph_start(guesses[0][0], P0), P0)[0].item()
        scale = max(abs(f0), 1e-3) if np.isfinite(f0) else 1.0
        best: tuple[float, Any, str, float] | None = None
        iters, statuses = 0, []
        for x0, sgn in guesses:
            P = np.concatenate([pvec, [heading0, speed0, scale, sgn]])
            x0 = self.with_epigraph_start(x0, P)
            use_warm = duals is not None
            solver = self._solver(use_warm, tol)
            kw: dict[str, Any] = {"x0": x0, "p": P, "lbx": lbw, "ubx": ubw, "lbg": lbg,
                                  "ubg": ubg}
            if duals is not None:
                kw.update(lam_x0=duals["lam_x"], lam_g0=duals["lam_g"])
            with solver_call():  # an interrupt raises, never a failed solve (issue 38)
                sol = solver(**kw)
            stats = solver.stats()
            status = str(stats.get("return_status", "unknown"))
            iters += int(stats.get("iter_count", 0))
            statuses.append(status)
            fval = float(sol["f"]) * scale
            ok = status in _OK and np.isfinite(fval)
            key = (0 if ok else 1, fval)
            if best is None or key < (0 if best[2] in _OK else 1, best[0]):
                best = (fval, sol, status, sgn)
        assert best is not None
        fval, sol, status, sgn = best
        success = status in _OK
        seconds = time.perf_counter() - t_start
        if not success:
            if "Infeasible" in " ".join(statuses):
                msg = (f"heading plan infeasible (IPOPT: {', '.join(sorted(set(statuses)))}): "
                       f"keep_out_range {self.keep_out:.0f} m, turn_rate_max "
                       f"{np.degrees(self.u_max):.3g} deg/s"
                       + (f", heading limits {self.heading_limits}" if self.heading_limits
                          else ""))
                if raise_on_failure:
                    raise InfeasibleError(msg)
            elif raise_on_failure:
                raise SolverError("ipopt", status, f"heading OCP ({self.transcription}) did "
                                  f"not converge from {len(guesses)} start(s)")
        P = np.concatenate([pvec, [heading0, speed0, scale, sgn]])
        # a min-max's epigraph variable at its tightest: the objective is the largest term's
        x = self.with_epigraph_start(np.asarray(sol["x"]).reshape(-1)[: self._n_w], P)
        warm = {"x": x, "lam_x": np.asarray(sol["lam_x"]).reshape(-1),
                "lam_g": np.asarray(sol["lam_g"]).reshape(-1), "sign": sgn,
                "shape": (self.transcription, self.n, self.n_arcs), "scale": scale}
        return self.make_plan(x, P, belief.t, p0, speed0, status, success, iters, seconds, warm,
                              ", ".join(statuses))

    def with_epigraph_start(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """A start ``x`` of the transcription's variables with the epigraph variable appended
        at its tightest value (max of the terms), when the objective has one."""
        if x.size != self._n_w or self._epi_guess is None:
            return x
        return np.append(x, float(self._epi_guess(x, P)))

    def start_state(self, heading0: float | None, speed0: float | None,
                    position0: np.ndarray | None) -> tuple[float, float, np.ndarray]:
        """The start ``(heading [rad], speed [m/s], position [m] shape (2,))``: the values
        given, the scenario's initial ones for those that are None."""
        obs = self.scenario.observer
        if heading0 is None:
            heading0 = float(course_speed(initial_velocity(obs))[0])
        speed0 = self.speed0 if speed0 is None else float(speed0)
        p0 = np.asarray(obs.position if position0 is None else position0, float)
        return float(heading0), speed0, p0

    def parameter_vector(self, belief: Belief, ping_steps: Sequence[int]) -> np.ndarray:
        """The objective's parameters (:attr:`layout`, the head of :attr:`nlp`'s ``P``).

        Parameters
        ----------
        belief : Belief
            Relative state at the plan's start ``belief.t``.
        ping_steps : sequence of int
            Plan steps with a range ping, each in [0, K] (others raise
            :class:`ArgumentError`; any without a range sensor :class:`PlanningError`).

        Returns
        -------
        ndarray, shape (layout.size,)
            The belief, the bearing and ping information per step and the step weights.
        """
        ping = np.zeros(self.K + 1)
        st = check_ping_steps(ping_steps, self.K, source=self.scenario.name)  # plan steps
        if st.size:
            if self.ping_scale == 0.0:
                raise PlanningError(f"{self.scenario.name}: ping_steps given but the scenario "
                                    "has no range sensor")
            ping[st] = 1.0
        bearing = belief_bearing_information(self.scenario, belief, self.K)
        weight = until_end_weights(self.scenario, belief.t, self.K) if self.until_end else None
        return self.layout.vector(belief, bearing, ping, weight)

    def evaluator(self, belief: Belief) -> ObjectiveEvaluator:
        """The :class:`ObjectiveEvaluator` of this planner's objective for ``belief``: same
        horizon K, turn-rate normaliser ``u_max`` [rad/s], belief samples and step weights,
        so its value of a plan's ``observer`` track is the plan's ``objective``."""
        return ObjectiveEvaluator(self.scenario, self.objective, n_steps=self.K, belief=belief,
                                  turn_rate_max=self.u_max, until_end=self.until_end)

    def check_start(self, belief: Belief, heading0: float, speed0: float) -> None:
        """Refuse a start no plan can satisfy, before any solve.

        Raises
        ------
        InfeasibleError
            The target estimate (``belief`` mean) already inside the keep-out range, or no
            turn possible (``u_max = 0``, fixed speed) and the straight course passing
            inside it.
        """
        check_start_keep_out(belief, keep_out=self.keep_out, u_max=self.u_max,
                             speed_choice=self.speed_choice, times=self.times)

    def make_plan(self, x: np.ndarray, P: np.ndarray, t0: float, p0: np.ndarray,
                  speed0: float, status: str, success: bool, iters: int, seconds: float,
                  warm: dict[str, Any], message: str,
                  evaluated: Sequence[Any] | None = None) -> HeadingPlan:
        """The :class:`HeadingPlan` of a decision vector, whoever solved for it.

        Parameters
        ----------
        x : ndarray
            Decision vector of :attr:`nlp`.
        P : ndarray
            The NLP's parameters ``x`` belongs to (see :attr:`nlp`).
        t0 : float
            Start of the plan [s] (absolute).
        p0 : ndarray, shape (2,)
            Start position [m] (places the track).
        speed0 : float
            Start speed [m/s].
        status, success, iters, seconds, warm, message
            The plan's solver report (:class:`HeadingPlan` fields ``status``, ``success``,
            ``iterations``, ``seconds`` [s], ``warm``, ``message``).
        evaluated : sequence, optional
            :attr:`plan_function` ``(x, P)`` if already computed (not evaluated again).
        """
        outs = self.plan_function(x, P) if evaluated is None else evaluated
        x = x[: self._n_w]  # without an epigraph variable
        f, rb, pos, vbar, head = (np.asarray(o) for o in outs[:5])
        head, times = head.reshape(-1), t0 + self.times
        # the solver meets the bound to its tolerance (~1e-8 rad/s over): clipped here, so
        # a plan's rates pass observer.turn_rates' check (issue 41)
        tr = np.clip(np.diff(nodes := head[:: self.m]) / self.Tc, -self.u_max, self.u_max)
        spd = x[-self.n:] if self.speed_choice else np.full(self.n, speed0)
        spd_steps = np.concatenate([[speed0], np.repeat(spd, self.m)])
        track = ObserverTrack(times=times, position=p0 + pos, velocity=velocity_from_course(
            spd_steps, head), mean_velocity=vbar, heading=wrap_angle(head), speed=spd_steps)
        switch = plan_switch_times(x, tr, transcription=self.transcription, t0=t0, K=self.K,
                                   dt=self.dt, Tc=self.Tc, n_arcs=self.n_arcs,
                                   sign=float(P[-1]), u_max=self.u_max)
        return HeadingPlan(times=t0 + self.Tc * np.arange(self.n + 1), heading=nodes,
                           turn_rate=tr, speed=spd, switch_times=switch, observer=track,
                           objective=float(f.reshape(-1)[0]), range_bound=rb.reshape(-1),
                           transcription=self.transcription, status=status, success=success,
                           iterations=iters, seconds=seconds, message=message, warm=warm)


def plan_heading(scenario: Scenario, *, belief: Belief | None = None,
                 **kw: Any) -> HeadingPlan:
    """Plan from the prior (or ``belief``) with a fresh :class:`HeadingPlanner`.

    Keyword arguments go to :class:`HeadingPlanner` (``objective``, ``horizon``,
    ``control_interval``, ``transcription``, ``n_starts``, ...).
    """
    solve_kw = {k: kw.pop(k) for k in ("heading0", "position0", "speed0", "ping_steps",
                                       "raise_on_failure") if k in kw}
    planner = HeadingPlanner(scenario, **kw)
    b = belief if belief is not None else Belief.from_prior(scenario)
    return planner.solve(b, **solve_kw)
