"""Ping scheduling (issue 6): exact vs exhaustive, gaps, monotonicity, constraints, errors."""

from __future__ import annotations

import dataclasses
import itertools
import warnings

import numpy as np
import pytest

from tmaplan.errors import PlanningError
from tmaplan.models.observer import observer_track
from tmaplan.planning import PingEvaluator, plan_joint, schedule_pings
from tmaplan.planning.ping_search import exact_search

CAND = list(range(4, 161, 4))  # 40 candidate steps


@pytest.fixture(scope="module")
def evaluator(default, prior):
    return PingEvaluator(default, observer_track(default.observer, default.time), prior,
                         "mean-range-bound")


@pytest.mark.solver_sensitive
def test_evaluator_matches_closed_form_model(default, evaluator):
    # independent evaluation path: tmaplan.bounds.closed_form (scenario prior, np.cov J0)
    from tmaplan.bounds.closed_form import closed_form_model

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cf = closed_form_model(default, prior_samples=20000)
    rng = np.random.default_rng(1)
    U = (rng.random((6, default.time.n_steps + 1)) < 0.03).astype(float)
    # the same J0 (one implementation, lpc_prior_information); the moments differ by round-off
    # (weighted cov + m mᵀ against XᵀX/n), amplified by the ill-conditioned recursion to 6e-7
    np.testing.assert_allclose(evaluator.per_step(U), cf.evaluate_schedules(U), rtol=1e-5)


@pytest.mark.parametrize("budget", [1, 2, 3])
@pytest.mark.parametrize("objective", ["mean-range-bound", "terminal-range-bound"])
def test_exact_equals_exhaustive(default, prior, budget, objective):
    from tmaplan.bounds.closed_form import closed_form_model

    res = schedule_pings(default, budget=budget, method="exact", objective=objective,
                         candidate_steps=CAND, min_spacing=0.0, belief=prior)
    assert res.status == "optimal" and res.gap == 0.0
    # exhaustive optimum with the independent closed-form evaluator
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cf = closed_form_model(default, prior_samples=20000)
    combos = list(itertools.combinations(CAND, budget))
    U = np.zeros((len(combos), default.time.n_steps + 1))
    for i, c in enumerate(combos):
        U[i, list(c)] = 1.0
    vals = cf.evaluate_schedules(U, reduce="mean" if objective.startswith("mean")
                                 else "terminal")
    best = int(np.argmin(vals))
    assert tuple(res.steps) == combos[best] or vals[combos.index(tuple(res.steps))] <= \
        vals[best] * (1 + 2e-4)
    assert res.objective == pytest.approx(vals[best], rel=2e-4)


def test_branch_and_bound_equals_enumeration(default, prior):
    kw = {"budget": 2, "method": "exact", "candidate_steps": CAND[:20], "belief": prior,
          "min_spacing": 0.0}
    enum = schedule_pings(default, **kw)
    bb = schedule_pings(default, max_enumerate=0, **kw)
    assert bb.status == "optimal"
    assert bb.objective == pytest.approx(enum.objective, rel=1e-12)


def test_more_pings_never_worse(default, prior):
    vals = [schedule_pings(default, budget=k, method="exact", objective="terminal-range-bound",
                           candidate_steps=CAND, min_spacing=0.0, belief=prior).objective
            for k in range(4)]
    assert all(b <= a for a, b in itertools.pairwise(vals))
    g = [schedule_pings(default, budget=k, method="greedy", objective="terminal-range-bound",
                        candidate_steps=CAND, min_spacing=0.0, belief=prior,
                        gap_reference="none").objective for k in range(1, 4)]
    assert all(b <= a for a, b in itertools.pairwise(g))


@pytest.mark.parametrize("method", ["relaxed", "greedy"])
def test_heuristics_report_gap_to_exact(default, prior, method):
    res = schedule_pings(default, budget=3, method=method, candidate_steps=CAND,
                         min_spacing=0.0, belief=prior, gap_reference="exact")
    ex = schedule_pings(default, budget=3, method="exact", candidate_steps=CAND,
                        min_spacing=0.0, belief=prior)
    assert res.gap_reference == "enumeration"
    assert res.lower_bound == pytest.approx(ex.objective, rel=1e-9)
    assert res.gap == pytest.approx((res.objective - ex.objective) / res.objective, abs=1e-9)
    assert res.gap >= -1e-12
    assert res.objective < res.uniform_objective < res.no_ping_objective


def test_relaxation_is_a_lower_bound_for_terminal(default, prior):
    # convex relaxation (cvxpy SDP): its optimum bounds the integer optimum below
    res = schedule_pings(default, budget=2, method="relaxed", objective="terminal-range-bound",
                         candidate_steps=CAND, min_spacing=0.0, belief=prior)
    ex = schedule_pings(default, budget=2, method="exact", objective="terminal-range-bound",
                        candidate_steps=CAND, min_spacing=0.0, belief=prior)
    assert res.gap_reference.startswith("relaxation")
    assert res.lower_bound <= ex.objective * (1 + 1e-9)
    assert res.objective >= ex.objective * (1 - 1e-12)


