"""Core of the closed-form PCRB in log-polar coordinates, written once on explicit entries.

Every function here works on *nested lists of entries* (``M[i][j]``) and uses only ``+``, ``-``,
``*`` and ``/``. An entry may be a Python float, a numpy array (all entries broadcast together:
a batch of candidate ping schedules, or the time axis) or a casadi ``SX``/``MX`` scalar, so the
same code gives

* the batched numpy evaluation over many ping schedules (:func:`tichavsky_step` on arrays of
  shape (S,)),
* the casadi one-step functions (:func:`step_functions`) that are ``mapaccum``-ed over the
  horizon, evaluated numerically (fast single evaluation) or symbolically (planning with exact
  derivatives),
* their compiled C versions for numeric speed (:mod:`tmaplan.bounds.lpc_codegen`).

Mathematics (brehard2005 §4 with the corrections of docs/errata.md, moment form of docs/errata.md):
the relative state obeys ``X_{t+1} = A X_t + c_t + w_t``, ``w_t ~ N(0, Q)`` with
``c_t = −H Δv_t``. The Jacobian ``J_X = ∂X/∂Y`` of the LPC → Cartesian map is linear in X,
``J_X = Σ_k X_k E_k``, so with ``m_t = E X_t``, ``S_t = E X_t X_tᵀ``, ``Z_t = A X_t + c_t``::

    D11 = Σ_kl S_t[k,l]               E_kᵀ AᵀQ⁻¹A E_l
    D12 = −Σ_kl (S_t Aᵀ + m_t c_tᵀ)[k,l] E_kᵀ AᵀQ⁻¹ E_l
    D22 = Σ_kl E[Z Zᵀ][k,l]          E_kᵀ Q⁻¹ E_l + 𝒞
    J_{t+1} = D22 + D33 − D12ᵀ (J_t + D11)⁻¹ D12          (information, NOT J_t⁻¹: brehard2005
                                                           Prop. 5 prints J_t⁻¹ — wrong)

𝒞 = Cov(J(w)ᵀQ⁻¹w) is computed exactly (Isserlis); for the CV model it equals
diag(0, 8, 8δ²/3, 8δ²/3), *not* brehard2005 eq. 43/101's constant (docs/errata.md).
These moments replace the paper's Γ/Ψ/Ω/Λ/Υ recursions (whose printed Γ₀¹², Λ³³ and Γ₀³³ are
wrong, docs/errata.md); they are exact for any prior (no E r₀² factorisation).
"""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np

from tmaplan.geometry import jacobian_cart_wrt_lpc_from_cart

__all__ = [
    "SYM_INDEX",
    "aux_to_dterms",
    "basis",
    "inverse_diagonal",
    "ldl",
    "lpc_noise_constant",
    "moment_dterm_step",
    "pack_sym",
    "step_functions",
    "tichavsky_step",
    "unpack_sym",
]

Entry = Any
Mat = list[list[Entry]]

#: Upper-triangle (i, j) pairs in the packing order of symmetric 4×4 matrices.
SYM_INDEX: tuple[tuple[int, int], ...] = tuple((i, j) for i in range(4) for j in range(i, 4))


def pack_sym(M: Mat) -> list[Entry]:
    """10 upper-triangle entries of a symmetric 4×4 nested list (order :data:`SYM_INDEX`)."""
    return [M[i][j] for i, j in SYM_INDEX]


def unpack_sym(v: Any) -> Mat:
    """Symmetric 4×4 nested list from 10 packed entries (``v[n]`` indexing)."""
    M: Mat = [[None] * 4 for _ in range(4)]
    for n, (i, j) in enumerate(SYM_INDEX):
        M[i][j] = M[j][i] = v[n]
    return M


def _is_zero(x: Entry) -> bool:
    return isinstance(x, float | int) and x == 0


def _acc(total: Entry, term: Entry) -> Entry:
    if total is None:
        return term
    return total + term


def _or_zero(x: Entry) -> Entry:
    return 0.0 if x is None else x


# ----------------------------------------------------------------------------- constants
@cache
def basis() -> np.ndarray:
    """Basis ``E_k`` (4, 4, 4) with ``∂X/∂Y = Σ_k X_k E_k`` (rows Cartesian, cols LPC).

    Built from :func:`tmaplan.geometry.jacobian_cart_wrt_lpc_from_cart`, which is linear in X.
    """
    return np.asarray(jacobian_cart_wrt_lpc_from_cart(np.eye(4)))


def _tensor(M: np.ndarray) -> np.ndarray:
    """``T[k, l] = E_kᵀ M E_l``, shape (4, 4, 4, 4)."""
    E = basis()
    return np.einsum("kai,ab,lbj->klij", E, M, E)


