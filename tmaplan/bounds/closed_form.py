"""Closed-form PCRB in log-polar coordinates (Bréhard & Le Cadre, file 000), with range pings.

One implementation, three uses (DESIGN §2): the recursion of :mod:`tmaplan.bounds._lpc_terms`
(written once on explicit entries) is

* evaluated numerically as ``mapaccum``-ed casadi ``SX`` functions (:func:`closed_form_pcrb`,
  :meth:`ClosedFormModel.evaluate`),
* evaluated with numpy over a leading axis of candidate ping schedules
  (:meth:`ClosedFormModel.evaluate_schedules`),
* built as a casadi expression of the observer velocities and relaxed pings u_k ∈ [0, 1]
  (:meth:`ClosedFormModel.casadi_function`, :func:`closed_form_casadi`) for planners.

Speed (issue 4 targets): numerically, the casadi step functions are compiled to C once per
(A, Q) (casadi code generation + gcc, cached under ``~/.cache/tmaplan/jit``) and called through
zero-copy buffers; the batched schedule path runs a C kernel emitted from the ``SX`` graph of
the same generic step, vectorised over schedules. Without a C compiler (or with
``TMAPLAN_JIT=0``) the casadi VM and the numpy reference loop are used; every path is selectable
with ``backend=`` and the tests check that they agree to 1e-10.

Corrections to file 000 that are implemented (NOTES_000): information (not its inverse) in the
Tichavský bracket (Prop. 5, L327); the true Jacobian ∂X/∂Y instead of the printed F (eq. 31);
the constant 𝒞 = diag(0, 8, 2α3²/detΣ, 2α3²/detΣ) instead of eq. 43/101; exact moment
propagation instead of the Γ recursions (whose printed Γ₀¹² term order, Λ³³ third row and
Γ₀³³ are wrong, and whose E r₀² factorisation is only exact for independent range and rates);
``E r²_{t+1}`` for the ping information of eq. 51 from the exact second moments.

J₀ is the inverse of the LPC covariance of ``scenario.prior.samples`` prior samples (file 000
eq. 56, read as an outer product; default 100 000 samples for the brehard2005 problems, drawn
with ``prior.seed``); the range truncation is the prior's ``range_min`` (100 m there).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import special

from tmaplan.bounds._jit import compiled_step_functions, schedule_kernel
from tmaplan.bounds._lpc_terms import (
    SYM_INDEX,
    aux_to_dterms,
    basis,
    inverse_diagonal,
    pack_sym,
    step_functions,
    tichavsky_step,
)
from tmaplan.bounds._pcrb_setup import PCRBInputs, prepare
from tmaplan.bounds.pcrb import PCRBResult, SideAssumptionWarning
from tmaplan.errors import ObservabilityError, ScenarioError

if TYPE_CHECKING:
    from tmaplan.models.observer import ObserverTrack
    from tmaplan.scenario import Scenario

__all__ = [
    "ClosedFormModel",
    "closed_form_casadi",
    "closed_form_model",
    "closed_form_pcrb",
    "side_assumption_density",
    "side_density_gaussian",
]

#: Default tolerance on κ = (wrap period)·p_β(wrap) for the side assumption (NOTES_000 §3.2).
SIDE_TOL = 1e-3


def side_density_gaussian(theta: float, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Density of the bearing ``atan2(r_x, r_y)`` at ``theta`` for Gaussian positions.

    ``p(θ) = ∫₀^∞ ρ N(ρ u_θ; m, C) dρ``, u_θ = (sin θ, cos θ), in closed form:
    ``[e^{−c/2}/a + (b/a)·sqrt(2π/a)·e^{−(c − b²/a)/2}·Φ(b/√a)] / (2π sqrt(det C))`` with
    ``a = uᵀC⁻¹u, b = uᵀC⁻¹m, c = mᵀC⁻¹m`` (NOTES_000 §3.2 (b)).

    Parameters
    ----------
    theta : float
        Bearing [rad].
    mean : ndarray, shape (..., 2)
        Mean relative position [m].
    cov : ndarray, shape (..., 2, 2)
        Its covariance [m²].

    Returns
    -------
    ndarray, shape (...)
        Density [1/rad].
    """
    u = np.array([np.sin(theta), np.cos(theta)])
    Ci = np.linalg.inv(cov)
    a = np.einsum("i,...ij,j->...", u, Ci, u)
    b = np.einsum("i,...ij,...j->...", u, Ci, mean)
    c = np.einsum("...i,...ij,...j->...", mean, Ci, mean)
    det = np.linalg.det(cov)
    term = (np.exp(-0.5 * c) / a + (b / a) * np.sqrt(2 * np.pi / a)
            * np.exp(-0.5 * (c - b**2 / a)) * special.ndtr(b / np.sqrt(a)))
    return term / (2 * np.pi * np.sqrt(det))


