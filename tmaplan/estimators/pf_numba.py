"""Numba kernels of the particle filter (``PFConfig.kernel = "numba"``).

Private helpers of :mod:`tmaplan.estimators.particle_filter`; the numpy kernels of
:mod:`tmaplan.estimators.pf_kernels` stay the reference (``kernel="numpy"``).

Design (issue 42: ≥ 10⁸ particle-steps/s at N = 10⁵ on 2 cores):

* **Blocks of fixed size.** Every kernel loops over blocks of :data:`BLOCK` particles in a
  ``prange`` and over the particles of a block in a plain inner loop that LLVM vectorises;
  reductions (maximum, sums, moments) are kept per block and combined in block order by one
  thread. The arithmetic done for a particle, and the order of every sum, depend only on N,
  never on the number of threads or their schedule: results are bit-identical for any
  ``numba.set_num_threads`` (and between the parallel and the serial build).
* **Few launches.** Waking numba's threads costs 50–100 µs a parallel launch on the 2-core VM
  of the speed record (passive OpenMP), so a step makes one (two when it resamples): the
  prediction is lazy (:class:`PredictedState`) and :func:`_fused_kernel` runs it with the
  likelihoods block by block (:mod:`tmaplan.estimators.pf_blocks`), and the resampling
  indices come with the gather. The serial build runs the kernels one after the other (the
  fused body is slower there). The same bits either way.
* **Counter-based random numbers.** The noise of particle i is Philox4x32-10 (Salmon et al.
  2011, "Parallel random numbers: as easy as 1, 2, 3"; Random123's known-answer vectors are
  tested) at counter ``(i, 0, s0, s1)`` under key ``(k0, k1)``, where (k0, k1, s0, s1) are four
  32-bit words drawn from the injected ``numpy.random.Generator`` once per kernel call. So the
  draws are a function of that Generator alone (deterministic, any thread count), at no
  serial cost: drawing 4 normals per particle with the Generator itself costs more than the
  whole fused step (``benchmarks/particle_filter.py`` reports it). The normals are Box–Muller
  on the 32-bit words, computed in float32 like the numpy kernel's default noise (radius at
  most 5.89: the Gaussian mass beyond, 3·10⁻⁸ per pair, is not drawn); the particles stay
  float64. A ziggurat (Marsaglia & Tsang 2000) on the same words was measured no faster here
  (its fast path alone, vectorised, costs what Box–Muller does: the table lookups become
  gathers, slow on AMD Zen 4), so Box–Muller stays, its polynomials in fused multiply-adds.
* **Recycled arrays.** The kernels' outputs come from :mod:`tmaplan.estimators.pf_buffers`,
  which reuses the memory of arrays nothing sees any more: fresh arrays cost ~430 page faults
  a step at N = 10⁵ (glibc returns the freed heap to the system), a third of the step.
* **Branch-free elementary functions** (float64 ``log``, ``atan``, ``exp``; float32 ``log``
  and ``sin``/``cos`` of a turn fraction) from fdlibm / Cephes polynomials, accurate to about
  1 ulp (tested against numpy), so that the loops vectorise without a vector math library:
  the same code, hence the same bits, whatever the SIMD width (the moments' sums excepted,
  below).
* ``fastmath=False`` (IEEE, no reassociation or contraction; the block sums alone are
  reassociated), ``error_model="numpy"`` (no division check in the loops),
  ``cache=True`` (compiled once per machine, then loaded).
* **Threads.** From :data:`PARALLEL_MIN` particles on, the parallel build runs on numba's
  threads (``NUMBA_NUM_THREADS``, ``numba.set_num_threads``); below, the serial build. OpenMP
  threads wait passively between kernels (``OMP_WAIT_POLICY=PASSIVE`` unless set): spinning
  threads take the cores from the one with work when other processes load the machine (a
  launch then waits ~20 ms instead of ~0.1 ms at load 11 on 2 cores). numba reads it when it
  starts its threads, at the first parallel kernel or ``numba.get_num_threads()``: a program
  that calls these before it imports this module keeps OpenMP's default.
"""

from __future__ import annotations

import math
import os
import threading
import types
from collections.abc import Sequence
from typing import Any

import numpy as np

