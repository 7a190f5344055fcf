"""A plan as a navigator uses it: the leg table (CSV) and the track (GPX, CSV).

A **leg** is a stretch of constant turn rate: straight, or turning to starboard (clockwise)
or port at a constant rate. The leg table ``legs.csv`` has the columns

``start_min,course_deg,turn,rate_deg_s,duration_min`` (and ``start_time``, ISO 8601 UTC, when
the plan has an absolute start time):

* ``start_min``: the leg's start [min] after the plan's start;
* ``course_deg``: the course at the leg's start [deg], clockwise from North, in [0, 360);
* ``turn``: ``straight``, ``starboard`` or ``port``;
* ``rate_deg_s``: the turn rate's magnitude [deg/s] (0 on a straight leg);
* ``duration_min``: [min]; each leg starts where the one before ends.

The track is written as GPX (:func:`tmaplan.io.gpx.write_gpx`) and as the own-ship CSV
``time,lat_deg,lon_deg`` (:func:`tmaplan.io.nav.write_ownship_csv`), which the navigation
readers read back.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from collections.abc import Sequence
from pathlib import Path
from typing import Literal, cast

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import ArgumentError, DataError
from tmaplan.io.frame import LocalFrame
from tmaplan.io.gpx import write_gpx
from tmaplan.io.nav import write_ownship_csv
from tmaplan.io.table import read_table, write_csv
from tmaplan.io.times import parse_utc, time_text

__all__ = ["RATE_TOL", "Leg", "Turn", "legs_from_track", "legs_json", "legs_table", "read_legs_csv",
           "step_turn_rates", "write_legs_csv", "write_plan", "write_track"]

#: Turn rates [rad/s] closer than this are one leg; smaller in magnitude, a straight leg.
RATE_TOL = 1e-6
Turn = Literal["straight", "starboard", "port"]
_COLUMNS = ("start_min", "course_deg", "turn", "rate_deg_s", "duration_min")


@dataclasses.dataclass(frozen=True, kw_only=True)
class Leg:
    """One leg of a plan.

    Attributes
    ----------
    start : float
        [s] after the plan's start.
    course : float
        Course at the leg's start [rad], clockwise from North, in [0, 2π).
    turn : {"straight", "starboard", "port"}
    rate : float
        Turn rate's magnitude [rad/s], >= 0 (0 on a straight leg).
    duration : float
        [s], > 0.
    """

    start: float
    course: float
    turn: Turn
    rate: float
    duration: float

    @property
    def signed_rate(self) -> float:
        """Turn rate [rad/s], positive to starboard (clockwise), as ``observer.turn_rates``."""
        return -self.rate if self.turn == "port" else self.rate


def legs_from_track(times: ArrayLike, courses: ArrayLike, *,
                    turn_rates: ArrayLike | None = None, tol: float = RATE_TOL
                    ) -> tuple[Leg, ...]:
    """The legs of a course program: maximal runs of intervals with one turn rate.

    Parameters
    ----------
    times : array_like, shape (K + 1,)
        [s], increasing.
    courses : array_like, shape (K + 1,)
        Course at each time [rad], clockwise from North.
    turn_rates : array_like, shape (K,), optional
        Turn rate over each interval [rad/s], positive to starboard; default the course
        differences (unwrapped) over the intervals.
    tol : float
        Rates within ``tol`` [rad/s] of a run's first are the same leg; a run whose rate is
        within ``tol`` of 0 is straight.

    Returns
    -------
    tuple of Leg
    """
    t = np.asarray(times, float).ravel()
    c = np.asarray(courses, float).ravel()
    if t.size < 2 or c.shape != t.shape or np.any(np.diff(t) <= 0):
        raise ArgumentError("times", "increasing times (at least 2), as many as the courses",
                            f"{t.size} times, {c.size} courses")
    u = (np.diff(np.unwrap(c)) / np.diff(t) if turn_rates is None
         else np.asarray(turn_rates, float).ravel())
    if u.shape != (t.size - 1,):
        raise ArgumentError("turn_rates", f"one per interval ({t.size - 1})", u.size)
    legs = []
    i = 0
    while i < u.size:  # one leg per run of equal rates
        j = i + 1
        while j < u.size and abs(u[j] - u[i]) <= tol:
            j += 1
        rate = float(np.median(u[i:j]))  # within the run's range: never above a limit
        turn: Turn = (
            "straight" if abs(rate) <= tol else "starboard" if rate > 0 else "port")
        legs.append(Leg(start=float(t[i] - t[0]), course=float(np.mod(c[i], 2 * np.pi)),
                        turn=turn, rate=0.0 if turn == "straight" else abs(rate),
                        duration=float(t[j] - t[i])))
        i = j
    return tuple(legs)


def write_legs_csv(path: str | Path, legs: Sequence[Leg], *,
                   start: dt.datetime | None = None) -> Path:
    """Write the leg table (module doc) that :func:`read_legs_csv` reads back exactly.

    Parameters
    ----------
    path : str or Path
    legs : sequence of Leg
    start : datetime.datetime, optional
        Aware time of the plan's start: adds the ``start_time`` column.

    Returns
    -------
    Path
    """
    cols: list[list[str]] = [[repr(leg.start / 60.0) for leg in legs],
            [repr(float(np.rad2deg(leg.course)) % 360.0) for leg in legs],
            [leg.turn for leg in legs],
            [repr(float(np.rad2deg(leg.rate))) for leg in legs],
            [repr(leg.duration / 60.0) for leg in legs]]
    header = list(_COLUMNS)
    if start is not None:
        cols.append([time_text(leg.start, start) for leg in legs])
        header.append("start_time")
    return write_csv(path, header, cols)


def read_legs_csv(path: str | Path) -> tuple[tuple[Leg, ...], dt.datetime | None]:
    """Read a leg table (module doc).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    legs : tuple of Leg
    start : datetime.datetime or None
        UTC start of the plan (from the first ``start_time``), None without the column.

    Raises
    ------
    DataError
        The table's faults (as every CSV reader), a ``turn`` other than the three, a negative
        rate or a straight leg with one, a duration not > 0, a leg not starting where the one
        before ends.
    """
    src = str(path)
    t = read_table(path, required=_COLUMNS, optional=("start_time",), what="leg")
    start_min, course, rate, dur = (t.numbers(c) for c in ("start_min", "course_deg",
                                                           "rate_deg_s", "duration_min"))
    turns = [x.lower() for x in t.text("turn")]
    legs = []
    for i, turn in enumerate(turns):  # one row per leg
        def fault(col: str, expected: str, row: int = i) -> DataError:
            cell = t.text(col)[row]
            return DataError(src, f"column '{col}': expected {expected}, received {cell!r}",
                             int(t.lines[row]), col, cell)
        if turn not in ("straight", "starboard", "port"):
            raise fault("turn", "straight, starboard or port")
        if rate[i] < 0 or (turn == "straight" and rate[i] != 0):
            raise fault("rate_deg_s", "a rate >= 0 (0 on a straight leg)")
        if dur[i] <= 0:
            raise fault("duration_min", "> 0")
        end = start_min[i - 1] + dur[i - 1] if i else start_min[i]
        if abs(start_min[i] - end) > 1e-6 * max(1.0, abs(end)):
            raise fault("start_min", f"the previous leg's end {float(end)!r}")
        legs.append(Leg(start=float(start_min[i] * 60.0),
                        course=float(np.mod(np.deg2rad(course[i]), 2 * np.pi)),
                        turn=cast(Turn, turn),
                        rate=float(np.deg2rad(rate[i])), duration=float(dur[i] * 60.0)))
    start = None
    if t.has("start_time"):
        first = t.text("start_time")[0]
        begin = parse_utc(first)
        if begin is None:
            raise DataError(src, "column 'start_time': expected an ISO 8601 time with a zone, "
                            f"received {first!r}", int(t.lines[0]), "start_time", first)
        start = begin - dt.timedelta(seconds=legs[0].start)
    return tuple(legs), start


def write_track(path: str | Path, times: ArrayLike, *, start: dt.datetime,
                lat: ArrayLike | None = None, lon: ArrayLike | None = None,
                east: ArrayLike | None = None, north: ArrayLike | None = None,
                frame: LocalFrame | None = None, name: str | None = None) -> Path:
    """Write a plan's (or any) track as GPX (``.gpx``) or own-ship CSV (any other suffix).

    Parameters
    ----------
    path : str or Path
        ``*.gpx``: GPX 1.1; otherwise CSV ``time,lat_deg,lon_deg``.
    times : array_like, shape (m,)
        [s] after ``start``.
    start : datetime.datetime
        Aware time of ``times == 0``.
    lat, lon : array_like, shape (m,), optional
        [deg]; or
    east, north : array_like, shape (m,), optional
        [m] in ``frame``.
    frame : LocalFrame, optional
        Needed with ``east``/``north``.
    name : str, optional
        The GPX track's name.

    Returns
    -------
    Path
    """
    if lat is None or lon is None:
        if east is None or north is None or frame is None:
            raise ArgumentError("lat/lon", "lat and lon, or east, north and frame",
                                "neither")
        lat, lon = frame.to_latlon(east, north)
    if Path(path).suffix.lower() == ".gpx":
        return write_gpx(path, times, lat, lon, start=start, name=name)
    return write_ownship_csv(path, times, lat, lon, start=start)


def legs_table(legs: Sequence[Leg]) -> str:
    """The leg table as text (what ``plan`` and ``advise`` print): start [min], course [°],
    turn, rate [°/s], duration [min], one row per leg."""
    rows = ["  start min  course °  turn        rate °/s  duration min"]
    for leg in legs:
        rows.append(f"  {leg.start / 60:9.1f}  {float(np.rad2deg(leg.course)) % 360:8.1f}  "
                    f"{leg.turn:<10}  {float(np.rad2deg(leg.rate)):8.3f}  "
                    f"{leg.duration / 60:12.1f}")
    return "\n".join(rows)


def legs_json(legs: Sequence[Leg]) -> list[dict[str, float | str]]:
    """The legs as the verbs' JSON writes them: ``start``, ``course``, ``turn``, ``rate``,
    ``duration`` [s, rad, rad/s] per leg."""
    return [{"start": leg.start, "course": leg.course, "turn": leg.turn, "rate": leg.rate,
             "duration": leg.duration} for leg in legs]


def step_turn_rates(legs: Sequence[Leg], dt: float, n_steps: int) -> np.ndarray:
    """The mean turn rate over each step ``[k·dt, (k+1)·dt]`` of a grid starting at the
    plan's start (``observer.turn_rates``; a step across a leg boundary gets its mean; after
    the last leg, straight).

    Parameters
    ----------
    legs : sequence of Leg
    dt : float
        [s], > 0.
    n_steps : int
        Steps K.

    Returns
    -------
    ndarray, shape (K,)
        [rad/s], positive to starboard; never above the legs' largest rate.
    """
    starts = np.array([leg.start for leg in legs] + [legs[-1].start + legs[-1].duration])
    rates = np.array([leg.signed_rate for leg in legs])
    # the course change up to each leg boundary, then linear within a leg
    turned = np.concatenate([[0.0], np.cumsum(rates * np.diff(starts))])
    t = dt * np.arange(n_steps + 1) + starts[0]
    psi = np.interp(t, starts, turned)  # constant after the last leg: straight
    top = float(np.max(np.abs(rates))) if rates.size else 0.0
    return np.clip(np.diff(psi) / dt, -top, top)


def write_plan(directory: str | Path, stem: str, legs: Sequence[Leg], times: ArrayLike,
               east: ArrayLike, north: ArrayLike, *, start: dt.datetime | None,
               frame: LocalFrame | None, navigator: Sequence[Leg] | None = None
               ) -> dict[str, str]:
    """Write a plan as a navigator uses it: ``<stem>_legs.csv`` (the exact table), with
    ``navigator`` ``<stem>_navigator_legs.csv`` (the merged table,
    :mod:`tmaplan.models.leg_table`) and, with a start time and a geographic frame,
    ``<stem>_track.gpx`` and ``<stem>_track.csv``.

    Parameters
    ----------
    directory : str or Path
    stem : str
        File names' start.
    legs : sequence of Leg
    times : array_like, shape (m,)
        The track's times [s after ``start``].
    east, north : array_like, shape (m,)
        [m] in ``frame``.
    start : datetime.datetime or None
        Aware time of ``times == 0``.
    frame : LocalFrame or None
    navigator : sequence of Leg, optional
        The navigator's (merged) table.

    Returns
    -------
    dict of str to str
        ``legs``, ``navigator_legs``, ``track_gpx``, ``track_csv`` to paths.
    """
    d = Path(directory)
    files = {"legs": str(write_legs_csv(d / f"{stem}_legs.csv", legs, start=start))}
    if navigator is not None:
        files["navigator_legs"] = str(write_legs_csv(d / f"{stem}_navigator_legs.csv",
                                                     navigator, start=start))
    if start is not None and frame is not None:
        for suffix in ("gpx", "csv"):
            files[f"track_{suffix}"] = str(write_track(
                d / f"{stem}_track.{suffix}", times, start=start, east=east, north=north,
                frame=frame, name=stem))
    return files
