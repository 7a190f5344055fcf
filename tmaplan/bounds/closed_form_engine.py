"""The closed-form PCRB engine in log-polar coordinates (brehard2005), with range pings.

:class:`ClosedFormEngine` is the one assembly of the corrected brehard2005 recursion: built from
a belief on the relative state (moments and the LPC prior information J₀, eq. 56), an observer
track and the per-step sensor information, it evaluates one ping schedule
(:meth:`~ClosedFormEngine.evaluate`: casadi step functions, compiled to C when a compiler is
available), many at once (:meth:`~ClosedFormEngine.evaluate_schedules`: a C kernel vectorised
over schedules, or the numpy reference loop), gives the casadi graph with symbolic pings
(:meth:`~ClosedFormEngine.schedule_graph`) or with the belief itself symbolic
(:func:`lpc_pcrb_graph`, for the planners' parametric NLPs), and the per-step
information-form matrices (:meth:`~ClosedFormEngine.information_terms`, for convex
relaxations). The planner, the ping scheduler and ``tmaplan bound`` all use it. The maths is
written once on explicit entries in :mod:`tmaplan.bounds.lpc_terms` (compiled by
:mod:`tmaplan.bounds.lpc_codegen`); the tests check every path against the others to 1e-10.

Corrections to brehard2005 (docs/errata.md): information (not its inverse) in the Tichavský bracket
(Prop. 5); the true Jacobian ∂X/∂Y instead of the printed F (eq. 31); the constant
𝒞 = diag(0, 8, 2α3²/detΣ, 2α3²/detΣ) instead of eq. 43/101; exact moment propagation instead
of the Γ recursions (whose printed Γ₀¹², Λ³³ third row and Γ₀³³ are wrong); ``E r²_{t+1}``
of the ping information (eq. 51) from the exact second moments.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np

from tmaplan.bounds.lpc_codegen import compiled_step_functions, schedule_kernel
from tmaplan.bounds.lpc_terms import (
    SYM_INDEX,
    aux_to_dterms,
    basis,
    inverse_diagonal,
    pack_sym,
    step_functions,
    tichavsky_step,
    unpack_sym,
)
from tmaplan.errors import ArgumentError, ObservabilityError, ScenarioError, finite_real
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import ncv_matrices

if TYPE_CHECKING:  # typing_extensions: for the annotation only, not a dependency
    from typing_extensions import Buffer

__all__ = [
    "BeliefMoments",
    "ClosedFormEngine",
    "StepInformation",
    "lpc_pcrb_graph",
    "lpc_position_bound_graph",
    "pack_symmetric",
]

def pack_symmetric(M: np.ndarray) -> np.ndarray:
    """The 10 upper-triangle entries (row-major) of symmetric (..., 4, 4) -> (10, ...): the
    packing of the engine's moments, information and of :func:`lpc_pcrb_graph`'s inputs."""
    return np.array([M[..., i, j] for i, j in SYM_INDEX])


def _unpack_np(v: np.ndarray) -> np.ndarray:
    """(10, ...) packed -> (..., 4, 4)."""
    out = np.empty((*v.shape[1:], 4, 4))
    for n, (i, j) in enumerate(SYM_INDEX):
        out[..., i, j] = out[..., j, i] = v[n]
    return out


class BeliefMoments(Protocol):
    """What the engine reads from a belief (:class:`tmaplan.planning.Belief`)."""

    @property
    def mean(self) -> np.ndarray:
        """``E X`` (4,) [m, m, m/s, m/s]."""

    @property
    def second_moment(self) -> np.ndarray:
        """``E X Xᵀ`` (4, 4)."""

    def lpc_information(self) -> np.ndarray:
        """LPC prior information J₀ (4, 4) (brehard2005 eq. 56)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class StepInformation:
    """Information-form matrices of the closed-form recursion, per step (SI, LPC order).

    With ``Y = [β, ln r, β̇, ṙ/r]`` [rad, 1, rad/s, 1/s] and ping weights u_k ∈ [0, 1], the
    engine's recursion (brehard2005 Prop. 5, corrected: information in the bracket) is::

        J_0     = J_prior + B_0 + u_0 M_0
        J_{t+1} = D22_t + B_{t+1} + u_{t+1} M_{t+1} − D12_tᵀ (J_t + D11_t)⁻¹ D12_t

    and the range bound of eq. 58 is ``sqrt(E r_k² [J_k⁻¹]_{ln r})`` [m]. Entry (i, j) of
    every matrix has the units of ``1/(Y_i Y_j)``.

    Attributes
    ----------
    prior : ndarray, shape (4, 4)
        J_prior, the LPC prior information (eq. 56).
    D11, D12, D22 : ndarray, shape (K, 4, 4)
        Tichavský's D-terms of the transition t → t + 1 (eq. 29; D22 includes the constant 𝒞,
        docs/errata.md); D11, D22 symmetric, D21 = D12ᵀ.
    B : ndarray, shape (K + 1, 4, 4)
        Bearing information ``diag(Σ 1/σ_β², 0, 0, 0)`` at step k (eq. 47, D33).
    M : ndarray, shape (K + 1, 4, 4)
        Information of one ping at step k, ``diag(0, E r_k²/σ_r², 0, 0)`` (eq. 51); zeros
        without a range sensor.
    er2 : ndarray, shape (K + 1,)
        ``E r_k²`` [m²].
    """

    prior: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    D22: np.ndarray
    B: np.ndarray
    M: np.ndarray
    er2: np.ndarray


