"""Search methods of the active-ping scheduler (brehard2005 §5, docs/errata.md).

Role: the combinatorial side of :func:`tmaplan.planning.pings.schedule_pings`, which builds
a :class:`~tmaplan.planning.pings.PingEvaluator` (the batched closed-form PCRB of Bréhard &
Le Cadre, brehard2005, with a ping adding ``u_k·E r_k²/σ_r²`` to ``J_k[ln r, ln r]``, eq. 51) and
hands it to the helpers here:

* feasibility: candidate steps outside the forbidden windows, minimum spacing, the largest
  number of pings the spacing allows;
* :func:`exact_search`: exhaustive enumeration, or best-first branch and bound with the
  monotone lower bound "all remaining candidates pinged" (docs/errata.md) — used for the
  position objective, which the compiled kernel of :mod:`tmaplan.planning.ping_exact` does
  not evaluate;
* :func:`round_weights`: the roundings of the relaxed weights of
  :mod:`tmaplan.planning.ping_relaxation`;
* :func:`greedy_schedule` and :func:`local_swaps`, which polish every method;
* :func:`uniform_ping_steps`, the one definition of the evenly spaced reference schedule.

:mod:`tmaplan.planning.pings` re-exports the user-facing ones (:func:`ping_candidates`,
:func:`uniform_ping_steps`, :func:`max_pings`); the searches serve it and
:mod:`tmaplan.planning.joint_ocp` (rounding the joint OCP's ping weights).
"""

from __future__ import annotations

import heapq
import itertools
import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from tmaplan.errors import ArgumentError, as_real, finite_real, is_integer

if TYPE_CHECKING:
    from tmaplan.planning.pings import PingEvaluator
    from tmaplan.scenario import Scenario

__all__ = [
    "exact_search",
    "greedy_schedule",
    "local_swaps",
    "max_pings",
    "ping_candidates",
    "round_weights",
    "spacing_ok",
    "uniform_ping_steps",
]


# --------------------------------------------------------------------------------------------
# Feasibility helpers
# --------------------------------------------------------------------------------------------
def _windows(windows: Sequence[tuple[float, float]], field: str) -> list[tuple[float, float]]:
    """Time windows [s] checked: pairs of finite times with start <= end (a reversed or NaN
    window forbade nothing, silently)."""
    out = []
    for i, win in enumerate(windows):
        pair = tuple(win) if isinstance(win, (tuple, list, np.ndarray)) else ()
        a, b = (as_real(pair[0]), as_real(pair[1])) if len(pair) == 2 else (math.nan, math.nan)
        if not (np.isfinite(a) and np.isfinite(b) and a <= b):
            raise ArgumentError(f"{field}[{i}]", "a window (start, end) of finite times [s] "
                                "with start <= end", win)
        out.append((a, b))
    return out


def ping_candidates(scenario: Scenario, times: np.ndarray, *,
                    candidate_steps: Sequence[int] | None = None,
                    forbidden: Sequence[tuple[float, float]] = (),
                    min_spacing: float | None = None) -> tuple[np.ndarray, int, float]:
    """The ping constraints of a scenario on a track with step times ``times`` (K + 1,) [s].

    Returns the sorted candidate steps (``candidate_steps`` in [0, K], default 1..K, outside
    the closed time windows ``forbidden`` and ``planning.ping_forbidden`` [s]), the minimum
    gap between pings [steps] ``ceil(spacing/dt)`` and the spacing [s] (``min_spacing``,
    default ``planning.ping_min_spacing``).

    Raises
    ------
    ArgumentError
        A candidate step that is not an integer in [0, K] (a float was truncated, a bool
        taken as 0 or 1), a window that is not (start, end) finite with start <= end, a
        ``min_spacing`` that is not a finite time >= 0.
    """
    pl = scenario.planning
    times = np.asarray(times, float)
    K = times.shape[0] - 1
    if candidate_steps is None:
        cand = np.arange(1, K + 1)
    else:
        given = list(candidate_steps)
        if not all(is_integer(c, 0) and c <= K for c in given):
            raise ArgumentError("candidate_steps", f"integer steps in [0, {K}]", given)
        cand = np.unique(np.asarray(given, int))
    # (the scenario's windows are checked by the scenario: end > start)
    for a, b in [*_windows(forbidden, "forbidden"),
                 *(pl.ping_forbidden if pl is not None else ())]:
        t = times[cand]
        cand = cand[~((t >= a) & (t <= b))]
    if min_spacing is not None:
        spacing = finite_real("min_spacing", min_spacing, "a finite time >= 0 s (None: "
                              "planning.ping_min_spacing)", lower=0.0)
    else:
        spacing = float(pl.ping_min_spacing if pl is not None else 0.0)
    return cand, max(1, math.ceil(spacing / float(scenario.time.dt) - 1e-9)), spacing


