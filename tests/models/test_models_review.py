"""Review of the motion, sensor, fault and prior models: defects found and their fixes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ScenarioError
from tmaplan.models.checks import check_scenario
from tmaplan.models.faults import dropped
from tmaplan.models.observer import observer_track
from tmaplan.models.prior import sample_prior
from tmaplan.scenario import (
    Observer,
    ObserverLeg,
    RangeSensor,
    Target,
    TargetLeg,
    TimeGrid,
    load_problem,
)
from tmaplan.scenario.faults import Dropout, Faults
from tmaplan.simulate import measurement_batches, simulate
from tmaplan.units import DEG


@pytest.fixture(scope="module")
def default():
    return load_problem("default")


def test_observer_leg_before_t0_is_refused(default):
    # The message said "within the horizon [t0, t1]" but only the upper bound was checked.
    grid = dataclasses.replace(default.time, t0=100.0)
    legs = (ObserverLeg(start=50.0, course=90 * DEG),)
    with pytest.raises(ScenarioError) as exc:
        default.replace(time=grid, observer=dataclasses.replace(default.observer, legs=legs))
    assert exc.value.field == "observer.legs[0].start"


@pytest.mark.parametrize("start", [20.0, 50.0])
def test_target_leg_at_or_before_t0_is_refused(default, start):
    # A leg starting before t0 moved the simulated target away from target.position at t0
    # (the batch track model kept it there); one at t0 overrode target.velocity silently.
    grid = dataclasses.replace(default.time, t0=50.0)
    tgt = Target(model="multi-leg", position=default.target.position, velocity=(3.0, 0.0),
                 legs=(TargetLeg(start=start, velocity=(0.0, 3.0)),))
    with pytest.raises(ScenarioError) as exc:
        default.replace(time=grid, target=tgt)
    assert exc.value.field == "target.legs[0].start"


def test_observer_leg_inside_previous_turn_is_refused(default):
    # The second leg's turn started when the first turn ended (190 s), not at its start
    # (150 s) as documented: the whole rest of the track was shifted without a word.
    legs = (ObserverLeg(start=100.0, course=90 * DEG, turn_rate=1 * DEG),
            ObserverLeg(start=150.0, course=0.0, turn_rate=1 * DEG))
    obs = Observer(position=(0.0, 0.0), course=0.0, speed=3.0, legs=legs)
    with pytest.raises(ScenarioError) as exc:
        observer_track(obs, TimeGrid(dt=10.0, horizon=400.0))
    assert exc.value.field == "observer.legs[1].start" and "190" in str(exc.value)
    # a scenario with such legs: the schema takes them (it reads no motion model), the
    # model-level check that the command line runs on every scenario it loads refuses them
    slow = tuple(dataclasses.replace(leg, turn_rate=0.4 * DEG) for leg in legs)  # ≤ max
    flown = default.replace(observer=dataclasses.replace(default.observer, legs=slow))
    with pytest.raises(ScenarioError) as exc:
        check_scenario(flown, source="file.toml")
    assert exc.value.field == "observer.legs[1].start" and "file.toml" in str(exc.value)
    check_scenario(default)  # its own legs are fine
    # a leg at the end of the previous turn (or later) is fine, and starts at its start
    ok = (legs[0], dataclasses.replace(legs[1], start=190.0))
    tr = observer_track(Observer(position=(0.0, 0.0), course=0.0, speed=3.0, legs=ok),
                        TimeGrid(dt=10.0, horizon=400.0))
    assert np.degrees(tr.heading[19]) == pytest.approx(90.0)
    assert np.degrees(tr.heading[20]) == pytest.approx(80.0)


def test_range_dropout_keeps_frequency_lines():
    # Dropout.sensors = "range" is documented as passive ranges and ping echoes; it also
    # deleted the frequency lines of the passive array.
    f = Faults(dropouts=(Dropout(start=0.0, end=100.0, sensors="range"),))
    t = np.array([10.0, 200.0])
    assert not dropped(f, t, "frequency").any()
    assert dropped(f, t, "range").tolist() == [True, False]
    everything = Faults(dropouts=(Dropout(start=0.0, end=100.0, sensors="all"),))
    assert dropped(everything, t, "frequency").tolist() == [True, False]
    s = load_problem("clavard2013-halfturn-cw")
    f = Faults(dropouts=(Dropout(start=0.0, end=300.0, sensors="range"),))
    base = simulate(s, np.random.default_rng(0))
    faded = simulate(s.replace(faults=f), np.random.default_rng(0))
    for a, b in zip(base.measurements, faded.measurements, strict=True):
        assert np.array_equal(a.steps, b.steps), a.kind


def test_open_loop_pings_are_flagged_as_pings(default):
    # measure_step flags a ping (Measurement.ping: the particle filter's progressive
    # correction); measurement_batches did not, so the same echo was assimilated differently
    # in open loop.
    s = default.replace(sensors=(default.sensors[0], RangeSensor(sigma=50.0, steps=(5,)),
                                 RangeSensor(sigma=50.0, steps=(6,), active=False)))
    sim = simulate(s, np.random.default_rng(0))
    batches = measurement_batches(s, sim.measurements, sim.observer)
    assert [m.ping for m in batches[5] if m.kind == "range"] == [True]
    assert [m.ping for m in batches[6] if m.kind == "range"] == [False]


def test_prior_speed_max_below_speed_min_is_refused(default):
    # was numpy's "high - low < 0" (uniform) or a scipy domain error (normal) at sampling
    p = dataclasses.replace(default.prior, speed_min=5.0, speed_max=2.0)
    with pytest.raises(ScenarioError) as exc:
        default.replace(prior=p)
    assert exc.value.field == "prior.speed_max"


@pytest.mark.parametrize(("changes", "field"), [
    ({"range_distribution": "normal", "range_mean": 3000.0, "range_std": 0.0}, "prior.range_mean"),
    ({"speed_distribution": "normal", "speed_mean": 9.0, "speed_std": 0.0}, "prior.speed_mean"),
])
def test_point_mass_outside_its_truncation_is_refused(default, changes, field):
    # with a zero std the truncation to [min, max] was ignored: every sample at the mean
    p = dataclasses.replace(default.prior, **changes)
    with pytest.raises(ScenarioError) as exc:
        sample_prior(default.replace(prior=p), 4, np.random.default_rng(0))
    assert exc.value.field == field


def test_point_mass_at_the_truth_outside_its_truncation_names_the_scenario(default):
    # a given mean is refused at load (tests/data/invalid/68_*); the true range (12 km) only
    # when sampled, and that error did not name the scenario
    p = dataclasses.replace(default.prior, range_distribution="normal", range_std=0.0,
                            range_min=15e3, centred_on_truth=True)
    with pytest.raises(ScenarioError) as exc:
        sample_prior(default.replace(prior=p), 4, np.random.default_rng(0))
    assert exc.value.field == "prior.range_mean" and str(exc.value).startswith("default: ")


def test_scenario_truth_follows_the_scenario_target_model(default):
    # draw_truth(from_prior=False) (`compare --truth scenario`) propagated the initial state of
    # a constant-turn or multi-leg target in a straight line.
    from tmaplan.models.target import target_track
    from tmaplan.simulate import draw_truth

    circle = load_problem("clavard2013-halfturn-cw")
    x = draw_truth(circle, np.random.default_rng(0), from_prior=False)
    np.testing.assert_allclose(x, target_track(circle.target, circle.time, None), atol=1e-6)
    legs = Target(model="multi-leg", position=default.target.position, velocity=(3.0, 0.0),
                  legs=(TargetLeg(start=600.0, velocity=(0.0, 3.0)),), q=1e-4)
    s = default.replace(target=legs)
    x = draw_truth(s, np.random.default_rng(0), from_prior=False)
    k = 80  # 20 min
    assert x[k, 3] == pytest.approx(3.0, abs=0.5) and x[k, 2] == pytest.approx(0.0, abs=0.5)
    # an ncv target's truth is unchanged (bit for bit): x_{k+1} = F x_k + L z_k
    from tmaplan.models.prior import true_initial_state
    from tmaplan.models.target import ncv_matrices

    ncv = default.replace(target=dataclasses.replace(default.target, q=1e-4))
    got = draw_truth(ncv, np.random.default_rng(3), from_prior=False)
    F, Q = ncv_matrices(ncv.time.dt, 1e-4)
    w = np.random.default_rng(3).standard_normal((ncv.n_steps, 4)) @ \
        np.linalg.cholesky(Q + 1e-30 * np.eye(4)).T
    want = [true_initial_state(ncv)]
    for k in range(ncv.n_steps):
        want.append(F @ want[-1] + w[k])
    assert np.array_equal(got, np.array(want))


def test_prior_truth_follows_the_scenario_target_model(default):
    # draw_truth(from_prior=True) (`compare --truth prior`, the default) propagated the drawn
    # initial state in a straight line whatever the model: a multi-leg target's legs were
    # dropped; a constant-turn circle cannot start from a drawn state, so it is refused
    from tmaplan.scenario import Prior
    from tmaplan.simulate import draw_truth

    legs = Target(model="multi-leg", position=default.target.position, velocity=(3.0, 0.0),
                  legs=(TargetLeg(start=600.0, velocity=(0.0, 3.0)),), q=0.0)
    s = default.replace(target=legs)
    x = draw_truth(s, np.random.default_rng(0), from_prior=True)
    x0 = sample_prior(s, 1, np.random.default_rng(0))[0]  # the same draw
    t, k = s.times, 40  # the leg starts at 600 s
    np.testing.assert_allclose(x[:k], np.hstack([x0[:2] + t[:k, None] * x0[2:],
                                                 np.tile(x0[2:], (k, 1))]), atol=1e-9)
    np.testing.assert_allclose(x[k:, 2:], np.tile([0.0, 3.0], (t.size - k, 1)))
    np.testing.assert_allclose(x[-1, :2], x0[:2] + 600.0 * x0[2:] + [0.0, 3.0 * (t[-1] - 600.0)])
    # with process noise: the legs plus the noise an ncv truth of the same draw gets
    def truth(**changes):
        sc = s.replace(target=dataclasses.replace(legs, **({"q": 1e-4} | changes)))
        return draw_truth(sc, np.random.default_rng(5), from_prior=True)

    noise = truth(model="ncv", legs=()) - truth(model="ncv", legs=(), q=0.0)
    np.testing.assert_allclose(truth() - truth(q=0.0), noise, atol=1e-6)

    circle = load_problem("clavard2013-halfturn-cw")
    prior = Prior(kind="gaussian", mean=(7530.0, 11000.0, 5.0, 0.0), std=(100.0, 100.0, 1.0, 1.0))
    with pytest.raises(ScenarioError) as exc:
        draw_truth(circle.replace(prior=prior), np.random.default_rng(0), from_prior=True)
    assert (exc.value.field, exc.value.received) == ("target.model", "constant-turn")
    # without a prior, from_prior flies the scenario's circle, as before
    np.testing.assert_array_equal(draw_truth(circle, np.random.default_rng(0)),
                                  draw_truth(circle, np.random.default_rng(0), from_prior=False))


def test_prior_truth_of_an_ncv_target_is_unchanged(default):
    # the drawn state through x_{k+1} = F x_k + L z_k, bit for bit (the quoted campaigns)
    from tmaplan.models.target import ncv_matrices
    from tmaplan.simulate import draw_truth

    rng = np.random.default_rng(7)
    got = draw_truth(default, np.random.default_rng(7), from_prior=True)
    want = [sample_prior(default, 1, rng)[0]]
    F, Q = ncv_matrices(default.time.dt, default.target.q)
    w = rng.standard_normal((default.n_steps, 4)) @ np.linalg.cholesky(Q + 1e-30 * np.eye(4)).T
    for k in range(default.n_steps):
        want.append(F @ want[-1] + w[k])
    assert np.array_equal(got, np.array(want))