def lpc_noise_constant(Q: np.ndarray) -> np.ndarray:
    """The constant 𝒞 = Cov(J(w)ᵀ Q⁻¹ w), w ~ N(0, Q), added to D22 (4, 4).

    Exact by Isserlis' theorem: the score component ``g_i = wᵀ B_i w`` is a quadratic form,
    so ``Cov(g_i, g_j) = 2 tr(B_i^s Q B_j^s Q)`` with ``B^s`` the symmetric part. brehard2005's
    printed constant (eq. 43 / 101) is wrong (sign of the +4 ln r term, the wrong
    Jacobian, unit-intensity CV only); the correct value for any Σ is
    diag(0, 8, 2α3²/detΣ, 2α3²/detΣ) (docs/errata.md), which the tests check.

    Parameters
    ----------
    Q : ndarray, shape (4, 4)
        Process-noise covariance [m², m²/s, m²/s²], positive definite.
    """
    P = np.linalg.inv(Q)
    E = basis()
    # g_i = Σ_k w_k (E_kᵀ P w)_i  ->  B_i[k, l] = (E_kᵀ P)[i, l]
    B = np.einsum("kai,al->ikl", E, P)
    Bs = 0.5 * (B + np.swapaxes(B, 1, 2))
    BQ = Bs @ Q
    return 2.0 * np.einsum("iab,jba->ij", BQ, BQ)


# ------------------------------------------------------------------------- generic maths
def _contract(Smat: Mat, T: np.ndarray, symmetric: bool) -> Mat:
    """``D[i][j] = Σ_kl Smat[k][l] T[k, l, i, j]`` on entries, skipping structural zeros."""
    D: Mat = [[None] * 4 for _ in range(4)]
    for i in range(4):
        for j in range(i if symmetric else 0, 4):
            tot = None
            for k in range(4):
                for l in range(4):
                    t = float(T[k, l, i, j])
                    if t != 0.0 and not _is_zero(Smat[k][l]):
                        tot = _acc(tot, Smat[k][l] * t)
            D[i][j] = _or_zero(tot)
            if symmetric:
                D[j][i] = D[i][j]
    return D


def _matmul(A: Any, B: Any) -> Mat:
    """Product of two nested lists whose entries may be numbers (zeros are skipped)."""
    n, m, p = len(A), len(B), len(B[0])
    out: Mat = [[None] * p for _ in range(n)]
    for i in range(n):
        for j in range(p):
            tot = None
            for k in range(m):
                a, b = A[i][k], B[k][j]
                if _is_zero(a) or _is_zero(b):
                    continue
                if isinstance(a, float | int) and a == 1:
                    tot = _acc(tot, b)
                elif isinstance(b, float | int) and b == 1:
                    tot = _acc(tot, a)
                else:
                    tot = _acc(tot, a * b)
            out[i][j] = _or_zero(tot)
    return out


def _transpose(A: Mat) -> Mat:
    return [list(r) for r in zip(*A)]


def moment_dterm_step(m: list[Entry], S: Mat, c: list[Entry], A: np.ndarray,
                      Q: np.ndarray) -> tuple[list[Entry], Mat, Mat, Mat, Mat, Entry]:
    """One step of the exact moment propagation and the D-terms at time t.

    Parameters
    ----------
    m : list of 4 entries
        ``E X_t`` [m, m, m/s, m/s].
    S : 4×4 nested list
        ``E X_t X_tᵀ`` (raw second moment).
    c : list of 4 entries
        ``c_t = −H Δv_t`` [m, m, m/s, m/s].
    A, Q : ndarray, shape (4, 4)
        Transition and process-noise covariance.

    Returns
    -------
    m_next, S_next, D11, D12, D22, er2_next
        Moments at t+1, the D-terms (D22 includes 𝒞) and ``E r²_{t+1}`` [m²] (brehard2005
        eq. 52, here exact from S_{t+1}; the printed Λ³³ third row is wrong, docs/errata.md).
    """
    Al = A.tolist()
    Am = [_or_zero(sum_entries(Al[i], m)) for i in range(4)]
    m_next = [Am[i] + c[i] for i in range(4)]
    AS = _matmul(Al, S)
    SAt = _transpose(AS)  # S Aᵀ (S symmetric)
    ASAt = _matmul(AS, _transpose(Al))
    # E[Z Zᵀ] = A S Aᵀ + (A m) cᵀ + c (A m)ᵀ + c cᵀ, symmetric
    Szz: Mat = [[None] * 4 for _ in range(4)]
    for i in range(4):
        for j in range(i, 4):
            Szz[i][j] = Szz[j][i] = (ASAt[i][j] + Am[i] * c[j] + c[i] * Am[j]
                                     + c[i] * c[j])
    W = [[SAt[k][l] + m[k] * c[l] for l in range(4)] for k in range(4)]
    D11 = _contract(S, _tensor_cached(A, Q, "11"), symmetric=True)
    D12n = _contract(W, _tensor_cached(A, Q, "12"), symmetric=False)
    D12 = [[-x for x in row] for row in D12n]
    D22 = _contract(Szz, _tensor_cached(A, Q, "22"), symmetric=True)
    C = lpc_noise_constant(Q)
    for i in range(4):
        for j in range(i, 4):
            if C[i, j] != 0.0:
                D22[i][j] = D22[i][j] + float(C[i, j])
                D22[j][i] = D22[i][j]
    S_next = [[Szz[i][j] + float(Q[i, j]) for j in range(4)] for i in range(4)]
    er2 = S_next[0][0] + S_next[1][1]
    return m_next, S_next, D11, D12, D22, er2


