"""Review of the policies and of the planning helpers they use (belief, baselines, joint plan):
inputs that were silently accepted or crashed without naming the field, and reports that
contradicted their documentation."""

from __future__ import annotations

import dataclasses
import re
import types

import numpy as np
import pytest

from tmaplan.caching import LRUCache
from tmaplan.errors import ArgumentError, PlanningError, ScenarioError
from tmaplan.planning import baselines
from tmaplan.planning.belief import Belief
from tmaplan.policies import AlarmResponse, NoPing, Receding, parse_policy
from tmaplan.scenario import load_problem


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _cloud(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, 4)) * [100.0, 100.0, 1.0, 1.0] + [5000.0, 5000.0, 0.0, 0.0]


# ------------------------------------------------------------------------------ belief


@pytest.mark.parametrize("n_weights", [2500, 3500])
def test_from_particles_refuses_weights_not_one_per_particle_when_subsampling(n_weights):
    # 3000 particles, max_samples 2000: the systematic subsample used to pick rows by the
    # wrong weights (2500 weights: the last 500 particles never drawn) or crash (IndexError)
    with pytest.raises(PlanningError, match="one weight per particle"):
        Belief.from_particles(_cloud(3000), np.ones(n_weights), max_samples=2000)


def test_from_particles_still_subsamples_systematically():
    X = _cloud(3000)
    w = np.zeros(3000)
    w[:10] = 1.0  # all the mass on ten particles: the subsample holds only those
    b = Belief.from_particles(X, w, max_samples=2000)
    assert b.samples.shape == (2000, 4)
    assert {tuple(r) for r in b.samples} <= {tuple(r) for r in X[:10]}
    assert b.mean == pytest.approx(X[:10].mean(axis=0))


@pytest.mark.parametrize("mean", [[np.nan, 0, 0, 0], [np.inf, 0, 0, 0]])
def test_from_moments_refuses_a_non_finite_mean(mean):
    with pytest.raises(PlanningError, match="mean"):
        Belief.from_moments(mean, np.eye(4))


@pytest.mark.parametrize("t", [np.nan, np.inf, "10", True])
def test_a_belief_time_must_be_finite(t):
    with pytest.raises(PlanningError, match="t: expected a finite time"):
        Belief.from_moments([1000.0, 0, 0, 0], np.eye(4), t=t)
    with pytest.raises(PlanningError, match="t: expected a finite time"):
        Belief.from_samples(_cloud(10), t=t)


@pytest.mark.parametrize("n", [7.9, True, 3])
def test_from_prior_refuses_a_sample_count_that_is_not_an_integer_ge_5(scenario, n):
    with pytest.raises(ArgumentError, match="'n'"):
        Belief.from_prior(scenario, n=n)


# ------------------------------------------------------------------------------ baselines


@pytest.mark.parametrize("call, field", [
    (lambda sc: baselines.zigzag_track(sc, np.nan, 0.5), "leg_duration"),
    (lambda sc: baselines.zigzag_track(sc, 1e-9, 0.5), "leg_duration"),  # was a hang
    (lambda sc: baselines.zigzag_track(sc, 300.0, np.nan), "angle"),
    (lambda sc: baselines.single_turn_track(sc, np.nan, 100.0), "angle"),
    (lambda sc: baselines.single_turn_track(sc, 0.5, np.nan), "time"),
    (lambda sc: baselines.single_turn_track(sc, 0.5, 100.0, turn_rate=np.nan), "turn_rate"),
    (lambda sc: baselines.single_turn_track(sc, 0.5, 100.0, turn_rate=True), "turn_rate"),
    (lambda sc: baselines.course_program_track(sc, [(100.0, np.nan)]), "courses[0].course"),
])
def test_baseline_tracks_refuse_non_finite_angles_times_and_rates(scenario, call, field):
    # they gave a NaN track, a track without the turn, or int(nan)'s ValueError
    with pytest.raises(ArgumentError, match=re.escape(f"'{field}'")):
        call(scenario)


@pytest.mark.parametrize("kw, field", [
    ({"n_starts": 0}, "n_starts"), ({"n_samples": 3}, "n_samples"),
    ({"rate_max": np.nan}, "rate_max"), ({"switch_time": 60.0}, "switch_time"),
])
def test_bearing_rate_plan_checks_its_arguments_before_solving(kw, field):
    args = {"n_samples": 50, "rate_max": 1e-2, **kw}
    with pytest.raises(ArgumentError, match=rf"'{field}'"):
        baselines.bearing_rate_plan(args.pop("n_samples"), args.pop("rate_max"), **args)


# ------------------------------------------------------------------------------ alarms


@pytest.mark.parametrize("kw, field", [
    ({"turn": "0.5"}, "turn"), ({"turn": True}, "turn"), ({"spacing": "10"}, "spacing"),
    ({"spacing": np.inf}, "spacing"),
])
def test_alarm_response_refuses_non_real_turns_and_spacings(kw, field):
    with pytest.raises(ArgumentError, match=rf"alarm_response\.{field}"):
        AlarmResponse(**kw)


