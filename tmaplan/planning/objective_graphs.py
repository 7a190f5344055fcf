"""casadi inputs of the planning objectives and the cost graphs they share.

Role: the layer below :mod:`tmaplan.planning.objectives`. It lays out the belief and the
per-step sensor information as one casadi parameter vector (:class:`ParamLayout`,
:func:`ping_sigma`), defines the symbolic plan inputs
(:class:`PlanContext`) and builds, once per context, the graphs the objectives are sums of:

* :func:`closed_form_graph`: the closed-form LPC PCRB of brehard2005 (corrected) over the
  horizon, :func:`tmaplan.bounds.closed_form_engine.lpc_pcrb_graph` (the one engine) with the
  prior moments and J₀ as casadi parameters, and its range bound ``r̂_k·sqrt([J_k⁻¹]_{ln r})``
  (brehard2005 eq. 58);
* :func:`position_bound_graph`: ``sqrt(tr P_pos)`` of the Cartesian position PCRB;
* :func:`logdet_graph`: ``log det(F + I₀)`` with F the exact bearing FIM of the relative
  initial state (lecadre1997 eq. 64–65, :func:`tmaplan.bounds.fimdet.fim_bearings_generic`),
  in scaled units (km, 100 s);
* :func:`relative_range_crlb_graph`: σ_r/r of the batch bearings CRLB with prior information
  (lecadre1997's batch setting, delta method).

The names are re-exported by :mod:`tmaplan.planning.objectives`; import them from there.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.bounds.closed_form_engine import (
    lpc_pcrb_graph,
    lpc_position_bound_graph,
    pack_symmetric,
)
from tmaplan.bounds.fimdet import fim_bearings_generic, inverse_quadratic_generic, logdet_generic
from tmaplan.errors import ArgumentError, is_integer
from tmaplan.planning.belief import Belief
from tmaplan.scenario import RangeSensor

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = [
    "ParamLayout",
    "PlanContext",
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

    ``p = [x0 (14), j0 (10), icart (10), samples (4·n_samples), bearing (K+1), ping (K+1),
    weight (K+1)]``: prior raw moments ``[m, pack(S)]`` of X₀, packed LPC prior information J₀,
    packed Cartesian prior information, logdet samples (row-major), bearing information Σ1/σ²
    per step [rad⁻²], ping weights u_k ∈ [0, 1] per step and step weights w_k ∈ [0, 1]: how
    much step k counts in the objectives that sum or average over the steps (1 everywhere
    by default; 0 after the end of the scenario for a plan that must not count time the
    mission does not have, :class:`tmaplan.planning.HeadingPlanner` ``until_end``): the
    weighted means (``mean-*``, ``*time-to-accuracy``) weight step k's value by w_k, and
    ``logdet`` its bearing information (``Σ_k w_k F_k``). The terminal objectives
    (``range-bound``, ``position-bound``, ``relative-range-bound``, ``relative-range-crlb``)
    are the value at the horizon's last step K and do not read the weights.
    """

    n_steps: int
    n_samples: int

    def __post_init__(self) -> None:
        # vector() packs at least one sample (the mean), so 0 samples would not fit the layout
        if not is_integer(self.n_steps, 0):
            raise ArgumentError("n_steps", "an integer >= 0", self.n_steps)
        if not is_integer(self.n_samples, 1):
            raise ArgumentError("n_samples", "an integer >= 1", self.n_samples)

    @property
    def size(self) -> int:
        """Length of p."""
        return 34 + 4 * self.n_samples + 3 * (self.n_steps + 1)

    def mean_offsets(self) -> tuple[int, ...]:
        """Offsets in p of each belief's mean relative state ``E X_0`` (4 entries): one
        belief here (the planner's keep-out reads them)."""
        return (0,)

    def slices(self) -> dict[str, slice]:
        """Name -> slice of p."""
        K1, ns = self.n_steps + 1, 4 * self.n_samples
        o = [0, 14, 24, 34, 34 + ns, 34 + ns + K1, 34 + ns + 2 * K1, 34 + ns + 3 * K1]
        names = ("x0", "j0", "icart", "samples", "bearing", "ping", "weight")
        return {n: slice(o[i], o[i + 1]) for i, n in enumerate(names)}

    def vector(self, belief: Belief, bearing: np.ndarray, ping: np.ndarray | None = None,
               weight: np.ndarray | None = None) -> np.ndarray:
        """Numeric p for a belief, bearing information (K+1,), ping weights (K+1,) (default
        none) and step weights (K+1,) (default ones)."""
        K1 = self.n_steps + 1
        x0 = np.concatenate([belief.mean, pack_symmetric(belief.second_moment)])
        smp = belief.representative_samples(self.n_samples).reshape(-1)
        ping = np.zeros(K1) if ping is None else np.asarray(ping, float)
        weight = np.ones(K1) if weight is None else np.asarray(weight, float)
        bearing = np.asarray(bearing, float)
        if bearing.shape != (K1,) or ping.shape != (K1,) or weight.shape != (K1,):
            raise ArgumentError("bearing/ping/weight", f"shape ({K1},)",
                                (bearing.shape, ping.shape, weight.shape))
        return np.concatenate([x0, pack_symmetric(belief.lpc_information()),
                               pack_symmetric(belief.cartesian_information()), smp, bearing,
                               ping, weight])


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
    compiled : bool
        Evaluate the objectives that have one by their compiled kernel
        (:mod:`tmaplan.planning.compiled_objective`) instead of the casadi graph: the same
        values and first derivatives, no second derivatives.
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
    compiled: bool = False
    cache: dict[str, Any] = dataclasses.field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.compiled, bool):  # (HeadingPlanner's argument of that name)
            raise ArgumentError("compiled", "True or False", self.compiled)

    @property
    def n_steps(self) -> int:
        """K."""
        return self.times.shape[0] - 1

    def param(self, name: str) -> Any:
        """Slice of the parameter vector."""
        return self.p[self.layout.slices()[name]]