def sum_entries(row: list[Any], vec: list[Entry]) -> Entry:
    """``Σ_k row[k]·vec[k]`` with numeric ``row`` (zeros skipped, ones not multiplied)."""
    tot = None
    for a, b in zip(row, vec):
        if a == 0:
            continue
        tot = _acc(tot, b if a == 1 else b * float(a))
    return tot


_TENSORS: dict[tuple[bytes, bytes, str], np.ndarray] = {}


def _tensor_cached(A: np.ndarray, Q: np.ndarray, which: str) -> np.ndarray:
    key = (A.tobytes(), Q.tobytes(), which)
    if key not in _TENSORS:
        P = np.linalg.inv(Q)
        M = {"11": A.T @ P @ A, "12": A.T @ P, "22": P}[which]
        T = _tensor(M)
        T[np.abs(T) < 1e-14 * max(np.abs(T).max(), 1e-300)] = 0.0
        _TENSORS[key] = T
    return _TENSORS[key]


def ldl(M: Mat) -> tuple[Mat, list[Entry]]:
    """LDLᵀ factorisation of a symmetric 4×4 nested list (unit lower L, diagonal d)."""
    L: Mat = [[None] * 4 for _ in range(4)]
    Ld: Mat = [[None] * 4 for _ in range(4)]  # L[i][k]·d[k]
    d: list[Entry] = [None] * 4
    for j in range(4):
        s = M[j][j]
        for k in range(j):
            s = s - L[j][k] * Ld[j][k]
        d[j] = s
        for i in range(j + 1, 4):
            s = M[i][j]
            for k in range(j):
                s = s - L[i][k] * Ld[j][k]
            Ld[i][j] = s
            L[i][j] = s / d[j]
    return L, d


def tichavsky_step(J: Mat, D11: Mat, D12: Mat, D22: Mat, bearing_info: Entry,
                   range_info: Entry) -> tuple[Mat, list[Entry]]:
    """Tichavský's recursion ``J_{t+1} = D22 + D33 − D12ᵀ (J_t + D11)⁻¹ D12``.

    Corrected form of brehard2005 Prop. 5: the bracket holds the information ``J_t``, not
    ``J_t⁻¹`` (docs/errata.md). ``D33 = diag(bearing_info, range_info, 0, 0)`` (eq. 47 and
    eq. 51: ``range_info = u_{t+1}·E r²_{t+1}/σ_r²``).

    Parameters
    ----------
    J, D11, D22 : symmetric 4×4 nested lists
    D12 : 4×4 nested list
    bearing_info : entry
        Σ 1/σ_β² of the bearings at t+1 [rad⁻²].
    range_info : entry
        Range-ping information on ln r at t+1 [dimensionless].

    Returns
    -------
    J_next : symmetric 4×4 nested list
    d : list of 4 entries
        LDLᵀ pivots of ``J_t + D11`` (all > 0 iff it is positive definite).
    """
    M = [[J[i][j] + D11[i][j] for j in range(4)] for i in range(4)]
    L, d = ldl(M)
    # T = L⁻¹ D12 (forward substitution, column by column)
    T: Mat = [[None] * 4 for _ in range(4)]
    for col in range(4):
        for i in range(4):
            s = D12[i][col]
            for k in range(i):
                s = s - L[i][k] * T[k][col]
            T[i][col] = s
    U = [[T[k][a] / d[k] for a in range(4)] for k in range(4)]
    Jn: Mat = [[None] * 4 for _ in range(4)]
    for a in range(4):
        for b in range(a, 4):
            w = U[0][a] * T[0][b] + U[1][a] * T[1][b] + U[2][a] * T[2][b] + U[3][a] * T[3][b]
            v = D22[a][b] - w
            if a == b == 0:
                v = v + bearing_info
            elif a == b == 1:
                v = v + range_info
            Jn[a][b] = Jn[b][a] = v
    return Jn, d


