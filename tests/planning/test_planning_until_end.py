"""Step weights of the planning objectives and ``until_end`` (plans that stop counting at the
scenario's end)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.planning import HeadingPlanner
from tmaplan.planning.objectives import ParamLayout

_KW = {"objective": "expected-time-to-accuracy", "horizon": 900.0, "control_interval": 60.0,
       "n_starts": 1}


def test_step_weights_default_to_one_and_are_checked(prior):
    lay = ParamLayout(n_steps=4, n_samples=2)
    p = lay.vector(prior, np.ones(5))
    assert p.size == lay.size
    assert np.array_equal(p[lay.slices()["weight"]], np.ones(5))
    w = np.array([1.0, 1.0, 0.5, 0.0, 0.0])
    assert np.array_equal(lay.vector(prior, np.ones(5), weight=w)[lay.slices()["weight"]], w)
    with pytest.raises(ArgumentError, match="weight"):
        lay.vector(prior, np.ones(5), weight=np.ones(4))


def test_until_end_changes_nothing_while_the_horizon_fits(default, prior):
    """At the start the whole 15-minute horizon lies inside the 45-minute scenario: every
    step weight is 1, so the plan is the same bit for bit."""
    sc = default
    a = HeadingPlanner(sc, **_KW).solve(prior)
    b = HeadingPlanner(sc, until_end=True, **_KW).solve(prior)
    assert a.objective == b.objective
    assert np.array_equal(a.turn_rate, b.turn_rate)


def test_until_end_counts_only_the_time_left(default, prior):
    """Five minutes before the end, the expected time not localised can only count the 21
    steps left (≤ 21·15 s) plus the turn penalty (≤ 0.02·61·15 s); counted over the whole
    15-minute horizon it is far larger for a prior that is not localised."""
    sc = default
    end = sc.time.t0 + sc.time.dt * sc.time.n_steps
    late = dataclasses.replace(prior, t=end - 300.0)
    short = HeadingPlanner(sc, until_end=True, **_KW).solve(late)
    full = HeadingPlanner(sc, **_KW).solve(late)
    dt = sc.time.dt
    assert short.objective <= 21 * dt + 0.02 * 61 * dt
    assert full.objective > 2 * (21 * dt + 0.02 * 61 * dt)


def test_receding_until_end_builds_its_planner_with_it(default):
    from tmaplan.policies import Receding

    sc = default
    for solver in ("real-time", "multi-start"):
        pol = Receding(until_end=True, horizon=900.0, objective="mean-range-bound",
                       solver=solver).resolve(sc)
        ctl = pol.controller(sc)
        assert ctl.planner.until_end
        assert ctl.rti is None if solver == "multi-start" else ctl.rti.planner is ctl.planner
        assert not Receding(horizon=900.0, objective="mean-range-bound",
                            solver=solver).resolve(sc).controller(sc).planner.until_end


@pytest.mark.parametrize("objective", ["expected-time-to-accuracy", "mean-relative-range-crlb",
                                       "logdet"])
def test_until_end_equals_a_horizon_that_stops_at_the_end(default, prior, objective):
    """Cross-check of the step weights: on the straight course (the first guess, IPOPT stopped
    before its first iteration), a 15-minute horizon that counts only the 5 minutes left
    gives the objective of a 5-minute horizon (the bound at step k uses the steps ≤ k only)."""
    sc = default
    end = sc.time.t0 + sc.time.dt * sc.time.n_steps
    late = dataclasses.replace(prior, t=end - 300.0)
    kw = {"objective": objective, "control_interval": 60.0, "n_starts": 1,
          "solver_options": {"max_iter": 0}}
    counted = HeadingPlanner(sc, horizon=900.0, until_end=True, **kw).solve(
        late, raise_on_failure=False)
    short = HeadingPlanner(sc, horizon=300.0, **kw).solve(late, raise_on_failure=False)
    whole = HeadingPlanner(sc, horizon=900.0, **kw).solve(late, raise_on_failure=False)
    assert np.allclose(counted.turn_rate, 0.0) and np.allclose(short.turn_rate, 0.0)
    assert counted.objective == pytest.approx(short.objective, rel=1e-10)
    assert abs(whole.objective - short.objective) > 1e-3 * abs(short.objective)


def test_terminal_objectives_do_not_read_the_step_weights(default, prior):
    """Documented (ParamLayout): a terminal objective is the value at the horizon's last step,
    step weights or not; the mean one and logdet count only the weighted steps."""
    from tmaplan.planning.baselines import straight_track
    from tmaplan.planning.objectives import ObjectiveEvaluator

    sc = default
    end = sc.time.t0 + sc.time.dt * sc.time.n_steps
    late = dataclasses.replace(prior, t=end - 300.0)
    track = straight_track(sc, n_steps=60)
    for name, same in (("range-bound", True), ("relative-range-crlb", True),
                       ("mean-range-bound", False), ("logdet", False)):
        a, b = (ObjectiveEvaluator(sc, name, n_steps=60, belief=late, until_end=u)(track)[0]
                for u in (False, True))
        assert (a == b) is same, name
