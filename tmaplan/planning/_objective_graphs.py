"""casadi inputs of the planning objectives and the cost graphs they share.

Role: the layer below :mod:`tmaplan.planning.objectives`. It lays out the belief and the
per-step sensor information as one casadi parameter vector (:class:`ParamLayout`,
:func:`bearing_information`, :func:`ping_sigma`), defines the symbolic plan inputs
(:class:`PlanContext`) and builds, once per context, the graphs the objectives are sums of:

* :func:`closed_form_graph`: the closed-form LPC PCRB of Bréhard & Le Cadre (file 000,
  corrected, NOTES_000 §2.9) over the horizon, re-wired from
  :func:`tmaplan.bounds._lpc_terms.step_functions` with the prior moments and J₀ as casadi
  parameters, and its range bound ``r̂_k·sqrt([J_k⁻¹]_{ln r})`` (file 000 eq. 58);
* :func:`position_bound_graph`: ``sqrt(tr P_pos)`` of the Cartesian position PCRB;
* :func:`logdet_graph`: ``log det(F + I₀)`` with F the exact bearing FIM of the relative
  initial state (Le Cadre & Jauffret, file 003 eq. 64–65), in scaled units (km, 100 s);
* :func:`relative_range_crlb_graph`: σ_r/r of the batch bearings CRLB with prior information
  (file 003's batch setting, delta method).

The names are re-exported by :mod:`tmaplan.planning.objectives`; import them from there.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.bounds._lpc_terms import (
    SYM_INDEX,
    basis,
    inverse_diagonal,
    step_functions,
    unpack_sym,
)
from tmaplan.errors import ScenarioError
from tmaplan.scenario import BearingSensor, RangeSensor, TimeGrid, measurement_steps

if TYPE_CHECKING:
    from tmaplan.planning.belief import Belief
    from tmaplan.scenario import Scenario

__all__ = [
    "ParamLayout",
    "PlanContext",
    "bearing_information",
    "closed_form_graph",
    "logdet_graph",
    "ping_sigma",
    "position_bound_graph",
    "relative_range_crlb_graph",
]

_L = 1000.0  # length scale of the logdet FIM [m]
_T = 100.0  # time scale of the logdet FIM [s]


# --------------------------------------------------------------------------------------------
# Parameters (the belief and per-step sensor information as one casadi parameter vector)
# --------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, kw_only=True)
class ParamLayout:
    """Layout of the parameter vector ``p`` of a plan horizon of K steps.

    ``p = [x0 (14), j0 (10), icart (10), samples (4·n_samples), bearing (K+1), ping (K+1)]``:
    prior raw moments ``[m, pack(S)]`` of X₀, packed LPC prior information J₀, packed
    Cartesian prior information, logdet samples (row-major), bearing information Σ1/σ² per
    step [rad⁻²] and ping weights u_k ∈ [0, 1] per step.
    """

    n_steps: int
    n_samples: int

    @property
    def size(self) -> int:
        """Length of p."""
        return 34 + 4 * self.n_samples + 2 * (self.n_steps + 1)

    def slices(self) -> dict[str, slice]:
        """Name -> slice of p."""
        K1, ns = self.n_steps + 1, 4 * self.n_samples
        o = [0, 14, 24, 34, 34 + ns, 34 + ns + K1, 34 + ns + 2 * K1]
        names = ("x0", "j0", "icart", "samples", "bearing", "ping")
        return {n: slice(o[i], o[i + 1]) for i, n in enumerate(names)}

    def vector(self, belief: Belief, bearing: np.ndarray, ping: np.ndarray | None = None,
               ) -> np.ndarray:
        """Numeric p for a belief, bearing information (K+1,) and ping weights (K+1,)."""
        K1 = self.n_steps + 1
        S = belief.second_moment
        x0 = np.concatenate([belief.mean, [S[i, j] for i, j in SYM_INDEX]])
        J0 = belief.lpc_information()
        Ic = belief.cartesian_information()
        smp = belief.representative_samples(self.n_samples).reshape(-1)
        ping = np.zeros(K1) if ping is None else np.asarray(ping, float)
        bearing = np.asarray(bearing, float)
        if bearing.shape != (K1,) or ping.shape != (K1,):
            raise ScenarioError("bearing/ping", f"shape ({K1},)", (bearing.shape, ping.shape))
        return np.concatenate([x0, [J0[i, j] for i, j in SYM_INDEX],
                               [Ic[i, j] for i, j in SYM_INDEX], smp, bearing, ping])


def bearing_information(scenario: Scenario, t_start: float, n_steps: int) -> np.ndarray:
    """Bearing information Σ 1/σ² [rad⁻²] per plan step k = 0..K starting at ``t_start``.

    Uses the bearing sensors' measurement steps on the scenario grid extended past its horizon
    if needed; step 0 is excluded (the belief at ``t_start`` already holds its measurement).
    """
    grid = scenario.time
    k0 = round((t_start - grid.t0) / grid.dt)
    ext = TimeGrid(dt=grid.dt, horizon=grid.dt * max(k0 + n_steps, 1), t0=grid.t0)
    info = np.zeros(n_steps + 1)
    for s in scenario.sensors:
        if isinstance(s, BearingSensor):
            st = measurement_steps(s, ext) - k0
            st = st[(st >= 1) & (st <= n_steps)]
            info[st] += 1.0 / float(s.sigma) ** 2
    return info


def ping_sigma(scenario: Scenario) -> float | None:
    """σ of a scheduled ping [m]: ``planning.ping_sigma`` or the first range sensor's σ."""
    if scenario.planning is not None and scenario.planning.ping_sigma is not None:
        return float(scenario.planning.ping_sigma)
    for s in scenario.sensors:
        if isinstance(s, RangeSensor):
            return float(s.sigma)
    return None


