"""Ping scheduling (issue 6): exact vs exhaustive, gaps, monotonicity, constraints, errors."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

from tmaplan.errors import PlanningError
from tmaplan.models.observer import observer_track
from tmaplan.planning import PingEvaluator, plan_joint, schedule_pings

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
