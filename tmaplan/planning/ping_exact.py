"""Exact ping scheduling: tree enumeration with prefix reuse, valid pruning, both cores.

Role: ``method="exact"`` of :func:`tmaplan.planning.pings.schedule_pings` for the range
objectives (``mean-range-bound``, ``terminal-range-bound``).

Structure used (brehard2005, eq. 43–51): a ping at step s changes only the terms of steps
≥ s, so a node of the enumeration tree — the pings fixed so far, the last one at step p —
keeps its exact prefix cost ``C_p = Σ_{t ≤ p} c_t g_t`` and its information ``J_p``; its children
(next ping at s > p) start from the no-ping trajectory of ``J_p``, and its completions (no
further ping) are that trajectory's cost. The last level (one ping left) is evaluated in
batches by the compiled schedule kernel of the closed form, started at each node's state.

Pruning is valid only with a true lower bound on the subtree (never a "diminishing returns"
cut: pings reinforce each other). The recursion is matrix-monotone, so any schedule of the
subtree has ``J_t`` ⪯ the information with *every* allowed candidate after p pinged; the
subtree bound is therefore ``C_p + Σ_{t > p} c_t g(J_t^{all})`` (all-remaining-pinged bound,
computed from the node's own J_p). A subtree is cut when its bound reaches the incumbent.

Parallelism: the first-ping subtrees are dealt round-robin to ``workers`` processes
(``fork``); each returns its best schedule and the smallest bound of any subtree it left open
at the time limit. The result is the best over workers with ties broken by the smaller step
tuple, so it does not depend on the worker count.
"""

from __future__ import annotations

import dataclasses
import multiprocessing as mp
import os
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.errors import PlanningError
from tmaplan.parallel import worker_signals
from tmaplan.planning.ping_relaxation import (
    information_matrices,
    objective_vectors,
    schedule_kernel_of,
)

if TYPE_CHECKING:
    from tmaplan.planning.pings import PingEvaluator

__all__ = ["ExactResult", "tree_search"]

_SYM = tuple((i, j) for i in range(4) for j in range(i, 4))
_IDX = np.array([[_SYM.index((min(i, j), max(i, j))) for j in range(4)] for i in range(4)])


@dataclasses.dataclass(frozen=True, kw_only=True)
class ExactResult:
    """Best schedule found and the certified bound on the optimum.

    Attributes
    ----------
    steps : tuple of int
    value : float
        Objective of ``steps`` [m].
    lower_bound : float
        Valid lower bound on the optimum [m] (= ``value`` when the tree was exhausted).
    complete : bool
        True if every subtree was enumerated or pruned.
    leaves : int
        Schedules evaluated.
    nodes : int
        Tree nodes expanded (not pruned).
    seconds : float
    """

    steps: tuple[int, ...]
    value: float
    lower_bound: float
    complete: bool
    leaves: int
    nodes: int
    seconds: float