# --------------------------------------------------------------------------------------------
# Context and the shared closed-form graph
# --------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, kw_only=True)
class PlanContext:
    """casadi inputs of an objective over a plan horizon of K steps of ``dt``.

    Attributes
    ----------
    dt : float
        [s].
    times : ndarray, shape (K + 1,)
        Times since the plan start [s].
    A, Q : ndarray, shape (4, 4)
        NCV transition and process noise of the target.
    v_obs : casadi.MX, shape (K + 1, 2)
        Observer mean velocity over (t_{k−1}, t_k] (row 0: the initial velocity) [m/s].
    disp : casadi.MX, shape (K + 1, 2)
        Observer position minus its start position [m].
    turn_rate : casadi.MX, shape (K, 1)
        Turn rate per step [rad/s].
    p : casadi.MX
        Parameter vector (:class:`ParamLayout`).
    layout : ParamLayout
    ping_scale : float
        1/σ_r² of a ping [m⁻²] (0 without a range sensor).
    turn_rate_max : float
        [rad/s] (for penalty normalisation).
    """

    dt: float
    times: np.ndarray
    A: np.ndarray
    Q: np.ndarray
    v_obs: Any
    disp: Any
    turn_rate: Any
    p: Any
    layout: ParamLayout
    ping_scale: float
    turn_rate_max: float
    cache: dict[str, Any] = dataclasses.field(default_factory=dict, compare=False)

    @property
    def n_steps(self) -> int:
        """K."""
        return self.times.shape[0] - 1

    def param(self, name: str) -> Any:
        """Slice of the parameter vector."""
        return self.p[self.layout.slices()[name]]


_ACC: dict[tuple[int, int], Any] = {}


def _acc(fn: Any, K: int) -> Any:
    key = (id(fn), K)
    if key not in _ACC:
        _ACC[key] = fn.mapaccum(f"{fn.name()}_plan_acc", K)
    return _ACC[key]


_POSVAR: dict[str, Any] = {}


def _posvar_fn() -> Any:
    """SX Function ``(j[10], x[14]) -> tr E[J_X J⁻¹ J_Xᵀ]_pos`` [m²]."""
    if "f" not in _POSVAR:
        import casadi as ca

        j = ca.SX.sym("j", 10)
        x = ca.SX.sym("x", 14)
        J = ca.SX(4, 4)
        for n, (a, b) in enumerate(SYM_INDEX):
            J[a, b] = j[n]
            J[b, a] = j[n]
        P = ca.inv(J)
        S = unpack_sym([x[4 + n] for n in range(10)])
        E = basis()[:, :2, :]
        T = np.einsum("kai,laj->klij", E, E)  # tr(E_k P E_lᵀ) = Σ_ij T[k,l,i,j] P[i,j]
        tot = 0
        for k in range(4):
            for m in range(4):
                tkl = 0
                for i in range(4):
                    for jj in range(4):
                        if T[k, m, i, jj] != 0.0:
                            tkl = tkl + float(T[k, m, i, jj]) * P[i, jj]
                tot = tot + S[k][m] * tkl
        _POSVAR["f"] = ca.Function("plan_position_var", [j, x], [tot])
    return _POSVAR["f"]


