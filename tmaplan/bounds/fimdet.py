"""FIM-determinant cost functionals of a bearing sequence (lecadre1997, Le Cadre & Jauffret 1997).

Exact values
    :func:`fim_bearings`, :func:`logdet_fim_bearings` — FIM of the relative constant-velocity
    state ``X = [r_x, r_y, v_x, v_y]`` at a reference time from bearings (lecadre1997 eq. 64–65),
    ``log det`` by a column-scaled QR of the whitened Jacobian (never a raw det).
    :func:`fim_bearings_generic`, :func:`logdet_generic` and :func:`inverse_quadratic_generic`
    build the same 4×4 FIM with only ``+ − * /`` so that they evaluate on numpy arrays *and*
    casadi SX/MX symbols (the planner's ``logdet`` and relative-range objectives).
    :func:`logdet_fim_from_bearings` takes measured bearings and (assumed) ranges.

lecadre1997's identities and bearing-rate approximations
    Constant range, unit sampling period, ``(σr)^8 det F`` normalisation, rates in rad per
    sample. :func:`det4_subset` (general 4-sample identity, docs/errata.md), :func:`det4_eq68`
    (eq. 68, expanded form), :func:`det4_second_order` (Property 5, eq. 69),
    :func:`nardone_aidala` (eq. 71/73 with the third derivative restored),
    :func:`single_leg_det` (Result 1, eq. 76, with the corrected ℓ = 8 coefficient 3876),
    :func:`single_leg_small_rate_constant` (k_n of eq. 89), :func:`quartic_coefficients`
    and :func:`bearing_rate_det_approx` (two- and three-leg polynomials, eq. 90–92 and
    Appendix B, "Model A" sample convention of docs/errata.md), and
    :func:`exact_det_piecewise` (the exact value under the same model).

Corrections of printed equations (docs/errata.md): eq. (71) prints ``2θ̇θ̈`` for
``2θ̇θ⃛``; eq. (76) prints 3867 for 3876 (ℓ = 8); eq. (78) prints ``(c−b)(c−a)`` for
``(c−b)(b−a)``; eq. (80) swaps ``(a−d)``/``(c−d)`` for ``(a−b)``/``(c−b)``; eq. (91) loses the
``784x⁴`` term of F_{3,6} and misplaces ``−5488``; Appendix B prints ``+5264`` for ``−5264``.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from tmaplan.bounds.lpc_terms import ldl
from tmaplan.errors import ArgumentError, ObservabilityError, finite_real, is_integer

__all__ = [
    "SINGLE_LEG_COEFFICIENTS",
    "bearing_derivatives",
    "bearing_rate_det_approx",
    "det4_eq68",
    "det4_second_order",
    "det4_subset",
    "exact_det_piecewise",
    "fim_bearings",
    "fim_bearings_generic",
    "inverse_quadratic_generic",
    "logdet_bearing_rate_approx",
    "logdet_fim_bearings",
    "logdet_fim_from_bearings",
    "logdet_generic",
    "model_a_phases",
    "nardone_aidala",
    "quartic_coefficients",
    "single_leg_det",
    "single_leg_small_rate_constant",
]

#: Result 1 (lecadre1997 eq. 76): ``(σr)^8 det F_{k,ℓ} = 32 sin⁸θ̇ Σ_j c_j cos(2jθ̇)``.
#: ℓ = 8 uses the corrected coefficient 3876 (printed 3867; docs/errata.md, T13).
SINGLE_LEG_COEFFICIENTS: dict[int, tuple[float, ...]] = {
    4: (0.5,),  # 16 sin⁸θ̇
    5: (18.0, 16.0, 1.0),
    6: (313.0, 416.0, 136.0, 16.0, 1.0),
    8: (26691.0, 44912.0, 27608.0, 12368.0, 3876.0, 816.0, 136.0, 16.0, 1.0),
}

#: Largest number of samples for the subset (Cauchy–Binet) enumerations.
MAX_SUBSET_SAMPLES = 60


# --------------------------------------------------------------------------------------------
# Exact FIM of the relative CV state from bearings
# --------------------------------------------------------------------------------------------


#: What a ``t_ref`` argument must be.
_T_REF = "a finite reference time [s]"

def _check_bearing_inputs(rel_pos: Any, times: Any, sigma: Any) -> tuple[np.ndarray, ...]:
    rel = np.asarray(rel_pos, dtype=float)
    t = np.asarray(times, dtype=float)
    if rel.ndim < 2 or rel.shape[-1] != 2:
        raise ArgumentError("rel_pos", "relative positions of shape (..., n, 2) [m]", rel.shape)
    n = rel.shape[-2]
    if t.shape != (n,):
        raise ArgumentError("times", f"shape ({n},) [s]", t.shape)
    if not np.all(np.isfinite(rel)):
        raise ArgumentError("rel_pos", "finite relative positions [m] (no NaN)", "nan/inf")
    if not np.all(np.isfinite(t)):
        raise ArgumentError("times", "finite times [s] (no NaN)", "nan/inf")
    s = np.asarray(sigma, dtype=float)
    if s.shape not in ((), (1,), (n,)):
        raise ArgumentError("sigma", f"a scalar or shape ({n},) [rad]", s.shape)
    s = np.broadcast_to(s, (n,))
    if np.any(~np.isfinite(s) | (s <= 0)):
        raise ArgumentError("sigma", "bearing noise std > 0 [rad]", float(np.min(s)))
    if n < 4:
        raise ObservabilityError(f"too few bearings: {n} for the 4 relative-state parameters "
                                 "(need at least 4)")
    r2 = np.sum(rel * rel, axis=-1)
    if np.any(r2 <= 0.0):
        raise ObservabilityError("the observer is at the target (zero range): the bearing is "
                                 "undefined")
    return rel, t, s, r2


def _rows(rel: np.ndarray, tau: np.ndarray, s: np.ndarray, r2: np.ndarray) -> np.ndarray:
    """Whitened rows ``[cos β, −sin β, τ cos β, −τ sin β]/(σ r)`` (lecadre1997 eq. 65)."""
    k = 1.0 / (s * r2)
    ry, rx = rel[..., 1] * k, rel[..., 0] * k
    return np.stack([ry, -rx, tau * ry, -tau * rx], axis=-1)


def fim_bearings(rel_pos: Any, times: Any, sigma: Any, *, t_ref: float = 0.0) -> np.ndarray:
    """FIM of ``X(t_ref) = [r_x, r_y, v_x, v_y]`` from bearings of a CV relative track
    (:func:`fim_bearings_generic`, the planner's form, on numpy arrays).

    Parameters
    ----------
    rel_pos : array_like, shape (..., n, 2)
        Relative positions target − observer at the bearing times [m] (batched).
    times : array_like, shape (n,)
        [s].
    sigma : float or array_like, shape (n,)
        Bearing std [rad].
    t_ref : float
        Reference time of the state [s].

    Returns
    -------
    ndarray, shape (..., 4, 4)
        [1/m², 1/(m·m/s), 1/(m/s)²].
    """
    rel, t, s, _ = _check_bearing_inputs(rel_pos, times, sigma)
    tr = finite_real("t_ref", t_ref, _T_REF)
    steps = (-1,) + (1,) * (rel.ndim - 2)  # steps along axis 0, batch axes after
    F = fim_bearings_generic(np.moveaxis(rel[..., 0], -1, 0), np.moveaxis(rel[..., 1], -1, 0),
                             (t - tr).reshape(steps),
                             (1.0 / s**2).reshape(steps))
    return np.moveaxis(np.array(F), (0, 1), (-2, -1))


def logdet_fim_bearings(rel_pos: Any, times: Any, sigma: Any, *,
                        t_ref: float | None = None) -> np.ndarray:
    """Exact ``log det FIM`` of the relative CV state from bearings (stable, batched).

    Computed as ``2 Σ log|R_ii|`` from the QR factorisation of the column-scaled whitened
    Jacobian (docs/errata.md), never as ``log(det(F))`` of a matrix with det ~ 1e−30.

    Parameters
    ----------
    rel_pos : array_like, shape (..., n, 2)
        [m].
    times : array_like, shape (n,)
        [s].
    sigma : float or array_like, shape (n,)
        [rad].
    t_ref : float, optional
        Reference time [s]; det is invariant to it (lecadre1997); the default, mid-horizon,
        is the best conditioned.

    Returns
    -------
    ndarray, shape (...)
        ``log det F`` (F in SI units); ``-inf`` when F is exactly singular.
    """
    rel, t, s, r2 = _check_bearing_inputs(rel_pos, times, sigma)
    tr = 0.5 * (t[0] + t[-1]) if t_ref is None else finite_real("t_ref", t_ref, _T_REF)
    rows = _rows(rel, t - tr, s, r2)
    norms = np.sqrt(np.sum(rows * rows, axis=-2))  # (..., 4)
    safe = np.where(norms > 0, norms, 1.0)
    r = np.linalg.qr(rows / safe[..., None, :], mode="r")
    diag = np.abs(np.diagonal(r, axis1=-2, axis2=-1))
    with np.errstate(divide="ignore"):
        out = 2.0 * np.sum(np.log(diag), axis=-1) + 2.0 * np.sum(np.log(norms), axis=-1)
    return out


def logdet_fim_from_bearings(bearings: Any, times: Any, sigma: Any, ranges: Any) -> float:
    """``log det FIM`` from measured bearings and (assumed) ranges (lecadre1997 eq. 66).

    Parameters
    ----------
    bearings : array_like, shape (n,)
        β_k = atan2(r_x, r_y) [rad].
    times : array_like, shape (n,)
        [s].
    sigma : float or array_like
        [rad].
    ranges : float or array_like, shape (n,)
        Range [m]; a constant is lecadre1997's long-range hypothesis r_n ≡ r.

    Returns
    -------
    float
    """
    b = np.asarray(bearings, dtype=float)
    if b.ndim != 1:
        raise ArgumentError("bearings", "a 1-D array of bearings [rad]", b.shape)
    bad = ~np.isfinite(b)
    if np.any(bad):
        raise ArgumentError("bearings", "finite bearings [rad]",
                            f"{b[np.argmax(bad)]} at index {int(np.argmax(bad))}")
    r = np.asarray(ranges, dtype=float)
    if r.shape not in ((), (1,), b.shape):
        raise ArgumentError("ranges", f"a scalar or shape {b.shape} [m]", r.shape)
    r = np.broadcast_to(r, b.shape)
    if np.any(~np.isfinite(r) | (r <= 0)):
        raise ArgumentError("ranges", "finite ranges > 0 [m]", float(np.min(r)))
    rel = r[:, None] * np.stack([np.sin(b), np.cos(b)], axis=-1)
    return float(logdet_fim_bearings(rel, times, sigma))


# --------------------------------------------------------------------------------------------
# Generic (numpy or casadi) form for the planner
# --------------------------------------------------------------------------------------------


def _is_casadi(x: Any) -> bool:
    return type(x).__module__.split(".")[0] == "casadi"


def fim_bearings_generic(rx: Any, ry: Any, tau: Any, information: Any, *,
                         total: Callable[[Any], Any] | None = None,
                         min_range: float = 0.0) -> list[list[Any]]:
    """Bearing FIM of the relative CV state as 4×4 nested entries, from ``+ − * /`` only.

    The one generic form, for numpy arrays and casadi symbols alike (the planner's ``logdet``
    and relative-range objectives): entry (i, j) is ``total(info·g_i g_j / r⁴)`` with
    ``g = [r_y, −r_x, τ r_y, −τ r_x]`` (lecadre1997 eq. 65 with ``cos β/r = r_y/r²``, ``sin β/r =
    r_x/r²``), i.e. :func:`fim_bearings` when ``info = 1/σ²`` and ``total`` sums the steps.

    ``rx, ry`` [m] (steps along axis 0, e.g. belief samples along axis 1), ``tau`` [s] and
    ``information`` [rad⁻²] broadcast together (numpy arrays or casadi matrices); ``total``
    reduces over the steps (default the sum; ``casadi.cumsum``: the FIM of the steps up to
    each step); ``min_range`` [m] floors r in 1/r⁴ (a sample the observer sails through would
    otherwise give an infinite information). Returns the nested entries ``F[i][j]``.
    """
    cas = _is_casadi(rx) or _is_casadi(ry) or _is_casadi(tau)
    r2 = rx * rx + ry * ry
    if cas:
        import casadi as ca  # deferred: casadi is slow to import

        total = ca.sum1 if total is None else total
        r2 = ca.fmax(r2, min_range**2) if min_range > 0.0 else r2
    else:
        total = (lambda v: np.sum(v, axis=0)) if total is None else total
        r2 = np.maximum(r2, min_range**2) if min_range > 0.0 else r2
    w = information / (r2 * r2)
    g = (ry, -rx, tau * ry, -tau * rx)
    return [[total(g[i] * g[j] * w) for j in range(4)] for i in range(4)]


def logdet_generic(F: list[list[Any]]) -> Any:
    """``log det F`` of a positive-definite 4×4 nested-entry matrix (sum of log LDLᵀ pivots),
    for numpy arrays or casadi symbols (:func:`fim_bearings_generic`)."""
    _, d = ldl(F)
    if any(_is_casadi(x) for x in d):
        import casadi as ca  # deferred: casadi is slow to import

        return ca.log(d[0]) + ca.log(d[1]) + ca.log(d[2]) + ca.log(d[3])
    return np.log(d[0]) + np.log(d[1]) + np.log(d[2]) + np.log(d[3])


def inverse_quadratic_generic(F: list[list[Any]], g: Sequence[Any]) -> Any:
    """``gᵀ F⁻¹ g`` for a positive-definite 4×4 nested-entry matrix (LDLᵀ solve on entries)."""
    L, d = ldl(F)
    y: list[Any] = []
    for i in range(4):  # forward substitution L y = g
        acc = g[i]
        for k in range(i):
            acc = acc - L[i][k] * y[k]
        y.append(acc)
    return y[0] * y[0] / d[0] + y[1] * y[1] / d[1] + y[2] * y[2] / d[2] + y[3] * y[3] / d[3]


# --------------------------------------------------------------------------------------------
# lecadre1997 identities (constant range, (σr)^8 normalisation)
# --------------------------------------------------------------------------------------------


def det4_subset(phases: Any, times: Any) -> np.ndarray:
    """Exact ``det 𝒢_E`` of four samples with arbitrary bearings and times.

    ``𝒢_E = (G_a, G_b, G_c, G_d)``, ``G = (cos φ, −sin φ, t cos φ, −t sin φ)`` (lecadre1997 eq.
    66). General identity of docs/errata.md (time origin at sample b, ``S_pq = sin(φ_p−φ_q)``):
    ``S_ab S_cd t_cb t_db − S_ac S_bd t_ab t_cb + S_ad S_bc t_ab t_db``; it contains the
    corrected Property 6 (eq. 78, Appendix C2) and Property 7 (eq. 80) as special cases.

    Parameters
    ----------
    phases, times : array_like, shape (..., 4)
        [rad], [samples or s].

    Returns
    -------
    ndarray, shape (...)
    """
    p = np.asarray(phases, dtype=float)
    t = np.asarray(times, dtype=float)
    a, b, c, d = (p[..., i] for i in range(4))
    ta, tc, td = (t[..., i] - t[..., 1] for i in (0, 2, 3))

    def S(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.sin(x - y)

    return (S(a, b) * S(c, d) * tc * td - S(a, c) * S(b, d) * ta * tc
            + S(a, d) * S(b, c) * ta * td)


def det4_eq68(phi1: Any, phi2: Any, phi3: Any) -> np.ndarray:
    """lecadre1997 eq. (68) for samples at 0, 1, 2, 3 with bearing offsets φ_i = θ_{k+i} − θ_k.

    Expanded exact form (docs/errata.md): ``4 α1 α3 c2 − 3 α1 α2 c3 − α2 α3 c1`` with
    ``α_i = sin φ_i``, ``c_i = cos φ_i`` (equal to the printed ``α1(2α3β'2 − α2β'3)``).
    """
    p1, p2, p3 = (np.asarray(x, dtype=float) for x in (phi1, phi2, phi3))
    a1, a2, a3 = np.sin(p1), np.sin(p2), np.sin(p3)
    c1, c2, c3 = np.cos(p1), np.cos(p2), np.cos(p3)
    return 4.0 * a1 * a3 * c2 - 3.0 * a1 * a2 * c3 - a2 * a3 * c1


def det4_second_order(rate: Any, accel: Any) -> np.ndarray:
    """Property 5 (lecadre1997 eq. 69): ``det 𝒢_{k,4} ≈ 6θ̇⁴ − 3θ̈²`` (second-order model).

    Only the θ̈ term is consistent: the second-order truncation drops the ``−θ̇³`` part of
    the third-order coefficient, so with θ̈ = 0 the true leading term is ``4θ̇⁴``
    (see :func:`nardone_aidala`); the tests show this failure.
    """
    r, a = np.asarray(rate, float), np.asarray(accel, float)
    return 6.0 * r**4 - 3.0 * a**2


def nardone_aidala(rate: Any, accel: Any, jerk: Any) -> np.ndarray:
    """Nardone–Aidala determinant ``4θ̇⁴ − 3θ̈² + 2θ̇θ⃛`` (lecadre1997 eq. 71 and 73).

    Corrected: the paper prints ``2θ̇θ̈``; the last factor is the third derivative.
    ``(σr)^{−8} (·)²`` is the third-order approximation of ``det F_{k,4}`` (eq. 73); it vanishes
    identically on rectilinear uniform relative motion (unobservable).
    """
    r, a, j = (np.asarray(x, float) for x in (rate, accel, jerk))
    return 4.0 * r**4 - 3.0 * a**2 + 2.0 * r * j


def bearing_derivatives(X: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """θ̇, θ̈, θ⃛ of a rectilinear uniform relative motion at state ``X = [r_x, r_y, v_x, v_y]``.

    With ``z = r_y + i r_x`` (so ``θ = arg z``) and ``ż = v_y + i v_x`` constant:
    ``θ̇ = Im(ż/z)``, ``θ̈ = −Im((ż/z)²)``, ``θ⃛ = 2 Im((ż/z)³)``.

    Returns
    -------
    rate, accel, jerk : ndarray, shape (...)
        [rad/s], [rad/s²], [rad/s³].
    """
    X = np.asarray(X, dtype=float)
    q = (X[..., 3] + 1j * X[..., 2]) / (X[..., 1] + 1j * X[..., 0])
    return q.imag, -(q**2).imag, 2.0 * (q**3).imag


def single_leg_det(rate: Any, n: int) -> np.ndarray:
    """Result 1 (lecadre1997 eq. 76): ``(σr)^8 det F_{k,n}`` for a constant bearing rate.

    Exact for the first-order bearing model ``θ_{k+i} = θ_k + iθ̇`` at constant range, for
    n ∈ {4, 5, 6, 8} (the printed cases; ℓ = 8 with the corrected 3876).

    Parameters
    ----------
    rate : array_like
        θ̇ [rad per sample].
    n : int
    """
    if n not in SINGLE_LEG_COEFFICIENTS:
        raise ArgumentError("n", f"one of {sorted(SINGLE_LEG_COEFFICIENTS)}", n)
    x = np.asarray(rate, dtype=float)
    c = SINGLE_LEG_COEFFICIENTS[n]
    poly = sum(cj * np.cos(2 * j * x) for j, cj in enumerate(c))
    return 32.0 * np.sin(x) ** 8 * poly


def _subsets(n: int) -> np.ndarray:
    if n > MAX_SUBSET_SAMPLES:
        raise ArgumentError("samples", f"at most {MAX_SUBSET_SAMPLES} samples for a subset "
                            "(Cauchy–Binet) enumeration; use logdet_fim_bearings instead", n)
    if n < 4:
        raise ObservabilityError(f"too few samples: {n} (need at least 4)")
    return np.array(list(itertools.combinations(range(n), 4)), dtype=int)


def _vandermonde(E: np.ndarray, t: np.ndarray) -> np.ndarray:
    tt = t[E]
    v = np.ones(E.shape[0])
    for p, q in itertools.combinations(range(4), 2):
        v = v * (tt[:, q] - tt[:, p])
    return v


def single_leg_small_rate_constant(n: int) -> float:
    """k_n of lecadre1997 eq. (89): ``(σr)^8 det F ≈ k_n θ̇⁸`` for n samples on one leg.

    ``k_n = (1/9) Σ_E V(E)²`` with V the Vandermonde product of the subset's sample indices
    (docs/errata.md; k_4 = 16).
    """
    if not is_integer(n, 4):
        raise ArgumentError("n", "an integer number of samples >= 4", n)
    E = _subsets(int(n))
    return float(np.sum(_vandermonde(E, np.arange(int(n), dtype=float)) ** 2) / 9.0)


def _leg_times(leg_lengths: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Model A (docs/errata.md): samples t = 0..N−1; time spent on each leg, shape (N, L)."""
    lengths = list(leg_lengths)
    if not lengths or not all(is_integer(x, 1) for x in lengths):
        raise ArgumentError("leg_lengths", "positive integer sample counts per leg",
                            leg_lengths)
    lengths = [int(x) for x in lengths]
    n = sum(lengths)
    t = np.arange(n, dtype=float)
    ends = np.cumsum(lengths)[:-1] - 1.0  # leg j ends at its last sample
    edges = np.concatenate([[0.0], ends, [np.inf]])
    tau = np.clip(t[:, None], edges[:-1], edges[1:]) - edges[:-1]
    return t, tau


def model_a_phases(rates: Any, leg_lengths: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and bearing phases of lecadre1997's piecewise-rate model ("Model A").

    Leg 1 has ``leg_lengths[0]`` samples with phase ``t·x_1``; the first sample of the next
    leg is one step after the last sample of the previous leg and already carries the new
    rate (docs/errata.md; this convention reproduces the printed polynomials).

    Returns
    -------
    times : ndarray, shape (N,)
    phases : ndarray, shape (..., N)
    """
    t, tau = _leg_times(leg_lengths)
    x = np.asarray(rates, dtype=float)
    _check_rates(x, tau.shape[1])
    return t, np.einsum("nl,...l->...n", tau, x)


def _check_rates(x: np.ndarray, n_legs: int) -> None:
    if x.ndim == 0 or x.shape[-1] != n_legs:
        raise ArgumentError("rates", f"one rate per leg, shape (..., {n_legs})", x.shape)


def exact_det_piecewise(rates: Any, leg_lengths: Sequence[int]) -> np.ndarray:
    """Exact ``(σr)^8 det F`` under Model A (constant range, unit σ r, unit step).

    Returns
    -------
    ndarray, shape (...)
    """
    t, ph = model_a_phases(rates, leg_lengths)
    G = np.stack([np.cos(ph), -np.sin(ph), t * np.cos(ph), -t * np.sin(ph)], axis=-1)
    sign, ld = np.linalg.slogdet(np.einsum("...ni,...nj->...ij", G, G))
    return np.where(sign > 0, np.exp(ld), 0.0)


def _leading_forms(leg_lengths: Sequence[int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Leading-order quadratic forms ``det 𝒢_E ≈ xᵀ A_E x`` over all 4-subsets E.

    Replaces ``sin(φ_p − φ_q)`` by ``(τ_p − τ_q)·x`` in :func:`det4_subset`. Subsets inside
    one leg have ``A_E = 0``; for them the leading term is ``(x_j⁴/3) V(E)`` (eq. 89).

    Returns
    -------
    A : ndarray, shape (M, L, L), symmetric
    single_leg : ndarray, shape (M,), int
        Leg index of subsets inside one leg, −1 otherwise.
    vander : ndarray, shape (M,)
    """
    t, tau = _leg_times(leg_lengths)
    E = _subsets(t.size)
    tt = t[E]
    dt = tt - tt[:, 1:2]
    tauE = tau[E]  # (M, 4, L)

    def lin(p: int, q: int) -> np.ndarray:
        return tauE[:, p] - tauE[:, q]

    def sym(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        o = u[:, :, None] * v[:, None, :]
        return 0.5 * (o + np.swapaxes(o, 1, 2))

    A = (sym(lin(0, 1), lin(2, 3)) * (dt[:, 2] * dt[:, 3])[:, None, None]
         - sym(lin(0, 2), lin(1, 3)) * (dt[:, 0] * dt[:, 2])[:, None, None]
         + sym(lin(0, 3), lin(1, 2)) * (dt[:, 0] * dt[:, 3])[:, None, None])
    # Subsets whose four phases lie on one straight phase line (inside one leg; under Model A
    # the last sample of leg j−1 is also on leg j's line) have A_E = 0 exactly (integer
    # arithmetic); their rate is that of the leg of the last sample.
    leg_of = np.searchsorted(np.cumsum(leg_lengths), t, side="right")
    on_line = np.all(A == 0.0, axis=(1, 2))
    single = np.where(on_line, leg_of[E[:, 3]], -1)
    return A, single, _vandermonde(E, t)


def bearing_rate_det_approx(rates: Any, leg_lengths: Sequence[int]) -> np.ndarray:
    """lecadre1997's bearing-rate approximation of ``(σr)^8 det F`` for one, two or three legs.

    ``Σ_E det²𝒢_E`` (Cauchy–Binet, eq. 75) with each subset's determinant replaced by its
    leading term: ``(xᵀA_E x)²`` for subsets spanning a manoeuvre (eq. 81–82, 90–91, the
    two-leg polynomials; Appendix B for three legs) and ``(x_j⁴ V(E)/3)²`` for subsets inside
    one leg (eq. 89; structure of eq. 110). Valid for small per-sample rates ``|x| ≪ 1``.

    Parameters
    ----------
    rates : array_like, shape (..., L)
        Bearing rate on each leg [rad per sample].
    leg_lengths : sequence of int, length L
        Samples per leg (Model A).

    Returns
    -------
    ndarray, shape (...)
    """
    A, single, vander = _leading_forms(leg_lengths)
    x = np.asarray(rates, dtype=float)
    _check_rates(x, A.shape[1])
    q = np.einsum("...i,mij,...j->...m", x, A, x)
    xs = np.where(single >= 0, np.take(x, np.clip(single, 0, None), axis=-1), 0.0)
    s = np.where(single >= 0, xs**4 * vander / 3.0, 0.0)
    return np.sum(q**2 + s**2, axis=-1)


def quartic_coefficients(leg_lengths: Sequence[int]) -> dict[tuple[int, ...], int]:
    """Exact integer coefficients of the cross-leg quartic ``Σ_E (xᵀA_E x)²``.

    For two legs this is ``(σr)^8 det F_{ℓ,m} ≃ P(θ̇_1, θ̇_2)`` of eq. (90)–(91), e.g. Model A
    (3, 4) gives ``200x⁴ − 800x³y + 5120x²y² − 8640xy³ + 4120y⁴`` (printed as "F_{4,3}").

    Returns
    -------
    dict
        Exponent tuple (one exponent per leg) → integer coefficient (zeros omitted).
    """
    A, _, _ = _leading_forms(leg_lengths)
    L = A.shape[1]
    # quadratic form as monomial coefficients: x_i x_j (i <= j)
    pairs = [(i, j) for i in range(L) for j in range(i, L)]
    coef = np.stack([A[:, i, j] * (1.0 if i == j else 2.0) for i, j in pairs], axis=-1)
    coef = np.rint(2 * coef) / 2  # entries are (half-)integers under Model A
    out: dict[tuple[int, ...], float] = {}
    for (p, (i, j)), (q, (k, m)) in itertools.product(enumerate(pairs), repeat=2):
        e = [0] * L
        for idx in (i, j, k, m):
            e[idx] += 1
        key = tuple(e)
        out[key] = out.get(key, 0.0) + float(np.sum(coef[:, p] * coef[:, q]))
    return {k: round(v) for k, v in sorted(out.items(), reverse=True) if round(v) != 0}


def logdet_bearing_rate_approx(rates: Any, leg_lengths: Sequence[int], sigma: float,
                               rng_: float, dt: float = 1.0) -> np.ndarray:
    """``log det F`` (SI, velocity in m/s) from the bearing-rate approximation.

    ``det_SI = P(x)·dt⁴/(σ r)^8`` with x the per-sample rates (docs/errata.md).

    Parameters
    ----------
    rates : array_like, shape (..., L)
        [rad per sample].
    leg_lengths : sequence of int
    sigma : float
        [rad].
    rng_ : float
        Constant range r [m].
    dt : float
        Sampling period [s].
    """
    for field, value in (("sigma", sigma), ("rng_", rng_), ("dt", dt)):
        finite_real(field, value, "a finite value > 0", lower=0.0, strict=True)
    p = bearing_rate_det_approx(rates, leg_lengths)
    with np.errstate(divide="ignore"):
        return np.log(p) + 4.0 * np.log(dt) - 8.0 * np.log(sigma * rng_)
