"""Course-steering manoeuvre policies (SingleTurn, Zigzag): the closed loop flies the track the
policy is planned and costed on (tmaplan.planning.baselines), whichever way a turn goes."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.policies import BeliefView, Receding, SingleTurn, Zigzag
from tmaplan.scenario import load_problem

DEG = np.pi / 180.0


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")   # dt 15 s, turn rate ≤ 0.5 °/s, 180 steps


def _fly(ctrl, scenario, heading0: float) -> np.ndarray:
    """Closed-loop heading history [rad] of a controller (the belief does not matter)."""
    dt, h, out = scenario.time.dt, heading0, [heading0]
    p = np.array([[5000.0, 8000.0, 0.0, -3.0], [5200.0, 8100.0, 0.5, -3.0]])
    for k in range(scenario.n_steps):
        t = float(scenario.times[k])
        b = BeliefView(step=k, t=t, heading=h, position=np.zeros(2), particles=p,
                       weights=np.array([0.5, 0.5]), pings_used=0)
        h += ctrl.act(b, t).turn_rate * dt
        out.append(h)
    return np.array(out)


@pytest.mark.parametrize("angle_deg", [-180.0, 180.0, -150.0, 90.0])
def test_a_single_turn_turns_the_way_its_sign_says_as_its_nominal_track(scenario, angle_deg):
    pol = SingleTurn(angle=angle_deg * DEG, time=scenario.time.t0 + 0.25 * scenario.time.horizon)
    nominal = np.unwrap(pol.nominal_track(scenario).heading)
    flown = _fly(pol.controller(scenario), scenario, float(nominal[0]))
    assert flown[-1] - flown[0] == pytest.approx(angle_deg * DEG, abs=1e-9)
    assert nominal[-1] - nominal[0] == pytest.approx(angle_deg * DEG, abs=1e-9)
    np.testing.assert_allclose(flown, nominal, atol=1e-9)


@pytest.mark.parametrize("angle_deg", [100.0, -100.0, 90.0, 45.0])
def test_a_zigzag_flies_its_nominal_track_even_when_a_leg_change_exceeds_180_deg(scenario,
                                                                               angle_deg):
    pol = Zigzag(leg_duration=600.0, angle=angle_deg * DEG, start=scenario.time.t0)
    nominal = np.unwrap(pol.nominal_track(scenario).heading)
    flown = _fly(pol.controller(scenario), scenario, float(nominal[0]))
    np.testing.assert_allclose(flown, nominal, atol=1e-9)


@pytest.mark.parametrize("t0", [600.0, -600.0])
def test_a_default_zigzag_starts_at_t0_whatever_t0_is(scenario, t0):
    # the default start was 0 s: refused when t0 > 0; when t0 < 0 the closed loop flew
    # straight until 0 s while the nominal track (from t0) was refused
    import dataclasses

    sc = dataclasses.replace(scenario, time=dataclasses.replace(scenario.time, t0=t0))
    pol = Zigzag(leg_duration=600.0, angle=45.0 * DEG)
    heading = pol.nominal_track(sc).heading
    np.testing.assert_allclose(_fly(pol.controller(sc), sc, float(heading[0])),
                               np.unwrap(heading), atol=1e-9)
    # the zig-zag started at t0 explicitly, and the one at t0 = 0 shifted in time
    started = Zigzag(leg_duration=600.0, angle=45.0 * DEG, start=t0).nominal_track(sc)
    np.testing.assert_array_equal(started.heading, heading)
    np.testing.assert_array_equal(pol.nominal_track(scenario).heading, heading)
    assert heading[1] != heading[0]  # turning from the first step
    with pytest.raises(ArgumentError) as exc:  # an absolute start before t0 stays refused
        Zigzag(leg_duration=600.0, angle=0.5, start=t0 - 60.0).controller(sc)
    assert exc.value.field == "zigzag.start"


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize(("policy", "field"), [
    (SingleTurn(angle=NAN, time=600.0), "single-turn.angle"),
    (SingleTurn(angle=INF, time=600.0), "single-turn.angle"),
    (SingleTurn(angle=4.0, time=600.0), "single-turn.angle"),
    (SingleTurn(angle=1.0, time=NAN), "single-turn.time"),
    (SingleTurn(angle=1.0, time=INF), "single-turn.time"),
    (SingleTurn(angle=1.0, time=-60.0), "single-turn.time"),
    (SingleTurn(angle=1.0, time=1e6), "single-turn.time"),
    (Zigzag(leg_duration=INF, angle=0.5), "zigzag.leg_duration"),
    (Zigzag(leg_duration=NAN, angle=0.5), "zigzag.leg_duration"),
    # shorter than a step (dt = 15 s): 1e-9 s hung building ~1e12 legs
    (Zigzag(leg_duration=1e-9, angle=0.5), "zigzag.leg_duration"),
    (Zigzag(leg_duration=14.0, angle=0.5), "zigzag.leg_duration"),
    (Zigzag(leg_duration=300.0, angle=NAN), "zigzag.angle"),
    (Zigzag(leg_duration=300.0, angle=-4.0), "zigzag.angle"),
    (Zigzag(leg_duration=300.0, angle=0.5, start=NAN), "zigzag.start"),
    (Zigzag(leg_duration=300.0, angle=0.5, start=-60.0), "zigzag.start"),
])
def test_bad_manoeuvre_parameters_give_a_one_line_error(scenario, policy, field):
    for make in (policy.controller, policy.nominal_track):
        with pytest.raises(ArgumentError) as exc:
            make(scenario)
        msg = str(exc.value)
        assert exc.value.field == field and "expected" in msg and "\n" not in msg


@pytest.mark.parametrize("value", [0.0, -60.0, NAN, INF])
def test_a_receding_replan_interval_must_be_a_positive_time(scenario, value):
    pol = Receding(replan_interval=value)
    for make in (pol.controller, pol.resolve):
        with pytest.raises(ArgumentError) as exc:
            make(scenario)
        assert (exc.value.field, exc.value.expected) == ("receding.replan_interval", "> 0 s")
        assert exc.value.received is value


def test_a_receding_replan_interval_must_be_whole_steps(scenario):
    """The controller acts on the grid: 1.5 steps would silently re-plan every 2 steps."""
    pol = Receding(replan_interval=1.5 * scenario.time.dt)
    for make in (pol.controller, pol.resolve):
        with pytest.raises(ArgumentError) as exc:
            make(scenario)
        assert exc.value.field == "receding.replan_interval"
        assert exc.value.expected.startswith("a whole number (>= 1) of steps of dt")
    Receding(replan_interval=4 * scenario.time.dt).controller(scenario)   # whole: accepted


@pytest.mark.parametrize(("kw", "field"), [
    ({"horizon": 0.0}, "receding.horizon"), ({"horizon": NAN}, "receding.horizon"),
    ({"rti_steps": 0}, "receding.rti_steps"), ({"rti_steps": 1.5}, "receding.rti_steps"),
])
def test_other_receding_parameters_are_checked(scenario, kw, field):
    with pytest.raises(ArgumentError) as exc:
        Receding(**kw).controller(scenario)
    assert exc.value.field == field


def test_good_manoeuvre_parameters_pass(scenario):
    t0, H = scenario.time.t0, scenario.time.horizon
    SingleTurn(angle=-np.pi, time=t0).controller(scenario)
    SingleTurn(angle=np.pi, time=t0 + H - 1.0).nominal_track(scenario)
    Zigzag(leg_duration=300.0, angle=-np.pi / 4).nominal_track(scenario)


@pytest.mark.parametrize(("policy", "field"), [
    ("AdaptivePings(threshold=float('nan'))", "adaptive.threshold"),
    ("AdaptivePings(threshold=0.0)", "adaptive.threshold"),
    ("AdaptivePings(threshold='0.1')", "adaptive.threshold"),
    ("AdaptivePings(min_spacing=-60.0)", "adaptive.min_spacing"),
    ("AdaptivePings(min_spacing=float('nan'))", "adaptive.min_spacing"),
    ("AdaptivePings(budget=-1)", "pings.budget"),
    ("UniformPings(budget=2.5)", "pings.budget"),
    ("UniformPings(budget=True)", "pings.budget"),
])
def test_bad_ping_parameters_give_a_one_line_error(scenario, policy, field):
    """A NaN threshold never pinged, a NaN spacing never waited, a negative or fractional
    budget was truncated: each is refused, naming the field; good values pass."""
    from tmaplan.policies import AdaptivePings, UniformPings

    pol = eval(policy, {"AdaptivePings": AdaptivePings, "UniformPings": UniformPings})
    with pytest.raises(ArgumentError, match=field.replace(".", r"\.")):
        pol.controller(scenario)
    AdaptivePings(threshold=0.2, min_spacing=0.0, budget=0).controller(scenario)
    UniformPings(budget=np.int64(3)).controller(scenario)
