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

The NLP is built once; the belief, the initial heading and speed, the bearing and ping
information and the objective scale are casadi parameters, so :meth:`HeadingPlanner.solve`
re-solves for a new belief (receding horizon) with a warm start.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.bounds.inputs import check_ping_steps
from tmaplan.errors import (
    ArgumentError,
    InfeasibleError,
    PlanningError,
    SolverError,
)
from tmaplan.geometry import course_speed, velocity_from_course, wrap_angle
from tmaplan.interrupts import solver_call
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import initial_velocity, ncv_matrices
from tmaplan.planning.arcs import arc_displacement_casadi, safe_sinc
from tmaplan.planning.belief import Belief
from tmaplan.planning.casadi_eval import NumpyFunction
from tmaplan.planning.feasibility import check_plan_memory, check_planning_horizon
from tmaplan.planning.heading_plan import HeadingPlan
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
#: this many (:meth:`HeadingPlanner._guesses`: the direct transcription's straight, two
#: turn-reverse, two zig-zag and two turn-early patterns; the bang-bang one's equal and
#: front-loaded arcs to both sides).
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
        [s]; default ``planning.horizon`` or the scenario's. Rounded to whole intervals.
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
                 until_end: bool = False) -> None:
        import casadi as ca

        pl = scenario.planning
        obs = scenario.observer
        self.scenario = scenario
        if objective is None:
            objective = pl.objective if pl is not None else DEFAULT_OBJECTIVE
        self.objective = make_objective(objective, samples=logdet_samples)
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
        check_plan_memory(scenario, self.n * self.m, horizon=horizon)
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
        A, Q = ncv_matrices(dt, float(scenario.target.q))
        self.layout = self.objective.param_layout(self.K)
        sig = ping_sigma(scenario)
        self._ping_scale = 0.0 if sig is None else 1.0 / sig**2
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
            w, lbw, ubw, g, lbg, ubg, traj = self._direct(hd0, spd0)
        else:
            w, lbw, ubw, g, lbg, ubg, traj = self._bang_bang(hd0, spd0, sgn)
        pos, vbar, head, urate = traj
        ctx = PlanContext(dt=dt, times=self.times, A=A, Q=Q, v_obs=vbar, disp=pos,
                          turn_rate=urate, p=p_obj, layout=self.layout,
                          ping_scale=self._ping_scale, turn_rate_max=max(self.u_max, 1e-9))
        f = self.objective.expression(ctx)
        # a min-max objective (Objective.epigraph_terms): an epigraph variable t = scale·τ,
        # τ last in the NLP's variables (O(1), as the constraints g_c/scale − τ <= 0)
        epi, self._n_w = self.objective.epigraph_terms(ctx), w.shape[0]
        if epi:
            gc, tau = ca.vertcat(*epi) / scale, ca.MX.sym("epigraph")
            self._epi_guess = ca.Function("epigraph_guess", [w, P], [ca.mmax(gc)])
            w, f = ca.vertcat(w, tau), f + scale * tau
            lbw, ubw = np.append(lbw, -np.inf), np.append(ubw, np.inf)
            g, lbg, ubg = [*g, gc - tau], [*lbg, np.full(len(epi), -np.inf)], [
                *ubg, np.zeros(len(epi))]
        rb = closed_form_graph(ctx)["range_bound"]
        # keep-out from the target estimate: E X_0 propagated at constant velocity
        if self.keep_out > 0:
            m0 = p_obj[0:4]
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
        self._nlp = {"x": w, "p": P, "f": f / scale, "g": G}
        # the plan's outputs and the constraints (the real-time iteration's trial point is
        # tested and, if accepted, becomes the plan from one evaluation)
        self._f_eval = NumpyFunction(ca.Function("plan_eval", [w, P],
                                                 [f, rb, pos, vbar, head, urate, G]))
        self._opts = solver_options or {}
        self._solvers: dict[tuple[bool, float | None], Any] = {}

    # ------------------------------------------------------------------ transcriptions
    def _direct(self, hd0: Any, spd0: Any) -> tuple[Any, ...]:
        import casadi as ca

        n, m, dt = self.n, self.m, self.dt
        psi = ca.MX.sym("psi", n + 1)
        pk = ca.MX.sym("p_km", 2, n + 1)
        uu = ca.MX.sym("u", n)  # ω / ω_max
        spd = ca.MX.sym("speed", n) if self.speed_choice else None
        # one control interval, m exact sub-steps
        ps, om, vs = ca.SX.sym("ps"), ca.SX.sym("om"), ca.SX.sym("v")
        heads = ps + om * dt * ca.DM(np.arange(m)).T
        dx, dy = arc_displacement_casadi(heads, om, vs, dt)
        interval = ca.Function("interval", [ps, om, vs],
                               [ca.vertcat(ca.cumsum(dx.T).T, ca.cumsum(dy.T).T),
                                ca.vertcat(dx, dy) / dt])
        om_all = uu * self.u_max
        v_all = spd if spd is not None else spd0 * ca.DM.ones(n)
        cum, vb = interval.map(n)(psi[:n].T, om_all.T, v_all.T)  # 2 × (n m)
        start = ca.repmat(pk[:, :n] * 1000.0, 1, 1)
        rep = ca.kron(start, ca.DM.ones(1, m))
        pos_steps = rep + cum
        pos = ca.vertcat(ca.DM.zeros(1, 2), pos_steps.T)  # (K+1) × 2, relative to start
        vbar = ca.vertcat(spd0 * ca.horzcat(ca.sin(hd0), ca.cos(hd0)), vb.T)
        urate = ca.kron(om_all, ca.DM.ones(m, 1))
        head = ca.vertcat(ca.kron(psi[:n], ca.DM.ones(m, 1))
                          + urate * ca.DM(np.tile(np.arange(m) * dt, n)), psi[n])
        g = [psi[0] - hd0, pk[:, 0],
             psi[1:] - psi[:n] - om_all * self.Tc,
             ca.vec(pk[:, 1:] - pos_steps[:, m - 1::m] / 1000.0)]
        ng = 1 + 2 + n + 2 * n
        w = ca.vertcat(psi, ca.vec(pk), uu, *( [spd] if spd is not None else []))
        lb_psi, ub_psi = np.full(n + 1, -np.inf), np.full(n + 1, np.inf)
        self._psi_limits_index = np.arange(n + 1)
        lbw = np.concatenate([lb_psi, np.full(2 * (n + 1), -np.inf), -np.ones(n)]
                             + ([np.full(n, self.speed_bounds[0])] if spd is not None else []))
        ubw = np.concatenate([ub_psi, np.full(2 * (n + 1), np.inf), np.ones(n)]
                             + ([np.full(n, self.speed_bounds[1])] if spd is not None else []))
        return (w, lbw, ubw, g, [np.zeros(ng)], [np.zeros(ng)], (pos, vbar, head, urate))

    def _arc_pattern(self) -> np.ndarray:
        base = [1.0, 0.0, -1.0, 0.0]
        return np.array([base[i % 4] for i in range(self.n_arcs)])

    def _bang_bang(self, hd0: Any, spd0: Any, sgn: Any) -> tuple[Any, ...]:
        import casadi as ca

        H, K, dt = self.K * self.dt, self.K, self.dt
        na = self.n_arcs
        tau = ca.MX.sym("tau", na)  # durations / H
        om = sgn * self.u_max * ca.DM(self._arc_pattern())
        dur = tau * H
        T = ca.vertcat(0, ca.cumsum(dur)[:-1])
        psi_i = hd0 + ca.vertcat(0, ca.cumsum(om * dur)[:-1])
        t = ca.DM(self.times.reshape(-1, 1))
        ones_a = ca.DM.ones(1, na)
        D = ca.fmin(ca.fmax(ca.mtimes(t, ones_a) - ca.repmat(T.T, K + 1, 1), 0),
                    ca.repmat(dur.T, K + 1, 1))
        dx, dy = arc_displacement_casadi(ca.repmat(psi_i.T, K + 1, 1),
                                         ca.repmat(om.T, K + 1, 1), spd0, D)
        pos = ca.horzcat(ca.sum2(dx), ca.sum2(dy))
        head = hd0 + ca.mtimes(D, om)
        vbar = ca.vertcat(spd0 * ca.horzcat(ca.sin(hd0), ca.cos(hd0)),
                          (pos[1:, :] - pos[:-1, :]) / dt)
        urate = (head[1:] - head[:-1]) / dt
        g = [ca.sum1(tau) - 1]
        lbg, ubg = [np.zeros(1)], [np.zeros(1)]
        if self.heading_limits is not None:
            psi_end = ca.vertcat(psi_i, hd0 + ca.sum1(om * dur))
            g.append(psi_end)
            lbg.append(np.full(na + 1, -np.inf))
            ubg.append(np.full(na + 1, np.inf))
        return (tau, np.zeros(na), np.ones(na), g, lbg, ubg, (pos, vbar, head, urate))

    # ------------------------------------------------------------------------- solve
    @staticmethod
    def check_tolerance(tol: Any, field: str = "tol") -> None:
        """Raise :class:`ArgumentError` naming ``field`` unless ``tol`` is a number in (0, 1)
        or None (an IPOPT ``tol`` for :meth:`solve`)."""
        if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float))
                                or not 0 < tol < 1):
            raise ArgumentError(field, "a number in (0, 1) or None", tol)

    def _solver(self, warm: bool, tol: float | None = None) -> Any:
        import casadi as ca

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
            self._solvers[key] = ca.nlpsol(f"heading_{len(self._solvers)}", "ipopt", self._nlp,
                                           {"print_time": False, "ipopt": ipopt})
        return self._solvers[key]

    def _bounds(self, heading0: float) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                 np.ndarray]:
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
            na = self.n_arcs
            eq = np.full(na, 1.0 / na)
            front = np.where(self._arc_pattern() == 0, 0.05, 1.0)
            front = front / front.sum()
            out = [(eq, 1.0), (eq, -1.0), (front, 1.0), (front, -1.0)]
            return out[: self.n_starts]
        return [(self._direct_w(u, heading0, speed0), 1.0)
                for u in self.start_programs()[: self.n_starts]]

    def start_programs(self) -> list[np.ndarray]:
        """The direct transcription's built-in starts, turn-rate programs ``u_j/u_max`` (n,)
        in [−1, 1] in the order a cold solve tries them (:data:`BUILT_IN_STARTS`)."""
        n, j = self.n, np.arange(self.n)
        return [np.zeros(n), np.where(j < n / 3, 1.0, -1.0), np.where(j < n / 3, -1.0, 1.0),
                np.where((j // max(1, n // 6)) % 2 == 0, 0.7, -0.7),
                np.where((j // max(1, n // 6)) % 2 == 0, -0.7, 0.7),
                np.where(j < n / 4, 1.0, 0.0), np.where(j < n / 4, -1.0, 0.0)]

    def _direct_w(self, u: np.ndarray, heading0: float, speed0: float) -> np.ndarray:
        from tmaplan.models.observer import turn_rate_track

        om = np.repeat(u * self.u_max, self.m)
        trk = turn_rate_track(np.zeros(2), heading0, speed0, om, self.dt)
        psi = heading0 + self.Tc * np.concatenate([[0.0], np.cumsum(u * self.u_max)])
        pk = trk.position[:: self.m] / 1000.0
        parts = [psi, pk.reshape(-1), u]
        if self.speed_choice:
            parts.append(np.full(self.n, speed0))
        return np.concatenate(parts)

    def _shift_warm(self, plan: HeadingPlan, t: float, heading0: float,
                    speed0: float) -> tuple[np.ndarray, dict[str, Any] | None]:
        """Primal warm start from a previous plan shifted to time t (duals if unshifted)."""
        warm = plan.warm or {}
        k = round((t - plan.times[0]) / self.Tc)
        same = warm.get("shape") == (self.transcription, self.n, self.n_arcs)
        if same and k == 0:
            return warm["x"], warm
        if self.transcription == "bang-bang":
            if same:
                tau = np.asarray(warm["x"])[: self._n_w] * self.K * self.dt
                cut = (t - plan.times[0])
                T = np.concatenate([[0.0], np.cumsum(tau)])
                new = np.clip(T[1:], cut, None) - np.clip(T[:-1], cut, None)
                new[-1] += cut
                return new / new.sum(), None
            return self._guesses(heading0, speed0)[0][0], None
        u = plan.turn_rate / max(self.u_max, 1e-12)
        u = np.clip(np.concatenate([u[k:], np.full(max(k, 0), u[-1] if u.size else 0.0)]),
                    -1, 1)
        u = np.resize(u, self.n) if u.size != self.n else u
        return self._direct_w(u, heading0, speed0), None

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
        heading0, speed0, p0 = self._start_state(heading0, speed0, position0)
        self._precheck(belief, heading0, speed0)
        pvec = self._parameters(belief, ping_steps)
        lbw, ubw, lbg, ubg = self._bounds(heading0)
        guesses: list[tuple[np.ndarray, float]]
        duals: dict[str, Any] | None
        if warm_start is not None:
            x0, duals = self._shift_warm(warm_start, belief.t, heading0, speed0)
            sgn = float(warm_start.warm.get("sign", 1.0)) if warm_start.warm else 1.0
            guesses = [(x0, sgn)]
        elif starts is not None and self.transcription == "direct":
            progs = [np.clip(np.asarray(u, float).reshape(-1), -1, 1) for u in starts]
            if not progs or any(u.shape != (self.n,) for u in progs):
                raise PlanningError(f"starts: expected turn-rate programs of shape "
                                    f"({self.n},), received {[u.shape for u in progs]}")
            duals, guesses = None, [(self._direct_w(u, heading0, speed0), 1.0) for u in progs]
        else:
            duals, guesses = None, self._guesses(heading0, speed0)
        P0 = np.concatenate([pvec, [heading0, speed0, 1.0, guesses[0][1]]])
        f0 = self._f_eval(self._with_epigraph(guesses[0][0], P0), P0)[0].item()
        scale = max(abs(f0), 1e-3) if np.isfinite(f0) else 1.0
        best: tuple[float, Any, str, float] | None = None
        iters, statuses = 0, []
        for x0, sgn in guesses:
            P = np.concatenate([pvec, [heading0, speed0, scale, sgn]])
            x0 = self._with_epigraph(x0, P)
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
        x = np.asarray(sol["x"]).reshape(-1)
        warm = {"x": x, "lam_x": np.asarray(sol["lam_x"]).reshape(-1),
                "lam_g": np.asarray(sol["lam_g"]).reshape(-1), "sign": sgn,
                "shape": (self.transcription, self.n, self.n_arcs), "scale": scale}
        return self._make_plan(x, np.concatenate([pvec, [heading0, speed0, scale, sgn]]),
                               belief.t, p0, speed0, status, success, iters, seconds, warm,
                               ", ".join(statuses))

    def _with_epigraph(self, x: np.ndarray, P: np.ndarray) -> np.ndarray:
        """A start ``x`` of the transcription's variables with the epigraph variable appended
        at its tightest value (max of the terms), when the objective has one."""
        if x.size != self._n_w or not hasattr(self, "_epi_guess"):
            return x
        return np.append(x, float(self._epi_guess(x, P)))

    def _start_state(self, heading0: float | None, speed0: float | None,
                     position0: np.ndarray | None) -> tuple[float, float, np.ndarray]:
        """(heading [rad], speed [m/s], position [m]) with the scenario's defaults."""
        obs = self.scenario.observer
        if heading0 is None:
            heading0 = float(course_speed(initial_velocity(obs))[0])
        speed0 = self.speed0 if speed0 is None else float(speed0)
        p0 = np.asarray(obs.position if position0 is None else position0, float)
        return float(heading0), speed0, p0

    def _parameters(self, belief: Belief, ping_steps: Sequence[int]) -> np.ndarray:
        """The objective's parameter vector (:class:`ParamLayout`) for a belief and pings."""
        ping = np.zeros(self.K + 1)
        st = check_ping_steps(ping_steps, self.K, source=self.scenario.name)  # plan steps
        if st.size:
            if self._ping_scale == 0.0:
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

    def _precheck(self, belief: Belief, heading0: float, speed0: float) -> None:
        if self.keep_out <= 0:
            return
        r0 = belief.mean_range()
        if r0 < self.keep_out:
            raise InfeasibleError(f"keep_out_range {self.keep_out:.0f} m: the target estimate "
                                  f"is already inside it (range {r0:.0f} m)")
        if self.u_max == 0.0 and not self.speed_choice:
            t = self.times
            rel = belief.mean[:2] + t[:, None] * belief.mean[2:]
            if np.min(np.hypot(rel[:, 0], rel[:, 1])) < self.keep_out:
                raise InfeasibleError(
                    f"infeasible: turn_rate_max = 0 (no turn possible) and the straight course "
                    f"comes within {np.min(np.hypot(rel[:, 0], rel[:, 1])):.0f} m of the target "
                    f"estimate, inside keep_out_range {self.keep_out:.0f} m")

    def _make_plan(self, x: np.ndarray, P: np.ndarray, t0: float, p0: np.ndarray,
                   speed0: float, status: str, success: bool, iters: int, seconds: float,
                   warm: dict[str, Any], message: str,
                   evaluated: Sequence[Any] | None = None) -> HeadingPlan:
        outs = self._f_eval(x, P) if evaluated is None else evaluated
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
        if self.transcription == "bang-bang":
            dur = x * self.K * self.dt
            om = float(P[-1]) * self._arc_pattern()
            keep = dur > 1e-6 * self.K * self.dt
            vals, ends = om[keep], np.cumsum(dur)[keep]
            sw = [t0 + ends[i] for i in range(len(vals) - 1) if vals[i] != vals[i + 1]]
            switch = np.asarray(sw)
        else:
            du = np.abs(np.diff(tr))
            switch = t0 + self.Tc * (1 + np.flatnonzero(du > 0.01 * max(self.u_max, 1e-12)))
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