def test_spacing_and_forbidden_windows(default, prior):
    res = schedule_pings(default, budget=3, method="exact", candidate_steps=CAND,
                         min_spacing=600.0, forbidden=[(0.0, 400.0)], belief=prior)
    t = np.sort(res.times)
    assert t.size == 3  # the checks below are not vacuous: three pings fit after 400 s
    assert np.all(np.diff(t) >= 600.0 - 1e-9)
    assert np.all(t > 400.0)
    for m in ("relaxed", "greedy"):
        r = schedule_pings(default, budget=3, method=m, min_spacing=600.0,
                           forbidden=[(0.0, 400.0)], belief=prior, gap_reference="none")
        assert r.times.size == 3, m
        assert np.all(np.diff(np.sort(r.times)) >= 600.0 - 1e-9) and np.all(r.times > 400.0)


def test_infeasible_requests(default, prior):
    with pytest.raises(PlanningError, match="budget"):
        schedule_pings(default, budget=500, belief=prior)
    with pytest.raises(PlanningError, match="min_spacing"):
        schedule_pings(default, budget=30, min_spacing=600.0, belief=prior)
    no_range = default.replace(sensors=tuple(s for s in default.sensors if s.kind != "range"))
    with pytest.raises(PlanningError, match="range sensor"):
        schedule_pings(no_range, budget=2, belief=prior)


def test_joint_plan_improves_on_separate(default, prior):
    joint = plan_joint(default, budget=2, belief=prior, n_starts=1, control_interval=120.0)
    assert all(b <= a * (1 + 1e-6) for a, b in zip(joint.history, joint.history[1:]))
    sep = schedule_pings(default, budget=2, belief=prior, gap_reference="none")
    assert joint.objective < sep.objective
    assert joint.pings.steps.size == 2


def test_uniform_ping_steps_rule():
    # centres of `budget` equal sub-intervals: (i + ½)·K/budget, snapped to candidates
    from tmaplan.planning import uniform_ping_steps

    t = 6.0 * np.arange(451)
    assert uniform_ping_steps(t, 4) == [56, 169, 281, 394]
    assert uniform_ping_steps(t, 0) == []
    # a forbidden stretch: 168.75 moves to the nearest allowed step, 149
    cand = [c for c in range(1, 451) if not 150 <= c <= 190]
    assert uniform_ping_steps(t, 4, candidates=cand) == [56, 149, 281, 394]
    # spacing: no two pings closer than `gap` steps; a target without a free step is dropped
    assert uniform_ping_steps(t, 3, candidates=[10, 11, 12], gap=2) == [10, 12]


@pytest.mark.parametrize("forbidden", [(), ((300.0, 700.0),)])
def test_scheduler_uniform_reference_is_what_the_uniform_policy_flies(default, prior,
                                                                      forbidden):
    # issue 12: the uniform schedule `schedule` reports is, step for step, the one the
    # `uniform` ping policy flies in a closed-loop run (also around a forbidden window)
    import dataclasses

    from tmaplan.evaluation.closed_loop import run_closed_loop
    from tmaplan.policies import UniformPings
    from tmaplan.simulate import draw_truth

    sc = default.replace(planning=dataclasses.replace(default.planning,
                                                      ping_forbidden=forbidden))
    res = schedule_pings(sc, budget=4, method="greedy", belief=prior, gap_reference="none")
    run = run_closed_loop(sc, UniformPings(budget=4), draw_truth(sc, np.random.default_rng(1)),
                          noise_rng=np.random.default_rng(2),
                          filter_rng=np.random.default_rng(3), n_particles=200)
    assert res.uniform_steps.size == 4
    np.testing.assert_array_equal(run.ping_steps, res.uniform_steps)
    ev = PingEvaluator(sc, observer_track(sc.observer, sc.time), prior, "mean-range-bound")
    assert res.uniform_objective == ev.value(run.ping_steps.tolist())
    assert not any(a <= sc.times[k] <= b for k in run.ping_steps for a, b in forbidden)


def test_uniform_policy_steps_unchanged_on_default(default):
    # the uniform policy flew round((i + ½)·K/budget) (numpy rounding, half to even) before the
    # rule became one function; the default problem's steps are unchanged: [22, 68, 112, 158]
    from tmaplan.planning import uniform_ping_steps

    assert uniform_ping_steps(default.times, 4) == [22, 68, 112, 158]


def test_evaluator_refuses_steps_outside_the_track(evaluator):
    """PingEvaluator.schedules: a step past the track's last step K was an IndexError, a
    negative one silently pinged from the end; both are an ArgumentError naming ping_steps."""
    from tmaplan.errors import ArgumentError

    K = evaluator.K
    for bad in ([K + 1], [-1]):
        with pytest.raises(ArgumentError, match=rf"ping_steps.*\[0, {K}\]"):
            evaluator.schedules([[3], bad])
        with pytest.raises(ArgumentError, match="ping_steps"):
            evaluator.value(bad)
    assert evaluator.schedules([[0, K]])[0, [0, K]].tolist() == [1.0, 1.0]


