"""The bearings CSV (tmaplan.io.bearings): reading, writing (a round trip) and every fault
with its one-line message naming the file, the line and the column."""

from __future__ import annotations

import datetime as dt
import warnings

import numpy as np
import pytest

from tmaplan.errors import DataError
from tmaplan.io import DataWarning, read_bearings, write_bearings


def _write(tmp_path, text, name="b.csv"):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def quiet(fn, *args, **kw):
    """``fn(*args, **kw)``, which must not warn."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        return fn(*args, **kw)


def one_warning(fn, *args, match, **kw):
    """``fn(*args, **kw)``, which must warn once, one line matching ``match``."""
    with pytest.warns(DataWarning) as rec:
        out = fn(*args, **kw)
    msgs = [str(w.message) for w in rec if issubclass(w.category, DataWarning)]
    assert len(msgs) == 1 and match in msgs[0] and "\n" not in msgs[0], msgs
    return out, msgs[0]


def data_error(fn, *args, **kw) -> str:
    """The one-line message of the DataError ``fn`` raises."""
    with pytest.raises(DataError) as exc:
        fn(*args, **kw)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


# ------------------------------------------------------------------------------ reading
def test_iso_times_mixed_zones_are_utc_and_columns_come_in_any_order(tmp_path):
    p = _write(tmp_path, "contact,sigma_deg,bearing_deg,time\n"
                         "A,0.5,10,2024-06-01T12:00:00Z\n"
                         "A,0.5,20,2024-06-01T14:00:05+02:00\n"
                         "A,0.5,30,2024-06-01T07:00:10-05:00\n")
    log = quiet(read_bearings, p)
    assert log.epoch == dt.datetime(2024, 6, 1, 12, tzinfo=dt.UTC)
    (a,) = log.contacts
    np.testing.assert_array_equal(a.times, [0.0, 5.0, 10.0])
    np.testing.assert_allclose(a.bearing, np.deg2rad([10, 20, 30]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(a.sigma, np.deg2rad(0.5))
    np.testing.assert_array_equal(a.lines, [2, 3, 4])


def test_plain_seconds_and_several_contacts(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,contact\n0,10,A\n0,200,B\n1.5,11,A\n2,201,B\n")
    log = read_bearings(p, sigma_deg=2.0)  # given: no warning about sigma
    assert log.epoch is None and log.names == ("A", "B")
    np.testing.assert_array_equal(log.contact("A").times, [0.0, 1.5])
    np.testing.assert_allclose(log.contact("B").bearing, np.deg2rad([200, 201]) - 2 * np.pi)
    np.testing.assert_allclose(log.contact("B").sigma, np.deg2rad(2.0))
    with pytest.raises(KeyError):
        log.contact("C")


def test_no_contact_column_is_one_contact_and_no_sigma_is_warned(tmp_path):
    p = _write(tmp_path, "time,bearing_deg\n0,10\n1,11\n")
    log, msg = one_warning(read_bearings, p, match="no sigma_deg column")
    assert "1°" in msg and str(p) in msg
    assert log.names == ("contact",)
    np.testing.assert_allclose(log.contacts[0].sigma, np.deg2rad(1.0))


def test_bearings_wrap_silently_in_minus_360_to_720_and_with_a_warning_beyond(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,-90,1\n1,360,1\n2,450,1\n3,719,1\n")
    b = quiet(read_bearings, p).contacts[0].bearing
    np.testing.assert_allclose(b, np.deg2rad([-90, 0, 90, -1]), atol=1e-12)
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,10,1\n1,1000,1\n2,-400,1\n")
    log, msg = one_warning(read_bearings, p, match="2 bearing_deg values outside [-360, 720)")
    assert "first 1000 at line 3" in msg and "wrapped" in msg
    np.testing.assert_allclose(log.contacts[0].bearing, np.deg2rad([10, -80, -40]), atol=1e-12)


def test_values_that_look_like_radians_are_warned_and_read_as_degrees(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,0.1,1\n1,1.2,1\n2,2.5,1\n3,-1.0,1\n")
    log, msg = one_warning(read_bearings, p, match="look like radians")
    assert "'bearing_deg'" in msg and "read as degrees" in msg
    np.testing.assert_allclose(log.contacts[0].bearing, np.deg2rad([0.1, 1.2, 2.5, -1.0]))
    # degrees near North with a small spread are not warned
    quiet(read_bearings, _write(tmp_path, "time,bearing_deg,sigma_deg\n0,1,1\n1,1.5,1\n2,1.8,1\n"))


def test_exact_repeats_are_dropped_and_different_bearings_at_one_time_kept(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,10,1\n1,11,1\n1,11,1\n2,12,1\n")
    log, msg = one_warning(read_bearings, p, match="1 repeated row")
    assert "line 4" in msg and "dropped" in msg
    np.testing.assert_array_equal(log.contacts[0].times, [0, 1, 2])
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,10,1\n1,11,1\n1,12,1\n2,12,1\n")
    log, msg = one_warning(read_bearings, p, match="several different bearings")
    assert "lines 3 and 4" in msg and "all kept" in msg
    np.testing.assert_array_equal(log.contacts[0].times, [0, 1, 1, 2])


def test_empty_sigma_cells_take_the_default_with_a_warning(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n0,10,0.5\n1,11,\n")
    log, msg = one_warning(read_bearings, p, match="1 empty sigma_deg cell")
    assert "line 3" in msg
    np.testing.assert_allclose(log.contacts[0].sigma, np.deg2rad([0.5, 1.0]))


def test_gaps_are_warned_with_their_length_and_place(tmp_path):
    times = [0, 1, 2, 3, 4, 64, 65, 66]
    p = _write(tmp_path, "time,bearing_deg,sigma_deg\n" + "".join(
        f"{t},{10 + t * 0.01},1\n" for t in times))
    _, msg = one_warning(read_bearings, p, match="1 gap in the bearings longer than 10 s")
    assert "the longest 60 s from 4.0 (line 6) to 64.0 (line 7)" in msg
    quiet(read_bearings, p, gap=100.0)  # the threshold is configurable


def test_comments_blank_lines_bom_and_case_are_tolerated(tmp_path):
    p = tmp_path / "b.csv"
    p.write_bytes("\ufeff# sonar log\n\nTime, Bearing_Deg ,SIGMA_DEG\n0,10,1\n\n1,11,1\n"
                  .encode())
    log = quiet(read_bearings, p)
    np.testing.assert_array_equal(log.contacts[0].lines, [4, 6])


# ------------------------------------------------------------------------------ faults
@pytest.mark.parametrize(("text", "expect"), [
    ("", "the file is empty"),
    ("# only a comment\n\n", "the file is empty"),
    ("time,bearing_deg\n", ":1: no data rows"),
    ("time;bearing_deg\n0;10\n", ":1: expected comma-separated; the file looks ';'-separated"),
    ("time\tbearing_deg\n0\t10\n", ":1: expected comma-separated; the file looks tab-separated"),
    ("time,bearing\n0,10\n", ":1: missing column 'bearing_deg'"),
    ("bearing_deg,sigma_deg\n0,10\n", ":1: missing column 'time'"),
    ("time,bearing_deg\n0,10\n1,abc\n", ":3: column 'bearing_deg': expected a number, "
                                       "received 'abc'"),
    ("time,bearing_deg\n0,10\n1,nan\n", ":3: column 'bearing_deg': expected a number, "
                                       "received 'nan'"),
    ("time,bearing_deg\n0,10\n1\n", ":3: expected 2 comma-separated values (as the header), "
                                    "received 1"),
    ("time,bearing_deg,time\n0,10,1\n", ":1: column 'time' appears 2 times"),
    ("time,bearing_deg\n2024-06-01T12:00:00,10\n", ":2: column 'time': expected a time zone"),
    ("time,bearing_deg\nnoon,10\n", ":2: column 'time': expected an ISO 8601 time with a zone"),
    ("time,bearing_deg\n0,10\n2024-06-01T12:00:00Z,11\n",
     ":3: column 'time': expected seconds, as the first row's time"),
    ("time,bearing_deg\n2024-06-01T12:00:00Z,10\n5,11\n",
     ":3: column 'time': expected an ISO 8601 time with a zone, as the first row's time"),
    ("time,bearing_deg\n0,10\n5,11\n4,12\n", ":4: time goes backwards: 4.0 after 5.0 (line 3)"),
    ("time,bearing_deg,contact\n0,10,A\n5,11,A\n1,12,B\n4,12,A\n",
     ":5: contact 'A': time goes backwards: 4.0 after 5.0 (line 3)"),
    ("time,bearing_deg,contact\n0,10,A\n5,11,\n", ":3: column 'contact': expected a contact's"
                                                  " name, received ''"),
    ("time,bearing_deg,sigma_deg\n0,10,0\n", ":2: column 'sigma_deg': expected a standard "
                                             "deviation in (0, 180) degrees, received '0'"),
    ("time,bearing_deg,sigma_deg\n0,10,x\n", ":2: column 'sigma_deg': expected a number, "
                                             "received 'x'"),
])
def test_every_fault_is_one_line_naming_file_line_and_column(tmp_path, text, expect):
    p = _write(tmp_path, text)
    msg = data_error(read_bearings, p, sigma_deg=1.0)
    assert msg.startswith(str(p)) and expect in msg, msg


def test_a_missing_file_and_binary_data_are_data_errors(tmp_path):
    assert data_error(read_bearings, tmp_path / "none.csv").endswith("none.csv: no such file")
    assert data_error(read_bearings, tmp_path).endswith(": not a file")
    p = tmp_path / "b.csv"
    p.write_bytes(b"time,bearing_deg\n0,\xff\xfe\n")
    assert "expected UTF-8 text" in data_error(read_bearings, p)


def test_unknown_columns_are_ignored_with_a_warning(tmp_path):
    p = _write(tmp_path, "time,bearing_deg,sigma_deg,depth\n0,10,1,50\n1,11,1,50\n")
    _, msg = one_warning(read_bearings, p, match="ignored column 'depth'")
    assert "read: time, bearing_deg, sigma_deg" in msg


# ------------------------------------------------------------------------------ writing
def test_written_bearings_read_back_exactly(tmp_path, rng):
    n = 50
    t = np.sort(rng.uniform(0, 7200, n)).round(6)
    b = rng.uniform(-np.pi, np.pi, n)
    s = rng.uniform(0.001, 0.05, n)
    names = rng.choice(["alpha", "bravo, 2", 'say "c"'], n).tolist()
    start = dt.datetime(2024, 6, 1, 23, 0, tzinfo=dt.timezone(dt.timedelta(hours=2)))
    p = write_bearings(tmp_path / "b.csv", t, b, sigma=s, contact=names, start=start)
    log = quiet(read_bearings, p, gap=1e9)
    assert log.epoch == start + dt.timedelta(seconds=float(t[0]))
    for c in log.contacts:
        m = np.array(names) == c.name
        np.testing.assert_allclose(c.times + (log.epoch - start).total_seconds(), t[m],
                                   rtol=0, atol=1e-6)
        np.testing.assert_allclose(c.bearing, b[m], rtol=0, atol=1e-14)
        np.testing.assert_allclose(c.sigma, s[m], rtol=1e-15)
    assert set(log.names) == set(names)


def test_written_plain_seconds_read_back_exactly(tmp_path):
    t = np.array([0.1, 0.2, 1e5 / 3])
    b = np.array([0.3, -3.0, np.pi])
    log = quiet(read_bearings, write_bearings(tmp_path / "b.csv", t, b, sigma=0.01))
    np.testing.assert_array_equal(log.contacts[0].times, t)
    np.testing.assert_allclose(log.contacts[0].bearing, b, rtol=0, atol=1e-15)


def test_a_naive_start_is_refused():
    from tmaplan.errors import ArgumentError

    with pytest.raises(ArgumentError, match="start"):
        write_bearings("unused.csv", [0.0], [0.0], start=dt.datetime(2024, 1, 1))