@dataclasses.dataclass(frozen=True, kw_only=True)
class ClosedFormEngine:
    """The closed-form LPC PCRB of one belief and observer track, ready for fast evaluation.

    The moments and D-terms depend only on the belief and the observer (docs/errata.md);
    a ping schedule u enters only through ``u_k·E r_k²/σ_r²`` on ln r. Build with
    :meth:`from_belief` (planners) or :func:`tmaplan.bounds.closed_form.closed_form_model`
    (a scenario's prior).

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    dt : float
        [s].
    A, Q : ndarray, shape (4, 4)
        NCV transition and process-noise covariance of the relative state.
    observer : ObserverTrack
    prior_information : ndarray, shape (4, 4)
        LPC prior information J₀ (brehard2005 eq. 56).
    moments : ndarray, shape (14, K + 1)
        ``[m_k, pack_sym(S_k)]``: raw moments ``E X_k``, ``E X_k X_kᵀ`` for k = 0..K.
    aux : ndarray, shape (37, K)
        Packed D11, D12 (row-major), D22 at t = 0..K−1 and ``E r²_{t+1}`` (a view whose
        transpose is C-contiguous: the compiled kernel reads it without a copy).
    er2 : ndarray, shape (K + 1,)
        ``E r_k²`` [m²].
    bearing_info : ndarray, shape (K + 1,)
        Σ 1/σ_β² of the bearings at each step [rad⁻²].
    ping_sigma : float or None
        σ_r of a ping [m] (u_k = 1 means one ping of this σ); None: no range sensor.
    """

    times: np.ndarray
    dt: float
    A: np.ndarray
    Q: np.ndarray
    observer: ObserverTrack
    prior_information: np.ndarray
    moments: np.ndarray
    aux: np.ndarray
    er2: np.ndarray
    bearing_info: np.ndarray
    ping_sigma: float | None

    # --------------------------------------------------------------------- construction
    @classmethod
    def build(cls, *, mean: np.ndarray, second_moment: np.ndarray,
              prior_information: np.ndarray, observer: ObserverTrack, dt: float, q: float,
              bearing_info: np.ndarray, ping_sigma: float | None,
              backend: str = "auto") -> ClosedFormEngine:
        """Engine from the moments of X₀ (``E X₀`` (4,) [m, m/s], ``E X₀X₀ᵀ`` (4, 4)), the LPC
        J₀ (4, 4), an observer track (K + 1 instants; only its velocity increments enter,
        ``c_t = −H Δv_t``, docs/conventions.md), dt [s], the NCV intensity q > 0 [m²/s³],
        the bearing information per step (K + 1,) [rad⁻²]
        (:func:`tmaplan.bounds.inputs.information_rates`) and σ_r of a ping [m]; ``backend``
        ("auto", "compiled", "casadi") evaluates the moment recursion.

        Raises :class:`ArgumentError` naming the argument for a non-positive or non-finite
        ``dt``, ``q`` or ``ping_sigma``, arrays of another shape or with non-finite entries,
        or a negative bearing information."""
        K = observer.position.shape[0] - 1
        for name, val in (("dt", dt), ("q", q)) + ((("ping_sigma", ping_sigma),)
                                                  if ping_sigma is not None else ()):
            finite_real(name, val, "a finite number > 0", lower=0.0, strict=True)
        mean = _finite_array("mean", mean, (4,))
        second_moment = _finite_array("second_moment", second_moment, (4, 4))
        prior_information = _finite_array("prior_information", prior_information, (4, 4))
        bearing_info = _finite_array("bearing_info", bearing_info, (K + 1,))
        if np.any(bearing_info < 0.0):
            raise ArgumentError("bearing_info", "Σ 1/σ_β² >= 0 [rad⁻²] at each step",
                                bearing_info)
        A, Q = ncv_matrices(float(dt), float(q))
        dv = observer.velocity_increments
        c = -np.hstack([dt * dv, dv])
        x0 = np.concatenate([np.asarray(mean, float),
                             pack_symmetric(np.asarray(second_moment, float))])
        moment_fn, _ = _numeric_step_functions(A, Q, backend)
        xs, aux = _call(_accumulated(moment_fn, K), [x0, c.T])
        moments = np.hstack([x0[:, None], xs])
        J0 = np.asarray(prior_information, float)
        return cls(times=np.asarray(observer.times, float), dt=float(dt), A=A, Q=Q,
                   observer=observer, prior_information=0.5 * (J0 + J0.T), moments=moments,
                   aux=np.ascontiguousarray(aux.T).T, er2=moments[4] + moments[8],
                   bearing_info=bearing_info, ping_sigma=ping_sigma)

    @classmethod
    def from_belief(cls, belief: BeliefMoments, observer: ObserverTrack, *, dt: float,
                    q: float, bearing_info: np.ndarray, ping_sigma: float | None,
                    backend: str = "auto") -> ClosedFormEngine:
        """Engine from a belief (its mean, second moment and LPC information); see
        :meth:`build`."""
        return cls.build(mean=belief.mean, second_moment=belief.second_moment,
                         prior_information=belief.lpc_information(), observer=observer,
                         dt=dt, q=q, bearing_info=bearing_info, ping_sigma=ping_sigma,
                         backend=backend)

    @property
    def n_steps(self) -> int:
        """K."""
        return self.times.shape[0] - 1

    @property
    def ping_scale(self) -> float:
        """1/σ_r² of a ping [m⁻²] (0 without a range sensor)."""
        return 0.0 if self.ping_sigma is None else 1.0 / self.ping_sigma**2

    def _ping_scale(self, u: np.ndarray) -> float:
        """:attr:`ping_scale` if any ping is requested (0 otherwise)."""
        if np.any(u) and self.ping_sigma is None:
            raise ScenarioError("sensors", "a range sensor (kind = 'range') to ping with",
                                "no range sensor")
        return self.ping_scale if np.any(u) else 0.0

    def _start_entries(self, u0: Any, scale: float) -> list[list[Any]]:
        """``J_0 = J_prior + B_0 + u_0 M_0`` as nested entries (u0 a number or an array)."""
        J = [[float(x) + 0.0 * u0 for x in row] for row in self.prior_information.tolist()]
        J[0][0] = J[0][0] + float(self.bearing_info[0])
        J[1][1] = J[1][1] + u0 * scale * float(self.er2[0])
        return J

    # ----------------------------------------------------------------- one schedule
    def evaluate(self, u: np.ndarray | None = None, *, backend: str = "auto"
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Bound for one ping schedule.

        Parameters
        ----------
        u : ndarray, shape (K + 1,), optional
            Ping weights (1 = a ping of σ_r at that step); default no pings.
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

        Raises
        ------
        ArgumentError
            ``u`` not of shape (K + 1,), or with a NaN, infinite or negative weight.
        ObservabilityError
            If J₀ or some ``J_t + D11`` is not positive definite.
        """
        K = self.n_steps
        u = np.zeros(K + 1) if u is None else _ping_weights(u, (K + 1,), f"shape ({K + 1},)")
        scale = self._ping_scale(u)
        _, riccati_fn = _numeric_step_functions(self.A, self.Q, backend)
        J0 = np.array(self._start_entries(float(u[0]), scale))
        jn, varn, piv = _call(_accumulated(riccati_fn, K), [
            pack_symmetric(J0), self.aux, self.bearing_info[1:][None, :], (u[1:] * scale)[None, :]])
        var0, d0 = inverse_diagonal(J0.tolist())
        if min(d0) <= 0 or np.any(piv <= 0):
            raise ObservabilityError("closed-form PCRB: J_0 or J_t + D11 is not positive "
                                     "definite")
        var = np.vstack([np.asarray(var0)[None, :], varn.T])
        info = np.concatenate([J0[None], _unpack_np(jn)], axis=0)
        return var, info, piv.T

    # ------------------------------------------------------------- batched schedules
    def evaluate_schedules(self, u: np.ndarray, *, reduce: str | None = None,
                           quantity: str = "range", backend: str = "auto") -> np.ndarray:
        """Bound [m] of ping schedules ``u`` (S, K + 1), batched over schedules.

        :func:`tmaplan.bounds.lpc_terms.tichavsky_step` on entries of shape (S,): with numpy
        (``backend="numpy"``), or as the C kernel emitted from its ``SX`` graph, SIMD over
        schedules (``"compiled"``: an error without a compiler; ``"auto"``: when available).
        ``quantity``: "range", eq. 58's ``sqrt(E r_k²·[J_k⁻¹]_{ln r})``, or "position",
        ``sqrt(tr P_pos)`` of the Cartesian bound ``E[J_X J_k⁻¹ J_Xᵀ]_pos`` (numpy only).
        ``reduce``: None, per step (S, K + 1); "mean" over the K + 1 steps (docs/cli.md);
        "terminal", the last step (S,). Raises :class:`ObservabilityError` if some
        ``J_t + D11`` is not positive definite, :class:`ArgumentError` for weights ``u`` of
        another shape, NaN, infinite or negative.
        """
        K = self.n_steps
        u = np.atleast_2d(_ping_weights(u, None, f"shape (S, {K + 1})"))
        if u.ndim != 2 or u.shape[1] != K + 1:
            raise ArgumentError("u", f"shape (S, {K + 1})", u.shape)
        if reduce not in (None, "mean", "terminal"):
            raise ArgumentError("reduce", "None, 'mean' or 'terminal'", reduce)
        if quantity not in ("range", "position"):
            raise ArgumentError("quantity", "'range' or 'position'", quantity)
        scale = self._ping_scale(u)
        J = self._start_entries(u[:, 0], scale)
        kernel = _schedule_backend(backend if quantity == "range" or backend == "numpy"
                                   else "numpy")
        if kernel is not None and u.shape[0]:
            out = self._schedules_compiled(kernel, u, J, scale, reduce)
            if np.all(np.isfinite(out)):
                return out
        rb = np.empty((u.shape[0], K + 1))
        aux = self.aux.T.tolist()
        b = self.bearing_info.tolist()
        pw = u * (scale * self.er2)[None, :]
        W = self.position_weights() if quantity == "position" else None
        for k in range(K + 1):  # loop over time steps; schedules are batched
            if k > 0:
                D11, D12, D22 = aux_to_dterms(aux[k - 1])
                J, piv = tichavsky_step(J, D11, D12, D22, b[k], pw[:, k])
                if np.any(np.minimum.reduce(piv) <= 0):
                    raise ObservabilityError("closed-form PCRB: J_t + D11 is not positive "
                                             "definite")
            if W is None:
                rb[:, k] = np.sqrt(self.er2[k] * inverse_diagonal(J)[0][1])
            else:
                P = np.linalg.inv(np.stack([np.stack(r, axis=-1) for r in J], axis=-2))
                rb[:, k] = np.sqrt(np.maximum(np.einsum("ij,sij->s", W[k], P), 0.0))
        if reduce == "mean":  # summed step by step as in the C kernel: identical results
            acc = 0.0 + rb[:, 0]
            for k in range(1, K + 1):
                acc += rb[:, k]
            return acc / (K + 1)
        return rb[:, -1] if reduce == "terminal" else rb

    @staticmethod
    def schedule_kernel(backend: str = "auto") -> Any:
        """The compiled batched schedule kernel of :meth:`evaluate_schedules` (None without a
        working C compiler, or for ``backend="numpy"``); its C signature is the one called in
        :meth:`_schedules_compiled`. For searches that restart the recursion mid-horizon."""
        return _schedule_backend(backend)

    def _schedules_compiled(self, kernel: Any, u: np.ndarray, J: list[list[Any]],
                            scale: float, reduce: str | None) -> np.ndarray:
        """:meth:`evaluate_schedules` through the C kernel (step 0 with the generic code)."""
        K, S = self.n_steps, u.shape[0]
        u = np.ascontiguousarray(u)
        val0 = np.sqrt(self.er2[0] * inverse_diagonal(J)[0][1])
        acc = np.array(np.broadcast_to(0.0 + val0, (S,)))
        last = acc.copy()
        out = None if reduce is not None else np.empty((S, K + 1))
        if out is not None:
            out[:, 0] = val0
        j0 = np.array([J[i][k] for i, k in SYM_INDEX])  # (10, S), structure of arrays
        b = np.ascontiguousarray(self.bearing_info[1:])
        pw = np.ascontiguousarray((scale * self.er2)[1:])
        er2 = np.ascontiguousarray(self.er2[1:])
        rows = np.ascontiguousarray(self.aux.T)  # no copy: aux is a transposed C array
        kernel(K, S, j0.ctypes.data, rows.ctypes.data, b.ctypes.data, pw.ctypes.data,
               er2.ctypes.data, u.ctypes.data, K + 1, acc.ctypes.data, last.ctypes.data,
               None if out is None else out.ctypes.data)
        if reduce == "mean":
            return acc / (K + 1)
        if reduce == "terminal":
            return last if K > 0 else acc
        return out  # type: ignore[return-value]

    def position_weights(self) -> np.ndarray:
        """``W_k = Σ_kl S_k[k,l] E_kᵀ_pos E_l,pos`` (K + 1, 4, 4): ``tr P_pos = tr(W_k J_k⁻¹)``.

        ``J_X = ∂X/∂Y = Σ_k X_k E_k`` is linear in X (docs/errata.md), so the Cartesian
        position covariance bound is ``E[J_X J⁻¹ J_Xᵀ]_pos`` with trace ``tr(W J⁻¹)`` [m²·Y²].
        """
        E = basis()[:, :2, :]
        return np.einsum("nkl,kai,laj->nij", _unpack_np(self.moments[4:]), E, E)

    # ------------------------------------------------------------ information form
    def information_terms(self) -> StepInformation:
        """The per-step information-form matrices of the recursion (:class:`StepInformation`).

        For convex relaxations of ping scheduling (the recursion is matrix-monotone and
        J_{t+1} is concave in J_t, so Schur-complement LMIs of these matrices relax it).
        """
        K = self.n_steps
        d11, d12, d22 = (np.empty((K, 4, 4)) for _ in range(3))
        for t, a in enumerate(self.aux.T.tolist()):
            d11[t], d12[t], d22[t] = (np.array(m, float) for m in aux_to_dterms(a))
        B = np.zeros((K + 1, 4, 4))
        B[:, 0, 0] = self.bearing_info
        M = np.zeros((K + 1, 4, 4))
        M[:, 1, 1] = self.er2 * self.ping_scale
        return StepInformation(prior=self.prior_information.copy(), D11=d11, D12=d12, D22=d22,
                               B=B, M=M, er2=self.er2.copy())

    # ---------------------------------------------------------------------- symbolic
    def schedule_graph(self, u: Any) -> dict[str, Any]:
        """casadi graph of the bound for symbolic ping weights ``u`` ((K+1)×1 MX).

        Returns the dict of :func:`lpc_pcrb_graph` (moments and D-terms numeric constants).
        """
        import casadi as ca  # deferred: casadi is slow to import

        g = _information_graph(self.A, self.Q, j0=ca.DM(pack_symmetric(self.prior_information)),
                               aux=ca.DM(self.aux), er2=ca.DM(self.er2),
                               bearing=ca.DM(self.bearing_info), ping=u,
                               ping_scale=self.ping_scale)
        g["X"] = ca.DM(self.moments)
        return g

    def casadi_function(self) -> Any:
        """casadi Function ``(v_obs (K+1)×2, u (K+1)×1) -> (var (K+1)×4, range_bound (K+1)×1)``.

        ``v_obs`` are the observer's mean velocities per step (``ObserverTrack.mean_velocity``);
        only their increments enter; the moments of X₀ and J₀ are the engine's. ``var`` is the
        diagonal of J_k⁻¹; ``range_bound`` is eq. 58's [m]. Exact derivatives by casadi AD.
        """
        import casadi as ca  # deferred: casadi is slow to import

        K = self.n_steps
        v = ca.MX.sym("v_obs", K + 1, 2)
        u = ca.MX.sym("u", K + 1, 1)
        g = lpc_pcrb_graph(self.A, self.Q, self.dt, v_obs=v, x0=ca.DM(self.moments[:, 0]),
                           j0=ca.DM(pack_symmetric(self.prior_information)),
                           bearing=ca.DM(self.bearing_info), ping=u,
                           ping_scale=self.ping_scale)
        return ca.Function("closed_form_pcrb_lpc", [v, u], [g["var"], g["range_bound"]],
                           ["v_obs", "u"], ["var", "range_bound"])


# ------------------------------------------------------------------------ casadi graphs
def _information_graph(A: np.ndarray, Q: np.ndarray, *, j0: Any, aux: Any, er2: Any,
                       bearing: Any, ping: Any, ping_scale: float) -> dict[str, Any]:
    """Tichavský recursion over the horizon on casadi inputs (see :func:`lpc_pcrb_graph`)."""
    import casadi as ca  # deferred: casadi is slow to import

    K = aux.shape[1]
    _, riccati_fn = step_functions(A, Q)
    J0 = unpack_sym([j0[n] for n in range(10)])
    J0[0][0] = J0[0][0] + bearing[0]
    J0[1][1] = J0[1][1] + ping[0] * ping_scale * er2[0]
    j0s = ca.vertcat(*pack_sym(J0))
    jn, varn, _ = _accumulated(riccati_fn, K)(j0s, aux, ca.reshape(bearing[1:], 1, K),
                                              ca.reshape(ping[1:] * ping_scale, 1, K))
    var0, _ = inverse_diagonal(J0)
    var = ca.vertcat(ca.horzcat(*var0), varn.T)
    return {"range_bound": ca.sqrt(er2 * var[:, 1]), "var": var, "J": ca.horzcat(j0s, jn),
            "er2": er2}


def lpc_pcrb_graph(A: np.ndarray, Q: np.ndarray, dt: float, *, v_obs: Any, x0: Any, j0: Any,
                   bearing: Any, ping: Any, ping_scale: float) -> dict[str, Any]:
    """The closed-form LPC PCRB over a horizon as casadi expressions of all its inputs.

    The same step functions as :class:`ClosedFormEngine`, wired with the belief as casadi
    inputs, so a planner's NLP is built once and re-solved for a new belief. Inputs (casadi):
    ``v_obs`` (K+1)×2 observer mean velocities [m/s] (only increments enter, ``c_t = −H Δv_t``),
    ``x0`` 14×1 ``[E X₀, pack_symmetric(E X₀X₀ᵀ)]``, ``j0`` 10×1 packed J₀, ``bearing`` (K+1)×1
    [rad⁻²] and ``ping`` (K+1)×1 weights u_k; ``ping_scale`` 1/σ_r² [m⁻²], ``dt`` [s].

    Returns a dict: ``range_bound`` (K+1)×1 [m], ``var`` (K+1)×4 diagonal of J_k⁻¹, ``J``
    10×(K+1) packed information, ``X`` 14×(K+1) moments, ``er2`` (K+1)×1 [m²].
    """
    import casadi as ca  # deferred: casadi is slow to import

    K = v_obs.shape[0] - 1
    moment_fn, _ = step_functions(A, Q)
    dv = v_obs[1:, :] - v_obs[:-1, :]
    c = -ca.horzcat(dt * dv, dv).T  # c_t = −H Δv_t (docs/conventions.md), 4 × K
    xs, aux = _accumulated(moment_fn, K)(x0, c)
    er2 = ca.vertcat(x0[4] + x0[8], aux[36, :].T)  # S[0,0] + S[1,1] in the packed order
    g = _information_graph(A, Q, j0=j0, aux=aux, er2=er2, bearing=bearing, ping=ping,
                           ping_scale=ping_scale)
    g["X"] = ca.horzcat(x0, xs)
    return g


_POSVAR: dict[str, Any] = {}


def lpc_position_bound_graph(graph: dict[str, Any]) -> Any:
    """``sqrt(tr P_pos)`` per step ((K+1)×1) [m] of a :func:`lpc_pcrb_graph` dict.

    ``tr E[J_X J⁻¹ J_Xᵀ]_pos = Σ_kl S[k,l] tr(E_k J⁻¹ E_lᵀ)_pos`` (the symbolic counterpart of
    :meth:`ClosedFormEngine.position_weights`).
    """
    import casadi as ca  # deferred: casadi is slow to import

    if "f" not in _POSVAR:
        j, x = ca.SX.sym("j", 10), ca.SX.sym("x", 14)
        P = ca.inv(ca.blockcat(unpack_sym([j[n] for n in range(10)])))
        S = unpack_sym([x[4 + n] for n in range(10)])
        E = basis()[:, :2, :]
        T = np.einsum("kai,laj->klij", E, E)  # tr(E_k P E_lᵀ)_pos = Σ_ij T[k,l,i,j] P[i,j]
        tot = 0
        for k, m, i, jj in zip(*np.nonzero(T)):
            tot = tot + S[k][m] * float(T[k, m, i, jj]) * P[i, jj]
        _POSVAR["f"] = ca.Function("lpc_position_var", [j, x], [tot])
    pv = _POSVAR["f"].map(graph["J"].shape[1])(graph["J"], graph["X"])
    return ca.sqrt(ca.fmax(pv.T, 0.0))


# ------------------------------------------------------------------- numeric helpers
_ACC_CACHE: dict[tuple[int, int], tuple[Any, Any]] = {}


def _numeric_step_functions(A: np.ndarray, Q: np.ndarray, backend: str) -> tuple[Any, Any]:
    """Step functions for numeric evaluation: compiled C when available, else the casadi VM."""
    if backend not in ("auto", "compiled", "casadi"):
        raise ArgumentError("backend", "'auto', 'compiled' or 'casadi'", backend)
    if backend != "casadi":
        fns = compiled_step_functions(A, Q)
        if fns is not None:
            return fns
        if backend == "compiled":
            raise RuntimeError("backend='compiled': no working C compiler (set CC, or "
                               "TMAPLAN_JIT is 0)")
    return step_functions(A, Q)


def _finite_array(name: str, value: Any, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a finite float array of ``shape``, else :class:`ArgumentError`."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError(name, f"a finite array of shape {shape}", value) from None
    if arr.shape != shape:
        raise ArgumentError(name, f"shape {shape}", arr.shape)
    if not np.all(np.isfinite(arr)):
        raise ArgumentError(name, "finite entries", arr)
    return arr


def _ping_weights(u: Any, shape: tuple[int, ...] | None, expected: str) -> np.ndarray:
    """Ping weights ``u`` as a float array: finite, >= 0, of ``shape`` (if given)."""
    try:
        arr = np.asarray(u, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError("u", f"ping weights (finite, >= 0) of {expected}", u) from None
    if shape is not None and arr.shape != shape:
        raise ArgumentError("u", expected, arr.shape)
    if not np.all(np.isfinite(arr) & (arr >= 0.0)):
        raise ArgumentError("u", "finite ping weights >= 0", arr)
    return arr


def _schedule_backend(backend: str) -> Any:
    if backend not in ("auto", "compiled", "numpy"):
        raise ArgumentError("backend", "'auto', 'compiled' or 'numpy'", backend)
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
        buf.set_arg(i, memoryview(cast("Buffer", a)))
    outs = []
    for i in range(fn.n_out()):
        rows, cols = fn.size_out(i)
        o = np.empty((cols, rows))
        buf.set_res(i, memoryview(cast("Buffer", o)))
        outs.append(o)
    run()
    if buf.ret() != 0:
        raise RuntimeError(f"casadi function {fn.name()} failed (status {buf.ret()})")
    return [o.T for o in outs]


def _accumulated(fn: Any, K: int) -> Any:
    # keyed on identity; the entry holds ``fn`` itself, so its id cannot be reused by another
    key = (id(fn), K)
    if key not in _ACC_CACHE:
        _ACC_CACHE[key] = (fn, fn.mapaccum(f"{fn.name()}_acc", K))
    return _ACC_CACHE[key][1]