def closed_form_graph(ctx: PlanContext) -> dict[str, Any]:
    """The closed-form LPC PCRB over the horizon as casadi expressions (cached in ``ctx``).

    Returns
    -------
    dict
        :func:`tmaplan.bounds.closed_form_engine.lpc_pcrb_graph`'s ``range_bound`` (K+1, 1)
        [m], ``var`` (K+1, 4) diagonal of J_k⁻¹, ``J`` (10, K+1) packed information, ``X``
        (14, K+1) moments ``[m_k, pack(S_k)]``, ``er2`` (K+1, 1).
    """
    if "cf" not in ctx.cache:
        ctx.cache["cf"] = lpc_pcrb_graph(
            ctx.A, ctx.Q, ctx.dt, v_obs=ctx.v_obs, x0=ctx.param("x0"), j0=ctx.param("j0"),
            bearing=ctx.param("bearing"), ping=ctx.param("ping"), ping_scale=ctx.ping_scale)
    return ctx.cache["cf"]


def position_bound_graph(ctx: PlanContext) -> Any:
    """``sqrt(tr P_pos)`` per step (K+1, 1) [m] (cached in ``ctx``)."""
    if "pos" not in ctx.cache:
        ctx.cache["pos"] = lpc_position_bound_graph(closed_form_graph(ctx))
    return ctx.cache["pos"]