def closed_form_graph(ctx: PlanContext) -> dict[str, Any]:
    """The closed-form LPC PCRB over the horizon as casadi expressions (cached in ``ctx``).

    Returns
    -------
    dict
        ``range_bound`` (K+1, 1) [m], ``var`` (K+1, 4) diagonal of J_k⁻¹, ``J`` (10, K+1)
        packed information, ``X`` (14, K+1) moments ``[m_k, pack(S_k)]``, ``er2`` (K+1, 1).
    """
    if "cf" in ctx.cache:
        return ctx.cache["cf"]
    import casadi as ca

    K = ctx.n_steps
    moment_fn, riccati_fn = step_functions(ctx.A, ctx.Q)
    x0, j0p = ctx.param("x0"), ctx.param("j0")
    b, u = ctx.param("bearing"), ctx.param("ping")
    v = ctx.v_obs
    dv = v[1:, :] - v[:-1, :]
    c = -ca.horzcat(ctx.dt * dv, dv).T  # c_t = −H Δv_t (DESIGN §1), 4 × K
    xs, aux = _acc(moment_fn, K)(x0, c)
    er2_0 = x0[4] + x0[8]  # S[0,0] + S[1,1] in the packed order
    er2 = ca.vertcat(er2_0, aux[36, :].T)
    j0 = ca.vertcat(j0p[:4], j0p[4] + u[0] * ctx.ping_scale * er2_0, j0p[5:])
    jn, varn, _ = _acc(riccati_fn, K)(j0, aux, b[1:].T, (u[1:] * ctx.ping_scale).T)
    var0, _ = inverse_diagonal(unpack_sym([j0[n] for n in range(10)]))
    var = ca.vertcat(ca.horzcat(*var0), varn.T)
    rb = ca.sqrt(er2 * var[:, 1])
    out = {"range_bound": rb, "var": var, "J": ca.horzcat(j0, jn), "X": ca.horzcat(x0, xs),
           "er2": er2}
    ctx.cache["cf"] = out
    return out


def position_bound_graph(ctx: PlanContext) -> Any:
    """``sqrt(tr P_pos)`` per step (K+1, 1) [m] (cached in ``ctx``)."""
    if "pos" not in ctx.cache:
        import casadi as ca

        cf = closed_form_graph(ctx)
        pv = _posvar_fn().map(ctx.n_steps + 1)(cf["J"], cf["X"])
        ctx.cache["pos"] = ca.sqrt(ca.fmax(pv.T, 0.0))
    return ctx.cache["pos"]


