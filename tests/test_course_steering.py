"""Course-steering manoeuvre policies (SingleTurn, Zigzag): the closed loop flies the track the
policy is planned and costed on (tmaplan.planning.baselines), whichever way a turn goes."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.policies import BeliefView, SingleTurn, Zigzag
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