from tmaplan.estimators import pf_buffers
from tmaplan.estimators.particle_filter import PFState
from tmaplan.estimators.pf_blocks import BLOCK, loglik_block, predict_block
from tmaplan.estimators.pf_kernels import (
    clutter_floor,
    frequency_update,
    measurement_ll,
    particle_rows,
)
from tmaplan.estimators.pf_math import (
    MASK32,
    SH32,
    U64,
    box_muller_f32,
    njit,
    numba,
    philox,
    prange,
)
from tmaplan.interrupts import compiled_entry

__all__ = ["BLOCK"]

#: From this many particles on, the parallel build runs (with numba's thread count); below,
#: the serial build (a parallel launch costs more than it saves, and campaign workers would
#: oversubscribe the cores). Both give the same bits.
PARALLEL_MIN = 8 * BLOCK
_FLAGS: dict[str, Any] = {"cache": True, "fastmath": False, "error_model": "numpy",
                          "nogil": True}


class _Kernel:
    """A parallel and a serial build of one kernel, called as ``kernel(n, *args)``: the
    parallel one from ``grain`` × :data:`PARALLEL_MIN` particles on when numba has more than
    one thread (``grain`` > 1 for a kernel so cheap per particle that waking the threads costs
    more than it saves below that: both builds give the same bits)."""

    def __init__(self, fn: Any, flags: dict[str, Any], grain: int = 1) -> None:
        serial = types.FunctionType(fn.__code__, fn.__globals__, fn.__name__ + "_serial",
                                    fn.__defaults__, fn.__closure__)
        serial.__qualname__ = fn.__qualname__ + "_serial"  # its own cache file
        self.par = njit(parallel=True, **flags)(fn)
        self.ser = njit(**flags)(serial)
        self.grain = grain
        self.__doc__ = fn.__doc__

    def parallel(self, n: int) -> bool:
        """Whether a call for ``n`` particles runs the parallel build."""
        return n >= PARALLEL_MIN * self.grain and numba.get_num_threads() > 1

    @compiled_entry
    def __call__(self, n: int, *args: Any) -> None:
        (self.par if self.parallel(n) else self.ser)(*args)


def _kernel(grain: int = 1, **flags: Any) -> Any:
    """Decorator: :class:`_Kernel` with :data:`_FLAGS` updated by ``flags``."""
    return lambda fn: _Kernel(fn, _FLAGS | flags, grain)

# --------------------------------------------------------------------------------------------
# Kernels (blocks in a prange; see the module docstring)
# --------------------------------------------------------------------------------------------


def _n_blocks(n: int) -> int:
    return (n + BLOCK - 1) // BLOCK


# Each kernel: ``for blk in prange(nb)`` over blocks; the loops inside run over 1-D views of
# the block (``x = A[0, lo:lo + m]``, index j from 0): the form that LLVM vectorises.