class _Tree:
    """Batched numpy trajectories from node states (packed symmetric 10-vectors)."""

    def __init__(self, ev: PingEvaluator, cand: np.ndarray, gap: int) -> None:
        im = information_matrices(ev)
        self.ev, self.im, self.K = ev, im, ev.K
        self.cand = np.asarray(cand, int)
        self.gap = int(gap)
        c, _ = objective_vectors(ev)
        self.c = c
        self.allowed = np.zeros(self.K + 1, bool)
        self.allowed[self.cand] = True
        self.D = [(im.D11[t], im.D12[t], im.D22[t]) for t in range(self.K)]
        self.aux = np.ascontiguousarray(ev.engine.aux.T, dtype=float)
        self.kernel = schedule_kernel_of(ev)
        # global all-candidates-pinged trajectory: J_t of any schedule is below it, so
        # tail_all[p] = Σ_{t>p} c_t g(J_t^all) bounds every completion after step p
        J0 = np.asarray(ev.engine.prior_information, float)[None]
        _, costs, _ = self.trajectories(np.zeros(1, int), J0 + self._ping0(), True,
                                        keep_states=False)
        self.tail_all = np.concatenate([np.cumsum(costs[::-1, 0])[::-1], [0.0]])

    def _ping0(self) -> np.ndarray:
        X = np.zeros((4, 4))
        X[1, 1] = self.im.ping[0] if self.allowed[0] else 0.0
        return X

    # ------------------------------------------------------------------ packed algebra
    @staticmethod
    def _mat(P: np.ndarray) -> np.ndarray:
        """(10, S) packed -> (S, 4, 4)."""
        return np.moveaxis(P[_IDX], -1, 0)

    @staticmethod
    def _pack(M: np.ndarray) -> np.ndarray:
        return np.stack([M[:, i, j] for i, j in _SYM])

    def g(self, t: int, M: np.ndarray) -> np.ndarray:
        """Range bound (S,) [m] at step t of information matrices M (S, 4, 4)."""
        var = np.linalg.inv(M)[:, 1, 1]
        return np.sqrt(self.im.er2[t] * np.maximum(var, 0.0))

    def g_at(self, steps: np.ndarray, M: np.ndarray) -> np.ndarray:
        """Range bounds (S,) [m] of M (S, 4, 4) at the steps (S,)."""
        var = np.linalg.inv(M)[:, 1, 1]
        return np.sqrt(self.im.er2[steps] * np.maximum(var, 0.0))

    def step(self, t: int, M: np.ndarray, ping: np.ndarray | float) -> np.ndarray:
        """J_{t+1} (S, 4, 4) from J_t (S, 4, 4) with ping weight(s) at t+1."""
        D11, D12, D22 = self.D[t]
        X = np.linalg.solve(M + D11, np.broadcast_to(D12, M.shape))
        Jn = D22 - np.einsum("ia,sib->sab", D12, X)
        Jn = 0.5 * (Jn + np.swapaxes(Jn, 1, 2))
        Jn[:, 0, 0] += self.im.bearing[t + 1]
        Jn[:, 1, 1] += ping * self.im.ping[t + 1]
        return Jn

    def trajectories(self, p: np.ndarray, M: np.ndarray, all_pinged: bool,
                     keep_states: bool = True) -> tuple[np.ndarray, np.ndarray, int]:
        """From node states J_{p_i} (S, 4, 4) at steps p (S,): the states (K−p0, S, 4, 4) and
        costs (K−p0, S) at steps p0+1..K (p0 = min p; zero cost before a node's own p),
        without pings, or with every allowed candidate pinged."""
        p0 = int(p.min())
        n = self.K - p0
        S = M.shape[0]
        states = np.empty((n, S, 4, 4)) if keep_states else np.empty((0,))
        costs = np.zeros((n, S))
        J = M
        for k in range(n):
            t = p0 + k
            act = t >= p
            w = float(self.allowed[t + 1]) if all_pinged else 0.0
            if act.all():
                J = self.step(t, J, w)
            else:
                J = J.copy()
                J[act] = self.step(t, J[act], w)
            if keep_states:
                states[k] = J
            costs[k, act] = self.c[t + 1] * self.g(t + 1, J[act])
        return states, costs, p0

    def leaves(self, p: int, M: np.ndarray, C: float, s: np.ndarray) -> np.ndarray:
        """Objective of "this node (state M (4, 4) at step p, prefix cost C), then one last
        ping at each s" (s = K + 1: no further ping), by the compiled kernel from p."""
        S = s.size
        return self.leaves_many(p, np.broadcast_to(M, (S, 4, 4)), np.full(S, C), s)

    def leaves_many(self, p: int, M: np.ndarray, C: np.ndarray, s: np.ndarray) -> np.ndarray:
        """As :meth:`leaves` with one state M[i] (S, 4, 4) and prefix cost C[i] per schedule."""
        K = self.K
        S = s.size
        n = K - p
        if n == 0:
            return np.array(C, float)
        if self.kernel is None or self.ev.objective not in ("mean-range-bound",
                                                             "terminal-range-bound"):
            J = np.array(M)
            acc = np.array(C, float)
            for k in range(n):
                t = p + k
                J = self.step(t, J, (s == t + 1).astype(float))
                acc += self.c[t + 1] * self.g(t + 1, J)
            return acc
        j0 = np.ascontiguousarray(self._pack(np.asarray(M)))
        u = np.zeros((S, n + 2))
        u[np.arange(S), s - p] = 1.0  # column n + 1 (s = K + 1) is never read
        mean = self.ev.objective == "mean-range-bound"
        acc = np.ascontiguousarray(np.asarray(C, float) * (K + 1) if mean else np.zeros(S))
        last = np.zeros(S)
        b = np.ascontiguousarray(self.im.bearing[p + 1:])
        pw = np.ascontiguousarray(self.im.ping[p + 1:])
        er2 = np.ascontiguousarray(self.im.er2[p + 1:])
        aux = np.ascontiguousarray(self.aux[p:])
        self.kernel(n, S, j0.ctypes.data, aux.ctypes.data, b.ctypes.data, pw.ctypes.data,
                    er2.ctypes.data, u.ctypes.data, n + 2, acc.ctypes.data, last.ctypes.data,
                    None)
        return acc / (K + 1) if mean else last


