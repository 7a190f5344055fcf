"""Heading OCP (issue 6): transcriptions, objectives, lecadre1997 bang-bang results, errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tmaplan.errors import ArgumentError, PlanningError, SolverError
from tmaplan.models.observer import arc_displacement, turn_rate_track
from tmaplan.planning import (
    Belief,
    HeadingPlanner,
    ObjectiveEvaluator,
    bearing_rate_plan,
    evaluate_baselines,
    straight_track,
)


@pytest.fixture(scope="module")
def direct_plan(default, prior):
    # the closed-form range bound's plan (the tests below check it against its baselines)
    return HeadingPlanner(default, objective="range-bound").solve(prior)


def test_arc_displacement_casadi_matches_numpy():
    import casadi as ca

    from tmaplan.planning.heading import arc_displacement_casadi

    psi, u, v, dt = 0.3, np.array([0.0, 1e-9, 2e-3, -0.05, 0.4]), 3.1, 15.0
    ref = arc_displacement(np.full(5, psi), u, np.full(5, v), dt)
    dx, dy = arc_displacement_casadi(psi, ca.DM(u), v, dt)
    np.testing.assert_allclose(np.hstack([np.asarray(dx), np.asarray(dy)]), ref, rtol=1e-12,
                               atol=1e-12)
    # derivative at u = 0 is finite and matches a central difference
    x = ca.SX.sym("u")
    fx = ca.Function("f", [x], [ca.jacobian(arc_displacement_casadi(psi, x, v, dt)[0], x)])
    h = 1e-5
    fd = (arc_displacement(psi, h, v, dt)[0] - arc_displacement(psi, -h, v, dt)[0]) / (2 * h)
    assert np.isfinite(float(fx(0.0)))
    assert float(fx(0.0)) == pytest.approx(fd, rel=1e-6)


@pytest.mark.solver_sensitive
def test_range_and_position_bound_match_closed_form(default, prior):
    from tmaplan.bounds.closed_form import closed_form_pcrb

    trk = straight_track(default)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = closed_form_pcrb(default, prior_samples=20000)
    rb = ObjectiveEvaluator(default, "range-bound", belief=prior)(trk)[1]
    pb = ObjectiveEvaluator(default, "position-bound", belief=prior)(trk)[0]
    # Same prior samples and one J0 (lpc_prior_information); the moments differ by round-off
    # (weighted cov + m mᵀ against XᵀX/n), amplified by the ill-conditioned recursion.
    np.testing.assert_allclose(rb, ref.range_bound, rtol=1e-5)
    assert pb == pytest.approx(ref.position_std[-1], rel=1e-5)


def test_logdet_matches_independent_fim(default, prior):
    from tmaplan.bounds.fimdet import fim_bearings

    trk = turn_rate_track(np.zeros(2), 0.0, 3.0, np.r_[np.zeros(60), np.full(60, 0.008),
                                                       np.zeros(60)], 15.0)
    val = ObjectiveEvaluator(default, "logdet", belief=prior)(trk)[0]
    t = trk.times
    X0 = prior.mean
    rel = X0[:2] + t[1:, None] * (X0[2:] + trk.mean_velocity[0]) - trk.position[1:]
    F = fim_bearings(rel, t[1:], np.radians(1.0)) + np.linalg.inv(prior.cov)
    assert val == pytest.approx(-np.linalg.slogdet(F)[1], rel=1e-8, abs=1e-7)


def test_relative_range_crlb_matches_independent_computation(default, prior):
    # mean over steps and belief samples of sqrt(g_kᵀ (F_k + I₀)⁻¹ g_k)/r_k, with F_k the
    # bearing FIM of X₀ from steps 1..k (rows [r_y, −r_x, t r_y, −t r_x]/(σ r²), numpy) and
    # g_k the range gradient
    trk = turn_rate_track(np.zeros(2), 0.0, 3.0, np.r_[np.zeros(60), np.full(60, 0.008),
                                                       np.zeros(60)], 15.0)
    val = ObjectiveEvaluator(default, "mean-relative-range-crlb", belief=prior)(trk)[0]
    t = trk.times
    I0 = np.linalg.inv(prior.cov)
    vals = []
    for X0 in prior.representative_samples(16):
        rel = X0[:2] + t[:, None] * (X0[2:] + trk.mean_velocity[0]) - trk.position
        r2 = (rel**2).sum(axis=1)
        rows = np.stack([rel[:, 1], -rel[:, 0], t * rel[:, 1], -t * rel[:, 0]], axis=1)
        rows /= np.radians(1.0) * r2[:, None]
        rows[0] = 0.0  # no bearing at plan step 0 (the belief already holds it)
        cum = np.cumsum(rows[:, :, None] * rows[:, None, :], axis=0)
        for k in range(len(t)):
            F = I0 + cum[k]
            r = np.sqrt(r2[k])
            u = rel[k] / r
            g = np.r_[u, t[k] * u]
            vals.append(np.sqrt(g @ np.linalg.solve(F, g)) / r)
    assert val == pytest.approx(np.mean(vals), rel=1e-6)


def test_rotation_and_translation_invariance(default, prior):
    th = 0.7
    R = np.array([[np.cos(th), np.sin(th)], [-np.sin(th), np.cos(th)]])  # bearing += th
    Rb = np.kron(np.eye(2), R)
    rot = Belief.from_samples(prior.samples @ Rb.T)
    u = np.r_[np.full(40, 0.008), np.zeros(100), np.full(40, -0.008)]
    a = turn_rate_track(np.zeros(2), 0.0, 3.0, u, 15.0)
    b = turn_rate_track(np.array([5e3, -2e3]), th, 3.0, u, 15.0)
    for obj in ("range-bound", "logdet", "mean-position-bound"):
        va = ObjectiveEvaluator(default, obj, belief=prior)(a)[0]
        vb = ObjectiveEvaluator(default, obj, belief=rot)(b)[0]
        assert vb == pytest.approx(va, rel=1e-6), obj


# ------------------------------------------------------------------ lecadre1997 (docs/errata.md)
@pytest.mark.parametrize("n", [12, 15])
def test_two_leg_fixed_switch_is_bang_bang_opposite(n):
    # lecadre1997 eq. 87 (docs/errata.md, T18): |θ̇1| = |θ̇2| = θ̇max and θ̇2 = −θ̇1.
    res = bearing_rate_plan(n, 1e-2, switch="fixed")
    np.testing.assert_allclose(np.abs(res.rates), 1e-2, rtol=1e-6)
    assert res.rates[0] * res.rates[1] < 0


@pytest.mark.parametrize("n", [12, 15, 20])
@pytest.mark.solver_sensitive
def test_free_switch_gives_one_switch_near_third(n):
    # docs/errata.md: exhaustive search gives ONE switch near N/3 (or 2N/3 by time
    # reversal); the printed alternating three-leg optimum (eq. 92) is not reproduced. The
    # switching-time NLP starts with three alternating arcs and must drop one.
    res = bearing_rate_plan(n, 1e-2, switch="free", n_arcs=3, n_starts=4)
    assert res.switch_times.size == 1
    T = float(res.switch_times[0])
    assert min(abs(T - n / 3), abs(T - 2 * n / 3)) <= 1.5
    # independent check: brute force over switch instants on a half-sample grid
    from tmaplan.planning.baselines import _logdet_switches

    grid = np.arange(0.5, n - 1, 0.5)
    vals = [_logdet_switches([1e-2, -1e-2], np.array([s]), n) for s in grid]
    assert res.logdet == pytest.approx(max(vals), abs=1e-9)


# ------------------------------------------------------------------------ default problem
@pytest.mark.solver_sensitive
def test_default_plan_beats_every_baseline(default, prior, direct_plan):
    plan = direct_plan
    assert plan.success
    base = evaluate_baselines(default, "range-bound", belief=prior)
    for lst in base.values():
        for b in lst:
            assert plan.objective < b.objective
            assert plan.range_bound[-1] < b.range_bound[-1]
    # limits at every step
    umax = default.observer.turn_rate_max
    rate = np.diff(np.unwrap(plan.observer.heading)) / default.time.dt
    assert np.all(np.abs(rate) <= umax * (1 + 1e-6))
    np.testing.assert_allclose(plan.observer.speed, default.observer.speed_max, rtol=1e-12)
    # the returned track is the exact integration of the returned controls
    trk = turn_rate_track(plan.observer.position[0], plan.heading[0],
                          float(default.observer.speed_max), rate, default.time.dt)
    np.testing.assert_allclose(trk.position, plan.observer.position, atol=1e-3)


def test_default_objective_plan_beats_every_baseline_and_tactic(default, prior):
    from tmaplan.planning.objectives import DEFAULT_OBJECTIVE
    from tmaplan.policies import LeadLag, LegTurnLeg
    from tmaplan.policies.plan_starts import plan_from_prior

    plan = plan_from_prior(default)
    assert plan.success and plan.message.startswith("best of the multi-start")
    ev = ObjectiveEvaluator(default, DEFAULT_OBJECTIVE, belief=prior)
    assert plan.objective == pytest.approx(ev(plan.observer)[0], rel=1e-6)
    base = evaluate_baselines(default, DEFAULT_OBJECTIVE, belief=prior, evaluator=ev)
    others = [b.objective for lst in base.values() for b in lst]
    others += [ev(t.nominal_track(default))[0] for t in (LegTurnLeg(), LeadLag())]
    assert plan.objective < min(others) - 1e-3
    # the cold one-start solve from the straight course stays on the plateau
    flat = HeadingPlanner(default, n_starts=1).solve(prior)
    assert flat.objective > plan.objective + 0.1


@pytest.mark.solver_sensitive
def test_bang_bang_transcription(default, prior):
    planner = HeadingPlanner(default, transcription="bang-bang", n_starts=2)
    plan = planner.solve(prior)
    assert plan.success
    # on the functional it optimised (the default objective)
    straight = ObjectiveEvaluator(default, planner.objective, belief=prior)(
        straight_track(default))
    assert plan.objective < straight[0]
    rate = np.diff(np.unwrap(plan.observer.heading)) / default.time.dt
    umax = default.observer.turn_rate_max
    # away from the switch instants the turn rate is exactly one of {−u_max, 0, +u_max}
    t = plan.observer.times
    far = np.all(np.abs(t[:-1, None] - plan.switch_times[None, :]) > default.time.dt, axis=1)
    far &= np.all(np.abs(t[1:, None] - plan.switch_times[None, :]) > default.time.dt, axis=1)
    d = np.min(np.abs(rate[far, None] - np.array([-umax, 0.0, umax])[None, :]), axis=1)
    assert np.all(d < 1e-3 * umax)  # arcs shorter than 1e-6 H are not reported as switches


@pytest.mark.solver_sensitive
def test_warm_start_and_receding(default, prior, direct_plan):
    # range-bound: the default objective is flat at the straight course (every prior draw
    # unlocalised, the logistic saturated), so its one-start cold solve stays there
    planner = HeadingPlanner(default, objective="range-bound", n_starts=1)
    cold = planner.solve(prior)
    warm = planner.solve(prior, warm_start=cold)
    assert warm.objective == pytest.approx(cold.objective, rel=1e-4)
    assert warm.iterations < cold.iterations
    later = Belief.from_samples(prior.samples, t=300.0)
    nxt = planner.solve(later, heading0=0.3, warm_start=cold)
    assert nxt.times[0] == pytest.approx(300.0)
    assert nxt.observer.heading[0] == pytest.approx(0.3)


def test_infeasible_and_failed_requests(default, prior):
    # a contact dead ahead and closing; no turn possible -> keep-out infeasible
    rng = np.random.default_rng(0)
    X = np.array([0.0, 3000.0, 0.0, -3.0]) + rng.normal(0, [200, 200, 0.3, 0.3], (500, 4))
    planner = HeadingPlanner(default, turn_rate_max=0.0, n_starts=1)
    with pytest.raises(PlanningError, match="keep_out"):
        planner.solve(Belief.from_samples(X))
    with pytest.raises(PlanningError, match="no mass"):
        Belief.from_samples(X, weights=np.zeros(500))
    bad = HeadingPlanner(default, n_starts=1, solver_options={"max_iter": 2})
    with pytest.raises(SolverError, match="Maximum_Iterations"):
        bad.solve(prior)
    res = bad.solve(prior, raise_on_failure=False)
    assert not res.success and "Maximum_Iterations" in res.status


def test_objective_names_are_one_list(default):
    # issue 12: the objective names are listed once (tmaplan.planning.objectives); the
    # scenario's planning.objective, `plan --objective` and the scheduler use that list
    import dataclasses

    from tmaplan.errors import ScenarioError
    from tmaplan.planning import OBJECTIVE_NAMES, PING_OBJECTIVES, make_objective
    from tmaplan.scenario import from_dict, to_dict

    for name in OBJECTIVE_NAMES:
        assert make_objective(name).terms
        assert dataclasses.replace(default.planning, objective=name).objective == name
    assert set(PING_OBJECTIVES) <= set(OBJECTIVE_NAMES)
    d = to_dict(default)
    d["planning"]["objective"] = "fastest"
    with pytest.raises(ScenarioError, match=r"planning\.objective.*'logdet'"):
        from_dict(d)


def test_multi_start_on_worker_processes_gives_the_same_plans(default):
    """The starts solved on 2 spawned processes (each with its own planner) give the plans of
    one process, bit for bit, in the same order; ``workers`` is checked."""
    from tmaplan.errors import ArgumentError
    from tmaplan.policies.plan_starts import plan_candidates

    kw = dict(horizon=900.0, control_interval=60.0)
    one = plan_candidates(default, "mean-range-bound", **kw)
    two = plan_candidates(default, "mean-range-bound", workers=2, **kw)
    assert list(one) == list(two) and len(one) >= 1
    for name in one:
        assert one[name].objective == two[name].objective
        assert np.array_equal(one[name].turn_rate, two[name].turn_rate)
        assert np.array_equal(one[name].observer.position, two[name].observer.position)
    for bad in (0, 1.5, True):
        with pytest.raises(ArgumentError, match="workers"):
            plan_candidates(default, "mean-range-bound", workers=bad, **kw)
    # on a pool shared by a job's steps: the same plans
    from tmaplan.parallel import process_pool

    with process_pool(2) as pool:
        three = plan_candidates(default, "mean-range-bound", pool=pool, **kw)
    assert list(one) == list(three)
    for name in one:
        assert np.array_equal(one[name].turn_rate, three[name].turn_rate)


def test_worker_builds_a_new_planner_for_a_new_problem(default):
    """A worker of a shared pool keeps one planner per multi-start (its token): a later
    multi-start of another problem on the same worker does not reuse the first planner."""
    from tmaplan.policies import plan_starts

    def solve(token, horizon):
        kw = {"horizon": horizon, "control_interval": 60.0}
        u = np.where(np.arange(int(horizon / 60)) < 3, 1.0, 0.0)
        plan_starts._solve_in_worker((token, default, "mean-range-bound", kw), u)
        return plan_starts._WORKER["planner"]

    first = solve("a", 600.0)
    assert solve("a", 600.0) is first and first.n == 10  # built once per token
    assert solve("b", 900.0).n == 15


def test_belief_from_particles_keeps_the_filter_weights():
    """A filter between resamplings has unequal weights: with no more particles than
    ``max_samples`` the belief keeps them (its mean is the weighted mean, not the plain one);
    with more, the systematic subsample is equally weighted and its moments match the
    weighted ones to within the subsample's resolution; bad sizes are refused."""
    rng = np.random.default_rng(3)
    X = np.array([0.0, 8000.0, 0.0, -3.0]) + rng.normal(0, [500, 500, 1.0, 1.0], (1000, 4))
    w = np.where(X[:, 0] > 0, 9.0, 1.0)  # nine times the mass east of the mean bearing
    w /= w.sum()
    b = Belief.from_particles(X, w, t=60.0, max_samples=1000)
    assert b.t == 60.0
    np.testing.assert_allclose(b.mean, w @ X, rtol=1e-12)
    assert b.mean[0] > 250.0 > X[:, 0].mean() + 200.0  # the plain mean is ~0
    sub = Belief.from_particles(X, w, max_samples=200)
    assert sub.samples.shape == (200, 4)
    np.testing.assert_allclose(sub.weights, 1 / 200)
    sd = np.sqrt(np.diag(b.cov))
    assert np.all(np.abs(sub.mean - b.mean) < 0.1 * sd)
    for bad in (4, 10.0, True):
        with pytest.raises(PlanningError, match="max_samples"):
            Belief.from_particles(X, w, max_samples=bad)


