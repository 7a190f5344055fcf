"""run_closed_loop (tmaplan.evaluation.closed_loop): bad input is refused before any work."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.policies import Combined, Straight
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _bad_target(scenario, kind):
    tgt = draw_truth(scenario, np.random.default_rng(0), from_prior=True)
    if kind == "short":
        return tgt[:-1]          # was an IndexError at the last step
    if kind == "positions":
        return tgt[:, :2]        # was a broadcasting error
    tgt[5, 0] = np.nan           # was flown: NaN bearings and a "degenerate" filter
    return tgt


@pytest.mark.parametrize(("change", "field"), [
    ({"target": "short"}, "target"),
    ({"target": "positions"}, "target"),
    ({"target": "nan"}, "target"),
    ({"filter_q": -1.0}, "filter_q"),        # was floored to 1e-8 without a word
    ({"filter_q": float("nan")}, "filter_q"),
    ({"filter_q": "1e-5"}, "filter_q"),
    ({"noise_rng": 0}, "noise_rng"),          # was an AttributeError
    ({"filter_rng": None}, "filter_rng"),
])
def test_run_closed_loop_refuses_bad_input_naming_the_field(scenario, change, field):
    kw = {"noise_rng": np.random.default_rng(1), "filter_rng": np.random.default_rng(2),
          "n_particles": 100}
    target = draw_truth(scenario, np.random.default_rng(0), from_prior=True)
    if "target" in change:
        target = _bad_target(scenario, change["target"])
    else:
        kw |= change
    with pytest.raises(ArgumentError) as info:
        run_closed_loop(scenario, Combined(manoeuvre=Straight()), target, **kw)
    assert info.value.field == field


def test_closed_loop_assimilates_the_measurements_of_step_0():
    # sharma2024-range-only has a prior and its one bearing at step 0 (steps = [0]); the
    # closed loop started updating at step 1, so that bearing was never used
    import dataclasses

    from tmaplan.policies import parse_policy
    from tmaplan.simulate import draw_truth

    sc = load_problem("sharma2024-range-only")
    (b,) = [s for s in sc.sensors if s.kind == "bearing"]
    assert tuple(b.steps) == (0,)
    without = sc.replace(sensors=tuple(dataclasses.replace(s, steps=()) if s is b else s
                                       for s in sc.sensors))
    target = draw_truth(sc, np.random.default_rng(1))

    def run(s):
        return run_closed_loop(s, parse_policy("straight", s), target,
                               noise_rng=np.random.default_rng(2),
                               filter_rng=np.random.default_rng(3), n_particles=2000)

    with_b, no_b = run(sc), run(without)
    los = target[0, :2] - with_b.observer.position[0]
    perp = np.array([los[1], -los[0]]) / np.hypot(*los)  # cross-range direction

    def cross_std(r):
        return float(np.sqrt(perp @ r.covariance[0, :2, :2] @ perp))

    # one bearing as precise as the prior's bearing spread: posterior about 1/sqrt(2) of it
    assert b.sigma == pytest.approx(sc.prior.bearing_std)
    assert 0.55 < cross_std(with_b) / cross_std(no_b) < 0.85
    # nothing else at step 0: the runs differ only through that bearing
    assert np.array_equal(with_b.observer.position, no_b.observer.position)


def test_controller_cannot_write_the_filters_particles(scenario):
    # BeliefView handed the filter's own arrays: a controller could corrupt the filter
    seen = {}

    class Peek:
        name = "peek"

        def controller(self, sc):
            return self

        def act(self, belief, t):
            from tmaplan.policies import Action

            for field in ("particles", "weights"):
                arr = getattr(belief, field)
                with pytest.raises(ValueError, match="read-only"):
                    arr[0] = 0.0
                seen[field] = True
            return Action(turn_rate=0.0)

    target = draw_truth(scenario, np.random.default_rng(0), from_prior=True)
    run_closed_loop(scenario, Peek(), target, noise_rng=np.random.default_rng(1),
                    filter_rng=np.random.default_rng(2), n_particles=200)
    assert seen == {"particles": True, "weights": True}
