"""Bearings and navigation on one clock and plane (tmaplan.io.recording): the time origin, the
frame, the own ship's state at the bearing times, and the bearings outside the navigation."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from test_io_bearings import data_error, one_warning, quiet

from tmaplan.io import (
    LocalFrame,
    align,
    ownship_at,
    read_bearings,
    read_nav,
    read_recording,
    write_bearings,
    write_ownship_csv,
)

START = dt.datetime(2024, 6, 1, 12, 0, tzinfo=dt.UTC)


def test_ownship_state_is_linear_between_fixes_with_the_pieces_velocity():
    t = np.array([0.0, 10.0, 20.0, 40.0])
    e = np.array([0.0, 50.0, 50.0, 50.0])
    n = np.array([0.0, 0.0, 100.0, 100.0])
    s = ownship_at(t, e, n, [0.0, 5.0, 10.0, 15.0, 20.0, 30.0, 40.0])
    np.testing.assert_array_equal(s.position, [[0, 0], [25, 0], [50, 0], [50, 50], [50, 100],
                                               [50, 100], [50, 100]])
    # at a fix: the piece ending there; at the first fix: the first piece
    np.testing.assert_array_equal(s.velocity, [[5, 0], [5, 0], [5, 0], [0, 10], [0, 10],
                                               [0, 0], [0, 0]])
    np.testing.assert_allclose(s.course[:5], [np.pi / 2] * 3 + [0.0] * 2)
    np.testing.assert_allclose(s.speed, [5, 5, 5, 10, 10, 0, 0])
    assert s.lat is None and s.lon is None


def _files(tmp_path, *, b_times, n_fix=61, dt_fix=10.0, b_start=START, nav_start=START):
    """A recording: an own ship going north-east at 5 m/s, bearings at ``b_times``."""
    frame = LocalFrame(lat0=45.0, lon0=-5.0)
    t = np.arange(n_fix) * dt_fix
    e = 5.0 * t * np.sin(0.7)
    n = 5.0 * t * np.cos(0.7)
    lat, lon = frame.to_latlon(e, n)
    nav = write_ownship_csv(tmp_path / "o.csv", t, lat, lon, start=nav_start)
    bt = np.asarray(b_times, float)
    bearings = write_bearings(tmp_path / "b.csv", bt, np.full(bt.size, 0.3), sigma=0.01,
                              contact=["A"] * bt.size, start=b_start)
    return bearings, nav, frame


def test_the_origin_is_the_first_fix_in_time_and_plane(tmp_path):
    b, nav, frame = _files(tmp_path, b_times=[30.0, 45.0, 500.0],
                           b_start=START + dt.timedelta(seconds=20))
    rec = quiet(read_recording, b, nav)
    assert rec.start == START and rec.frame == frame and rec.start_seconds == 0.0
    a = rec.contact("A")
    np.testing.assert_array_equal(a.times, [50.0, 65.0, 520.0])  # on the navigation's clock
    np.testing.assert_allclose(a.ownship.speed, 5.0, rtol=1e-9)
    np.testing.assert_allclose(a.ownship.course, 0.7, atol=1e-9)
    np.testing.assert_allclose(a.ownship.position[0], 250 * np.array([np.sin(0.7),
                                                                       np.cos(0.7)]), atol=1e-6)
    lat, _lon = frame.to_latlon(*a.ownship.position.T)
    np.testing.assert_array_equal(a.ownship.lat, lat)
    assert rec.time_text(a.times[0]) == "2024-06-01T12:00:50Z"
    np.testing.assert_allclose(rec.nav.east[:2], [0.0, 50 * np.sin(0.7)], atol=1e-6)
    with pytest.raises(KeyError):
        rec.contact("B")


def test_an_origin_moves_the_plane(tmp_path):
    b, nav, _ = _files(tmp_path, b_times=[0.0, 10.0])
    rec = quiet(read_recording, b, nav, origin=(45.01, -5.0))
    assert rec.frame == LocalFrame(lat0=45.01, lon0=-5.0)
    assert 1100 < -rec.contacts[0].ownship.position[0, 1] < 1115


def test_bearings_outside_the_navigation_are_dropped_with_a_warning(tmp_path):
    b, nav, _ = _files(tmp_path, b_times=[-30.0, -10.0, 0.0, 300.0, 600.0, 601.0])
    rec, _msg = one_warning(read_recording, b, nav, gap=1e9, match="3 bearings outside the "
                           "navigation's span 2024-06-01T12:00:00Z to 2024-06-01T12:10:00Z "
                           "dropped (contact 'A': 2 before, 1 after)")
    np.testing.assert_array_equal(rec.contact("A").times, [0.0, 300.0, 600.0])
    np.testing.assert_array_equal(rec.contact("A").lines, [4, 5, 6])


def test_a_contact_without_bearings_in_the_span_is_left_out_and_none_is_an_error(tmp_path):
    frame = LocalFrame(lat0=45.0, lon0=-5.0)
    lat, lon = frame.to_latlon([0.0, 100.0], [0.0, 100.0])
    nav = write_ownship_csv(tmp_path / "o.csv", [0.0, 60.0], lat, lon, start=START)
    b = write_bearings(tmp_path / "b.csv", [10.0, 20.0, 100.0, 110.0], [0.1] * 4, sigma=0.01,
                       contact=["A", "A", "B", "B"], start=START)
    rec, msg = one_warning(read_recording, b, nav, match="left out contact without bearings: B")
    assert rec.names == ("A",)
    b = write_bearings(tmp_path / "b.csv", [100.0, 110.0], [0.1] * 2, sigma=0.01, start=START)
    msg = data_error(read_recording, b, nav, gap=1e9)
    assert msg.startswith(f"{b}: no bearing within the navigation's span 2024-06-01T12:00:00Z "
                          "to 2024-06-01T12:01:00Z (the bearings run from "
                          "2024-06-01T12:01:40Z to 2024-06-01T12:01:50Z)"), msg


def test_plain_seconds_keep_the_files_clock(tmp_path):
    (tmp_path / "o.csv").write_text("time,east_m,north_m\n100,0,0\n110,10,0\n120,20,0\n")
    (tmp_path / "b.csv").write_text("time,bearing_deg,sigma_deg\n105,10,1\n115,20,1\n")
    rec = quiet(read_recording, tmp_path / "b.csv", tmp_path / "o.csv")
    assert rec.start is None and rec.start_seconds == 100.0 and rec.frame is None
    c = rec.contacts[0]
    np.testing.assert_array_equal(c.times, [5.0, 15.0])
    np.testing.assert_array_equal(c.ownship.position, [[5, 0], [15, 0]])
    assert c.ownship.lat is None and rec.time_text(5.0) == "105.0"
    rec = quiet(read_recording, tmp_path / "b.csv", tmp_path / "o.csv", origin=(10.0, 20.0))
    assert rec.contacts[0].ownship.lat is not None and rec.nav.lat is not None


def test_mixed_kinds_of_time_are_an_error(tmp_path):
    b, _, _ = _files(tmp_path, b_times=[0.0])
    (tmp_path / "o.csv").write_text("time,east_m,north_m\n100,0,0\n110,10,0\n")
    msg = data_error(align, quiet(read_bearings, b), quiet(read_nav, tmp_path / "o.csv"))
    assert msg.startswith(f"{b}: times are ISO 8601 times but the navigation's") and \
        "are plain seconds: expected the same kind in both files" in msg


def test_the_reading_benchmark_runs_on_a_short_recording(benchmark_script, monkeypatch,
                                                         tmp_path, capsys):
    import json
    import sys

    bench = benchmark_script("io_read")
    out = tmp_path / "b.json"
    monkeypatch.setattr(sys, "argv", ["io_read.py", "--hours", "0.02", "--contacts", "2",
                                      "--repeat", "1", "--json", str(out)])
    bench.main()
    res = json.loads(out.read_text())
    assert res["rows"] == 2 * 73 and res["fixes"] == 73
    assert set(res["seconds"]) == {"read_bearings", "read_nav_nmea", "read_nav_gpx",
                                   "read_nav_csv", "read_recording"}
    assert "read_recording" in capsys.readouterr().out
