"""Motion and measurement models against hand-computed values and exact identities."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.geometry import bearing_of as bearing
from tmaplan.models.observer import observer_track, turn_rate_track
from tmaplan.models.sensors import bearing_loglik, doppler_frequency, range_rate
from tmaplan.models.target import constant_turn_state, ncv_matrices
from tmaplan.scenario import Observer, ObserverLeg, TimeGrid, load_problem


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
