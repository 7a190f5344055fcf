"""A plan's leg table and track (tmaplan.io.plans) and truth.json (tmaplan.io.truth): built
from arrays, written, and read back."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from test_io_bearings import data_error, quiet

from tmaplan.errors import ArgumentError
from tmaplan.io import (
    LocalFrame,
    legs_from_track,
    read_legs_csv,
    read_nav,
    read_truth,
    write_legs_csv,
    write_track,
    write_truth,
)

START = dt.datetime(2024, 6, 1, 12, 0, tzinfo=dt.UTC)
W = np.deg2rad(0.5)  # 0.5°/s


def program():
    """Straight 10 min on 000°, port at 0.5°/s for 3 min, straight 5 min, starboard 1 min."""
    u = np.r_[np.zeros(40), -W * np.ones(12), np.zeros(20), W * np.ones(4)]
    t = 15.0 * np.arange(u.size + 1)
    c = np.r_[0.0, np.cumsum(u * 15.0)]
    return t, c, u


def test_legs_of_a_course_program():
    t, c, u = program()
    for legs in (legs_from_track(t, c), legs_from_track(t, c, turn_rates=u)):
        assert [leg.turn for leg in legs] == ["straight", "port", "straight", "starboard"]
        np.testing.assert_allclose([leg.start for leg in legs], [0, 600, 780, 1080])
        np.testing.assert_allclose([leg.duration for leg in legs], [600, 180, 300, 60])
        np.testing.assert_allclose([leg.rate for leg in legs], [0, W, 0, W], atol=1e-12)
        np.testing.assert_allclose([leg.course for leg in legs],
                                   np.mod([0, 0, -90 * np.pi / 180, -np.pi / 2], 2 * np.pi),
                                   atol=1e-9)
        assert [leg.signed_rate for leg in legs][1] == pytest.approx(-W)


def test_legs_round_trip_through_the_csv(tmp_path):
    t, c, u = program()
    legs = legs_from_track(t, c, turn_rates=u)
    p = write_legs_csv(tmp_path / "legs.csv", legs, start=START)
    assert p.read_text().splitlines()[0] == ("start_min,course_deg,turn,rate_deg_s,duration_min,"
                                             "start_time")
    back, start = quiet(read_legs_csv, p)
    assert start == START and len(back) == len(legs)
    for a, b in zip(legs, back, strict=True):
        assert a.turn == b.turn
        np.testing.assert_allclose([a.start, a.course, a.rate, a.duration],
                                   [b.start, b.course, b.rate, b.duration], rtol=1e-14,
                                   atol=1e-12)
    back, start = quiet(read_legs_csv, write_legs_csv(tmp_path / "l2.csv", legs))
    assert start is None


@pytest.mark.parametrize(("row", "expect"), [
    ("10,0,left,0.5,3", ":3: column 'turn': expected straight, starboard or port, "
                        "received 'left'"),
    ("10,0,straight,0.5,3", ":3: column 'rate_deg_s': expected a rate >= 0 (0 on a straight "
                            "leg), received '0.5'"),
    ("10,0,port,0.5,0", ":3: column 'duration_min': expected > 0, received '0'"),
    ("12,0,port,0.5,3", ":3: column 'start_min': expected the previous leg's end 10.0, "
                        "received '12'"),
])
def test_leg_table_faults(tmp_path, row, expect):
    p = tmp_path / "legs.csv"
    p.write_text(f"start_min,course_deg,turn,rate_deg_s,duration_min\n0,0,straight,0,10\n{row}\n")
    msg = data_error(read_legs_csv, p)
    assert msg.startswith(str(p)) and expect in msg, msg


def test_a_track_is_written_as_gpx_or_csv_and_read_as_navigation(tmp_path):
    frame = LocalFrame(lat0=45.0, lon0=-5.0)
    t = np.arange(0.0, 600.0, 15.0)
    e, n = 3.0 * t, 1.0 * t
    for name in ("track.gpx", "track.csv"):
        p = write_track(tmp_path / name, t, start=START, east=e, north=n, frame=frame,
                        name="plan")
        nav = quiet(read_nav, p)
        e2, n2 = frame.to_local(nav.lat, nav.lon)
        np.testing.assert_allclose(e2, e, atol=1e-6)
        np.testing.assert_allclose(n2, n, atol=1e-6)
        assert nav.epoch == START
    with pytest.raises(ArgumentError, match="lat/lon"):
        write_track(tmp_path / "x.gpx", t, start=START, east=e, north=n)


def test_truth_round_trip(tmp_path):
    frame = LocalFrame(lat0=45.0, lon0=-5.0)
    t = np.arange(5) * 15.0
    x = np.column_stack([1000 + 3 * t, 2000 - t, np.full(5, 3.0), np.full(5, -1.0)])
    own = np.column_stack([np.zeros(5), 2 * t])
    p = write_truth(tmp_path / "truth.json", times=t, start=START, frame=frame,
                    contacts={"A": x}, ownship=own, extra={"seed": 4})
    tr = read_truth(p)
    assert tr.start == START and tr.frame == frame and tr.extra == {"seed": 4}
    np.testing.assert_array_equal(tr.times, t)
    np.testing.assert_array_equal(tr.contacts["A"], x)
    np.testing.assert_array_equal(tr.ownship, own)
    import json

    d = json.loads(p.read_text())
    lat, _lon = frame.to_latlon(x[:, 0], x[:, 1])
    np.testing.assert_array_equal(d["contacts"]["A"]["lat"], lat)
    # the course is true (from true north at the contact), the velocity the plane's
    np.testing.assert_allclose(d["contacts"]["A"]["course"],
                               frame.true_azimuth(x[:, 0], x[:, 1], np.arctan2(3.0, -1.0)))
    assert abs(d["contacts"]["A"]["course"][0] - np.arctan2(3.0, -1.0)) > 1e-5
    assert d["utc"][1] == "2024-06-01T12:00:15Z" and d["reference"]["lat"] == 45.0
    p.write_text('{"times": []}')
    assert "missing key 'reference'" in data_error(read_truth, p)
