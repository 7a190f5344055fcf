"""Review of the active-ping scheduler (fix/sched): exact search over *at most* ``budget``
pings, validation of the scheduling inputs, certificates of the joint plans."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tmaplan.planning._ping_search import _exact


class _Additive:
    """Stub evaluator: objective 10 − Σ of per-step gains (more pings never worse)."""

    objective = "mean-position-bound"

    def __init__(self, gains: dict[int, float], K: int) -> None:
        self.K = K
        self.w = np.zeros(K + 1)
        for s, g in gains.items():
            self.w[s] = g

    def schedules(self, sets):
        U = np.zeros((len(sets), self.K + 1))
        for i, st in enumerate(sets):
            U[i, list(st)] = 1.0
        return U

    def evaluate(self, U):
        return 10.0 - np.atleast_2d(U) @ self.w


@pytest.mark.parametrize("max_enumerate", [50_000, 0])  # enumeration, branch and bound
def test_exact_searches_at_most_budget_pings(max_enumerate):
    # candidates 1, 2, 3 with 2 steps between pings: the only 2-ping schedule is {1, 3}
    # (objective 8); the single ping {2} (objective 5) cannot be extended and is the optimum
    # of "at most 2 pings". The search looked at 2-ping schedules only and reported {1, 3}
    # "optimal" with the lower bound 8 above the optimum 5 (an invalid certificate).
    ev = _Additive({1: 1.0, 2: 5.0, 3: 1.0}, K=4)
    cand = np.array([1, 2, 3])
    steps, val, lb, status = _exact(ev, cand, 2, 2, [1, 3], 8.0, max_enumerate, 10.0)
    assert status == "optimal"
    assert steps == [2] and val == 5.0 and lb <= 5.0


def test_exact_equals_brute_force_on_random_gains():
    rng = np.random.default_rng(7)
    cand = np.array([1, 2, 4, 5, 6, 9, 10, 12])
    for _ in range(20):
        ev = _Additive({int(c): float(g) for c, g in zip(cand, rng.random(cand.size))}, K=12)
        for budget, gap in itertools.product((1, 2, 3), (1, 2, 3)):
            sets = [c for k in range(budget + 1)
                    for c in itertools.combinations(cand.tolist(), k)
                    if all(b - a >= gap for a, b in itertools.pairwise(c))]
            best = float(ev.evaluate(ev.schedules(sets)).min())
            for me in (50_000, 0):
                _, val, lb, status = _exact(ev, cand, budget, gap, [], 10.0, me, 10.0)
                assert status == "optimal"
                assert val == pytest.approx(best) and lb <= best + 1e-12