def test_an_alarm_turn_needs_a_turn_rate_limit(scenario):
    sc = dataclasses.replace(scenario, observer=dataclasses.replace(scenario.observer,
                                                                    turn_rate_max=None))
    with pytest.raises(ScenarioError, match="turn_rate_max"):
        AlarmResponse(turn=0.5).wrap(NoPing().controller(sc), sc)
    AlarmResponse().wrap(NoPing().controller(sc), sc)  # pings only: no limit needed


# ------------------------------------------------------------------------------ receding


@pytest.mark.parametrize("value", ["0.1", True])
def test_receding_full_above_must_be_a_real_fraction(scenario, value):
    # a string raised a bare TypeError, True was taken as 1.0
    with pytest.raises(ArgumentError, match=r"receding\.full_above"):
        Receding(full_above=value).controller(scenario)


# ------------------------------------------------------------------------------ parsing


@pytest.mark.parametrize("spec", [None, 3])
def test_parse_policy_refuses_a_non_string(scenario, spec):
    with pytest.raises(PlanningError, match="unknown policy"):
        parse_policy(spec, scenario)


# ------------------------------------------------------------------------------ joint plan


def test_plan_joint_history_never_reports_a_rejected_heading_block(scenario, monkeypatch):
    """A heading re-solve that does not improve on the pair is rejected: the pair's objective
    is then the schedule's, not the older heading plan's (computed with other pings)."""
    from tmaplan.planning import joint

    track = object()

    class Planner:
        def __init__(self, *a, **k):
            pass

        def solve(self, bel, warm_start=None, ping_steps=None):
            # pingless: 100; with pings the re-solve is worse than the schedule (95 > 90)
            return types.SimpleNamespace(objective=100.0 if ping_steps is None else 95.0,
                                         observer=track)

    def schedule(*a, **k):
        return types.SimpleNamespace(objective=90.0, steps=np.array([10, 20]))

    monkeypatch.setattr(joint, "HeadingPlanner", Planner)
    monkeypatch.setattr(joint, "schedule_pings", schedule)
    res = joint.plan_joint(scenario, budget=2, belief=object())
    assert res.objective == 90.0
    assert all(b <= a for a, b in zip(res.history, res.history[1:])), res.history


def test_the_offline_schedule_cache_is_bounded_lru(scenario, monkeypatch):
    """``_SCHEDULE_CACHE`` grew by one schedule per (scenario, budget, method, objective,
    track) for the life of the process; it keeps the most recently used ones only (the one
    :class:`tmaplan.caching.LRUCache`), and a
    cached schedule is the scheduler's steps, read only."""
    import tmaplan.planning
    import tmaplan.policies.pings as pings

    real = tmaplan.planning.schedule_pings
    calls = []

    def counted(sc, *, budget, **kw):
        calls.append(budget)
        return real(sc, budget=budget, **kw)

    monkeypatch.setattr(pings, "schedule_pings", counted)
    monkeypatch.setattr(pings, "_SCHEDULE_CACHE", LRUCache(2))

    def steps(budget):
        return pings.offline_schedule(scenario, budget, "greedy", "mean-range-bound")

    first = steps(1)
    assert np.array_equal(first, real(scenario, budget=1, method="greedy",
                                      objective="mean-range-bound").steps)
    assert not first.flags.writeable
    steps(2)
    assert steps(1) is first and calls == [1, 2]   # a hit, now the most recent
    steps(3)                                         # evicts budget 2, the least recent
    assert len(pings._SCHEDULE_CACHE) == 2 and calls == [1, 2, 3]
    assert steps(1) is first and calls == [1, 2, 3]
    assert np.array_equal(steps(2), real(scenario, budget=2, method="greedy",
                                         objective="mean-range-bound").steps)
    assert calls == [1, 2, 3, 2] and len(pings._SCHEDULE_CACHE) == 2


def test_short_horizons_keep_only_the_zigzags_that_can_be_flown():
    # the zig-zag grid's legs of 1/8..1/3 of the horizon were built whatever the horizon:
    # under 8 steps `plan` (and every planned policy) failed on an internal leg_duration error
    import dataclasses

    from tmaplan.planning.baselines import evaluate_baselines
    from tmaplan.policies.combine import best_zigzag

    sc = load_problem("default")

    def short(k):
        h = k * sc.time.dt
        return sc.replace(time=dataclasses.replace(sc.time, horizon=h),
                          planning=dataclasses.replace(sc.planning, horizon=h,
                                                       control_interval=sc.time.dt,
                                                       ping_budget=min(2, k),
                                                       ping_min_spacing=sc.time.dt,
                                                       replan_interval=None))

    five = evaluate_baselines(short(5), "range-bound")
    legs = {b.params["leg_duration"] for b in five["zigzag"]}
    assert legs == {5 * sc.time.dt / 4, 5 * sc.time.dt / 3}  # 1/8 and 1/6 are under a step
    assert len(five["single-turn"]) == len(evaluate_baselines(short(8), "range-bound")
                                           ["single-turn"])
    two = evaluate_baselines(short(2), "range-bound")
    assert set(two) == {"straight", "single-turn"}
    with pytest.raises(PlanningError, match="no zig-zag"):
        best_zigzag(short(2))