def test_ping_steps_outside_the_horizon_are_refused(default, prior):
    """A ping step before the plan's start or after its last step K is refused with an
    ArgumentError naming ping_steps, the valid range and the steps (it was dropped: the
    plan was solved as if that ping did not exist)."""
    from tmaplan.errors import ArgumentError
    from tmaplan.planning import plan_heading

    planner = HeadingPlanner(default, objective="mean-range-bound", horizon=900.0,
                             control_interval=300.0, n_starts=1)
    K = planner.K
    for bad in ([K + 1], [-1], [3, K + 5]):
        with pytest.raises(ArgumentError, match=rf"ping_steps.*\[0, {K}\].*{bad[-1]}"):
            planner.solve(prior, ping_steps=bad)
    with pytest.raises(ArgumentError, match="ping_steps"):
        plan_heading(default, belief=prior, objective="mean-range-bound", horizon=900.0,
                     control_interval=300.0, n_starts=1, ping_steps=[K + 1])
    assert planner.parameter_vector(prior, [0, K])[planner.layout.slices()["ping"]][[0, K]].sum() \
        == 2.0


def test_evaluator_scores_the_objective_the_planner_minimised():
    """planner.evaluator(belief) values a plan's track at plan.objective (to round-off) with a
    turn_rate_max override (the turn penalty's normaliser), logdet_samples and until_end; the
    scenario-default evaluator did not (the turn penalty normalised by the scenario's rate,
    logdet at the belief mean)."""
    from tmaplan.planning import logdet, range_bound, turn_penalty
    from tmaplan.scenario import load_problem

    sc = load_problem("default")
    sc = sc.replace(time=type(sc.time)(dt=60.0, horizon=1800.0, t0=0.0))
    bel = Belief.from_prior(sc, n=3000)
    kw = dict(n_starts=1, control_interval=300.0, horizon=1800.0)
    obj = range_bound("mean") + turn_penalty(100.0)
    half = HeadingPlanner(sc, objective=obj, turn_rate_max=sc.observer.turn_rate_max / 2, **kw)
    plan = half.solve(bel)
    assert plan.success
    assert half.evaluator(bel)(plan.observer)[0] == pytest.approx(plan.objective, rel=1e-10)
    same = ObjectiveEvaluator(sc, obj, belief=bel, n_steps=half.K, turn_rate_max=half.u_max)
    assert same(plan.observer)[0] == pytest.approx(plan.objective, rel=1e-10)
    ld = HeadingPlanner(sc, objective="logdet", logdet_samples=8, **kw)
    plan = ld.solve(bel)
    assert ld.evaluator(bel)(plan.observer)[0] == pytest.approx(plan.objective, rel=1e-10)
    named = ObjectiveEvaluator(sc, "logdet", belief=bel, n_steps=ld.K, samples=8)
    assert named.objective.n_samples == logdet(8).n_samples == 8
    assert named(plan.observer)[0] == pytest.approx(plan.objective, rel=1e-10)
    late = Belief.from_samples(bel.samples, t=1200.0)  # 10 of the 30 plan steps left
    ue = HeadingPlanner(sc, objective="mean-range-bound", until_end=True, **kw)
    plan = ue.solve(late)
    assert ue.evaluator(late)(plan.observer)[0] == pytest.approx(plan.objective, rel=1e-10)
    with pytest.raises(ArgumentError, match="turn_rate_max"):
        ObjectiveEvaluator(sc, obj, belief=bel, turn_rate_max=-1.0)


def test_bearing_rate_arcs_merge_only_equal_rates():
    """The free-switch bearing-rate plan merged consecutive arcs whose rates were
    np.isclose (atol 1e-8): at rate_max 1e-9 rad per sample, +rate_max and −rate_max."""
    from tmaplan.planning.baselines import _merge_arcs

    r = 1e-9 * np.array([1.0, -1.0, 1.0, 1.0])
    assert _merge_arcs(r, np.array([10.0, 20.0, 15.0, 15.0]), 60.0) == (
        [1e-9, -1e-9, 1e-9], [10.0, 20.0, 30.0])