@_kernel()
def _predict_kernel(A: np.ndarray, out: np.ndarray, dt: float, l11: float, l21: float,
                    l22: float, dvx: float, dvy: float, key: np.ndarray) -> None:
    """``out = F A − H Δv + w`` on (4, N) rows, w the NCV noise from 4 Philox normals."""
    n = A.shape[1]
    for blk in prange((n + BLOCK - 1) // BLOCK):
        lo = blk * BLOCK
        predict_block(A, out, lo, min(BLOCK, n - lo), dt, l11, l21, l22, dvx, dvy, key)


@_kernel()
def _loglik_kernel(A: np.ndarray, lw: np.ndarray, bear: np.ndarray, rng_: np.ndarray,
                   extra: np.ndarray, out: np.ndarray, w: np.ndarray,
                   part: np.ndarray) -> None:
    """``out = lw + Σ log-likelihoods`` (up to constants) and, per block b, its maximum m_b
    over the finite values, the number of NaN or +inf values, and (when there is none and
    m_b is finite) ``w = exp(out − m_b)`` with Σw and Σw²: ``part[b]`` = (m_b, #bad, Σw, Σw²).

    ``bear`` rows (sin z, cos z, 1/(√2 σ), |wrap z|, clutter floor or −inf): Gaussian in the
    wrapped residual ``|d| = |atan2(sin(z − β), cos(z − β))|``, optionally mixed with clutter;
    ``rng_`` rows (z, 1/(√2 σ)): Gaussian range; ``extra`` (N,) or (0,): added as is.
    """
    for blk in prange((A.shape[1] + BLOCK - 1) // BLOCK):
        loglik_block(A, lw, bear, rng_, extra, out, w, part, blk)


@_kernel()
def _fused_kernel(A: np.ndarray, cloud: np.ndarray, dt: float, l11: float, l21: float,
                  l22: float, dvx: float, dvy: float, key: np.ndarray, lw: np.ndarray,
                  bear: np.ndarray, rng_: np.ndarray, out: np.ndarray, w: np.ndarray,
                  part: np.ndarray) -> None:
    """:func:`_predict_kernel` (``A`` → ``cloud``) and :func:`_loglik_kernel` (``cloud`` →
    ``out``, ``w``, ``part``; no ``extra``) in one launch, block by block: the same bits as
    the two kernels one after the other, one parallel launch and one pass over memory."""
    n = A.shape[1]
    for blk in prange((n + BLOCK - 1) // BLOCK):
        lo = blk * BLOCK
        predict_block(A, cloud, lo, min(BLOCK, n - lo), dt, l11, l21, l22, dvx, dvy, key)
        loglik_block(cloud, lw, bear, rng_, lw[:0], out, w, part, blk)


# 0.2 ns a particle: waking the threads (~40 µs on the 2-core VM of the speed record) pays
# from about half a million particles on
@_kernel(grain=32)
def _scale_kernel(lw: np.ndarray, w: np.ndarray, shift: float, scale: np.ndarray) -> None:
    """``lw −= shift``, ``w *= scale[b]`` in block b (normalisation)."""
    n = lw.shape[0]
    nb = (n + BLOCK - 1) // BLOCK
    for blk in prange(nb):
        lo = blk * BLOCK
        m = min(BLOCK, n - lo)
        p, o, f = lw[lo:lo + m], w[lo:lo + m], scale[blk]
        for j in range(m):
            p[j] = p[j] - shift
            o[j] = o[j] * f


@compiled_entry
@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _cumsum_kernel(w: np.ndarray, c: np.ndarray) -> None:
    """``c = cumsum(w)`` in numpy's order (sequential): the resampling CDF bit for bit."""
    t = 0.0
    for i in range(w.shape[0]):
        t += w[i]
        c[i] = t


@_kernel()
def _systematic_kernel(c: np.ndarray, u: float, idx: np.ndarray, A: np.ndarray,
                       out: np.ndarray) -> None:
    """Systematic resampling indices from the CDF ``c`` of normalised weights and one uniform
    u: the arithmetic of :func:`tmaplan.estimators.pf_kernels.systematic_indices`, so the same
    indices bit for bit. With ``c'_i = max(⌈(N / c_{N−1}) c_i − u⌉, 0)`` (``c'_{N−1} = N``),
    non-decreasing, output position j takes ``#{i : c'_i ≤ j}``. Block b owns the positions
    ``[c'_{lo−1}, c'_{hi−1})``; each of its particles marks ``t = c'_i`` with i + 1 (the last
    one wins), and a running maximum over the marks gives the count: no branch per particle.
    When ``out`` has N columns, block b also copies ``A[:, idx[j]]`` to ``out[:, j]`` for its
    positions j (the gather of :func:`_gather_kernel` without jitter, in the same launch).
    """
    n = c.shape[0]
    nb = (n + BLOCK - 1) // BLOCK
    scale = n / c[n - 1]
    for blk in prange(nb):
        lo = blk * BLOCK
        hi = min(lo + BLOCK, n)
        m = hi - lo
        p0 = 0 if lo == 0 else max(math.ceil(c[lo - 1] * scale - u), 0)
        p1 = n if hi == n else max(math.ceil(c[hi - 1] * scale - u), 0)
        if p1 > p0:
            cb = c[lo:hi]
            slot = np.empty(m, dtype=np.intp)  # min(c'_i, p1) − p0, in a loop that vectorises
            for j in range(m):
                slot[j] = min(max(np.intp(np.ceil(cb[j] * scale - u)), 0), p1) - p0
            if hi == n:
                slot[m - 1] = p1 - p0  # c'_{N−1} = N
            mark = np.zeros(p1 - p0 + 1, dtype=np.intp)  # the last slot takes c'_i ≥ p1
            for j in range(m):
                mark[slot[j]] = lo + j + 1
            run = lo
            ib = idx[p0:p1]
            for t in range(p1 - p0):
                run = max(run, mark[t])
                ib[t] = run
            if out.shape[1] == n:
                a0, a1, a2, a3 = A[0], A[1], A[2], A[3]
                o0, o1, o2, o3 = out[0, p0:p1], out[1, p0:p1], out[2, p0:p1], out[3, p0:p1]
                for t in range(p1 - p0):
                    o0[t], o1[t], o2[t], o3[t] = a0[ib[t]], a1[ib[t]], a2[ib[t]], a3[ib[t]]


@_kernel()
def _gather_kernel(A: np.ndarray, idx: np.ndarray, L: np.ndarray, key: np.ndarray,
                   jitter: bool, out: np.ndarray) -> None:
    """``out[:, j] = A[:, idx[j]] (+ L z_j)``, z_j 4 Philox normals, L lower triangular."""
    n = idx.shape[0]
    nb = (n + BLOCK - 1) // BLOCK
    k0, k1, s0, s1 = key[0], key[1], key[2], key[3]
    a0, a1, a2, a3 = A[0], A[1], A[2], A[3]
    l00, l10, l11, l20, l21, l22 = L[0, 0], L[1, 0], L[1, 1], L[2, 0], L[2, 1], L[2, 2]
    l30, l31, l32, l33 = L[3, 0], L[3, 1], L[3, 2], L[3, 3]
    for blk in prange(nb):
        lo = blk * BLOCK
        m = min(BLOCK, n - lo)
        ix = idx[lo:lo + m]
        o0, o1, o2, o3 = out[0, lo:lo + m], out[1, lo:lo + m], out[2, lo:lo + m], out[3, lo:lo + m]
        for j in range(m):
            o0[j], o1[j], o2[j], o3[j] = a0[ix[j]], a1[ix[j]], a2[ix[j]], a3[ix[j]]
        if jitter:
            for j in range(m):
                r0, r1, r2, r3 = philox(U64(lo + j), U64(0), s0, s1, k0, k1)
                z0, z1 = box_muller_f32(r0, r1)
                z2, z3 = box_muller_f32(r2, r3)
                o0[j] = o0[j] + l00 * z0  # the numpy kernel's order (row by row)
                o1[j] = (o1[j] + l10 * z0) + l11 * z1
                o2[j] = ((o2[j] + l20 * z0) + l21 * z1) + l22 * z2
                o3[j] = (((o3[j] + l30 * z0) + l31 * z1) + l32 * z2) + l33 * z3


@_kernel(fastmath={"reassoc"})
def _moments_kernel(A: np.ndarray, w: np.ndarray, part: np.ndarray) -> None:
    """Per-block Σw, Σw·d and Σw·d dᵀ (upper triangle, row by row) of d = x − x₀ (x₀ =
    particle 0, a shift against cancellation): ``part`` (n_blocks, 15).

    The one kernel compiled with reassociation (``fastmath={"reassoc"}``), so that LLVM
    vectorises its sums: their order is then fixed by the compiled code and the block, still
    independent of the threads.
    """
    n = A.shape[1]
    nb = (n + BLOCK - 1) // BLOCK
    o0, o1, o2, o3 = A[0, 0], A[1, 0], A[2, 0], A[3, 0]
    for blk in prange(nb):
        lo = blk * BLOCK
        m = min(BLOCK, n - lo)
        x0, x1, x2, x3 = A[0, lo:lo + m], A[1, lo:lo + m], A[2, lo:lo + m], A[3, lo:lo + m]
        wb = w[lo:lo + m]
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = s8 = s9 = s10 = s11 = s12 = s13 = s14 = 0.0
        for j in range(m):
            wi = wb[j]
            d0, d1, d2, d3 = x0[j] - o0, x1[j] - o1, x2[j] - o2, x3[j] - o3
            e0, e1, e2, e3 = wi * d0, wi * d1, wi * d2, wi * d3
            s0 += wi
            s1 += e0
            s2 += e1
            s3 += e2
            s4 += e3
            s5 += e0 * d0
            s6 += e0 * d1
            s7 += e0 * d2
            s8 += e0 * d3
            s9 += e1 * d1
            s10 += e1 * d2
            s11 += e1 * d3
            s12 += e2 * d2
            s13 += e2 * d3
            s14 += e3 * d3
        sums = (s0, s1, s2, s3, s4, s5, s6, s7, s8, s9, s10, s11, s12, s13, s14)
        for q in range(15):
            part[blk, q] = sums[q]


# --------------------------------------------------------------------------------------------
# Python entry points
# --------------------------------------------------------------------------------------------

# Before numba starts its OpenMP threads (at the first parallel kernel); the user's choice wins.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
_LOCK = threading.Lock()  # one launch at a time (numba's workqueue layer needs it)


def _key(rng: np.random.Generator) -> np.ndarray:
    """Four 32-bit words (key k0, k1; counter words s0, s1): two raw 64-bit draws of the
    injected Generator's bit generator (a tenth of the cost of ``integers``)."""
    r = np.asarray(rng.bit_generator.random_raw(2), dtype=np.uint64)
    return np.array([r[0] & MASK32, r[0] >> SH32, r[1] & MASK32, r[1] >> SH32],
                    dtype=np.uint64)


def predict_rows(A: np.ndarray, dt: float, chol: tuple[float, float, float], dv: np.ndarray,
                 rng: np.random.Generator | np.ndarray) -> np.ndarray:
    """The predicted (4, N) cloud (see :func:`_predict_kernel`); ``rng`` may be a key."""
    return Prediction(A, dt, chol, dv, rng).rows()


class Prediction:
    """A prediction of the (4, N) cloud ``A`` (:func:`_predict_kernel`), its random key drawn
    from ``rng`` now, computed when :meth:`rows` is first called, or together with the
    update's log-weights by :func:`log_weights` (one parallel launch for both)."""

    __slots__ = ("A", "args", "key", "result")

    def __init__(self, A: np.ndarray, dt: float, chol: tuple[float, float, float],
                 dv: np.ndarray, rng: np.random.Generator | np.ndarray) -> None:
        self.A = A
        l11, l21, l22 = chol
        self.args = (float(dt), float(l11), float(l21), float(l22), float(dv[0]), float(dv[1]))
        self.key = (np.asarray(rng, dtype=np.uint64) if isinstance(rng, np.ndarray)
                    else _key(rng))
        self.result: np.ndarray | None = None

    def rows(self) -> np.ndarray:
        """The predicted (4, N) cloud."""
        if self.result is None:
            out = pf_buffers.empty(self.A.shape)
            with _LOCK:
                _predict_kernel(self.A.shape[1], self.A, out, *self.args, self.key)
            self.result = out
            self.A = _NO_CLOUD  # the source cloud is no longer needed
        return self.result


class PredictedState(PFState):
    """A :class:`~tmaplan.estimators.particle_filter.PFState` made with ``particles`` a
    :class:`Prediction`: the particles are computed when first read, or by the update together
    with the log-weights (:func:`log_weights`, one parallel launch)."""

    @property
    def particles(self) -> np.ndarray:
        d = self.__dict__
        if d.get("particles") is None:
            d["particles"] = d["pending"].rows().T
        return d["particles"]

    @particles.setter
    def particles(self, value: np.ndarray | Prediction) -> None:
        pending = isinstance(value, Prediction)
        self.__dict__["pending"] = value if pending else None
        self.__dict__["particles"] = None if pending else value


def pending(state: Any) -> Prediction | None:
    """The prediction of a :class:`PredictedState` not computed yet, else None."""
    d = state.__dict__
    return d.get("pending") if d.get("particles") is None else None


def normals(key: np.ndarray, n: int) -> np.ndarray:
    """The (4, n) standard normals (rows z1x, z1y, z2x, z2y) that :func:`_predict_kernel` and
    :func:`_gather_kernel` draw under ``key`` (four uint64 < 2³²), exactly: a prediction of
    the zero cloud with dt = 0 and a unit Cholesky factor."""
    return predict_rows(np.zeros((4, n)), 0.0, (1.0, 0.0, 1.0), np.zeros(2), np.asarray(key))


def log_weights(state: Any, measurements: Sequence[Any], config: Any, move: bool,
                pending: Prediction | None = None
                ) -> tuple[np.ndarray, float, Any, Any, np.ndarray | None, Any]:
    """The unnormalised updated log-weights ``log w + Σ log p(z | x)`` of ``state`` (a
    :class:`~tmaplan.estimators.particle_filter.PFState`), as the numpy kernel computes them.

    Plain and clutter-mixture bearings and ranges go through :func:`_loglik_kernel`;
    π-ambiguous bearings and frequency lines through their numpy kernels. When the state's
    particles are the ``pending`` prediction, not yet computed, and there are no others, the
    prediction and these log-weights are computed in one launch (:func:`_fused_kernel`).

    Returns
    -------
    lw : ndarray, shape (N,)
    mx : float
        max(lw), NaN when some lw is NaN or +inf.
    freq_mean, freq_var : ndarray, shape (N, P), or None
        Updated by the frequency lines.
    ll : ndarray, shape (N,), or None
        Σ log p(z | x) alone (when ``move``).
    parts : tuple
        What :func:`normalise` needs of this pass (when mx is finite).
    """
    clutter = float(config.bearing_clutter)
    bear: list[tuple[float, ...]] = []
    ranges: list[tuple[float, float]] = []
    others: list[Any] = []
    for m in measurements:
        if m.kind == "bearing" and m.ambiguity == "none":
            z, sigma = float(m.value), float(m.sigma)
            fl = clutter_floor(sigma, clutter, 2.0 * math.pi) if clutter > 0.0 else -np.inf
            bear.append((math.sin(z), math.cos(z), math.sqrt(0.5) / sigma,
                         abs(z - 2.0 * math.pi * round(z / (2.0 * math.pi))), fl))
        elif m.kind == "range":
            ranges.append((float(m.value), math.sqrt(0.5) / float(m.sigma)))
        else:
            others.append(m)
    B = np.array(bear, dtype=float).reshape(-1, 5)
    R = np.array(ranges, dtype=float).reshape(-1, 2)
    fm, fv = state.freq_mean, state.freq_var
    extra: np.ndarray | None = None
    if pending is not None and pending.result is None and not others:
        A, lw, parts = _predict_and_weigh(pending, state.log_weights, B, R)
    else:
        X = state.particles
        A = particle_rows(X)
        for m in others:
            if m.kind == "frequency":
                c, fm, fv = frequency_update(X, m, fm, fv)
            else:
                c = measurement_ll(X, m, clutter)
            extra = c if extra is None else extra + c
        lw, parts = _weigh(A, state.log_weights, B, R, extra)
    ll = _weigh(A, np.zeros(A.shape[1]), B, R, extra)[0] if move else None
    mx = math.nan if parts[1][:, 1].any() else float(parts[1][:, 0].max())
    return lw, mx, fm, fv, ll, parts


@compiled_entry
def _predict_and_weigh(pending: Prediction, lw: np.ndarray, bear: np.ndarray,
                       ranges: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The predicted cloud of ``pending`` and :func:`_weigh` of it, in one launch."""
    A = pending.A
    n = A.shape[1]
    cloud = pf_buffers.empty(A.shape)
    out, w = pf_buffers.empty(n), pf_buffers.empty(n)
    part = np.zeros((_n_blocks(n), 4))
    lw = np.ascontiguousarray(lw, dtype=float)
    with _LOCK:
        if _fused_kernel.parallel(n):
            _fused_kernel.par(A, cloud, *pending.args, pending.key, lw, bear, ranges, out, w,
                              part)
        else:  # no launch to save: the two serial kernels, faster one after the other
            _predict_kernel.ser(A, cloud, *pending.args, pending.key)
            _loglik_kernel.ser(cloud, lw, bear, ranges, lw[:0], out, w, part)
    pending.result = cloud
    pending.A = _NO_CLOUD
    return cloud, out, (w, part)


def _weigh(A: np.ndarray, lw: np.ndarray, bear: np.ndarray, ranges: np.ndarray,
           extra: np.ndarray | None) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """``lw`` plus the log-likelihoods, and the parts (w, per-block table) of
    :func:`_loglik_kernel`."""
    n = lw.shape[0]
    out, w = pf_buffers.empty(n), pf_buffers.empty(n)
    part = np.zeros((_n_blocks(n), 4))
    ex = np.empty(0) if extra is None else np.ascontiguousarray(extra, dtype=float)
    with _LOCK:
        _loglik_kernel(n, A, np.ascontiguousarray(lw, dtype=float), bear, ranges, ex, out, w,
                       part)
    return out, (w, part)


_NO_ROWS = (np.zeros((0, 5)), np.zeros((0, 2)))
_NO_CLOUD = np.zeros((4, 0))


def normalise(lw: np.ndarray, parts: tuple[np.ndarray, np.ndarray] | None = None
              ) -> tuple[np.ndarray, float]:
    """Normalise log-weights ``lw`` (finite maximum; NaN, +inf excluded) in place: the
    weights and the ESS ``(Σw)²/Σw²``; ``parts`` from :func:`log_weights` if at hand.

    With the block maxima m_b and M = max m_b, block b's weights ``exp(lw − m_b)`` are scaled
    by ``e^(m_b − M)/Σw``, and ``lw`` shifted by ``M + log Σw``.
    """
    if parts is None:
        _, parts = _weigh(np.zeros((2, lw.shape[0])), lw, *_NO_ROWS, None)
    w, part = parts
    shift, f, ess = _weights_finish(part)
    with _LOCK:
        _scale_kernel(lw.shape[0], lw, w, shift, f)
    return w, ess


@compiled_entry
@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _weights_finish(part: np.ndarray) -> tuple[float, np.ndarray, float]:
    """From the per-block (m_b, #bad, Σw, Σw²) of :func:`_loglik_kernel`: the log-weight shift
    ``M + log Σw``, the block factors ``e^(m_b − M)/Σw`` and the ESS (sums in block order)."""
    nb = part.shape[0]
    M = -np.inf
    for b in range(nb):
        M = max(M, part[b, 0])
    f = np.empty(nb)
    tot = 0.0
    ssq = 0.0
    for b in range(nb):
        f[b] = math.exp(part[b, 0] - M)  # 0 for a block of −inf only
        tot += part[b, 2] * f[b]
        ssq += part[b, 3] * (f[b] * f[b])
    for b in range(nb):
        f[b] = f[b] / tot
    return M + math.log(tot), f, tot * tot / ssq


def systematic(w: np.ndarray, u: float) -> np.ndarray:
    """Systematic resampling indices from normalised weights and one uniform (the indices of
    :func:`tmaplan.estimators.pf_kernels.systematic_indices` for the same u, bit for bit)."""
    return resample(w, u, None)[0]


def resample(w: np.ndarray, u: float, A: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray | None]:
    """Systematic resampling indices (:func:`systematic`) and, when the (4, N) cloud ``A``
    is given, the resampled cloud ``A[:, idx]``, in one parallel launch."""
    n = w.shape[0]
    c = pf_buffers.empty(n)
    idx = pf_buffers.empty(n, np.intp)
    out = _NO_CLOUD if A is None else pf_buffers.empty((4, n))
    with _LOCK:
        _cumsum_kernel(w, c)
        _systematic_kernel(n, c, float(u), idx, _NO_CLOUD if A is None else A, out)
    return idx, None if A is None else out


def gather(A: np.ndarray, idx: np.ndarray, L: np.ndarray | None,
           rng: np.random.Generator | np.ndarray | None) -> np.ndarray:
    """``A[:, idx]``, plus ``L z`` per particle (4 Philox normals; ``rng`` a Generator or a
    key) when L is given."""
    out = pf_buffers.empty((4, idx.shape[0]))
    jitter = L is not None and rng is not None
    Lm = np.ascontiguousarray(L, dtype=float) if jitter else np.zeros((4, 4))
    key = (np.asarray(rng, dtype=np.uint64) if isinstance(rng, np.ndarray)
           else _key(rng) if rng is not None and jitter else np.zeros(4, dtype=np.uint64))
    with _LOCK:
        _gather_kernel(idx.shape[0], A, np.ascontiguousarray(idx, dtype=np.intp), Lm, key,
                       jitter, out)
    return out


def full(n: int, value: float) -> np.ndarray:
    """``numpy.full(n, value)`` in recycled memory (:func:`pf_buffers.empty`)."""
    out = pf_buffers.empty(n)
    out.fill(value)
    return out


def moments(A: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean (4,) and covariance (4, 4) of a (4, N) cloud with normalised weights w."""
    part = np.empty((_n_blocks(A.shape[1]), 15))
    with _LOCK:
        _moments_kernel(A.shape[1], A, w, part)
    return _moments_finish(part, A[:, 0].copy())


@compiled_entry
@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _moments_finish(part: np.ndarray, x0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance from the per-block sums of :func:`_moments_kernel` (block order)."""
    s = np.zeros(15)
    for b in range(part.shape[0]):
        for q in range(15):
            s[q] += part[b, q]
    m = s[1:5] / s[0]
    C = np.empty((4, 4))
    k = 5
    for r in range(4):
        for t in range(r, 4):
            C[r, t] = s[k] / s[0] - m[r] * m[t]
            C[t, r] = C[r, t]
            k += 1
    return x0 + m, C
