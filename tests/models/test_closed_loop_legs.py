"""The closed loop as a navigator sees it (issue 41, "plans a navigator can use"): ``compare``
prints and exports the own-ship track each policy flew on run 0 as a leg table (exact CSV,
merged navigator table) with its GPX/CSV track; the turn rates recovered from the flown
positions are the ones flown.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.cli.simulate import DEFAULT_ORIGIN
from tmaplan.io import LocalFrame, read_nav
from tmaplan.io.plans import Leg, read_legs_csv
from tmaplan.models.leg_table import flown_turn_rates, legs_track
from tmaplan.models.observer import turn_rate_track
from tmaplan.scenario import load

#: The plane of the exports (``simulate --export``'s default origin).
FRAME = LocalFrame(lat0=DEFAULT_ORIGIN[0], lon0=DEFAULT_ORIGIN[1])


def test_flown_turn_rates_are_the_flown_ones():
    rng = np.random.default_rng(0)
    u = np.repeat(rng.uniform(-1, 1, 12) * math.radians(0.5), 4)
    u[10:20] = 0.0
    tr = turn_rate_track(np.array([100.0, -50.0]), 2.0, 3.5, u, 15.0)
    rates, courses, speed = flown_turn_rates(tr.position, 2.0, 15.0)
    assert rates == pytest.approx(u, abs=1e-12)
    assert speed == pytest.approx(3.5, rel=1e-12)
    assert np.cos(courses - tr.heading) == pytest.approx(1.0, abs=1e-12)


def test_compare_exports_each_policys_flown_track(tmp_path, capsys):
    assert main(["compare", "default", "--policies", "straight,single-turn", "--runs", "1",
                 "--particles", "300", "--out", str(tmp_path),
                 "--json", str(tmp_path / "c.json")]) == 0
    text = capsys.readouterr().out
    got = json.loads((tmp_path / "c.json").read_text())
    sc = load("default")
    limit = float(sc.observer.turn_rate_max)
    dt = float(sc.time.dt)
    assert set(got["flown"]) == {"straight", "single-turn"}
    for name, flown in got["flown"].items():
        assert f"{name}, flown on run 0:" in text
        legs = [Leg(**leg) for leg in flown["legs"]]
        assert sum(leg.duration for leg in legs) == pytest.approx(float(sc.time.horizon))
        assert all(leg.rate <= limit * (1 + 1e-9) for leg in legs)
        nav = read_nav(flown["exports"]["track_gpx"])
        assert nav.times.size == sc.time.n_steps + 1
        # the exact table flies the flown track: back through the files' plane to a metre
        P = np.column_stack(FRAME.to_local(nav.lat, nav.lon))
        speed = float(np.hypot(*(P[1] - P[0]))) / dt
        flown_track = legs_track(legs, P[0], speed, dt, P.shape[0] - 1)
        assert np.max(np.hypot(*(flown_track.position - P).T)) < 1.0
        assert flown["navigator_legs"]["max_position_error"] <= \
            flown["navigator_legs"]["position_tolerance"]
        exact, start = read_legs_csv(flown["exports"]["legs"])
        assert len(exact) == len(legs) and start is not None
    turns = [leg["turn"] for leg in got["flown"]["single-turn"]["legs"]]
    assert turns[0] == "straight" and {"starboard", "port"} & set(turns)
    assert [leg["turn"] for leg in got["flown"]["straight"]["legs"]] == ["straight"]