def uniform_ping_steps(times: np.ndarray, budget: int, *,
                       candidates: Sequence[int] | np.ndarray | None = None,
                       gap: int = 1) -> list[int]:
    """The evenly spaced reference schedule: ``budget`` pings at the centres of ``budget`` equal
    sub-intervals of the horizon.

    The one definition of "uniform pings" (the scheduler's ``uniform_objective`` and the
    ``uniform`` ping policy): with K steps, the targets are the steps ``(i + ½)·K/budget``,
    i = 0..budget − 1, rounded half to even (K = 450, budget = 4: 56, 169, 281, 394); each is
    moved to the nearest candidate step (ties: the earlier) not within ``gap`` steps of an
    earlier choice; a target with no such candidate is dropped.

    ``times`` (K + 1,) [s] gives K; ``candidates`` (default 1..K) and ``gap`` [steps] are
    :func:`ping_candidates`'. Returns the sorted steps.
    """
    K = np.asarray(times).shape[0] - 1
    cand = np.arange(1, K + 1) if candidates is None else np.asarray(candidates, int)
    out: list[int] = []
    for i in range(max(int(budget), 0)):
        target = float(np.round((i + 0.5) * K / budget))
        free = [int(c) for c in cand if all(abs(int(c) - x) >= max(gap, 1) for x in out)]
        if free:
            out.append(min(free, key=lambda c: (abs(c - target), c)))
    return sorted(out)


def spacing_ok(steps: Sequence[int], gap: int) -> bool:
    """Whether the ping steps ``steps`` (any order) are pairwise at least ``gap`` steps
    apart."""
    s = sorted(steps)
    return all(b - a >= gap for a, b in itertools.pairwise(s))


def max_pings(cand: np.ndarray, gap: int) -> int:
    """Most pings that fit in the candidate steps ``cand`` (sorted) at least ``gap`` steps
    apart (earliest first: optimal for interval packing)."""
    n, last = 0, -10**9
    for c in cand:  # earliest-first is optimal for interval packing
        if c - last >= gap:
            n, last = n + 1, c
    return n


# --------------------------------------------------------------------------------------------
# Search: rounding, local swaps, greedy, relaxed NLP, exact
# --------------------------------------------------------------------------------------------
def round_weights(u: np.ndarray, cand: np.ndarray, budget: int, gap: int) -> list[list[int]]:
    """Two roundings of relaxed weights: largest-u-first, and systematic (the steps where the
    cumulative Σu crosses i + 1/2); both respect the spacing.

    Parameters
    ----------
    u : ndarray, shape (n,)
        Relaxed ping weights in [0, 1], one per candidate.
    cand : ndarray of int, shape (n,)
        Candidate steps (sorted).
    budget : int
        Pings wanted.
    gap : int
        Minimum spacing [steps].

    Returns
    -------
    list of list of int
        The two schedules (sorted steps; shorter than ``budget`` if the spacing allows no
        more).
    """
    def feasible(order: Sequence[int]) -> list[int]:
        chosen: list[int] = []
        for i in order:
            c = int(cand[i])
            if all(abs(c - x) >= gap for x in chosen):
                chosen.append(c)
            if len(chosen) == budget:
                break
        return chosen

    top = feasible(np.argsort(-u, kind="stable").tolist())
    cs = np.cumsum(u) * budget / max(u.sum(), 1e-12)
    idx = np.searchsorted(cs, np.arange(budget) + 0.5)
    syst = feasible(list(dict.fromkeys(np.clip(idx, 0, cand.size - 1).tolist()))
                    + np.argsort(-u, kind="stable").tolist())
    return [sorted(top), sorted(syst)]