def _running_sum(rows: int, cols: int) -> Any:
    """casadi function of a (rows, cols) matrix: its running sums along the columns.

    A ``mapaccum`` over the columns. ``casadi.cumsum`` of the (cols, rows) transpose computes
    the same, but between two transposes. Without them, the default objective on ``default``
    takes 5.6 instead of 6.6 ms and its gradient 18.4 instead of 20.4 ms, with the same values
    bit for bit (docs/findings.md)."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    a, b = ca.MX.sym("a", rows), ca.MX.sym("b", rows)
    acc = ca.Function("running_sum_step", [a, b], [a + b]).mapaccum(cols)
    m = ca.MX.sym("m", rows, cols)
    return ca.Function("running_sum", [m], [acc(ca.DM.zeros(rows), m)])


def _sample_fim_terms(ctx: PlanContext, cumulative: bool) -> dict[str, Any]:
    """Per-sample bearing geometry in scaled units (km, 100 s) and the FIM entries of X₀.

    Each belief sample is a deterministic relative track ``r_k = p₀ + t_k v₀ − d_k`` (d_k the
    own ship's displacement beyond constant velocity). The bearing FIM is
    :func:`tmaplan.bounds.fimdet.fim_bearings_generic` (lecadre1997 eq. 64–65), summed over
    steps (``cumulative``: up to each step), plus ``I₀``, the prior information. The total
    (not ``cumulative``) counts step k's bearing information with its step weight w_k
    (:class:`ParamLayout`): ``Σ_k w_k F_k + I₀``. The cumulative sums are unweighted: the
    objectives over them weight each step's value instead (the value at step k, from the
    steps ≤ k, is the same for weights that are 1 up to some step and 0 after).

    The matrices are laid out samples × steps (n_samples, K+1): the FIM entries (n_samples, K+1)
    when ``cumulative``, else (n_samples, 1).
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    ns = ctx.layout.n_samples
    smp = ca.reshape(ctx.param("samples"), 4, ns).T  # row s = sample s
    K1 = ctx.n_steps + 1
    t = ca.DM(ctx.times.reshape(1, -1) / _T)
    ones_k, ones_s = ca.DM.ones(1, K1), ca.DM.ones(ns, 1)
    v0 = ctx.v_obs[0, :]
    # observer displacement beyond constant-velocity motion: d_k = p_k − p_0 − t_k v̄_0
    d = ((ctx.disp - ca.mtimes(ca.DM(ctx.times.reshape(-1, 1)), v0)) / _L).T  # 2 × (K+1)
    sx, sy = smp[:, 0] / _L, smp[:, 1] / _L
    svx, svy = smp[:, 2] * _T / _L, smp[:, 3] * _T / _L
    rx = ca.mtimes(sx, ones_k) + ca.mtimes(svx, t) - ca.mtimes(ones_s, d[0, :])
    ry = ca.mtimes(sy, ones_k) + ca.mtimes(svy, t) - ca.mtimes(ones_s, d[1, :])
    # floor the range at 100 m: a prior sample the own ship sails through would otherwise
    # give an infinite (NaN) information and stall the solver
    tt = ca.mtimes(ones_s, t)
    info = ctx.param("bearing") if cumulative else ctx.param("bearing") * ctx.param("weight")
    F = fim_bearings_generic(rx, ry, tt, ca.mtimes(ones_s, info.T),
                             total=_running_sum(ns, K1) if cumulative else ca.sum2,
                             min_range=100.0 / _L)
    # prior information in the scaled units: I' = D⁻¹ I D⁻¹, D = diag(1/L, 1/L, T/L, T/L)
    Dinv = np.array([_L, _L, _L / _T, _L / _T])
    ic = ctx.param("icart")
    for n, (i, j) in enumerate(zip(*np.triu_indices(4), strict=True)):  # packing order
        F[i][j] = F[i][j] + ic[n] * float(Dinv[i] * Dinv[j])
        F[j][i] = F[i][j]
    r2 = ca.fmax(rx * rx + ry * ry, (100.0 / _L) ** 2)
    return {"F": F, "rx": rx, "ry": ry, "r2": r2, "tt": tt, "ns": ns}


def logdet_graph(ctx: PlanContext) -> Any:
    """``log det(F + I₀)`` [SI] averaged over the logdet samples (lecadre1997 eq. 64–65).

    ``F = Σ_k w_k F_k``: the bearings of step k count with its step weight w_k
    (:class:`ParamLayout`), so a step of weight 0 (after the scenario's end, ``until_end``)
    adds no information.
    """
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    terms = _sample_fim_terms(ctx, cumulative=False)
    ld = logdet_generic(terms["F"])  # (n_samples, 1)
    # log det F_SI = log det F' − 8 log L + 4 log T
    return ca.sum1(ld) / terms["ns"] - 8.0 * math.log(_L) + 4.0 * math.log(_T)


def relative_range_crlb_graph(ctx: PlanContext) -> Any:
    """Relative range std ``σ_{r_k}/r_k`` from the bearings up to step k, (K+1, n_samples).

    For each belief sample (a deterministic relative track, lecadre1997's batch setting) the
    information on X₀ after k steps is ``F_k + I₀`` (bearing FIM of the steps ≤ k, lecadre1997
    eq. 64–65, plus the prior information); the range at step k is ``r_k = ‖p₀ + t_k v₀ − d_k‖``
    with gradient ``g_k = [u_k, t_k u_k]`` (u_k the line of sight), so
    ``σ²_{r_k} = g_kᵀ (F_k + I₀)⁻¹ g_k`` (delta method, LDLᵀ solve on entries). Unlike the LPC
    PCRB's ln r component, it carries no coordinate pseudo-information (docs/errata.md item 3:
    the 𝒞 term), so it rewards exactly the bearing-rate geometry that localises the contact.
    """
    if "rel_crlb" in ctx.cache:
        return ctx.cache["rel_crlb"]
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    terms = _sample_fim_terms(ctx, cumulative=True)
    rx, ry, r2, tt = terms["rx"], terms["ry"], terms["r2"], terms["tt"]
    r = ca.sqrt(r2)
    ux, uy = rx / r, ry / r
    var = inverse_quadratic_generic(terms["F"], [ux, uy, tt * ux, tt * uy])
    rel = (ca.sqrt(ca.fmax(var, 0.0)) / r).T  # samples × steps -> steps × samples
    ctx.cache["rel_crlb"] = rel
    return rel