def _expand(tree: _Tree, budget: int, steps: list[tuple[int, ...]], p: np.ndarray,
            M: np.ndarray, C: np.ndarray, state: dict[str, Any]) -> None:
    """Enumerate the subtrees of a batch of nodes of equal depth (last pings at steps p)."""
    K, gap = tree.K, tree.gap
    depth = len(steps[0])
    if depth == budget - 1 and depth > 0:
        # last ping left: buffer by last-ping step for the block-dominance bound
        lb = C + tree.tail_all[p]
        keep = lb < state["best"] * (1 - 1e-12)
        for i in np.flatnonzero(keep).tolist():
            state["buffer"].setdefault(int(p[i]), []).append((steps[i], M[i], float(C[i])))
        state["buffered"] += int(keep.sum())
        if state["buffered"] > MAX_BUFFER:  # bounded memory: flush (smaller blocks, same bound)
            _flush(tree, state)
        return
    # valid subtree bound (monotone recursion): every remaining candidate pinged
    if depth < budget:
        _, tail, _ = tree.trajectories(p, M, True, keep_states=False)
        lb = C + tail.sum(axis=0)
    else:
        lb = C.copy()
    if time.perf_counter() > state["deadline"]:
        state["open"].append(float(np.min(lb)))
        return
    keep = lb < state["best"] * (1 - 1e-12)
    if not np.all(keep):
        idx = np.flatnonzero(keep)
        if idx.size == 0:
            return
        steps = [steps[i] for i in idx]
        p, M, C = p[idx], M[idx], C[idx]
    state["nodes"] += len(steps)
    if depth >= budget - 1:  # budget 1 from the root, or no ping left
        for i in range(len(steps)):
            pi = int(p[i])
            first = pi + (gap if depth > 0 else 1)
            kids = tree.cand[tree.cand >= first] if depth < budget else tree.cand[:0]
            ss = np.append(kids, K + 1)
            vals = tree.leaves(pi, M[i], float(C[i]), ss)
            state["leaves"] += vals.size
            j = int(np.argmin(vals))
            _offer(state, float(vals[j]), steps[i] + ((int(ss[j]),) if ss[j] <= K else ()))
        return
    states, costs, p0 = tree.trajectories(p, M, False)
    cum = np.concatenate([np.zeros((1, len(steps))), np.cumsum(costs, axis=0)])
    tot = C + cum[-1]
    j = int(np.argmin(tot))
    _offer(state, float(tot[j]), steps[j])
    for i in range(len(steps)):
        if time.perf_counter() > state["deadline"]:
            state["open"].append(float(np.min(lb[keep][i:])))
            return
        pi = int(p[i])
        first = pi + (gap if depth > 0 else 1)
        kids = tree.cand[tree.cand >= first]
        if not kids.size:
            continue
        k = kids - p0 - 1
        Ms = states[k, i].copy()
        Ms[:, 1, 1] += tree.im.ping[kids]
        Cs = C[i] + cum[k, i] + tree.c[kids] * tree.g_at(kids, Ms)
        _expand(tree, budget, [(*steps[i], int(s)) for s in kids], kids.astype(int), Ms, Cs,
                state)


#: Nodes per block of the dominance bound at the last level.
BLOCK = 16
#: Buffered last-level nodes per worker before a flush (≈ 200 bytes each).
MAX_BUFFER = 200_000


def _flush(tree: _Tree, state: dict[str, Any]) -> None:
    """Last level: nodes with one ping left, grouped by their last-ping step p.

    Dominance bound (valid by monotonicity): for a block of nodes with states M_i at the same
    step p, ``R = M_ref + Σ_i (M_i − M_ref)_+`` (PSD parts) satisfies R ⪰ M_i for every i, so
    every completion of node i costs at least ``C_i + min_s V_s(R)``, where ``V_s(R)`` is the
    exact cost after p of "last ping at s" from R (one kernel call per block instead of one
    per node). Nodes whose bound reaches the incumbent are cut; the others are evaluated.
    """
    K, gap = tree.K, tree.gap
    buf = state["buffer"]
    for n, p in enumerate(sorted(buf)):
        nodes = buf[p]
        if time.perf_counter() > state["deadline"]:
            state["open"].append(min(c + float(tree.tail_all[q]) for q in sorted(buf)[n:]
                                     for _, _, c in buf[q]))
            return
        nodes.sort(key=lambda x: x[0])
        kids = np.append(tree.cand[tree.cand >= p + gap], K + 1)
        for a in range(0, len(nodes), BLOCK):
            blk = nodes[a:a + BLOCK]
            Ms = np.stack([x[1] for x in blk])
            Cs = np.array([x[2] for x in blk])
            if len(blk) > 1:
                ref = Ms[-1]
                w, V = np.linalg.eigh(Ms - ref)
                R = ref + np.einsum("sij,sj,skj->ik", V, np.maximum(w, 0.0), V)
                tail = float(tree.leaves(p, R, 0.0, kids).min())
                state["leaves"] += kids.size
                alive = np.flatnonzero(Cs + tail < state["best"] * (1 - 1e-12))
            else:
                alive = np.arange(1)
            state["nodes"] += alive.size
            if not alive.size:
                continue
            S = alive.size
            own = np.repeat(alive, kids.size)
            ss = np.tile(kids, S)
            vals = tree.leaves_many(p, Ms[own], Cs[own], ss)
            state["leaves"] += vals.size
            j = int(np.argmin(vals))
            st = blk[own[j]][0]
            _offer(state, float(vals[j]), st + ((int(ss[j]),) if ss[j] <= K else ()))
        buf[p] = []
    buf.clear()
    state["buffered"] = 0