def local_swaps(ev: PingEvaluator, steps: list[int], cand: np.ndarray, gap: int,
                 max_rounds: int = 8, radius: Sequence[int] = (1, 2, 4, 8, 16)) -> tuple[
                     list[int], float]:
    """Move pings to nearby candidates (±radius in candidate index) while that improves.

    Each round evaluates every single move in one batch, then applies the best move of every
    ping together if that beats the best single move (else the best single move).

    Parameters
    ----------
    ev : PingEvaluator
        The objective of a schedule (batched).
    steps : list of int
        Starting schedule (steps in ``cand``).
    cand : ndarray of int, shape (n,)
        Candidate steps (sorted).
    gap : int
        Minimum spacing [steps].
    max_rounds : int
        Rounds of moves at most.
    radius : sequence of int
        Moves tried per ping [candidate indices, both ways].

    Returns
    -------
    steps : list of int
        The polished schedule (sorted).
    value : float
        Its objective.
    """
    pos = {int(c): i for i, c in enumerate(cand)}
    steps = sorted(steps)
    best = ev.value(steps)
    for _ in range(max_rounds):
        trials, owner, moves = [], [], []
        for i, s in enumerate(steps):
            for r in radius:
                for j in (pos[s] - r, pos[s] + r):
                    if 0 <= j < cand.size and int(cand[j]) not in steps:
                        trial = [*steps[:i], int(cand[j]), *steps[i + 1:]]
                        if spacing_ok(trial, gap):
                            trials.append(sorted(trial))
                            owner.append(i)
                            moves.append(int(cand[j]))
        if not trials:
            break
        vals = ev.evaluate(ev.schedules(trials))
        j = int(np.argmin(vals))
        if vals[j] >= best - 1e-12 * max(1.0, abs(best)):
            break
        combined = list(steps)
        for i in range(len(steps)):
            mine = [t for t, o in enumerate(owner) if o == i and vals[t] < best]
            if mine:
                combined[i] = moves[min(mine, key=lambda t: vals[t])]
        new, new_val = sorted(trials[j]), float(vals[j])
        if len(set(combined)) == len(combined) and spacing_ok(combined, gap) and \
                sorted(combined) != new:
            cv = ev.value(sorted(combined))
            if cv < new_val:
                new, new_val = sorted(combined), cv
        steps, best = new, new_val
    return steps, best


def greedy_schedule(ev: PingEvaluator, cand: np.ndarray, budget: int, gap: int) -> list[int]:
    """Pings added one at a time, each the candidate that lowers the objective most.

    Parameters
    ----------
    ev : PingEvaluator
        The objective of a schedule (batched).
    cand : ndarray of int, shape (n,)
        Candidate steps (sorted).
    budget : int
        Pings wanted.
    gap : int
        Minimum spacing [steps].

    Returns
    -------
    list of int
        The schedule (sorted; shorter than ``budget`` if the spacing allows no more).
    """
    chosen: list[int] = []
    for _ in range(budget):
        opts = [c for c in cand if all(abs(int(c) - x) >= gap for x in chosen)]
        if not opts:
            break
        vals = ev.evaluate(ev.schedules([[*chosen, int(c)] for c in opts]))
        chosen = sorted([*chosen, int(opts[int(np.argmin(vals))])])
    return chosen




def _maximal(chosen: Sequence[int], cand: np.ndarray, gap: int) -> bool:
    """Whether no candidate can be added to ``chosen`` within the spacing ``gap``."""
    return not any(all(abs(int(c) - x) >= gap for x in chosen) for c in cand
                   if int(c) not in chosen)