def _sample_fim_terms(ctx: PlanContext, cumulative: bool) -> dict[str, Any]:
    """Per-sample bearing geometry in scaled units (km, 100 s) and the FIM entries of X₀.

    Each belief sample is a deterministic relative track ``r_k = p₀ + t_k v₀ − d_k`` (d_k the
    own ship's displacement beyond constant velocity). The bearing FIM rows are
    ``g = [r_y, −r_x, t r_y, −t r_x]/r²`` (file 003 eq. 64–65); the entries of ``F + I₀`` are
    summed over steps (``cumulative``: up to each step), with ``I₀`` the prior information.
    """
    import casadi as ca

    ns = ctx.layout.n_samples
    smp = ca.reshape(ctx.param("samples"), 4, ns)  # column s = sample s
    K1 = ctx.n_steps + 1
    t = ca.DM(ctx.times.reshape(-1, 1) / _T)
    ones_k, ones_s = ca.DM.ones(K1, 1), ca.DM.ones(1, ns)
    v0 = ctx.v_obs[0, :]
    # observer displacement beyond constant-velocity motion: d_k = p_k − p_0 − t_k v̄_0
    d = (ctx.disp - ca.mtimes(ca.DM(ctx.times.reshape(-1, 1)), v0)) / _L
    sx, sy = smp[0, :] / _L, smp[1, :] / _L
    svx, svy = smp[2, :] * _T / _L, smp[3, :] * _T / _L
    rx = ca.mtimes(ones_k, sx) + ca.mtimes(t, svx) - ca.mtimes(d[:, 0], ones_s)
    ry = ca.mtimes(ones_k, sy) + ca.mtimes(t, svy) - ca.mtimes(d[:, 1], ones_s)
    # floor the squared range at (100 m)²: a prior sample the own ship sails through would
    # otherwise give an infinite (NaN) information and stall the solver
    r2 = ca.fmax(rx * rx + ry * ry, (100.0 / _L) ** 2)
    w = ca.mtimes(ctx.param("bearing"), ones_s) / (r2 * r2)
    tt = ca.mtimes(t, ones_s)
    g = (ry, -rx, tt * ry, -tt * rx)
    # prior information in the scaled units: I' = D⁻¹ I D⁻¹, D = diag(1/L, 1/L, T/L, T/L)
    Dinv = np.array([_L, _L, _L / _T, _L / _T])
    ic = unpack_sym([ctx.param("icart")[n] for n in range(10)])
    acc = ca.cumsum if cumulative else ca.sum1
    F = [[acc(g[i] * g[j] * w) + ic[i][j] * float(Dinv[i] * Dinv[j]) for j in range(4)]
         for i in range(4)]
    return {"F": F, "rx": rx, "ry": ry, "r2": r2, "tt": tt, "ns": ns}


def logdet_graph(ctx: PlanContext) -> Any:
    """``log det(F + I₀)`` [SI] averaged over the logdet samples (file 003 eq. 64–65)."""
    import casadi as ca

    terms = _sample_fim_terms(ctx, cumulative=False)
    _, piv = inverse_diagonal(terms["F"])
    ld = ca.log(piv[0]) + ca.log(piv[1]) + ca.log(piv[2]) + ca.log(piv[3])
    # log det F_SI = log det F' − 8 log L + 4 log T
    return ca.sum2(ld) / terms["ns"] - 8.0 * math.log(_L) + 4.0 * math.log(_T)


def relative_range_crlb_graph(ctx: PlanContext) -> Any:
    """Relative range std ``σ_{r_k}/r_k`` from the bearings up to step k, (K+1, n_samples).

    For each belief sample (a deterministic relative track, file 003's batch setting) the
    information on X₀ after k steps is ``F_k + I₀`` (bearing FIM of the steps ≤ k, file 003
    eq. 64–65, plus the prior information); the range at step k is ``r_k = ‖p₀ + t_k v₀ − d_k‖``
    with gradient ``g_k = [u_k, t_k u_k]`` (u_k the line of sight), so
    ``σ²_{r_k} = g_kᵀ (F_k + I₀)⁻¹ g_k`` (delta method, LDLᵀ solve on entries). Unlike the LPC
    PCRB's ln r component, it carries no coordinate pseudo-information (NOTES_000 §0 item 3:
    the 𝒞 term), so it rewards exactly the bearing-rate geometry that localises the contact.
    """
    if "rel_crlb" in ctx.cache:
        return ctx.cache["rel_crlb"]
    import casadi as ca

    from tmaplan.bounds._lpc_terms import _ldl

    terms = _sample_fim_terms(ctx, cumulative=True)
    F, rx, ry, r2, tt = terms["F"], terms["rx"], terms["ry"], terms["r2"], terms["tt"]
    L, piv = _ldl(F)
    r = ca.sqrt(r2)
    ux, uy = rx / r, ry / r
    grad = [ux, uy, tt * ux, tt * uy]
    y: list[Any] = []
    for i in range(4):  # forward substitution L y = g
        acc = grad[i]
        for k in range(i):
            acc = acc - L[i][k] * y[k]
        y.append(acc)
    var = y[0] * y[0] / piv[0] + y[1] * y[1] / piv[1] + y[2] * y[2] / piv[2] \
        + y[3] * y[3] / piv[3]
    rel = ca.sqrt(ca.fmax(var, 0.0)) / r
    ctx.cache["rel_crlb"] = rel
    return rel
