"""Practitioner tactics (tmaplan.policies.tactics): each rule checked on constructed geometry,
against an independent brute-force computation of the bearing-rate change, and in closed loop."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.geometry import wrap_angle
from tmaplan.policies import (
    BeliefView,
    LeadLag,
    LegTurnLeg,
    ManoeuvrePolicy,
    parse_policy,
)
from tmaplan.policies.tactics import belief_line_of_sight, doctrine_course, lead_lag_course
from tmaplan.scenario import load_problem

DEG = np.pi / 180.0


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _bearing_rate(rel_pos: np.ndarray, target_vel: np.ndarray, course: float,
                  speed: float) -> float:
    """dβ/dt of β = atan2(r_x, r_y) for the own ship on ``course`` (independent of the code)."""
    v = target_vel - speed * np.array([np.sin(course), np.cos(course)])
    rx, ry = rel_pos
    return float((ry * v[0] - rx * v[1]) / (rx * rx + ry * ry))


def _belief(rel_pos, rel_vel, heading, t=0.0, n=200, seed=0):
    rng = np.random.default_rng(seed)
    p = np.empty((n, 4))
    p[:, :2] = np.asarray(rel_pos, float) + rng.normal(0.0, 5.0, (n, 2))
    p[:, 2:] = np.asarray(rel_vel, float) + rng.normal(0.0, 0.01, (n, 2))
    return BeliefView(step=0, t=t, heading=heading, position=np.zeros(2), particles=p,
                      weights=np.full(n, 1.0 / n), pings_used=0)


@pytest.mark.parametrize("theta_deg", [10.0, 45.0, 80.0, 135.0, -20.0, -60.0, -150.0])
@pytest.mark.parametrize("course_deg", [0.0, 100.0, -170.0])
def test_doctrine_course_maximises_the_change_of_bearing_rate(theta_deg, course_deg):
    course = course_deg * DEG
    beta = float(wrap_angle(course + theta_deg * DEG))
    r = 8000.0 * np.array([np.sin(beta), np.cos(beta)])
    vt = np.array([2.0, -3.0])
    before = _bearing_rate(r, vt, course, 3.0)
    grid = np.radians(np.arange(-180.0, 180.0, 0.25))
    change = np.abs([_bearing_rate(r, vt, c, 3.0) - before for c in grid])
    new = doctrine_course(beta, course)
    assert abs(float(wrap_angle(new - grid[np.argmax(change)]))) < 0.3 * DEG
    # the contact ends on the other side, abeam
    theta2 = float(wrap_angle(beta - new))
    assert np.sign(theta2) == -np.sign(theta_deg) and abs(abs(theta2) - 0.5 * np.pi) < 1e-12


def test_doctrine_course_with_a_smaller_beam_angle_still_crosses_to_the_other_side():
    new = doctrine_course(30.0 * DEG, 0.0, beam_angle=60.0 * DEG)
    assert new == pytest.approx(90.0 * DEG)  # contact at 30° starboard -> 60° port
    assert doctrine_course(-30.0 * DEG, 0.0, beam_angle=60.0 * DEG) == pytest.approx(-90 * DEG)


def test_lead_then_lag_lowers_then_raises_the_bearing_rate():
    r, vt, speed = np.array([0.0, 10000.0]), np.array([5.0, 0.0]), 3.0  # drifting clockwise
    drift = _bearing_rate(r, vt, 0.0, speed)
    assert drift > 0
    lead = lead_lag_course(0.0, drift, 45 * DEG, lead=True)
    lag = lead_lag_course(0.0, drift, 45 * DEG, lead=False)
    assert lead == pytest.approx(45 * DEG) and lag == pytest.approx(-45 * DEG)
    assert _bearing_rate(r, vt, lead, speed) < drift < _bearing_rate(r, vt, lag, speed)
    # the change between the legs is 2 S sin(angle) / r
    assert _bearing_rate(r, vt, lag, speed) - _bearing_rate(r, vt, lead, speed) == \
        pytest.approx(2 * speed * np.sin(45 * DEG) / 10000.0)
    # counter-clockwise drift mirrors the legs
    assert lead_lag_course(0.0, -drift, 45 * DEG, lead=True) == pytest.approx(-45 * DEG)


def test_belief_line_of_sight_matches_the_particles():
    b = _belief([0.0, 10000.0], [5.0, 0.0], heading=0.0)
    beta, rate = belief_line_of_sight(b)
    assert abs(beta) < 1e-3 and rate == pytest.approx(5.0 / 10000.0, rel=1e-2)


def _fly(ctrl, belief_at, scenario, n_steps):
    """Heading history of a controller against a belief that does not move."""
    dt, heading, out = scenario.time.dt, 0.0, []
    for k in range(n_steps):
        t = scenario.time.t0 + k * dt
        heading += ctrl.act(belief_at(heading, t), t).turn_rate * dt
        out.append(heading)
    return np.array(out)


def test_leg_turn_leg_controller_holds_then_puts_the_contact_on_the_other_beam(scenario):
    pol = LegTurnLeg(first_leg=600.0)
    rel = 9000.0 * np.array([np.sin(45 * DEG), np.cos(45 * DEG)])
    hd = _fly(pol.controller(scenario), lambda h, t: _belief(rel, [0.0, -3.0], h, t),
              scenario, 80)
    n_turn = int(600.0 / scenario.time.dt)
    assert np.all(hd[:n_turn] == 0.0)
    u_max = scenario.observer.turn_rate_max
    assert hd[n_turn] == pytest.approx(u_max * scenario.time.dt)   # starboard, at full rate
    assert hd[-1] == pytest.approx(135 * DEG, abs=0.05 * DEG)        # contact at 90° port


def test_lead_lag_controller_flies_lead_then_lag(scenario):
    pol = LeadLag(angle=30 * DEG, lead_time=0.0, lag_time=900.0)
    rel = np.array([0.0, 10000.0])
    hd = _fly(pol.controller(scenario), lambda h, t: _belief(
        rel, np.array([5.0, 0.0]) - 3.0 * np.array([np.sin(h), np.cos(h)]), h, t),
        scenario, 110)
    n_lag = int(900.0 / scenario.time.dt)
    assert hd[n_lag - 1] == pytest.approx(30 * DEG, abs=0.05 * DEG)    # lead: ahead of LOS
    assert hd[-1] == pytest.approx(-30 * DEG, abs=0.05 * DEG)          # lag: behind it


def test_nominal_tracks_follow_the_rules_on_the_prior_mean(scenario):
    from tmaplan.planning.belief import Belief

    pol = LegTurnLeg()
    tr = pol.nominal_track(scenario)
    t_turn = pol.turn_time(scenario)
    k = round((t_turn - scenario.time.t0) / scenario.time.dt)
    assert np.all(tr.heading[:k + 1] == tr.heading[0])
    m = Belief.from_prior(scenario).mean
    vt = m[2:] + tr.velocity[0]
    rel = m[:2] + vt * (t_turn - scenario.time.t0) - (tr.position[k] - tr.position[0])
    beta = np.arctan2(rel[0], rel[1])
    assert float(wrap_angle(beta - tr.heading[-1])) == pytest.approx(-0.5 * np.pi, abs=1e-6)
    lt = LeadLag().nominal_track(scenario)
    assert len(np.unique(np.round(lt.heading, 9))) > 3   # two turns


def test_the_nominal_turn_uses_the_line_of_sight_at_the_turn_time_itself(scenario):
    """A first leg that ends between grid steps: the doctrine course is set by the prior
    mean's bearing at that instant (own ship on its straight first leg), not at the nearest
    step (7.5 s off: about 2 mrad here)."""
    from tmaplan.planning.belief import Belief

    dt = scenario.time.dt
    pol = LegTurnLeg(first_leg=100.5 * dt)
    tr = pol.nominal_track(scenario)
    t = pol.turn_time(scenario) - scenario.time.t0
    m = Belief.from_prior(scenario).mean
    vt = m[2:] + tr.velocity[0]
    rel = m[:2] + (vt - tr.velocity[0]) * t        # own ship straight until the turn
    beta = np.arctan2(rel[0], rel[1])
    assert float(wrap_angle(beta - tr.heading[-1])) == pytest.approx(-0.5 * np.pi, abs=1e-9)


def test_tactics_are_manoeuvre_policies_named_for_the_cli(scenario):
    for name, cls in (("leg-turn-leg", LegTurnLeg), ("lead-lag", LeadLag)):
        pol = parse_policy(name, scenario)
        assert isinstance(pol.manoeuvre, cls) and isinstance(pol.manoeuvre, ManoeuvrePolicy)
        assert pol.name == name
        assert parse_policy(f"{name}+uniform", scenario).name == f"{name}+uniform"


@pytest.mark.parametrize(("policy", "field"), [
    (LegTurnLeg(first_leg=-60.0), "leg-turn-leg.first_leg"),
    (LegTurnLeg(first_leg=1e6), "leg-turn-leg.first_leg"),
    (LegTurnLeg(beam_angle=0.0), "leg-turn-leg.beam_angle"),
    (LegTurnLeg(beam_angle=float("nan")), "leg-turn-leg.beam_angle"),
    (LeadLag(angle=4.0), "lead-lag.angle"),
    (LeadLag(lag_time=0.0), "lead-lag.lag_time"),
    (LeadLag(lead_time=1500.0, lag_time=1200.0), "lead-lag.lead_time"),
    (LeadLag(lead_time=float("nan")), "lead-lag.lead_time"),
    (LeadLag(lead_time=None), "lead-lag.lead_time"),            # type: ignore[arg-type]
    (LeadLag(lag_time=float("inf")), "lead-lag.lag_time"),
    (LegTurnLeg(beam_angle="90"), "leg-turn-leg.beam_angle"),   # type: ignore[arg-type]
    (LegTurnLeg(first_leg="600 s"), "leg-turn-leg.first_leg"),  # type: ignore[arg-type]
])
def test_bad_tactic_parameters_give_a_one_line_error(scenario, policy, field):
    for make in (policy.controller, policy.nominal_track):
        with pytest.raises(ArgumentError) as exc:
            make(scenario)
        msg = str(exc.value)
        assert f"field '{field}'" in msg and "expected" in msg and "\n" not in msg


def test_compare_cli_flies_the_tactics(tmp_path):
    from tmaplan.cli import main

    js = tmp_path / "c.json"
    assert main(["compare", "default", "--policies", "leg-turn-leg,lead-lag,straight", "--runs",
                 "2", "--particles", "200", "--out", str(tmp_path),
                 "--json", str(js)]) == 0
    d = json.loads(js.read_text())
    assert set(d["policies"]) == {"leg-turn-leg", "lead-lag", "straight"}
    assert d["policies"]["leg-turn-leg"]["rmse_range"] != d["policies"]["straight"]["rmse_range"]
