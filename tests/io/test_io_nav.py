"""Own-ship navigation (tmaplan.io.nav, .nmea, .gpx): CSV, NMEA 0183 and GPX readers and
writers, their round trips, and their faults (checksums counted, date rollover, segments)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pynmea2
import pytest
from test_io_bearings import data_error, one_warning, quiet

from tmaplan.io import (
    LocalFrame,
    read_gpx,
    read_nav,
    read_nav_csv,
    read_nmea,
    write_gpx,
    write_nmea,
    write_ownship_csv,
)
from tmaplan.units import KNOT

START = dt.datetime(2024, 6, 1, 23, 58, 0, tzinfo=dt.UTC)
FRAME = LocalFrame(lat0=-33.8, lon0=151.3)


def track(n=301, dt_s=1.0):
    """A curving own-ship track: times [s], lat, lon [deg], east, north [m], course, speed."""
    t = np.arange(n) * dt_s
    course = 0.3 + 0.002 * t
    speed = 5.0 + 0.001 * t
    e = np.cumsum(np.r_[0.0, (speed * np.sin(course))[:-1] * dt_s])
    nn = np.cumsum(np.r_[0.0, (speed * np.cos(course))[:-1] * dt_s])
    lat, lon = FRAME.to_latlon(e, nn)
    return t, lat, lon, e, nn, course, speed


def _write(tmp_path, text, name):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


# ------------------------------------------------------------------------------ CSV
def test_csv_latlon_round_trip_is_exact(tmp_path):
    t, lat, lon, *_ = track()
    nav = quiet(read_nav_csv, write_ownship_csv(tmp_path / "o.csv", t, lat, lon, start=START))
    assert nav.geographic and nav.epoch == START
    np.testing.assert_array_equal(nav.times, t)
    np.testing.assert_array_equal(nav.lat, lat)
    np.testing.assert_array_equal(nav.lon, lon)
    assert np.isnan(nav.course).all() and np.isnan(nav.speed).all()


def test_csv_local_frame_and_plain_seconds(tmp_path):
    p = _write(tmp_path, "time,east_m,north_m\n10,0,0\n11,1.5,2\n12,3,4\n", "o.csv")
    nav = quiet(read_nav_csv, p)
    assert not nav.geographic and nav.epoch is None and nav.lat is None
    np.testing.assert_array_equal(nav.times, [10, 11, 12])
    np.testing.assert_array_equal(nav.north, [0, 2, 4])


def test_csv_with_both_pairs_reads_latlon_and_warns(tmp_path):
    p = _write(tmp_path, "time,lat_deg,lon_deg,east_m,north_m\n0,45,-5,0,0\n1,45.001,-5,0,111\n",
               "o.csv")
    nav, _ = one_warning(read_nav_csv, p, match="east_m/north_m ignored")
    assert nav.geographic


@pytest.mark.parametrize(("text", "expect"), [
    ("time,lat_deg\n0,45\n", ":1: missing column 'lon_deg'"),
    ("time,speed\n0,45\n", ":1: missing column 'lat_deg' (expected the columns time,lat_deg,"
                          "lon_deg or time,east_m,north_m; the header has time,speed)"),
    ("time,lat_deg,lon_deg\n0,45,-5\n1,95,-5\n", ":3: column 'lat_deg': expected degrees in "
                                                 "[-90, 90], received 95.0"),
    ("time,lat_deg,lon_deg\n0,45,-5\n1,45,400\n", ":3: column 'lon_deg': expected degrees in "
                                                  "[-180, 360], received 400.0"),
    ("time,lat_deg,lon_deg\n0,45,-5\n1,45,x\n", ":3: column 'lon_deg': expected a number, "
                                                "received 'x'"),
    ("time,lat_deg,lon_deg\n0,45,-5\n", "expected at least 2 own-ship fixes at different "
                                        "times, received 1"),
    ("time,lat_deg,lon_deg\n0,45,-5\n2,45,-5\n1,45,-5\n", ":4: time goes backwards: 1.0 after "
                                                          "2.0 (line 3)"),
    ("time;lat_deg;lon_deg\n0;45;-5\n", ":1: expected comma-separated; the file looks "
                                        "';'-separated"),
])
def test_csv_faults(tmp_path, text, expect):
    p = _write(tmp_path, text, "o.csv")
    msg = data_error(read_nav_csv, p)
    assert msg.startswith(str(p)) and expect in msg, msg


def test_duplicated_fixes_are_dropped_keeping_the_first(tmp_path):
    p = _write(tmp_path, "time,east_m,north_m\n0,0,0\n1,1,1\n1,9,9\n2,2,2\n", "o.csv")
    nav, msg = one_warning(read_nav_csv, p, match="1 fix at the time of the fix before")
    assert "line 4" in msg and "dropped" in msg
    np.testing.assert_array_equal(nav.east, [0, 1, 2])


def test_navigation_gaps_are_warned(tmp_path):
    rows = "".join(f"{t},{t},0\n" for t in [*range(10), 300, 301])
    p = _write(tmp_path, "time,east_m,north_m\n" + rows, "o.csv")
    _, msg = one_warning(read_nav_csv, p, match="1 gap in the navigation longer than 10 s")
    assert "the longest 291 s from 9.0 (line 11) to 300.0 (line 12)" in msg
    assert "interpolated linearly" in msg


# ------------------------------------------------------------------------------ NMEA
def test_nmea_round_trip_across_midnight(tmp_path):
    t, lat, lon, e, n, course, speed = track()
    p = write_nmea(tmp_path / "o.nmea", t, lat, lon, start=START, course=course, speed=speed)
    lines = p.read_text().splitlines()
    assert len(lines) == 2 * t.size and all(len(x) + 2 <= 82 for x in lines)
    assert lines[-2].startswith("$GPRMC,000300.000,A,") and ",020624," in lines[-2]
    nav = quiet(read_nmea, p)
    assert nav.epoch == START
    np.testing.assert_allclose(nav.times, t, rtol=0, atol=1e-9)
    e2, n2 = FRAME.to_local(nav.lat, nav.lon)
    assert np.abs(e2 - e).max() < 1e-3 and np.abs(n2 - n).max() < 1e-3  # 1e-7 arc-minute
    np.testing.assert_allclose(nav.speed, speed, atol=1e-3 * KNOT)
    np.testing.assert_allclose(np.angle(np.exp(1j * (nav.course - course))), 0, atol=1e-4)


def test_checksum_errors_are_skipped_and_counted(tmp_path):
    t, lat, lon, *_ = track(20)
    good = write_nmea(tmp_path / "g.nmea", t, lat, lon, start=START).read_text().splitlines()
    bad = list(good)
    for i in (4, 9, 16):  # corrupt three sentences' data, keeping their checksums
        bad[i] = bad[i].replace(",A,", ",A,1", 1) if "RMC" in bad[i] else bad[i].replace(
            ",1,08,", ",1,09,")
    bad[20] = bad[20].split("*")[0]  # no checksum at all
    bad.insert(0, "$GPGSV,3,1,11,03,03,111,00,04,15,270,00,06,01,010,00,13,06,292,00*74")
    p = _write(tmp_path, "\n".join(bad) + "\n", "o.nmea")
    nav, _ = one_warning(read_nmea, p, match="4 sentences with a bad or missing checksum "
                                             "skipped (lines 6, 11, 18, 22)")
    assert nav.times.size == 20  # every fix still there (its other sentence)
    # a line that is no sentence is counted on its own
    one_warning(read_nmea, _write(tmp_path, "garbage\n" + "\n".join(good), "x.nmea"),
                match="1 unreadable line skipped (line 1)")


def _sentence(kind, fields):
    return str(pynmea2.RMC("GP", "RMC", fields) if kind == "RMC"
               else pynmea2.GGA("GP", "GGA", fields))


def _gga(hms, lat="4500.0000", lon="00500.0000", q="1"):
    return _sentence("GGA", (hms, lat, "N", lon, "W", q, "08", "1.0", "0.0", "M", "0.0", "M",
                             "", ""))


def _rmc(hms, date, lat="4500.0000", lon="00500.0000", status="A"):
    return _sentence("RMC", (hms, status, lat, "N", lon, "W", "5.0", "90.0", date, "", "", "A"))


def test_gga_takes_the_date_of_the_nearest_rmc_across_midnight(tmp_path):
    text = "\n".join([
        _gga("235958.5", lon="00500.0010"),   # before the first RMC, the day before it
        _gga("235959.5", lon="00500.0020"),
        _rmc("000000.5", "020624", lon="00500.0030"),
        _gga("000000.5", lon="00500.0030"),   # the RMC's fix: one fix
        _gga("000001.5", lon="00500.0040")])
    nav = quiet(read_nmea, _write(tmp_path, text, "o.nmea"))
    assert nav.epoch == dt.datetime(2024, 6, 1, 23, 59, 58, 500000, tzinfo=dt.UTC)
    np.testing.assert_allclose(nav.times, [0, 1, 2, 3])
    np.testing.assert_array_equal(nav.lines, [1, 2, 3, 5])
    assert not np.isnan(nav.speed[2]) and np.isnan(nav.speed[3])
    np.testing.assert_allclose(nav.speed[2], 5.0 * KNOT)


def test_gga_only_needs_the_date_and_rolls_over_at_midnight(tmp_path):
    text = "\n".join([_gga("235959"), _gga("000000", lon="00500.0010"),
                      _gga("000001", lon="00500.0020")])
    p = _write(tmp_path, text, "o.nmea")
    msg = data_error(read_nmea, p)
    assert "no RMC sentence with a date" in msg and msg.startswith(str(p))
    nav = quiet(read_nmea, p, date=dt.date(2024, 12, 31))
    assert nav.epoch == dt.datetime(2024, 12, 31, 23, 59, 59, tzinfo=dt.UTC)
    np.testing.assert_array_equal(nav.times, [0, 1, 2])


def test_fixes_without_a_valid_status_are_skipped_with_a_warning(tmp_path):
    text = "\n".join([_rmc("120000", "010624"), _rmc("120001", "010624", status="V"),
                      _gga("120002", q="0"), _rmc("120003", "010624", lon="00500.0010")])
    nav, msg = one_warning(read_nmea, _write(tmp_path, text, "o.nmea"),
                           match="2 sentences without a valid fix")
    assert "lines 2, 3" in msg
    np.testing.assert_array_equal(nav.times, [0, 3])


def test_nmea_faults(tmp_path):
    p = _write(tmp_path, "$GPGSV,3,1,11,03,03,111,00*4A\n", "o.nmea")
    assert "no RMC or GGA sentence with a valid fix" in data_error(read_nmea, p)
    text = "\n".join([_rmc("120005", "010624"), _rmc("120004", "010624")])
    msg = data_error(read_nmea, _write(tmp_path, text, "o.nmea"))
    assert ":2: time goes backwards: 2024-06-01T12:00:04Z after 2024-06-01T12:00:05Z (line 1)" \
        in msg


# ------------------------------------------------------------------------------ GPX
def test_gpx_round_trip_with_several_segments_and_tracks(tmp_path):
    t, lat, lon, *_ = track(30)
    p = write_gpx(tmp_path / "o.gpx", t, lat, lon, start=START, name="own", breaks=[10, 20])
    text = p.read_text()
    assert text.count("<trkseg>") == 3
    nav = quiet(read_gpx, p)
    assert nav.epoch == START
    np.testing.assert_array_equal(nav.times, t)
    np.testing.assert_array_equal(nav.lat, lat)
    np.testing.assert_array_equal(nav.lon, lon)
    # the second segment as a second track: read in document order all the same
    two = text.replace("</trkseg>\n    <trkseg>", "</trkseg>\n  </trk>\n  <trk>\n    <trkseg>",
                       1)
    assert two.count("<trk>") == 2
    nav2 = quiet(read_gpx, _write(tmp_path, two, "two.gpx"))
    np.testing.assert_array_equal(nav2.times, t)
    # each point's line is its <trkpt> tag's
    tags = [i + 1 for i, ln in enumerate(two.splitlines()) if "<trkpt" in ln]
    np.testing.assert_array_equal(nav2.lines, tags)


def test_gpx_faults(tmp_path):
    t, lat, lon, *_ = track(5)
    text = write_gpx(tmp_path / "o.gpx", t, lat, lon, start=START).read_text()
    no_time = text.replace("<time>2024-06-01T23:58:02Z</time>", "", 1)
    p = _write(tmp_path, no_time, "n.gpx")
    msg = data_error(read_gpx, p)
    assert "track 1, segment 1, point 3: expected a <time>, received none" in msg
    assert msg.startswith(f"{p}:") and msg.split(":")[1].isdigit()
    p = _write(tmp_path, "<gpx><wpt lat='1' lon='2'/></gpx>", "w.gpx")
    assert "expected track points" in data_error(read_gpx, p)
    p = _write(tmp_path, "<gpx><trk>", "x.gpx")
    assert "expected a GPX file" in data_error(read_gpx, p)


def test_gpx_times_without_a_zone_are_utc(tmp_path):
    t, lat, lon, *_ = track(3)
    text = write_gpx(tmp_path / "o.gpx", t, lat, lon, start=START).read_text()
    nav = quiet(read_gpx, _write(tmp_path, text.replace("Z</time>", "</time>"), "n.gpx"))
    assert nav.epoch == START


# ------------------------------------------------------------------------------ dispatch
def test_read_nav_tells_the_kind_by_the_content(tmp_path):
    t, lat, lon, *_ = track(5)
    for name, write in (("a.txt", lambda p: write_gpx(p, t, lat, lon, start=START)),
                        ("b.txt", lambda p: write_nmea(p, t, lat, lon, start=START)),
                        ("c.txt", lambda p: write_ownship_csv(p, t, lat, lon, start=START))):
        nav = quiet(read_nav, write(tmp_path / name))
        np.testing.assert_allclose(nav.lat, lat, atol=1e-8)
