"""Nothing crashes on a bad file: every reader of tmaplan.io, fed valid files mangled at
random (characters cut, inserted, replaced), either reads or raises a one-line DataError."""

from __future__ import annotations

import datetime as dt
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tmaplan.errors import DataError
from tmaplan.io import (
    LocalFrame,
    read_bearings,
    read_legs_csv,
    read_nav,
    read_recording,
    write_bearings,
    write_gpx,
    write_nmea,
    write_ownship_csv,
)

START = dt.datetime(2024, 6, 1, 23, 59, 50, tzinfo=dt.UTC)


def _valid(tmp_path_factory):
    d = tmp_path_factory.mktemp("valid")
    t = np.arange(0.0, 20.0, 1.0)
    lat, lon = LocalFrame(lat0=45.0, lon0=-5.0).to_latlon(3.0 * t, 2.0 * t)
    return {
        "bearings": write_bearings(d / "b.csv", t, 0.1 * t, sigma=0.01,
                                   contact=["A", "B"] * 10, start=START).read_text(),
        "csv": write_ownship_csv(d / "o.csv", t, lat, lon, start=START).read_text(),
        "nmea": write_nmea(d / "o.nmea", t, lat, lon, start=START, course=0.9 + 0 * t,
                           speed=3.6 + 0 * t).read_text(),
        "gpx": write_gpx(d / "o.gpx", t, lat, lon, start=START, breaks=[10]).read_text(),
        "legs": "start_min,course_deg,turn,rate_deg_s,duration_min,start_time\n"
                "0,0,straight,0,10,2024-06-01T12:00:00Z\n10,0,port,0.5,3,"
                "2024-06-01T12:10:00Z\n",
    }


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    return _valid(tmp_path_factory)


edits = st.lists(st.tuples(st.sampled_from(["cut", "insert", "replace"]),
                           st.floats(0.0, 1.0), st.integers(1, 12),
                           st.text(alphabet=st.sampled_from(
                               list(",;\t\n\r\"'$*<>/:.-+eEZT019 #°\x00")), max_size=8)),
                 min_size=1, max_size=4)


def _mangle(text: str, ops) -> str:
    for op, where, n, chars in ops:
        i = int(where * len(text))
        if op == "cut":
            text = text[:i] + text[i + n:]
        elif op == "insert":
            text = text[:i] + chars + text[i:]
        else:
            text = text[:i] + chars + text[i + len(chars):]
    return text


def _read(kind: str, path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            {"bearings": read_bearings, "legs": read_legs_csv}.get(kind, read_nav)(path)
        except DataError as exc:
            assert "\n" not in str(exc) and str(exc).startswith(str(path)), str(exc)


@pytest.mark.parametrize("kind", ["bearings", "csv", "nmea", "gpx", "legs"])
@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ops=edits)
def test_a_mangled_file_reads_or_is_one_data_error(tmp_path, valid, kind, ops):
    p = tmp_path / f"f.{kind}"
    p.write_text(_mangle(valid[kind], ops), encoding="utf-8")
    _read(kind, p)


@pytest.mark.parametrize("cell", ["9999-12-31T23:59:59-01:00", "0001-01-01T00:00:00+01:00",
                                  "1e308", "-1e308", "1e400"])
def test_extreme_times_are_data_errors_or_read(tmp_path, cell):
    p = tmp_path / "b.csv"
    p.write_text(f"time,bearing_deg,sigma_deg\n0,10,1\n{cell},11,1\n")
    _read("bearings", p)
    p.write_text(f"time,bearing_deg,sigma_deg\n{cell},10,1\n0,11,1\n")
    _read("bearings", p)


def test_a_recording_of_extreme_spans_is_one_data_error(tmp_path):
    (tmp_path / "b.csv").write_text("time,bearing_deg,sigma_deg\n-1e300,10,1\n1e300,11,1\n")
    (tmp_path / "o.csv").write_text("time,east_m,north_m\n0,0,0\n1e300,1,1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            read_recording(tmp_path / "b.csv", tmp_path / "o.csv")
        except DataError as exc:
            assert "\n" not in str(exc)
