"""Motion and measurement models against hand-computed values and exact identities."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ScenarioError
from tmaplan.geometry import bearing_of as bearing
from tmaplan.models.checks import check_scenario
from tmaplan.models.faults import dropped
from tmaplan.models.observer import arc_displacement, observer_track, turn_rate_track
from tmaplan.models.prior import sample_prior
from tmaplan.models.sensors import bearing_loglik, doppler_frequency, range_rate
from tmaplan.models.target import constant_turn_state, ncv_matrices
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


def test_ncv_matrices():
    F, Q = ncv_matrices(6.0, 0.0025)
    assert F[0, 2] == F[1, 3] == 6.0
    # docs/errata.md: var(r) = η²δ³/3 = 0.18, cov = η²δ²/2 = 0.045, var(v) = η²δ = 0.015
    assert Q[0, 0] == pytest.approx(0.18) and Q[0, 2] == pytest.approx(0.045)
    assert Q[2, 2] == pytest.approx(0.015) and Q[0, 1] == 0.0
    assert np.all(np.linalg.eigvalsh(Q) > 0)


def test_constant_turn_matches_file002_half_turn():
    # clavard2013 with the RECON geometry (docs/errata.md): the clockwise source is at
    # (7.537, 9.000) km at t = 627 s and starts heading 090° at 5 m/s.
    s = constant_turn_state([7530.0, 10000.0], 1000.0, 0.0, 0.005, np.array([0.0, 627.0]))
    assert s[0] == pytest.approx([7530.0, 11000.0, 5.0, 0.0], abs=1e-12)
    assert s[1, :2] == pytest.approx([7530 + 1000 * np.sin(3.135), 10000 + 1000 * np.cos(3.135)])
    assert s[1, 0] == pytest.approx(7536.59, abs=0.01) and s[1, 1] == pytest.approx(9000.0, abs=0.1)
    # speed = |ω| ρ_C at every time, and the velocity is the time derivative
    t = np.linspace(0, 1256, 50)
    st = constant_turn_state([0.0, 0.0], 1000.0, 0.3, -0.005, t)
    assert np.hypot(st[:, 2], st[:, 3]) == pytest.approx(np.full(50, 5.0))
    h = 1e-4
    fd = (constant_turn_state([0.0, 0.0], 1000.0, 0.3, -0.005, t + h)[:, :2]
          - constant_turn_state([0.0, 0.0], 1000.0, 0.3, -0.005, t - h)[:, :2]) / (2 * h)
    assert fd == pytest.approx(st[:, 2:], abs=1e-6)


def test_doppler_matches_file002_formula():
    # clavard2013 eq. 3 at t = 0 of the clockwise half turn: source (7530, 11000) m moving (5, 0),
    # observer at the origin moving (6, 0) m/s: Ṙ = (ẋS − ẋO) sin θ + (ẏS − ẏO) cos θ
    # = −1·7530/13330.40 = −0.564876 m/s, so f = 3000·(1 + 0.564876/1500) = 3001.12975 Hz.
    X = np.array([7530.0, 11000.0, 5.0 - 6.0, 0.0])
    f = doppler_frequency(X, np.array([3000.0, 4500.0]), 1500.0)
    assert f[0] == pytest.approx(3001.12975, abs=1e-5)
    assert f[1] == pytest.approx(4500 * (1 + 7530 / np.hypot(7530, 11000) / 1500), rel=1e-12)
    # Motionless observer: Ṙ = ρ_C ω sin(θ − ωt − φ) (clavard2013)
    t = np.linspace(0, 600, 7)
    st = constant_turn_state([7530.0, 10000.0], 1000.0, 0.2, 0.005, t)
    theta = bearing(st)
    assert range_rate(st) == pytest.approx(1000 * 0.005 * np.sin(theta - 0.005 * t - 0.2))


def test_bearing_quadrants_and_ambiguity():
    X = np.array([[1, 1, 0, 0], [1, -1, 0, 0], [-1, -1, 0, 0], [-1, 1, 0, 0]], float)
    assert np.degrees(bearing(X)) == pytest.approx([45, 135, -135, -45])
    assert np.degrees(bearing(X, "pi")) == pytest.approx([45, -45, 45, -45])


def test_pi_ambiguous_likelihood_keeps_both_modes():
    front = np.array([1000.0, 1000.0, 0, 0])
    back = -front
    z = np.radians(45.0)
    ll = bearing_loglik(z, np.stack([front, back]), 0.01, "pi")
    assert ll[0] == pytest.approx(ll[1])
    ll_plain = bearing_loglik(z, np.stack([front, back]), 0.01)
    assert ll_plain[0] - ll_plain[1] > 1000
    # density integrates to one over (−π/2, π/2] (brehard2005 eq. 71), even next to the wrap
    zz = np.linspace(-np.pi / 2, np.pi / 2, 20001)
    near_wrap = np.array([1000.0 * np.sin(1.55), 1000.0 * np.cos(1.55), 0, 0])
    dens = np.exp(bearing_loglik(zz, near_wrap, 0.05, "pi"))
    assert np.trapezoid(dens, zz) == pytest.approx(1.0, abs=1e-6)
    # a measured bearing given outside (−π/2, π/2] is the same ambiguous measurement: the
    # back mode's 225° (= 45° mod π) missed the nearest wrap (d ± π) and had ≈ zero likelihood
    for z_alt in (np.radians(225.0), np.radians(-135.0), np.radians(405.0)):
        np.testing.assert_allclose(bearing_loglik(z_alt, np.stack([front, back]), 0.01, "pi"),
                                   ll, rtol=1e-9)


def test_one_steps_arc_on_floats_has_the_bits_of_the_array_formula():
    # the closed loop flies one step at a time on floats (its fast path); a whole track
    # goes through the array formula: both must give the same bits, straight legs included
    rng = np.random.default_rng(7)
    h = rng.uniform(-20.0, 20.0, 4000)
    u = np.concatenate([rng.uniform(-0.02, 0.02, 3000), np.zeros(500), [-0.0] * 500])
    v = rng.uniform(0.5, 15.0, 4000)
    whole = arc_displacement(h, u, v, 10.0)
    for i in range(h.size):
        one = arc_displacement(float(h[i]), float(u[i]), float(v[i]), 10.0)
        assert one.shape == (2,)
        assert np.array_equal(one, whole[i]), (h[i], u[i], v[i])
    assert np.array_equal(arc_displacement(0.3, 0.01, 5.0, 10.0),
                          arc_displacement(np.array(0.3), np.array(0.01), np.array(5.0), 10.0))


def test_turn_rate_track_is_exact_circle():
    u = np.full(100, np.radians(0.5))
    tr = turn_rate_track(np.zeros(2), 0.0, 3.0, u, 2.0)
    radius = 3.0 / np.radians(0.5)
    centre = np.array([radius, 0.0])  # starboard turn from heading North
    assert np.hypot(*(tr.position - centre).T) == pytest.approx(np.full(101, radius), rel=1e-12)
    assert tr.heading[-1] == pytest.approx(np.radians(100.0))
    # straight line when u = 0
    tr0 = turn_rate_track(np.zeros(2), np.radians(30), 2.0, np.zeros(10), 5.0)
    assert tr0.position[-1] == pytest.approx(100 * np.array([np.sin(np.radians(30)),
                                                             np.cos(np.radians(30))]))


def test_relative_dynamics_exact_for_manoeuvring_observer():
    # X_{k+1} = F X_k − H Δv_k for a deterministic target and any scripted observer
    # (DESIGN §1), including rate turns that end inside a step.
    grid = TimeGrid(dt=7.0, horizon=700.0)
    obs = Observer(position=(100.0, -50.0), speed=5.0, course=0.3, legs=(
        ObserverLeg(start=70.0, course=2.0, turn_rate=0.013),
        ObserverLeg(start=400.0, velocity=(-3.0, 4.0)),
        ObserverLeg(start=505.0, course=-1.0, speed=7.0, turn_rate=0.02,
                    turn_direction="port"),
    ))
    tr = observer_track(obs, grid)
    target = np.hstack([np.array([3000.0, 8000.0]) + grid.times[:, None] * [2.0, -1.0],
                        np.tile([2.0, -1.0], (grid.n_steps + 1, 1))])
    X = target - tr.state
    F, _ = ncv_matrices(grid.dt, 0.0)
    H = np.vstack([grid.dt * np.eye(2), np.eye(2)])
    pred = X[:-1] @ F.T - tr.velocity_increments @ H.T
    assert pred == pytest.approx(X[1:], abs=1e-9)
    # the rate turn takes (2.0 − 0.3)/0.013 s and ends on course 2.0 rad
    k_end = int(np.ceil((70 + 1.7 / 0.013) / 7.0))
    assert tr.heading[k_end] == pytest.approx(2.0)
    assert np.all(np.abs(np.diff(np.unwrap(tr.heading[:k_end + 1]))) <= 0.013 * 7 + 1e-12)
    # speeds: 5 until 400 s, then 5 ((-3, 4)), then 7 after 505 s
    assert tr.speed[grid.times < 400] == pytest.approx(5.0)
    assert tr.speed[-1] == pytest.approx(7.0)


def test_brehard2005_s2_observer_changes_velocity():
    s = load_problem("brehard2005-s2")
    tr = observer_track(s.observer, s.time)
    t = s.times
    assert tr.velocity[t < 1500] == pytest.approx(np.tile([10.0, -2.0], ((t < 1500).sum(), 1)))
    assert tr.velocity[(t >= 1500) & (t < 4500)] == pytest.approx(
        np.tile([4.0, 12.0], (((t >= 1500) & (t < 4500)).sum(), 1)))
    assert tr.velocity[t >= 4500] == pytest.approx(np.tile([8.0, -7.0], ((t >= 4500).sum(), 1)))


# ----------------------------------------------------------------------------------------------
# From test_models_review.py (folded in, issue 39):
# Review of the motion, sensor, fault and prior models: defects found and their fixes.
# ----------------------------------------------------------------------------------------------

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
