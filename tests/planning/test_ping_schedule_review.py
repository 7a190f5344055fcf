"""Review of the active-ping scheduler (fix/sched): exact search over *at most* ``budget``
pings, validation of the scheduling inputs, certificates of the joint plans."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from tmaplan.planning.ping_search import exact_search


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
    steps, val, lb, status = exact_search(ev, cand, 2, 2, [1, 3], 8.0, max_enumerate, 10.0)
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
                _, val, lb, status = exact_search(ev, cand, budget, gap, [], 10.0, me, 10.0)
                assert status == "optimal"
                assert val == pytest.approx(best) and lb <= best + 1e-12


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(("kw", "field"), [
    # each was accepted: the budget truncated by int() (True -> 1, 1.7 -> 1, "1" -> 1) ...
    ({"budget": True}, "budget"), ({"budget": 1.7}, "budget"), ({"budget": "1"}, "budget"),
    ({"budget": -1}, "budget"),
    # ... a NaN/inf spacing a bare ValueError/OverflowError of math.ceil, a negative one taken
    ({"min_spacing": NAN}, "min_spacing"), ({"min_spacing": INF}, "min_spacing"),
    ({"min_spacing": -60.0}, "min_spacing"), ({"min_spacing": True}, "min_spacing"),
    # ... a reversed or NaN window forbade nothing
    ({"forbidden": [(400.0, 0.0)]}, r"forbidden\[0\]"),
    ({"forbidden": [(0.0, 100.0), (NAN, 400.0)]}, r"forbidden\[1\]"),
    ({"forbidden": [(0.0,)]}, r"forbidden\[0\]"),
    # ... candidate steps truncated (3.7 -> 3) or a bool taken as step 1
    ({"candidate_steps": [3.7, 10]}, "candidate_steps"),
    ({"candidate_steps": [True, 5]}, "candidate_steps"),
    ({"candidate_steps": [5, 37]}, "candidate_steps"),
    # ... a NaN time limit never stopped the exact enumeration, workers <= 0 ran with one
    ({"time_limit": NAN}, "time_limit"), ({"time_limit": -1.0}, "time_limit"),
    ({"workers": 0}, "workers"), ({"workers": -2}, "workers"), ({"workers": True}, "workers"),
    ({"max_enumerate": -1}, "max_enumerate"), ({"max_enumerate": 2.5}, "max_enumerate"),
])
def test_schedule_pings_refuses_invalid_inputs(short, short_prior, kw, field):
    from tmaplan.errors import ArgumentError
    from tmaplan.planning import schedule_pings

    args = {"budget": 1, **kw}
    with pytest.raises(ArgumentError, match=field):
        schedule_pings(short, belief=short_prior, method="greedy", gap_reference="none",
                       **args)


def test_schedule_pings_valid_inputs_unchanged(short, short_prior):
    from tmaplan.planning import schedule_pings

    a = schedule_pings(short, budget=np.int64(2), belief=short_prior, method="greedy",
                       gap_reference="none", min_spacing=60, forbidden=[(30.0, 60.0)],
                       candidate_steps=np.arange(1, 37), time_limit=INF, workers=1)
    b = schedule_pings(short, budget=2, belief=short_prior, method="greedy",
                       gap_reference="none", min_spacing=60.0, forbidden=((30, 60),))
    np.testing.assert_array_equal(a.steps, b.steps)
    assert not any(30.0 <= t <= 60.0 for t in a.times)


@pytest.mark.parametrize(("kw", "field"), [
    ({"max_rounds": 0}, "max_rounds"),  # was a bare AssertionError
    ({"budget": True}, "budget"), ({"budget": 1.5}, "budget"), ({"budget": -1}, "budget"),
])
def test_plan_joint_refuses_invalid_inputs(short, short_prior, kw, field):
    from tmaplan.errors import ArgumentError
    from tmaplan.planning import plan_joint

    args = {"budget": 1, "max_rounds": 2, **kw}
    with pytest.raises(ArgumentError, match=field):
        plan_joint(short, belief=short_prior, n_starts=1, control_interval=120.0, **args)


@pytest.mark.parametrize("steps", [(0, 5), (5, 37), (2.5,), (True, 5), (-3,)])
def test_scheduled_pings_refuses_steps_it_cannot_fly(short, steps):
    # step 0 and steps past the horizon were silently never pinged, 2.5 flown at step 2
    from tmaplan.errors import ArgumentError
    from tmaplan.policies import ScheduledPings

    with pytest.raises(ArgumentError, match=r"scheduled\.steps.*\[1, 36\]"):
        ScheduledPings(steps=steps).controller(short)
    ScheduledPings(steps=(1, 36)).controller(short)


def test_joint_ocp_own_pings_keep_a_valid_certificate(short, short_prior):
    # plan_joint_ocp replaces the scheduler's pings by its own when they are better; the gap
    # was max(0, (v − lb)/v): a bound above them (an invalid certificate) or a NaN bound
    # became a zero gap and "optimal"
    from tmaplan.errors import PlanningError
    from tmaplan.models.observer import observer_track
    from tmaplan.planning import PingEvaluator, schedule_pings
    from tmaplan.planning.joint_ocp import _with_own_pings

    cert = schedule_pings(short, budget=2, belief=short_prior, method="greedy",
                          gap_reference="none")
    ev = PingEvaluator(short, observer_track(short.observer, short.time), short_prior,
                       "mean-range-bound")
    own = [5, 20]
    v = ev.value(own)
    worse = dataclasses.replace(cert, objective=2 * v)
    ok = _with_own_pings(dataclasses.replace(worse, lower_bound=0.5 * v), ev, own)
    assert ok.steps.tolist() == own and ok.objective == v
    assert ok.gap == pytest.approx(0.5) and ok.status == "feasible"
    with pytest.raises(PlanningError, match="certificate invalid"):
        _with_own_pings(dataclasses.replace(worse, lower_bound=1.5 * v), ev, own)
    none = _with_own_pings(dataclasses.replace(worse, lower_bound=float("nan")), ev, own)
    assert np.isnan(none.gap) and none.status == "no bound"
    tight = _with_own_pings(dataclasses.replace(worse, lower_bound=v * (1 + 1e-9)), ev, own)
    assert tight.lower_bound == v and tight.gap == 0.0 and tight.status == "optimal"
    assert _with_own_pings(cert, ev, [36]) is cert  # the scheduler's pings are better


def test_schedule_results_are_read_only_and_independent_of_call_order(short, short_prior):
    # the relaxed weights of a result were the cached relaxation's array: zeroing them in one
    # result zeroed those of every later call on the same problem (and fed its roundings)
    from tmaplan.planning import schedule_pings

    s1 = schedule_pings(short, budget=2, belief=short_prior)
    w = s1.relaxed_weights.copy()
    assert w.size and w.max() > 0
    for name in ("steps", "times", "bound", "uniform_steps", "relaxed_weights"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(s1, name)[...] = 0
    s2 = schedule_pings(short, budget=2, belief=short_prior)
    np.testing.assert_array_equal(s2.relaxed_weights, w)
    np.testing.assert_array_equal(s2.steps, s1.steps)
