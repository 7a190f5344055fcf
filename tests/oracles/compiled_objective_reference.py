"""Oracle: :func:`tmaplan.planning.compiled_objective._value_grad` as it was before its loops
were restructured for the vectoriser (commit f4e63e6), kept verbatim (bar the decorator: no
``compiled_entry``, nothing here is called from the package) as the bit-for-bit reference of
tests/planning/test_compiled_objective_bits.py and benchmarks/compiled_objective.py.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit


@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _value_grad(sx: Any, sy: Any, svx: Any, svy: Any, t: Any, dx: Any, dy: Any, info: Any,
                weight: Any, ic: Any, tau: float, width: float, span: float, m2: float,
                grad: Any, A: Any, V: Any, c: Any, G: Any, Z: Any, store: bool,
                forward: bool, reverse: bool) -> float:  # pragma: no cover - compiled
    ns = sx.shape[0]
    K1 = t.shape[0]
    for i in range(10):
        for s in range(ns):
            c[i, s] = 0.0
    total = 0.0
    inv_wt = 1.0 / (width * tau)
    for k in range(K1 if forward else 0):
        tk = t[k]
        ik = info[k]
        dxk = dx[k]
        dyk = dy[k]
        a_k = A[k]
        v_k = V[k]
        for s in range(ns):
            rx = sx[s] + svx[s] * tk - dxk
            ry = sy[s] + svy[s] * tk - dyk
            r2 = max(rx * rx + ry * ry, m2)
            w = ik / (r2 * r2)
            g0 = ry
            g1 = -rx
            g2 = tk * ry
            g3 = -tk * rx
            c0 = c[0, s] + g0 * g0 * w
            c1 = c[1, s] + g0 * g1 * w
            c2 = c[2, s] + g0 * g2 * w
            c3 = c[3, s] + g0 * g3 * w
            c4 = c[4, s] + g1 * g1 * w
            c5 = c[5, s] + g1 * g2 * w
            c6 = c[6, s] + g1 * g3 * w
            c7 = c[7, s] + g2 * g2 * w
            c8 = c[8, s] + g2 * g3 * w
            c9 = c[9, s] + g3 * g3 * w
            c[0, s] = c0
            c[1, s] = c1
            c[2, s] = c2
            c[3, s] = c3
            c[4, s] = c4
            c[5, s] = c5
            c[6, s] = c6
            c[7, s] = c7
            c[8, s] = c8
            c[9, s] = c9
            f00 = c0 + ic[0]
            f01 = c1 + ic[1]
            f02 = c2 + ic[2]
            f03 = c3 + ic[3]
            f11 = c4 + ic[4]
            f12 = c5 + ic[5]
            f13 = c6 + ic[6]
            f22 = c7 + ic[7]
            f23 = c8 + ic[8]
            f33 = c9 + ic[9]
            # LDLᵀ, as tmaplan.bounds.lpc_terms.ldl
            d0 = f00
            l10 = f01 / d0
            l20 = f02 / d0
            l30 = f03 / d0
            d1 = f11 - l10 * f01
            ld21 = f12 - l20 * f01
            l21 = ld21 / d1
            ld31 = f13 - l30 * f01
            l31 = ld31 / d1
            d2 = f22 - l20 * f02 - l21 * ld21
            ld32 = f23 - l30 * f02 - l31 * ld21
            l32 = ld32 / d2
            d3 = f33 - l30 * f03 - l31 * ld31 - l32 * ld32
            r = np.sqrt(r2)
            ux = rx / r
            uy = ry / r
            y0 = ux
            y1 = uy - l10 * y0
            y2 = tk * ux - l20 * y0 - l21 * y1
            y3 = tk * uy - l30 * y0 - l31 * y1 - l32 * y2
            var = y0 * y0 / d0 + y1 * y1 / d1 + y2 * y2 / d2 + y3 * y3 / d3
            rel = np.sqrt(max(var, 0.0)) / r
            Z[s] = 0.5 * ((rel - tau) * inv_wt)
            if store:
                a3 = y3 / d3
                a2 = y2 / d2 - l32 * a3
                a1 = y1 / d1 - l21 * a2 - l31 * a3
                a0 = y0 / d0 - l10 * a1 - l20 * a2 - l30 * a3
                a_k[0, s] = a0
                a_k[1, s] = a1
                a_k[2, s] = a2
                a_k[3, s] = a3
                v_k[0, s] = var
                v_k[1, s] = r
                v_k[2, s] = rx
                v_k[3, s] = ry
        acc = 0.0
        for s in range(ns):
            th = np.tanh(Z[s])
            Z[s] = th
            acc += 0.5 * (1.0 + th)
        if store:
            for s in range(ns):
                v_k[4, s] = Z[s]
        total += weight[k] * acc
    scale = span / (K1 * ns)
    value = scale * total
    if not reverse:
        return value
    # reverse sweep: G holds Σ_{k' ≥ k} ∂value/∂F_k' (symmetric, packed)
    for i in range(10):
        for s in range(ns):
            G[i, s] = 0.0
    for k in range(K1 - 1, -1, -1):
        tk = t[k]
        ik = info[k]
        ck = scale * weight[k]
        a_k = A[k]
        v_k = V[k]
        for s in range(ns):
            var = v_k[0, s]
            r = v_k[1, s]
            rx = v_k[2, s]
            ry = v_k[3, s]
            th = v_k[4, s]
            a0 = a_k[0, s]
            a1 = a_k[1, s]
            a2 = a_k[2, s]
            a3 = a_k[3, s]
            adj_rel = ck * 0.25 * (1.0 - th * th) * inv_wt
            sq = np.sqrt(max(var, 0.0))
            adj_var = adj_rel / (2.0 * sq * r) if var > 0.0 else 0.0
            adj_r = -adj_rel * (sq / r) / r
            adj_ux = 2.0 * adj_var * (a0 + tk * a2)
            adj_uy = 2.0 * adj_var * (a1 + tk * a3)
            adj_rx = adj_ux / r
            adj_ry = adj_uy / r
            adj_r -= (adj_ux * rx + adj_uy * ry) / (r * r)
            m = -adj_var
            G0 = G[0, s] + m * a0 * a0
            G1 = G[1, s] + m * a0 * a1
            G2 = G[2, s] + m * a0 * a2
            G3 = G[3, s] + m * a0 * a3
            G4 = G[4, s] + m * a1 * a1
            G5 = G[5, s] + m * a1 * a2
            G6 = G[6, s] + m * a1 * a3
            G7 = G[7, s] + m * a2 * a2
            G8 = G[8, s] + m * a2 * a3
            G9 = G[9, s] + m * a3 * a3
            G[0, s] = G0
            G[1, s] = G1
            G[2, s] = G2
            G[3, s] = G3
            G[4, s] = G4
            G[5, s] = G5
            G[6, s] = G6
            G[7, s] = G7
            G[8, s] = G8
            G[9, s] = G9
            r2raw = rx * rx + ry * ry
            r2 = max(r2raw, m2)
            w = ik / (r2 * r2)
            g0 = ry
            g1 = -rx
            g2 = tk * ry
            g3 = -tk * rx
            Gg0 = G0 * g0 + G1 * g1 + G2 * g2 + G3 * g3
            Gg1 = G1 * g0 + G4 * g1 + G5 * g2 + G6 * g3
            Gg2 = G2 * g0 + G5 * g1 + G7 * g2 + G8 * g3
            Gg3 = G3 * g0 + G6 * g1 + G8 * g2 + G9 * g3
            adj_w = g0 * Gg0 + g1 * Gg1 + g2 * Gg2 + g3 * Gg3
            adj_ry += 2.0 * w * (Gg0 + tk * Gg2)
            adj_rx -= 2.0 * w * (Gg1 + tk * Gg3)
            adj_r2 = adj_r / (2.0 * r) - adj_w * 2.0 * ik / (r2 * r2 * r2)
            if r2raw <= m2:  # the floored range does not move with r
                adj_r2 = 0.0
            Z[s] = -(adj_rx + 2.0 * rx * adj_r2)
            v_k[0, s] = -(adj_ry + 2.0 * ry * adj_r2)
        gx = 0.0
        gy = 0.0
        for s in range(ns):
            gx += Z[s]
            gy += v_k[0, s]
        grad[0, k] = gx
        grad[1, k] = gy
    return value


def random_inputs(K1: int, ns: int, seed: int, *, floor: bool = False,
                  indefinite: bool = False) -> tuple[Any, ...]:
    """Arguments of the kernel up to ``m2`` in its scaled units (km, 100 s), of the size of a
    plan of ``K1`` steps and ``ns`` belief draws: draws about 16 km off, a wandering own-ship
    displacement, bearing information and 0/1 step weights (some steps without either).
    ``floor``: some draws pass within 100 m of the own ship (``r² ≤ m2``, and one at exactly
    the floor); ``indefinite``: a prior information that is not positive definite (a negative
    ``var``)."""
    rng = np.random.default_rng(seed)
    t = np.arange(K1) * 0.15
    dx = np.cumsum(rng.normal(0.0, 0.05, K1))
    dy = np.cumsum(rng.normal(0.0, 0.05, K1))
    sx = rng.normal(0.0, 3.0, ns)
    sy = rng.normal(16.0, 3.0, ns)
    svx = rng.normal(0.0, 0.4, ns)
    svy = rng.normal(-0.3, 0.4, ns)
    m2 = 0.1 ** 2
    if floor:
        for s in range(0, ns, 3):
            k = int(rng.integers(K1))
            sx[s] = dx[k] - svx[s] * t[k] + rng.normal(0.0, 0.03)
            sy[s] = dy[k] - svy[s] * t[k] + rng.normal(0.0, 0.03)
        dx[0] = dy[0] = 0.0
        sx[-1], sy[-1], svx[-1], svy[-1] = 0.1, 0.0, 0.0, 0.0  # at step 0, r² = m2 (to bits)
    info = rng.uniform(0.5, 2.0, K1) / np.radians(1.0) ** 2 * 1e-6
    info[rng.uniform(size=K1) < 0.1] = 0.0
    weight = (rng.uniform(size=K1) < 0.8).astype(float)
    L = rng.normal(0.0, 1.0, (4, 4)) * np.array([0.3, 0.3, 2.0, 2.0])
    icm = L @ L.T + np.diag([0.1, 0.1, 4.0, 4.0])
    if indefinite:
        icm = -1e-4 * icm  # (small: some draws keep var > 0 and a gradient)
    ic = icm[np.triu_indices(4)]
    return (sx, sy, svx, svy, t, dx, dy, info, weight, ic, 0.1, 0.25, t[-1] * 100.0 + 15.0,
            m2)


def workspace(K1: int, ns: int) -> tuple[Any, ...]:
    """The kernel's outputs and workspace, NaN-filled: grad, A, V, c, G, Z."""
    return tuple(np.full(shape, np.nan) for shape in
                 ((2, K1), (K1, 4, ns), (K1, 5, ns), (10, ns), (10, ns), (ns,)))