def _pack(M: np.ndarray) -> np.ndarray:
    return np.array([M[..., i, j] for i, j in SYM_INDEX])


def _unpack_np(v: np.ndarray) -> np.ndarray:
    """(10, ...) packed -> (..., 4, 4)."""
    out = np.empty((*v.shape[1:], 4, 4))
    for n, (i, j) in enumerate(SYM_INDEX):
        out[..., i, j] = out[..., j, i] = v[n]
    return out


@dataclasses.dataclass(frozen=True, kw_only=True)
class ClosedFormModel:
    """The closed-form LPC PCRB of one scenario and observer, ready for fast evaluation.

    The moments and D-terms depend only on the prior and the observer (NOTES_000 §4.2 (i));
    the ping schedule enters only through ``u_k·E r_k²/σ_r²`` on ln r.

    Attributes
    ----------
    inputs : PCRBInputs
    J0 : ndarray, shape (4, 4)
        Prior information (file 000 eq. 56) plus any step-0 bearing information.
    x0 : ndarray, shape (14,)
        ``[m₀, pack_sym(S₀)]`` (prior moments of X₀).
    moments : ndarray, shape (14, K + 1)
        ``[m_k, pack_sym(S_k)]`` for k = 0..K.
    aux : ndarray, shape (37, K)
        Packed D11, D12 (row-major), D22 at t = 0..K−1 and ``E r²_{t+1}``.
    er2 : ndarray, shape (K + 1,)
        ``E r_k²`` [m²].
    ping_sigma : float or None
        σ_r of the pings [m] (u_k = 1 means one ping of this σ).
    """

    inputs: PCRBInputs
    J0: np.ndarray
    x0: np.ndarray
    moments: np.ndarray
    aux: np.ndarray
    er2: np.ndarray
    ping_sigma: float | None

    @property
    def n_steps(self) -> int:
        """K."""
        return self.inputs.n_steps

    def _ping_scale(self) -> float:
        if self.ping_sigma is None:
            raise ScenarioError("sensors", "a range sensor (kind = 'range') to ping with",
                                "no range sensor")
        return 1.0 / self.ping_sigma**2

    def default_pings(self) -> np.ndarray:
        """Ping weights u (K + 1,) of the resolved ping steps (σ of each sensor)."""
        if self.ping_sigma is None:
            return np.zeros(self.n_steps + 1)
        return self.inputs.ping_weight * self.ping_sigma**2

    # ---------------------------------------------------------------- numeric (casadi VM)
    def evaluate(self, u: np.ndarray | None = None, *, backend: str = "auto"
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bound for one ping schedule.

        Parameters
        ----------
        u : ndarray, shape (K + 1,), optional
            Ping weights in [0, 1] (1 = a ping of σ_r at that step); default the resolved
            ping steps.
        backend : {"auto", "compiled", "casadi"}
            "compiled": the step function compiled to C (an error if there is no compiler);
            "casadi": the casadi VM; "auto": compiled when available.

        Returns
        -------
        var : ndarray, shape (K + 1, 4)
            Diagonal of J_k⁻¹ (β, ln r, β̇, ṙ/r variances).
        information : ndarray, shape (K + 1, 4, 4)
        pivots : ndarray, shape (K, 4)
            LDLᵀ pivots of ``J_t + D11`` (> 0 when the recursion is well defined).
        """
        K = self.n_steps
        u = self.default_pings() if u is None else np.asarray(u, float)
        scale = self._ping_scale() if np.any(u) else 0.0
        _, riccati_fn = _numeric_step_functions(self.inputs.A, self.inputs.Q, backend)
        J0 = self.J0.copy()
        J0[1, 1] += u[0] * scale * self.er2[0]
        jn, varn, piv = _call(_accumulated(riccati_fn, K), [
            _pack(J0), self.aux, self.inputs.bearing_info[1:][None, :],
            (u[1:] * scale)[None, :]])
        var0, d0 = inverse_diagonal(J0.tolist())
        if min(d0) <= 0 or np.any(piv <= 0):
            raise ObservabilityError("closed-form PCRB: J_0 or J_t + D11 is not positive "
                                     "definite")
        var = np.vstack([np.asarray(var0)[None, :], varn.T])
        info = np.concatenate([J0[None], _unpack_np(jn)], axis=0)
        return var, info, piv.T

    # ------------------------------------------------------------------- numpy batched
    def evaluate_schedules(self, u: np.ndarray, *, reduce: str | None = None,
                           backend: str = "auto") -> np.ndarray:
        """Range bound of eq. 58 for many ping schedules at once (batched).

        Runs :func:`tmaplan.bounds._lpc_terms.tichavsky_step` on entries of shape (S,) —
        with numpy, or as the C kernel emitted from its ``SX`` graph
        (:func:`tmaplan.bounds._jit.schedule_kernel`), SIMD-vectorised over schedules.
        The moments and D-terms are the model's (per observer track, schedule-independent).

        Parameters
        ----------
        u : ndarray, shape (S, K + 1)
            Ping weights in [0, 1] per schedule and step.
        reduce : {None, "mean", "terminal"}
            None: the per-step bound (S, K + 1); "mean": its mean over the K + 1 steps
            (the ``mean-range-bound`` objective, DESIGN §4); "terminal": the last step.
        backend : {"auto", "compiled", "numpy"}
            "compiled": the C kernel (an error if there is no compiler); "numpy": the
            reference loop over steps; "auto": compiled when available.

        Returns
        -------
        ndarray, shape (S, K + 1) or (S,)
            ``sqrt(E r_k²)·sqrt([J_k⁻¹]_{ln r})`` [m].
        """
        u = np.atleast_2d(np.asarray(u, float))
        K = self.n_steps
        if u.shape[1] != K + 1:
            raise ScenarioError("u", f"shape (S, {K + 1})", u.shape)
        if reduce not in (None, "mean", "terminal"):
            raise ScenarioError("reduce", "None, 'mean' or 'terminal'", reduce)
        scale = self._ping_scale() if np.any(u) else 0.0
        J = [[float(x) + 0.0 * u[:, 0] for x in row] for row in self.J0.tolist()]
        J[1][1] = J[1][1] + u[:, 0] * scale * self.er2[0]
        kernel = _schedule_backend(backend)
        if kernel is not None:
            return self._schedules_compiled(kernel, u, J, scale, reduce)
        rb = np.empty((u.shape[0], K + 1)) if reduce != "mean" else None
        acc = np.zeros(u.shape[0])
        aux = self.aux.T.tolist()
        b = self.inputs.bearing_info.tolist()
        pw = u * (scale * self.er2)[None, :]
        for k in range(K + 1):
            if k > 0:
                D11, D12, D22 = aux_to_dterms(aux[k - 1])
                J, _ = tichavsky_step(J, D11, D12, D22, b[k], pw[:, k])
            var, _ = _inverse_lnr(J)
            val = np.sqrt(self.er2[k] * var)
            if rb is not None:
                rb[:, k] = val
            else:
                acc += val
        if reduce == "mean":
            return acc / (K + 1)
        if reduce == "terminal":
            return rb[:, -1]  # type: ignore[index]
        return rb  # type: ignore[return-value]

    def _schedules_compiled(self, kernel: Any, u: np.ndarray, J: list[list[Any]],
                            scale: float, reduce: str | None) -> np.ndarray:
        """:meth:`evaluate_schedules` through the C kernel (step 0 with the generic code)."""
        K, S = self.n_steps, u.shape[0]
        u = np.ascontiguousarray(u)
        var0, _ = _inverse_lnr(J)
        val0 = np.sqrt(self.er2[0] * var0)
        acc = np.array(np.broadcast_to(0.0 + val0, (S,)))  # the numpy path's 0 + v₀
        last = acc.copy()
        out = None if reduce is not None else np.empty((S, K + 1))
        if out is not None:
            out[:, 0] = val0
        j0 = np.empty((10, S))  # packed J₀ per schedule, structure of arrays
        for n, (i, k) in enumerate(SYM_INDEX):
            j0[n] = J[i][k]
        aux = self._aux_rows()
        b = np.ascontiguousarray(self.inputs.bearing_info[1:], float)
        pw = np.ascontiguousarray((scale * self.er2)[1:])
        er2 = np.ascontiguousarray(self.er2[1:], float)
        kernel(K, S, j0.ctypes.data, aux.ctypes.data, b.ctypes.data, pw.ctypes.data,
               er2.ctypes.data, u.ctypes.data, K + 1, acc.ctypes.data, last.ctypes.data,
               None if out is None else out.ctypes.data)
        if reduce == "mean":
            return acc / (K + 1)
        if reduce == "terminal":
            return last if K > 0 else acc
        return out  # type: ignore[return-value]

    def _aux_rows(self) -> np.ndarray:
        """``aux.T`` as a C-contiguous (K, 37) array (cached on the frozen instance)."""
        cached = self.__dict__.get("_aux_rows_cache")
        if cached is None:
            cached = np.ascontiguousarray(self.aux.T, dtype=float)
            object.__setattr__(self, "_aux_rows_cache", cached)
        return cached

    # ---------------------------------------------------------------------- symbolic
    def casadi_function(self) -> Any:
        """casadi Function ``(v_obs (K+1)×2, u (K+1)×1) -> (var (K+1)×4, range_bound (K+1)×1)``.

        ``v_obs`` are the observer's mean velocities per step (``ObserverTrack.mean_velocity``);
        only their increments Δv_k enter (``c_k = −H Δv_k``), the prior moments of X₀ are those
        of the scenario's initial observer state. ``u`` are relaxed ping weights in [0, 1].
        ``var`` is the diagonal of J_k⁻¹; ``range_bound`` is eq. 58's
        ``sqrt(E r_k²·[J_k⁻¹]_{ln r})`` [m]. Exact derivatives follow from casadi AD.
        """
        import casadi as ca

        K = self.n_steps
        inp = self.inputs
        moment_fn, riccati_fn = step_functions(inp.A, inp.Q)
        v = ca.MX.sym("v_obs", K + 1, 2)
        u = ca.MX.sym("u", K + 1, 1)
        dv = v[1:, :] - v[:-1, :]
        c = -ca.horzcat(inp.dt * dv, dv).T  # 4 × K
        xs, aux = _accumulated(moment_fn, K)(ca.DM(self.x0), c)
        er2 = ca.vertcat(float(self.er2[0]), aux[36, :].T)
        scale = 1.0 / self.ping_sigma**2 if self.ping_sigma is not None else 0.0
        J0 = [[ca.MX(float(x)) for x in row] for row in self.J0.tolist()]
        J0[1][1] = J0[1][1] + u[0] * scale * float(self.er2[0])
        j0 = ca.vertcat(*pack_sym(J0))
        _, varn, _ = _accumulated(riccati_fn, K)(
            j0, aux, ca.DM(inp.bearing_info[1:][None, :]), (u[1:] * scale).T)
        var0, _ = inverse_diagonal(J0)
        var = ca.vertcat(ca.horzcat(*var0), varn.T)
        rb = ca.sqrt(er2 * var[:, 1])
        del xs
        return ca.Function("closed_form_pcrb_lpc", [v, u], [var, rb], ["v_obs", "u"],
                           ["var", "range_bound"])


_ACC_CACHE: dict[tuple[int, int], Any] = {}


def _numeric_step_functions(A: np.ndarray, Q: np.ndarray, backend: str) -> tuple[Any, Any]:
    """Step functions for numeric evaluation: compiled C when available, else the casadi VM."""
    if backend not in ("auto", "compiled", "casadi"):
        raise ScenarioError("backend", "'auto', 'compiled' or 'casadi'", backend)
    if backend != "casadi":
        fns = compiled_step_functions(A, Q)
        if fns is not None:
            return fns
        if backend == "compiled":
            raise RuntimeError("backend='compiled': no working C compiler (set CC, or "
                               "TMAPLAN_JIT is 0)")
    return step_functions(A, Q)


def _schedule_backend(backend: str) -> Any:
    if backend not in ("auto", "compiled", "numpy"):
        raise ScenarioError("backend", "'auto', 'compiled' or 'numpy'", backend)
    if backend == "numpy":
        return None
    kernel = schedule_kernel()
    if kernel is None and backend == "compiled":
        raise RuntimeError("backend='compiled': no working C compiler (set CC, or TMAPLAN_JIT "
                           "is 0)")
    return kernel


def _call(fn: Any, args: list[np.ndarray]) -> list[np.ndarray]:
    """Evaluate a casadi Function on numpy arrays through zero-copy buffers.

    Converting numpy arrays to ``casadi.DM`` and back costs more than the whole compiled
    recursion (≈ 2 ms for a 37 × 1000 aux array), so inputs and outputs are bound as raw
    column-major memory (``Function.buffer``). Dense inputs/outputs only.
    """
    buf, run = fn.buffer()
    keep = []
    for i, a in enumerate(args):
        a = np.asarray(a, dtype=float)
        a = np.ascontiguousarray(a.T if a.ndim == 2 else a)  # column-major bytes
        keep.append(a)
        buf.set_arg(i, memoryview(a))
    outs = []
    for i in range(fn.n_out()):
        rows, cols = fn.size_out(i)
        o = np.empty((cols, rows))
        buf.set_res(i, memoryview(o))
        outs.append(o)
    run()
    if buf.ret() != 0:
        raise RuntimeError(f"casadi function {fn.name()} failed (status {buf.ret()})")
    return [o.T for o in outs]


def _accumulated(fn: Any, K: int) -> Any:
    key = (id(fn), K)
    if key not in _ACC_CACHE:
        _ACC_CACHE[key] = fn.mapaccum(f"{fn.name()}_acc", K)
    return _ACC_CACHE[key]


def _inverse_lnr(J: list[list[Any]]) -> tuple[Any, Any]:
    """``[J⁻¹]_{ln r}`` (index 1) on entries, via the generic LDLᵀ inverse diagonal."""
    diag, d = inverse_diagonal(J)
    return diag[1], d


def closed_form_model(scenario: Scenario, *, ping_steps: Sequence[int] | None = None,
                      observer: ObserverTrack | None = None, prior_samples: int | None = None,
                      rng: np.random.Generator | None = None,
                      backend: str = "auto") -> ClosedFormModel:
    """Prepare the closed-form LPC PCRB of a scenario (moments, D-terms, J₀).

    Parameters are those of :func:`closed_form_pcrb`; ``backend`` ("auto", "compiled",
    "casadi") selects how the moment recursion is evaluated (see :meth:`ClosedFormModel.evaluate`).

    Raises
    ------
    ScenarioError
        Frequency sensors (no closed form; use the Monte Carlo PCRB), ``q = 0``, a prior with
        mass at zero range, no prior.
    ObservabilityError
        A non-positive-definite J₀.
    """
    if any(s.kind == "frequency" for s in scenario.sensors):
        raise ScenarioError("sensors", "bearing and range sensors only (frequency lines have "
                            "no LPC closed form; use method monte-carlo)",
                            [s.kind for s in scenario.sensors], source=scenario.name)
    if float(scenario.target.q) <= 0.0:
        raise ScenarioError("target.q", "> 0 (the LPC transition density needs process noise)",
                            scenario.target.q, source=scenario.name)
    inp = prepare(scenario, ping_steps=ping_steps, observer=observer,
                  prior_samples=prior_samples, rng=rng)
    K = inp.n_steps
    J0 = np.linalg.inv(inp.cov_lpc0)
    J0[0, 0] += inp.bearing_info[0]
    J0 = 0.5 * (J0 + J0.T)
    x0 = np.concatenate([inp.m0, _pack(inp.S0)])
    moment_fn, _ = _numeric_step_functions(inp.A, inp.Q, backend)
    xs, aux = _call(_accumulated(moment_fn, K), [x0, inp.c.T])
    moments = np.hstack([x0[:, None], xs])
    er2 = moments[4] + moments[4 + 4]  # S[0,0] and S[1,1] in the packed order
    sigma = inp.range_sigma
    return ClosedFormModel(inputs=inp, J0=J0, x0=x0, moments=moments, aux=aux, er2=er2,
                           ping_sigma=sigma)


def _position_var(moments: np.ndarray, cov_lpc: np.ndarray) -> np.ndarray:
    """``tr E[J_X P J_Xᵀ]_pos`` = Σ_kl S[k,l] tr(E_k P E_lᵀ)_pos, shape (K+1,)."""
    E = basis()[:, :2, :]  # position rows
    S = _unpack_np(moments[4:])
    # T[n, k, l] = tr(E_k P_n E_lᵀ)
    T = np.einsum("kai,nij,laj->nkl", E, cov_lpc, E)
    return np.einsum("nkl,nkl->n", S, T)


def closed_form_pcrb(scenario: Scenario, *, ping_steps: Sequence[int] | None = None,
                     observer: ObserverTrack | None = None, prior_samples: int | None = None,
                     rng: np.random.Generator | None = None,
                     side_tol: float = SIDE_TOL) -> PCRBResult:
    """Closed-form PCRB in LPC, passive or with range pings at any steps (file 000 §4–5).

    Parameters
    ----------
    scenario : Scenario
        NCV target with q > 0, a prior, bearing (and range) sensors.
    ping_steps : sequence of int, optional
        Ping steps; None = the steps of the scenario's range sensors.
    observer : ObserverTrack, optional
        Default: the scenario's (scripted) observer.
    prior_samples : int, optional
        Samples for J₀ and the prior moments (default ``scenario.prior.samples``).
    rng : numpy.random.Generator, optional
        For those samples (default ``default_rng(scenario.prior.seed)``).
    side_tol : float
        Tolerance on κ_k = (wrap period)·p_β(wrap); a :class:`SideAssumptionWarning` is
        issued where it is exceeded.

    Returns
    -------
    PCRBResult
        ``coords = "lpc"``, ``method = "closed-form"``, with ``range_bound`` (eq. 58 with
        ``r̂_k = sqrt(E r_k²)``), ``side_density`` (Gaussian approximation of X_k with the
        exact first two moments) and ``side_valid``.
    """
    t0 = time.perf_counter()
    model = closed_form_model(scenario, ping_steps=ping_steps, observer=observer,
                              prior_samples=prior_samples, rng=rng)
    var, info, _ = model.evaluate()
    seconds = time.perf_counter() - t0
    inp = model.inputs
    std = np.sqrt(var)
    rb = np.sqrt(model.er2 * var[:, 1])
    cov_lpc = np.linalg.inv(info)
    pos = np.sqrt(_position_var(model.moments, cov_lpc))
    dens, kappa = side_assumption_density(inp)
    valid = kappa <= side_tol
    msgs: list[str] = []
    if not valid.all():
        bad = inp.times[~valid]
        msg = (f"{scenario.name}: side assumption (file 000 eq. 27) violated at "
               f"{(~valid).sum()} steps between t = {bad.min():.0f} s and {bad.max():.0f} s "
               f"(max κ = {kappa.max():.3g} > {side_tol}): the true bearing reaches the wrap "
               "point, the β bound is not valid there")
        warnings.warn(msg, SideAssumptionWarning, stacklevel=2)
        msgs.append(msg)
    return PCRBResult(
        times=inp.times, coords="lpc", method="closed-form", information=info, std=std,
        position_std=pos, range_std=rb, seconds=seconds, samples=0,
        prior_samples=inp.prior_samples, ping_steps=inp.ping_steps, range_bound=rb,
        side_density=dens, side_valid=valid, warnings=tuple(msgs))


def side_assumption_density(inp: PCRBInputs, floor: float = 1.0
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Density of the true bearing at the wrap point per step, and κ (NOTES_000 §3.2).

    Given X₀ the relative position at step k is exactly Gaussian (linear dynamics), with mean
    ``(A^k X₀ + Σ A^{k−1−s} c_s)_pos`` and the process-noise covariance ``C_k``; the density is
    the average over ``inp.prior_subsample`` of :func:`side_density_gaussian` (C_k is floored
    at ``floor²·I`` [m²] so step 0 is a narrow kernel estimate).

    Returns
    -------
    density : ndarray, shape (K + 1,)
        [1/rad]: of β mod π at π/2 for π-ambiguous bearings, of β at ±π otherwise.
    kappa : ndarray, shape (K + 1,)
        (wrap period)·density: the file 000 eq. 25 correction 1 − κ of the β bound.
    """
    K, A, Q = inp.n_steps, inp.A, inp.Q
    X = inp.prior_subsample.copy()
    C = np.zeros((4, 4))
    means = np.empty((K + 1, X.shape[0], 2))
    covs = np.empty((K + 1, 2, 2))
    for k in range(K + 1):
        means[k] = X[:, :2]
        covs[k] = C[:2, :2] + floor**2 * np.eye(2)
        if k < K:
            X = X @ A.T + inp.c[k]
            C = A @ C @ A.T + Q
    cv = covs[:, None]
    if inp.ambiguity == "pi":
        dens = (side_density_gaussian(np.pi / 2, means, cv)
                + side_density_gaussian(-np.pi / 2, means, cv)).mean(axis=1)
        return dens, np.pi * dens
    dens = side_density_gaussian(np.pi, means, cv).mean(axis=1)
    return dens, 2 * np.pi * dens


def closed_form_casadi(scenario: Scenario, *, observer: ObserverTrack | None = None,
                       prior_samples: int | None = None,
                       rng: np.random.Generator | None = None) -> Any:
    """casadi Function of the closed-form LPC PCRB (see :meth:`ClosedFormModel.casadi_function`).

    ``(v_obs (K+1)×2 [m/s], u (K+1)×1 in [0, 1]) -> (var (K+1)×4, range_bound (K+1)×1 [m])``.
    The prior moments and J₀ come from ``scenario`` (and ``observer``'s initial state).
    """
    model = closed_form_model(scenario, ping_steps=[], observer=observer,
                              prior_samples=prior_samples, rng=rng)
    return model.casadi_function()