def _offer(state: dict[str, Any], v: float, steps: tuple[int, ...]) -> None:
    b, bs = state["best"], state["steps"]
    st = tuple(sorted(steps))
    if v < b or (v == b and st < bs):
        state["best"], state["steps"] = v, st


_WORK: dict[str, Any] = {}


def _run(chunk: list[int]) -> tuple[float, tuple[int, ...], list[float], int, int]:
    """Subtrees of the first pings in ``chunk`` (−1: the schedule without pings)."""
    tree, budget = _WORK["tree"], _WORK["budget"]
    state: dict[str, Any] = {"best": _WORK["inc_val"], "steps": _WORK["inc_steps"],
                             "open": [], "leaves": 0, "nodes": 0, "buffer": {}, "buffered": 0,
                             "deadline": _WORK["deadline"]}
    J0 = np.asarray(tree.ev.engine.prior_information, float)[None]
    C0 = tree.c[0] * tree.g(0, J0)
    states, costs, _ = tree.trajectories(np.zeros(1, int), J0, False)
    cum = np.concatenate([[0.0], np.cumsum(costs[:, 0])])
    if -1 in chunk:
        _offer(state, float(C0[0] + cum[-1]), ())
    firsts = np.array(sorted(s for s in chunk if s >= 0), int)
    if firsts.size:
        Ms = np.empty((firsts.size, 4, 4))
        Cs = np.empty(firsts.size)
        for n, s in enumerate(firsts):
            if s == 0:
                Ms[n] = J0[0]
                Cs[n] = 0.0
            else:
                Ms[n] = states[s - 1, 0]
                Cs[n] = C0[0] + cum[s - 1]
            Ms[n, 1, 1] += tree.im.ping[s]
            Cs[n] += tree.c[s] * tree.g(int(s), Ms[n:n + 1])[0]
        # deal the first pings in batches so the time limit and the incumbent act early
        for a in range(0, firsts.size, 16):
            sl = slice(a, a + 16)
            _expand(tree, budget, [(int(s),) for s in firsts[sl]], firsts[sl], Ms[sl], Cs[sl],
                    state)
        _flush(tree, state)
    return state["best"], state["steps"], state["open"], state["leaves"], state["nodes"]


def tree_search(ev: PingEvaluator, cand: np.ndarray, budget: int, gap: int,
                incumbent: tuple[int, ...], inc_val: float, time_limit: float,
                workers: int | None = None) -> ExactResult:
    """Best schedule of at most ``budget`` pings on ``cand`` with spacing ``gap`` steps.

    Parameters
    ----------
    incumbent, inc_val : tuple of int, float
        A known schedule and its objective (pruning starts from it).
    time_limit : float
        [s]; on expiry the open subtrees' bounds give the certified lower bound.
    workers : int, optional
        Processes (default: the CPUs available, at most 2; a falsy value is the default).
    """
    if ev.objective not in ("mean-range-bound", "terminal-range-bound"):
        raise PlanningError(f"objective: expected a range objective for the tree "
                            f"enumeration, received {ev.objective!r}")
    t0 = time.perf_counter()
    tree = _Tree(ev, cand, gap)
    firsts = [-1, *[int(c) for c in tree.cand]]
    cpus = (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
            else os.cpu_count() or 1)
    n_workers = max(1, int(workers or min(cpus, 2)))
    _WORK.update(tree=tree, budget=budget, inc_val=float(inc_val),
                 inc_steps=tuple(sorted(incumbent)), deadline=t0 + time_limit)
    # interleave first pings so that both workers get early (expensive) subtrees
    chunks = [firsts[i::n_workers] for i in range(n_workers)]
    if n_workers > 1:
        # (an interrupt of this process ends the pool's workers: `with` terminates them)
        with mp.get_context("fork").Pool(n_workers, initializer=worker_signals) as pool:
            outs = pool.map(_run, chunks)
    else:
        outs = [_run(firsts)]
    best, steps = float(inc_val), tuple(sorted(incumbent))
    opened: list[float] = []
    leaves = 0
    nodes = 0
    for v, st, op, lv, nd in outs:
        if v < best or (v == best and st < steps):
            best, steps = v, st
        opened += op
        leaves += lv
        nodes += nd
    lb = min([best, *opened])
    return ExactResult(steps=steps, value=best, lower_bound=lb, complete=not opened,
                       leaves=leaves, nodes=nodes, seconds=time.perf_counter() - t0)