def _first_step(sc, first_step):
    """``sc`` on a 30-min grid of 1-min steps, its bearings from ``first_step``, 20000 prior
    samples (those of closed_form_pcrb and of Belief.from_prior)."""
    import dataclasses

    sc = sc.replace(time=type(sc.time)(dt=60.0, horizon=1800.0, t0=0.0))
    sens = tuple(dataclasses.replace(s, first_step=first_step) if s.kind == "bearing" else s
                 for s in sc.sensors)
    return sc.replace(sensors=sens, prior=dataclasses.replace(sc.prior, samples=20000))


@pytest.mark.parametrize("first_step", [0, 1])
@pytest.mark.solver_sensitive
def test_planning_from_the_prior_counts_the_bearing_at_t0(default, first_step):
    """A plan from the prior (Belief.from_prior, which holds no measurement) counts a bearing
    taken at t0 (first_step = 0, e.g. clavard2013-*): the scheduler's, the ping evaluator's
    and the heading objective's values are closed_form_pcrb's for the same track and pings
    (the bearing at step 0 was dropped: 1.7e-5 relative off on this case). A belief that
    already holds it (a filter posterior, ``assimilated``) does not count it again. The
    remaining 4e-9 is the moments' round-off (test_evaluator_matches_closed_form_model),
    the same for first_step = 1."""
    from tmaplan.bounds.closed_form import closed_form_pcrb
    from tmaplan.planning import Belief, HeadingPlanner, ObjectiveEvaluator

    sc = _first_step(default, first_step)
    bel = Belief.from_prior(sc)
    assert not bel.assimilated
    track = observer_track(sc.observer, sc.time)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cf = closed_form_pcrb(sc, ping_steps=[5, 20])
        ev = PingEvaluator(sc, track, bel, "mean-range-bound")
        assert ev.value([5, 20]) == pytest.approx(cf.range_bound.mean(), rel=1e-7)
        np.testing.assert_allclose(ev.per_step(ev.schedules([[5, 20]]))[0], cf.range_bound,
                                   rtol=1e-7)
        u = np.zeros(sc.time.n_steps + 1)
        u[[5, 20]] = 1.0
        oe = ObjectiveEvaluator(sc, "mean-range-bound", belief=bel)
        assert oe(track, u)[0] == pytest.approx(cf.range_bound.mean(), rel=1e-7)
        sched = schedule_pings(sc, budget=2, gap_reference="none")
        ref = closed_form_pcrb(sc, ping_steps=sched.steps.tolist())
        assert sched.objective == pytest.approx(ref.range_bound.mean(), rel=1e-7)
        plan = HeadingPlanner(sc, objective="mean-range-bound", n_starts=1, horizon=1800.0,
                              control_interval=300.0).solve(bel, ping_steps=[5, 20])
        ref = closed_form_pcrb(sc, ping_steps=[5, 20], observer=plan.observer)
        assert plan.objective == pytest.approx(ref.range_bound.mean(), rel=1e-7)
        # a posterior that holds the bearing at t0: the scenario whose bearings start at 1
        post = Belief.from_samples(bel.samples, assimilated=True)
        cf1 = closed_form_pcrb(_first_step(default, 1), ping_steps=[5, 20])
        assert PingEvaluator(sc, track, post, "mean-range-bound").value([5, 20]) == \
            pytest.approx(cf1.range_bound.mean(), rel=1e-7)


# ----------------------------------------------------------------------------------------------
# From test_ping_schedule_review.py (folded in, issue 39):
# Review of the active-ping scheduler (fix/sched): exact search over *at most* ``budget``
# pings, validation of the scheduling inputs, certificates of the joint plans.
# ----------------------------------------------------------------------------------------------

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
    from tmaplan.planning.joint_ocp import with_own_pings

    cert = schedule_pings(short, budget=2, belief=short_prior, method="greedy",
                          gap_reference="none")
    ev = PingEvaluator(short, observer_track(short.observer, short.time), short_prior,
                       "mean-range-bound")
    own = [5, 20]
    v = ev.value(own)
    worse = dataclasses.replace(cert, objective=2 * v)
    ok = with_own_pings(dataclasses.replace(worse, lower_bound=0.5 * v), ev, own)
    assert ok.steps.tolist() == own and ok.objective == v
    assert ok.gap == pytest.approx(0.5) and ok.status == "feasible"
    with pytest.raises(PlanningError, match="certificate invalid"):
        with_own_pings(dataclasses.replace(worse, lower_bound=1.5 * v), ev, own)
    none = with_own_pings(dataclasses.replace(worse, lower_bound=float("nan")), ev, own)
    assert np.isnan(none.gap) and none.status == "no bound"
    tight = with_own_pings(dataclasses.replace(worse, lower_bound=v * (1 + 1e-9)), ev, own)
    assert tight.lower_bound == v and tight.gap == 0.0 and tight.status == "optimal"
    assert with_own_pings(cert, ev, [36]) is cert  # the scheduler's pings are better


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