def exact_search(ev: PingEvaluator, cand: np.ndarray, budget: int, gap: int, incumbent: list[int],
           inc_val: float, max_enumerate: int, time_limit: float) -> tuple[list[int], float,
                                                                          float, str]:
    """Exhaustive enumeration or best-first branch and bound over every schedule of *at most*
    ``budget`` pings.

    More pings never raise the objective, so the optimum is a set that cannot be extended:
    one of ``budget`` pings or, with a spacing (``gap`` > 1), a smaller set that no candidate
    fits beside (e.g. the middle one of three candidates too close to it); both kinds are
    searched. The lower bound of a node is its schedule with every remaining candidate
    pinged (docs/errata.md).

    Parameters
    ----------
    ev : PingEvaluator
        The objective of a schedule (batched).
    cand : ndarray of int, shape (n,)
        Candidate steps (sorted).
    budget : int
        Pings at most.
    gap : int
        Minimum spacing [steps].
    incumbent : list of int
        Best known schedule (the branch and bound's start).
    inc_val : float
        Its objective.
    max_enumerate : int
        Enumerate exhaustively when C(n, budget) is at most this.
    time_limit : float
        Branch and bound time limit [s].

    Returns
    -------
    steps : list of int
        The best schedule found.
    value : float
        Its objective.
    lower_bound : float
        Lower bound on every schedule (``value`` when optimal).
    status : str
        ``"optimal"`` or ``"gap (time limit)"``.
    """
    n = cand.size
    if math.comb(n, budget) <= max_enumerate:
        combos = [c for c in itertools.combinations(cand.tolist(), budget)
                  if spacing_ok(c, gap)]
        if gap > 1:  # the smaller sets that cannot be extended
            combos += [c for k in range(1, budget)
                       for c in itertools.combinations(cand.tolist(), k)
                       if spacing_ok(c, gap) and _maximal(c, cand, gap)]
        vals = ev.evaluate(ev.schedules(combos))
        j = int(np.argmin(vals))
        return list(combos[j]), float(vals[j]), float(vals[j]), "optimal"

    t0 = time.perf_counter()
    best, best_val = list(incumbent), inc_val
    # node: (lower bound, chosen tuple, next candidate index)
    root_lb = float(ev.evaluate(ev.schedules([cand.tolist()]))[0])
    heap: list[tuple[float, tuple[int, ...], int]] = [(root_lb, (), 0)]
    while heap and time.perf_counter() - t0 < time_limit:
        batch = [heapq.heappop(heap) for _ in range(min(len(heap), 64))]
        kids: list[tuple[tuple[int, ...], int]] = []
        kid_sets: list[list[int]] = []
        for lb, chosen, nxt in batch:
            if lb >= best_val - 1e-12:
                continue
            n_kids = len(kids)
            for i in range(nxt, n):
                c = int(cand[i])
                if chosen and c - chosen[-1] < gap:
                    continue
                ch = (*chosen, c)
                if len(ch) == budget or i == n - 1:
                    kids.append((ch, n))
                    kid_sets.append(list(ch))
                else:
                    kids.append((ch, i + 1))
                    kid_sets.append(list(ch) + cand[i + 1:].tolist())
            if len(kids) == n_kids and chosen:
                # no later candidate fits: the node's own set is a leaf (it may be the
                # optimum, e.g. a ping between two candidates too close to it)
                kids.append((chosen, n))
                kid_sets.append(list(chosen))
        if not kids:
            continue
        vals = ev.evaluate(ev.schedules(kid_sets))
        for (ch, nxt), v in zip(kids, vals):
            if nxt >= n or len(ch) == budget:
                if v < best_val:
                    best, best_val = list(ch), float(v)
            elif v < best_val - 1e-12:
                heapq.heappush(heap, (float(v), ch, nxt))
    lb = min([h[0] for h in heap], default=best_val)
    lb = min(lb, best_val)
    return best, best_val, lb, "optimal" if not heap else "gap (time limit)"
