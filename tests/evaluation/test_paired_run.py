"""The one per-run loop of the closed-loop Monte Carlo (tmaplan.evaluation.closed_loop.
paired_run): run i's truth and streams, every policy on the same truth and noise, the same
record the campaigns store."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.campaigns import CampaignSpec, run_one
from tmaplan.evaluation.closed_loop import fly, paired_run, run_closed_loop
from tmaplan.evaluation.seeding import run_streams
from tmaplan.policies import Combined, Straight, parse_policy
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth


@pytest.fixture(scope="module")
def default():
    return load_problem("default")


def test_a_paired_run_is_the_run_flown_by_hand_on_its_streams(default):
    pols = {"straight": parse_policy("straight", default).resolve(default),
            "zigzag": parse_policy("zigzag", default).resolve(default)}
    got = dict(paired_run(default, pols, seed=3, run=2, n_particles=60))
    assert list(got) == ["straight", "zigzag"]
    st = run_streams(3, 2)
    target = draw_truth(default, np.random.default_rng(st.truth), from_prior=True)
    for name, pol in pols.items():
        ref = run_closed_loop(default, pol, target, noise_rng=np.random.default_rng(st.noise),
                              filter_rng=np.random.default_rng(st.filter), n_particles=60)
        np.testing.assert_array_equal(got[name].estimate, ref.estimate)
        np.testing.assert_array_equal(got[name].target, target)
        np.testing.assert_array_equal(fly(default, pol, target, st, n_particles=60).estimate,
                                      ref.estimate)
    # paired: the same truth for both policies, different own-ship tracks
    assert not np.array_equal(got["straight"].observer.position,
                              got["zigzag"].observer.position)


def test_the_campaign_run_is_the_paired_run(default):
    spec = CampaignSpec(scenario=default, policies=("straight",), runs=1, seed=4,
                        n_particles=60)
    pol = {"straight": parse_policy("straight", default).resolve(default)}
    rec = run_one(spec, pol, 0)
    [(_, res)] = paired_run(default, pol, seed=4, run=0, n_particles=60)
    m = res.metrics(spec.accuracy)
    assert rec.policies["straight"].metrics.to_json() == m.to_json()
    np.testing.assert_array_equal(rec.policies["straight"].metrics.position_error,
                                  m.position_error)


def test_run_metrics_json_says_never_with_null(default):
    [(_, res)] = paired_run(default, {"s": Straight()}, seed=0, run=0, n_particles=60)
    js = res.metrics(1e-9).to_json()  # an accuracy no run reaches
    assert js["time_to_accuracy"] is None
    assert math.isfinite(js["final_range_error"]) and js["pings_used"] == 0
    assert isinstance(js["diverged"], bool)


# ----------------------------------------------------------------------------------------------
# From test_closed_loop_review.py (folded in, issue 39):
# run_closed_loop (tmaplan.evaluation.closed_loop): bad input is refused before any work.
# ----------------------------------------------------------------------------------------------

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


def test_the_own_ship_flies_a_step_as_the_whole_track_formula(default):
    """One step at a time on floats (OwnShipFlight.advance) is the track the array formula
    flies, bit for bit (positions, velocities, mean velocities), and a turn rate no ship
    flies (inf, 1e308 overflowing u·dt) gives NaN as the array formula does, not an error
    (the filter then refuses the increment, naming ``dv``)."""
    from tmaplan.evaluation.closed_loop import OwnShipFlight
    from tmaplan.models.observer import arc_displacement

    own = OwnShipFlight(default)
    rng = np.random.default_rng(5)
    u = np.clip(rng.normal(0.0, own.u_max, default.n_steps), -own.u_max, own.u_max)
    u[::7] = 0.0
    for k, uk in enumerate(u):
        own.advance(k, uk)
    hd = own.headings
    disp = arc_displacement(hd[:-1], u, np.full(u.size, own.speed), own.dt)
    assert np.array_equal(own.mean_velocity[1:], disp / own.dt)
    assert np.array_equal(own.positions[1:], own.positions[:-1] + disp)
    assert np.array_equal(own.velocity[1:], own.speed * np.stack([np.sin(hd[1:]),
                                                                  np.cos(hd[1:])], axis=-1))
    for wild in (math.inf, 1e308):
        free = OwnShipFlight(default)
        free.u_max = None  # no limit: the rate is flown as given
        with np.errstate(invalid="ignore", over="ignore"):
            free.advance(0, wild)
        assert np.isnan(free.mean_velocity[1]).all() and np.isnan(free.velocity[1]).all()
