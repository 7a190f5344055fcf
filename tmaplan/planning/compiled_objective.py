"""The expected time to accuracy and its gradient as one compiled kernel (issue 42).

Role: a compiled evaluation of :func:`tmaplan.planning.objectives.expected_time_to_accuracy`'s
main term, the same formula as its casadi graph (:func:`tmaplan.planning.objectives.
not_localised_graph` and :func:`tmaplan.planning.objectives.expected_time_of`, which stay the
reference the tests hold this kernel to, and the form whose second derivatives the real-time
iteration's model needs). For each belief draw s and step k (lecadre1997 eq. 64–65, the batch
bearings CRLB with prior information, in the scaled units km and 100 s of
:func:`tmaplan.planning.objective_graphs.relative_range_crlb_graph`):

* ``r_ks = p₀ₛ + t_k v₀ₛ − d_k`` with ``d_k`` the own ship's displacement beyond constant
  velocity, ``r²`` floored at (100 m)²;
* ``F_ks = I₀ + Σ_{j≤k} info_j g_js g_jsᵀ / r⁴_js``, ``g = [r_y, −r_x, t r_y, −t r_x]``;
* ``ρ_ks = sqrt(q_ksᵀ F_ks⁻¹ q_ks) / r_ks``, ``q = [u, t u]`` (u the line of sight), by the
  LDLᵀ factorisation of :func:`tmaplan.bounds.lpc_terms.ldl`;
* the value ``span · Σ_k w_k mean_s σ((ρ_ks − τ)/(wτ)) / (K+1)`` (σ logistic).

The gradient with respect to ``d`` is the hand-written reverse sweep of that recursion
(``dρ² = 2 aᵀ dq − aᵀ dF a`` with ``a = F⁻¹ q``, the adjoints of the cumulative sums summed
backwards over the steps): one pass forward, one back, the draws innermost, no
allocation. On ``default`` (121 steps, 128 draws) the value and gradient take about a seventh
of the casadi graph's time, with the same values to ~1e-13 (docs/findings.md). Each step's
loop over the draws is split in a few, each touching few arrays, which LLVM vectorises (the
same bits; twice as fast as one loop a step, benchmarks/compiled_objective.py).

:func:`compiled_expected_time` wraps it as a ``casadi.Callback`` with a reverse derivative, so
IPOPT and the converged SQP use it unchanged; the callback has no derivative with respect to
the parameter vector (that adjoint is NaN: nothing solves for it) and none of second order.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np
from numba import njit

from tmaplan.interrupts import as_interrupt, compiled_entry, defer

__all__ = ["compiled_all_contacts_time", "compiled_expected_time", "expected_time_value_grad"]

_L = 1000.0  # length scale [m] (as tmaplan.planning.objective_graphs)
_T = 100.0  # time scale [s]
_MIN_RANGE = 100.0  # floor of the range [m]


@njit(inline="always")
def _copy_row(dst: Any, i: int, src: Any, j: int) -> None:  # pragma: no cover - compiled
    for s in range(dst.shape[1]):
        dst[i, s] = src[j, s]


@compiled_entry
@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _value_grad(sx: Any, sy: Any, svx: Any, svy: Any, t: Any, dx: Any, dy: Any, info: Any,
                weight: Any, ic: Any, tau: float, width: float, span: float, m2: float,
                grad: Any, A: Any, V: Any, c: Any, G: Any, Z: Any, store: bool,
                forward: bool, reverse: bool,
                seed: Any = None) -> float:  # pragma: no cover - compiled
    # Each loop over the draws reads few arrays and writes rows of arrays that do not depend
    # on the step k (c, G, Z): LLVM then vectorises it (AVX2) behind runtime overlap checks
    # that pass. A loop that wrote one row of A[k] or V[k] and touched another would have
    # its checks hoisted out of the loop over k, over all of A or V, fail, and run scalar.
    # Same operations in the same order as one loop per step: the same bits.
    ns = sx.shape[0]
    K1 = t.shape[0]
    for i in range(10):
        for s in range(ns):
            c[i, s] = 0.0
    total = 0.0
    inv_wt = 1.0 / (width * tau)
    ic0, ic1, ic2, ic3, ic4 = ic[0], ic[1], ic[2], ic[3], ic[4]
    ic5, ic6, ic7, ic8, ic9 = ic[5], ic[6], ic[7], ic[8], ic[9]
    W = G  # the forward pass's rows, V[k]'s then A[k]'s: var r rx ry z a0 a1 a2 a3
    for k in range(K1 if forward else 0):
        tk = t[k]
        ik = info[k]
        dxk = dx[k]
        dyk = dy[k]
        for s in range(ns):
            rx = sx[s] + svx[s] * tk - dxk
            ry = sy[s] + svy[s] * tk - dyk
            r2 = max(rx * rx + ry * ry, m2)
            W[0, s] = ik / (r2 * r2)  # w until the next loop writes var
            W[1, s] = np.sqrt(r2)
            W[2, s] = rx
            W[3, s] = ry
        for s in range(ns):
            w = W[0, s]
            g0 = W[3, s]
            g1 = -W[2, s]
            g2 = tk * W[3, s]
            g3 = -tk * W[2, s]
            c[0, s] = c[0, s] + g0 * g0 * w
            c[1, s] = c[1, s] + g0 * g1 * w
            c[2, s] = c[2, s] + g0 * g2 * w
            c[3, s] = c[3, s] + g0 * g3 * w
            c[4, s] = c[4, s] + g1 * g1 * w
            c[5, s] = c[5, s] + g1 * g2 * w
            c[6, s] = c[6, s] + g1 * g3 * w
            c[7, s] = c[7, s] + g2 * g2 * w
            c[8, s] = c[8, s] + g2 * g3 * w
            c[9, s] = c[9, s] + g3 * g3 * w
        for s in range(ns):
            f00 = c[0, s] + ic0
            f01 = c[1, s] + ic1
            f02 = c[2, s] + ic2
            f03 = c[3, s] + ic3
            f11 = c[4, s] + ic4
            f12 = c[5, s] + ic5
            f13 = c[6, s] + ic6
            f22 = c[7, s] + ic7
            f23 = c[8, s] + ic8
            f33 = c[9, s] + ic9
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
            r = W[1, s]
            ux = W[2, s] / r
            uy = W[3, s] / r
            y0 = ux
            y1 = uy - l10 * y0
            y2 = tk * ux - l20 * y0 - l21 * y1
            y3 = tk * uy - l30 * y0 - l31 * y1 - l32 * y2
            var = y0 * y0 / d0 + y1 * y1 / d1 + y2 * y2 / d2 + y3 * y3 / d3
            rel = np.sqrt(max(var, 0.0)) / r
            a3 = y3 / d3
            a2 = y2 / d2 - l32 * a3
            a1 = y1 / d1 - l21 * a2 - l31 * a3
            W[0, s] = var
            W[4, s] = 0.5 * ((rel - tau) * inv_wt)
            W[5, s] = y0 / d0 - l10 * a1 - l20 * a2 - l30 * a3
            W[6, s] = a1
            W[7, s] = a2
            W[8, s] = a3
        acc = 0.0
        for s in range(ns):  # scalar: libm's tanh, and the sum in order
            th = np.tanh(W[4, s])
            W[4, s] = th
            acc += 0.5 * (1.0 + th)
        total += weight[k] * acc
        if store:
            for i in range(5):
                _copy_row(V[k], i, W, i)
            for i in range(4):
                _copy_row(A[k], i, W, 5 + i)
    scale = span / (K1 * ns)
    value = scale * total
    if not reverse:
        return value
    # reverse sweep: G holds Σ_{k' ≥ k} ∂value/∂F_k' (symmetric, packed); c's rows are free:
    # 1-4 hold -∂value/∂var, the adjoints of rx and ry by u and that of r, row 0 (and Z) the
    # draws' terms of ∂value/∂d_k; A and V are only read, so a second sweep gives the same
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
            th = v_k[4, s]
            if seed is None:  # (pruned when compiled: one kernel each way)
                adj_sig = ck
            else:  # ∂(the caller's value)/∂σ_ks given (several contacts' product form)
                adj_sig = seed[k, s]
            adj_rel = adj_sig * 0.25 * (1.0 - th * th) * inv_wt
            sq = np.sqrt(max(var, 0.0))
            adj_var = adj_rel / (2.0 * sq * r) if var > 0.0 else 0.0
            adj_r = -adj_rel * (sq / r) / r
            adj_ux = 2.0 * adj_var * (a_k[0, s] + tk * a_k[2, s])
            adj_uy = 2.0 * adj_var * (a_k[1, s] + tk * a_k[3, s])
            c[1, s] = -adj_var
            c[2, s] = adj_ux / r
            c[3, s] = adj_uy / r
            c[4, s] = adj_r - (adj_ux * v_k[2, s] + adj_uy * v_k[3, s]) / (r * r)
        for s in range(ns):
            m = c[1, s]
            a0 = a_k[0, s]
            a1 = a_k[1, s]
            a2 = a_k[2, s]
            a3 = a_k[3, s]
            G[0, s] = G[0, s] + m * a0 * a0
            G[1, s] = G[1, s] + m * a0 * a1
            G[2, s] = G[2, s] + m * a0 * a2
            G[3, s] = G[3, s] + m * a0 * a3
            G[4, s] = G[4, s] + m * a1 * a1
            G[5, s] = G[5, s] + m * a1 * a2
            G[6, s] = G[6, s] + m * a1 * a3
            G[7, s] = G[7, s] + m * a2 * a2
            G[8, s] = G[8, s] + m * a2 * a3
            G[9, s] = G[9, s] + m * a3 * a3
        for s in range(ns):
            rx = v_k[2, s]
            ry = v_k[3, s]
            r2raw = rx * rx + ry * ry
            r2 = max(r2raw, m2)
            w = ik / (r2 * r2)
            g0 = ry
            g1 = -rx
            g2 = tk * ry
            g3 = -tk * rx
            Gg0 = G[0, s] * g0 + G[1, s] * g1 + G[2, s] * g2 + G[3, s] * g3
            Gg1 = G[1, s] * g0 + G[4, s] * g1 + G[5, s] * g2 + G[6, s] * g3
            Gg2 = G[2, s] * g0 + G[5, s] * g1 + G[7, s] * g2 + G[8, s] * g3
            Gg3 = G[3, s] * g0 + G[6, s] * g1 + G[8, s] * g2 + G[9, s] * g3
            adj_w = g0 * Gg0 + g1 * Gg1 + g2 * Gg2 + g3 * Gg3
            adj_ry = c[3, s] + 2.0 * w * (Gg0 + tk * Gg2)
            adj_rx = c[2, s] - 2.0 * w * (Gg1 + tk * Gg3)
            adj_r2 = c[4, s] / (2.0 * v_k[1, s]) - adj_w * 2.0 * ik / (r2 * r2 * r2)
            if r2raw <= m2:  # the floored range does not move with r
                adj_r2 = 0.0
            Z[s] = -(adj_rx + 2.0 * rx * adj_r2)
            c[0, s] = -(adj_ry + 2.0 * ry * adj_r2)
        gx = 0.0
        gy = 0.0
        for s in range(ns):
            gx += Z[s]
            gy += c[0, s]
        grad[0, k] = gx
        grad[1, k] = gy
    return value


class _Kernel:
    """Inputs of :func:`_value_grad` taken from the parameter vector, and its workspace."""

    def __init__(self, ctx: Any, accuracy: float, width: float) -> None:
        layout = ctx.layout
        self.K1 = ctx.n_steps + 1
        self.ns = layout.n_samples
        self.slices = layout.slices()
        self.t = np.ascontiguousarray(ctx.times / _T)
        self.span = float(ctx.times[-1]) + float(ctx.dt)
        self.tau, self.width = float(accuracy), float(width)
        iu = np.triu_indices(4)
        dinv = np.array([_L, _L, _L / _T, _L / _T])
        self.ic_scale = dinv[iu[0]] * dinv[iu[1]]  # prior information in the scaled units
        K1, ns = self.K1, self.ns
        self.A = np.empty((K1, 4, ns))
        self.V = np.empty((K1, 5, ns))
        self.c = np.empty((10, ns))
        self.G = np.empty((10, ns))
        self.Z = np.empty(ns)
        self.grad = np.zeros((2, K1))
        self._stored: tuple[np.ndarray, np.ndarray, float] | None = None

    def __call__(self, d: np.ndarray, p: np.ndarray, need_grad: bool) -> float:
        """The value at (d, p), and with ``need_grad`` its gradient in :attr:`grad`. The
        forward pass stores what the reverse sweep reads: the gradient at the point of the
        last value (casadi asks for the value, then for the gradient at the same point) runs
        the reverse sweep alone, with the same bits as both together."""
        last = self._stored
        if (need_grad and last is not None and np.array_equal(d, last[0])
                and np.array_equal(p, last[1])):
            self._run(d, p, forward=False, reverse=True)
            return last[2]
        self._stored = None  # (until the forward pass is done: an interrupt may stop it)
        value = self._run(d, p, forward=True, reverse=need_grad)
        self._stored = (d.copy(), p.copy(), value)
        return value

    def _run(self, d: np.ndarray, p: np.ndarray, *, forward: bool, reverse: bool,
             seed: np.ndarray | None = None) -> float:
        sl = self.slices
        smp = p[sl["samples"]].reshape(self.ns, 4)
        return float(_value_grad(
            smp[:, 0] / _L, smp[:, 1] / _L, smp[:, 2] * (_T / _L), smp[:, 3] * (_T / _L),
            self.t, np.ascontiguousarray(d[:, 0]), np.ascontiguousarray(d[:, 1]),
            np.ascontiguousarray(p[sl["bearing"]]), np.ascontiguousarray(p[sl["weight"]]),
            p[sl["icart"]] * self.ic_scale, self.tau, self.width, self.span,
            (_MIN_RANGE / _L) ** 2, self.grad, self.A, self.V, self.c, self.G, self.Z,
            forward, forward, reverse, seed))

    def not_localised(self) -> np.ndarray:
        """σ_ks (K+1, n_samples) of the last stored forward pass (a new array)."""
        return 0.5 * (1.0 + self.V[:, 4, :])


class _ContactsKernel:
    """``all-contacts-time-to-accuracy``'s main term over N contacts: one :class:`_Kernel`
    per contact on the same own-ship displacement, combined as
    ``span · Σ_k w_k mean_s [1 − Π_c (1 − σ_cks)] / (K+1)``; its gradient by each contact's
    reverse sweep seeded with ``∂value/∂σ_cks = span w_k Π_{c'≠c} (1 − σ_c'ks) / ((K+1) n)``."""

    def __init__(self, ctxs: list[Any], blocks: list[slice], accuracies: list[float],
                 width: float) -> None:
        self.kernels = [_Kernel(c, a, width) for c, a in zip(ctxs, accuracies, strict=True)]
        self.blocks = list(blocks)
        first = self.kernels[0]
        self.K1, self.ns, self.span = first.K1, first.ns, first.span
        self.weight_slice = first.slices["weight"]
        self.grad = np.zeros((2, self.K1))
        self.seed = np.empty((self.K1, self.ns))
        self._free: list[np.ndarray] = []  # each contact's 1 − σ_c at the stored point
        self._stored: tuple[np.ndarray, np.ndarray, float] | None = None

    def __call__(self, d: np.ndarray, p: np.ndarray, need_grad: bool) -> float:
        """The value at (d, p), and with ``need_grad`` its gradient in :attr:`grad` (the
        reverse sweeps alone at the point of the last value, as :class:`_Kernel`)."""
        last = self._stored
        if not (need_grad and last is not None and np.array_equal(d, last[0])
                and np.array_equal(p, last[1])):
            self._stored = None  # (until every forward pass is done: an interrupt may stop one)
            for k, b in zip(self.kernels, self.blocks, strict=True):
                k._run(d, p[b], forward=True, reverse=False)
            self._free = [1.0 - k.not_localised() for k in self.kernels]
            last = self._stored = (d.copy(), p.copy(), self._value(p))
        if need_grad:
            self._gradient(d, p)
        return last[2]

    def _value(self, p: np.ndarray) -> float:
        localised = self._free[0]
        for f in self._free[1:]:
            localised = localised * f
        w = p[self.blocks[0]][self.weight_slice]
        return float(self.span * np.sum(w * np.sum(1.0 - localised, axis=1))
                     / (self.K1 * self.ns))

    def _gradient(self, d: np.ndarray, p: np.ndarray) -> None:
        ck = (self.span / (self.K1 * self.ns)) * p[self.blocks[0]][self.weight_slice]
        self.grad[:] = 0.0
        for c, (k, b) in enumerate(zip(self.kernels, self.blocks, strict=True)):
            self.seed[:] = ck[:, None]
            for j, f in enumerate(self._free):
                if j != c:
                    self.seed *= f
            k._run(d, p[b], forward=False, reverse=True, seed=self.seed)
            self.grad += k.grad


def expected_time_value_grad(ctx: Any, d: np.ndarray, p: np.ndarray, *, accuracy: float,
                             width: float) -> tuple[float, np.ndarray]:
    """The compiled value [s] and its gradient with respect to ``d`` (K+1, 2) [s/km].

    Parameters
    ----------
    ctx : PlanContext
        The plan horizon (times, step, parameter layout); its casadi symbols are not used.
    d : ndarray, shape (K + 1, 2)
        Own-ship displacement beyond constant velocity, ``(disp_k − t_k v̄₀)/1 km`` [km].
    p : ndarray, shape (layout.size,)
        The parameter vector (:class:`tmaplan.planning.objective_graphs.ParamLayout`).
    accuracy, width : float
        τ and the relative width w of :func:`tmaplan.planning.objectives.
        expected_time_to_accuracy` [-].
    """
    k = _Kernel(ctx, accuracy, width)
    value = k(np.asarray(d, float), np.asarray(p, float).ravel(), True)
    return value, k.grad.T.copy()


@functools.cache
def _callback_class() -> Any:
    """A ``casadi.Callback`` of dense inputs and outputs evaluated by a Python function, with
    an optional reverse derivative (a callback of the inputs, the outputs and one adjoint
    seed per output, returning one adjoint per input).

    The function receives one numpy array per input, of the input's shape, reading casadi's
    own buffer (valid during the call: copy what is kept), and returns one array-like per
    output (its values written into casadi's buffer): casadi's copy-free ``eval_buffer``, no
    ``DM`` made or read (that conversion was a tenth of a converged re-plan)."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    class Callback(ca.Callback):
        def __init__(self, name: str, ins: tuple[tuple[int, int], ...],
                     outs: tuple[tuple[int, int], ...], fn: Callable[[Any], list[Any]],
                     reverse: Any = None) -> None:
            ca.Callback.__init__(self)
            self.ins, self.outs, self.fn, self.adjoint = ins, outs, fn, reverse
            self.construct(name, {})

        def get_n_in(self) -> int:
            return len(self.ins)

        def get_n_out(self) -> int:
            return len(self.outs)

        def get_sparsity_in(self, i: int) -> Any:
            return ca.Sparsity.dense(*self.ins[i])

        def get_sparsity_out(self, i: int) -> Any:
            return ca.Sparsity.dense(*self.outs[i])

        def has_eval_buffer(self) -> bool:
            return True

        def eval_buffer(self, arg: Any, res: Any) -> int:
            # nonzeros in column-major order: (rows, cols) is the transpose of (cols, rows)
            ins = [np.frombuffer(a, dtype=np.float64).reshape(c, r).T
                   for a, (r, c) in zip(arg, self.ins)]
            try:
                outs = self.fn(ins)
            except (KeyboardInterrupt, SystemError) as exc:  # (compiled code: SystemError)
                interrupt = as_interrupt(exc)
                if interrupt is None:
                    raise
                defer(interrupt)  # NaN out; the solver call raises it after
                outs = [np.full(shape, np.nan) for shape in self.outs]
            for buf, out, (r, c) in zip(res, outs, self.outs):
                if buf is None:  # an output the caller does not need
                    continue
                np.frombuffer(buf, dtype=np.float64)[:] = np.reshape(
                    np.asarray(out, dtype=np.float64), (r, c)).T.ravel()
            return 0

        def has_reverse(self, nadj: int) -> bool:
            return self.adjoint is not None and nadj == 1

        def get_reverse(self, nadj: int, name: str, inames: Any, onames: Any,
                        opts: Any) -> Any:
            sym = [ca.MX.sym(f"a{i}", *shape) for i, shape in
                   enumerate(self.ins + self.outs + self.outs)]
            return ca.Function(name, sym, self.adjoint(*sym), inames, onames, opts)

    return Callback


def compiled_expected_time(ctx: Any, accuracy: float, width: float) -> Any:
    """The expected-time term of :func:`tmaplan.planning.objectives.expected_time_to_accuracy`
    [s] as a casadi expression of ``ctx``'s plan, evaluated by the compiled kernel.

    Same value as ``expected_time_of(ctx, not_localised_graph(ctx, accuracy, width))`` (to
    rounding). The callbacks are kept in ``ctx.cache["callbacks"]``: whoever builds a solver
    from the expression keeps them alive as long as the solver (casadi does not).
    """
    return _as_casadi(ctx, "expected_time", _Kernel(ctx, accuracy, width))


def compiled_all_contacts_time(ctx: Any, contexts: list[Any], blocks: list[slice],
                               accuracies: list[float], width: float) -> Any:
    """The main term of ``all-contacts-time-to-accuracy`` [s]
    (:class:`tmaplan.planning.multi_objectives.ContactsObjective`: the expected time until
    every contact is localised) as a casadi expression of ``ctx``'s plan, evaluated by one
    compiled kernel per contact.

    Same value as the casadi graph of ``ContactsObjective.combined`` (to rounding);
    callbacks kept as :func:`compiled_expected_time`'s.

    Parameters
    ----------
    ctx : PlanContext
        The joint plan's context (own ship, the whole parameter vector).
    contexts : list of PlanContext
        Each contact's one-contact context (its block of the parameter vector, ``blocks``).
    blocks : list of slice
        Each contact's block of ``ctx.p``.
    accuracies : list of float
        Each contact's τ_c [-].
    width : float
        The logistic's relative width [-].

    Returns
    -------
    casadi.MX
        Scalar [s].
    """
    return _as_casadi(ctx, "all_contacts_time",
                      _ContactsKernel(contexts, blocks, accuracies, width))


def _as_casadi(ctx: Any, name: str, kernel: _Kernel | _ContactsKernel) -> Any:
    """``kernel``'s value of ``ctx``'s own-ship displacement and parameters as a casadi
    expression, with the kernel's gradient as its reverse derivative."""
    import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

    K1, n_p = kernel.K1, ctx.layout.size
    Callback = _callback_class()

    def reverse_eval(arg: list[np.ndarray]) -> list[Any]:
        kernel(arg[0], arg[1].ravel(), True)
        # no derivative with respect to the parameters: NaN, so a use shows
        return [float(arg[3][0, 0]) * kernel.grad.T, np.full(n_p, np.nan)]

    def value_eval(arg: list[np.ndarray]) -> list[Any]:
        return [kernel(arg[0], arg[1].ravel(), False)]

    reverse = Callback(f"{name}_reverse", ((K1, 2), (n_p, 1), (1, 1), (1, 1)),
                       ((K1, 2), (n_p, 1)), reverse_eval)
    value = Callback(name, ((K1, 2), (n_p, 1)), ((1, 1),), value_eval, reverse=reverse)
    ctx.cache.setdefault("callbacks", []).extend([reverse, value])
    v0 = ctx.v_obs[0, :]
    d = (ctx.disp - ca.mtimes(ca.DM(ctx.times.reshape(-1, 1)), v0)) / _L
    return value(d, ctx.p)