def inverse_diagonal(J: Mat) -> tuple[list[Entry], list[Entry]]:
    """Diagonal of ``J⁻¹`` for a symmetric positive-definite 4×4 nested list.

    Returns
    -------
    diag : list of 4 entries
        ``[J⁻¹]_ii``.
    d : list of 4 entries
        LDLᵀ pivots of J (all > 0 iff J is positive definite).
    """
    L, d = ldl(J)
    # columns of L⁻¹ (unit lower triangular)
    Li: Mat = [[None] * 4 for _ in range(4)]
    for j in range(4):
        Li[j][j] = 1.0
        for i in range(j + 1, 4):
            s = L[i][j]
            for k in range(j + 1, i):
                s = s + L[i][k] * Li[k][j]
            Li[i][j] = -s
    diag = []
    for i in range(4):
        tot = 1.0 / d[i]
        for k in range(i + 1, 4):
            tot = tot + Li[k][i] * Li[k][i] / d[k]
        diag.append(tot)
    return diag, d


# -------------------------------------------------------------- casadi one-step functions
_STEP_CACHE: dict[tuple[bytes, bytes], tuple[Any, Any]] = {}


def step_functions(A: np.ndarray, Q: np.ndarray) -> tuple[Any, Any]:
    """casadi ``SX`` one-step functions built from the generic code above (cached).

    Returns
    -------
    moment_fn : casadi.Function
        ``(x[14], c[4]) -> (x_next[14], aux[37])`` with ``x = [m(4), pack_sym(S)(10)]`` and
        ``aux = [pack_sym(D11)(10), vec_rowmajor(D12)(16), pack_sym(D22)(10), E r²_{t+1}]``.
    riccati_fn : casadi.Function
        ``(j[10], aux[37], b, p) -> (j_next[10], var_next[4], pivots[4])``: Tichavský step with
        bearing information ``b`` and ping *weight* ``p`` times ``E r²_{t+1}`` (so ``p`` is
        ``u_{t+1}/σ_r²``), the diagonal of ``J_{t+1}⁻¹`` and the pivots of ``J_t + D11``.
    """
    key = (A.tobytes(), Q.tobytes())
    if key in _STEP_CACHE:
        return _STEP_CACHE[key]
    import casadi as ca  # deferred: casadi is slow to import

    x = ca.SX.sym("x", 14)
    c = ca.SX.sym("c", 4)
    m = [x[i] for i in range(4)]
    S = unpack_sym([x[4 + n] for n in range(10)])
    m1, S1, D11, D12, D22, er2 = moment_dterm_step(m, S, [c[i] for i in range(4)], A, Q)
    x_next = ca.vertcat(*m1, *pack_sym(S1))
    aux = ca.vertcat(*pack_sym(D11), *[D12[i][j] for i in range(4) for j in range(4)],
                     *pack_sym(D22), er2)
    moment_fn = ca.Function("lpc_moment_step", [x, c], [x_next, aux], ["x", "c"],
                            ["x_next", "aux"])

    j = ca.SX.sym("j", 10)
    a = ca.SX.sym("aux", 37)
    b = ca.SX.sym("b")
    p = ca.SX.sym("p")
    Jm = unpack_sym([j[n] for n in range(10)])
    d11, d12, d22 = aux_to_dterms([a[n] for n in range(37)])
    Jn, piv = tichavsky_step(Jm, d11, d12, d22, b, p * a[36])
    var, _ = inverse_diagonal(Jn)
    riccati_fn = ca.Function("lpc_tichavsky_step", [j, a, b, p],
                             [ca.vertcat(*pack_sym(Jn)), ca.vertcat(*var), ca.vertcat(*piv)],
                             ["j", "aux", "b", "p"], ["j_next", "var_next", "pivots"])
    _STEP_CACHE[key] = (moment_fn, riccati_fn)
    return moment_fn, riccati_fn


def aux_to_dterms(a: Any) -> tuple[Mat, Mat, Mat]:
    """Unpack ``aux`` (indexable, ≥ 36 entries) into D11, D12, D22 nested lists."""
    D11 = unpack_sym([a[n] for n in range(10)])
    D12 = [[a[10 + 4 * i + k] for k in range(4)] for i in range(4)]
    D22 = unpack_sym([a[26 + n] for n in range(10)])
    return D11, D12, D22
