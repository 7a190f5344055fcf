"""The per-block bodies of the particle filter's numba kernels (:mod:`pf_numba`).

Each function computes one block of :data:`BLOCK` particles; the kernels of
:mod:`tmaplan.estimators.pf_numba` run them in a ``prange`` over blocks, one kernel or several
fused in one launch (the prediction and the likelihoods: :func:`predict_block` then
:func:`loglik_block` on the same block), with the same bits either way: the arithmetic of a
particle and the order of every sum depend on the block alone. Inlined (``inline="always"``)
so that the loops vectorise inside each kernel (see :mod:`tmaplan.estimators.pf_math`).
"""

from __future__ import annotations

import math

import numpy as np

from tmaplan.estimators.pf_math import (
    U64,
    abs_atan2,
    box_muller_f32,
    fast_exp,
    fast_log,
    njit,
    philox,
)

__all__ = ["BLOCK", "block_sums", "loglik_block", "max_bad", "predict_block"]

#: Particles per block: the unit of work of a thread and of every partial sum.
BLOCK = 2048


@njit(fastmath={"reassoc"}, error_model="numpy", nogil=True)
def block_sums(v: np.ndarray) -> tuple[float, float]:
    """(Σv, Σv²) of one block, reassociated so that LLVM vectorises them: the order is then
    fixed by the compiled code and the block's length, not by the threads."""
    a = 0.0
    b = 0.0
    for j in range(v.shape[0]):
        a += v[j]
        b += v[j] * v[j]
    return a, b


@njit(inline="always")
def max_bad(o: np.ndarray) -> tuple[float, int]:
    """(maximum, number of NaN or +inf values) of one block; the maximum in 8 interleaved
    lanes, a NaN never selected (−inf for a block of NaN or −inf only)."""
    m = o.shape[0]
    m8 = m - m % 8
    l0 = l1 = l2 = l3 = l4 = l5 = l6 = l7 = -np.inf
    for j in range(0, m8, 8):
        v0, v1, v2, v3 = o[j], o[j + 1], o[j + 2], o[j + 3]
        v4, v5, v6, v7 = o[j + 4], o[j + 5], o[j + 6], o[j + 7]
        l0, l1 = (v0 if v0 > l0 else l0), (v1 if v1 > l1 else l1)
        l2, l3 = (v2 if v2 > l2 else l2), (v3 if v3 > l3 else l3)
        l4, l5 = (v4 if v4 > l4 else l4), (v5 if v5 > l5 else l5)
        l6, l7 = (v6 if v6 > l6 else l6), (v7 if v7 > l7 else l7)
    mx = max(max(max(l0, l1), max(l2, l3)), max(max(l4, l5), max(l6, l7)))
    for j in range(m8, m):
        mx = o[j] if o[j] > mx else mx
    bad = 0
    for j in range(m):
        bad += 0 if o[j] < np.inf else 1
    return mx, bad


@njit(inline="always")
def predict_block(A: np.ndarray, out: np.ndarray, lo: int, m: int, dt: float, l11: float,
                   l21: float, l22: float, dvx: float, dvy: float, key: np.ndarray) -> None:
    """Particles ``lo … lo + m − 1`` of :func:`tmaplan.estimators.pf_numba._predict_kernel`."""
    k0, k1, s0, s1 = key[0], key[1], key[2], key[3]
    pdx, pdy = dt * dvx, dt * dvy
    x, y, vx, vy = A[0, lo:lo + m], A[1, lo:lo + m], A[2, lo:lo + m], A[3, lo:lo + m]
    ox, oy = out[0, lo:lo + m], out[1, lo:lo + m]
    ovx, ovy = out[2, lo:lo + m], out[3, lo:lo + m]
    for j in range(m):
        r0, r1, r2, r3 = philox(U64(lo + j), U64(0), s0, s1, k0, k1)
        z1x, z1y = box_muller_f32(r0, r1)
        z2x, z2y = box_muller_f32(r2, r3)
        ox[j] = ((x[j] + dt * vx[j]) + l11 * z1x) - pdx
        oy[j] = ((y[j] + dt * vy[j]) + l11 * z1y) - pdy
        ovx[j] = (vx[j] + (l21 * z1x + l22 * z2x)) - dvx
        ovy[j] = (vy[j] + (l21 * z1y + l22 * z2y)) - dvy


@njit(inline="always")
def loglik_block(A: np.ndarray, lw: np.ndarray, bear: np.ndarray, rng_: np.ndarray,
                  extra: np.ndarray, out: np.ndarray, w: np.ndarray, part: np.ndarray,
                  blk: int) -> None:
    """Block ``blk`` of :func:`tmaplan.estimators.pf_numba._loglik_kernel`."""
    n = A.shape[1]
    lo = blk * BLOCK
    m = min(BLOCK, n - lo)
    x, y, o, p = A[0, lo:lo + m], A[1, lo:lo + m], out[lo:lo + m], lw[lo:lo + m]
    if extra.shape[0] == n:
        e = extra[lo:lo + m]
        for j in range(m):
            o[j] = p[j] + e[j]
    else:
        for j in range(m):
            o[j] = p[j]
    for k in range(bear.shape[0]):
        sz, cz, g, d0, fl = bear[k, 0], bear[k, 1], bear[k, 2], bear[k, 3], bear[k, 4]
        if fl == -np.inf:
            for j in range(m):
                d = abs_atan2(sz * y[j] - cz * x[j], cz * y[j] + sz * x[j])
                d = (d0 if (x[j] == 0.0 and y[j] == 0.0) else d) * g
                o[j] = o[j] - d * d
        else:  # log(e^ll + e^fl) = max + log(1 + e^(min − max))
            for j in range(m):
                d = abs_atan2(sz * y[j] - cz * x[j], cz * y[j] + sz * x[j])
                d = (d0 if (x[j] == 0.0 and y[j] == 0.0) else d) * g
                ll = -(d * d)
                hi = max(ll, fl)
                o[j] = o[j] + (hi + fast_log(1.0 + fast_exp(min(ll, fl) - hi)))
    for k in range(rng_.shape[0]):
        z, g = rng_[k, 0], rng_[k, 1]
        for j in range(m):
            d = (z - math.sqrt(x[j] * x[j] + y[j] * y[j])) * g
            o[j] = o[j] - d * d
    mx, bad = max_bad(o)
    part[blk, 0] = mx
    part[blk, 1] = bad
    wb = w[lo:lo + m]
    if bad == 0 and mx > -np.inf:
        for j in range(m):
            wb[j] = fast_exp(o[j] - mx)
        part[blk, 2], part[blk, 3] = block_sums(wb)
    else:
        for j in range(m):
            wb[j] = 0.0
        part[blk, 2], part[blk, 3] = 0.0, 0.0
