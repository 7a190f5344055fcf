"""Own-ship navigation: the fixes of a CSV, NMEA 0183 or GPX file as one :class:`NavTrack`.

* CSV: ``time,lat_deg,lon_deg`` (WGS84 degrees) or ``time,east_m,north_m`` (metres in a local
  frame, x = East, y = North); ``time`` as in the bearings file (ISO 8601 with a zone, or plain
  seconds). With both pairs, latitude/longitude are read and east/north ignored (warned).
* NMEA 0183 (``RMC``, ``GGA``): :mod:`tmaplan.io.nmea`; GPX 1.1 tracks: :mod:`tmaplan.io.gpx`;
  a file of any of the three kinds, told by its content: :func:`tmaplan.io.navigation.read_nav`.

Every reader then applies the same checks (:func:`finish_nav`): a time going backwards is an
error naming its line; a fix at the time of the fix before it is dropped (the first is kept)
with a warning; gaps longer than the gap threshold are warned (positions are interpolated
linearly across them); at least two fixes are needed.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import ArgumentError, DataError
from tmaplan.io.faults import check_not_backwards, warn, warn_gaps
from tmaplan.io.table import read_table, write_csv
from tmaplan.io.times import format_time, parse_stamps, time_text

__all__ = ["NavTrack", "check_latlon", "finish_nav", "fixes_to_write", "read_nav_csv",
           "write_ownship_csv"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class NavTrack:
    """The own ship's fixes from one file, in time order.

    Either geographic (``lat``, ``lon`` set; ``east``, ``north`` None) or in a local frame
    (the reverse).

    Attributes
    ----------
    source : str
        The file.
    epoch : datetime.datetime or None
        UTC time of ``times == 0`` (absolute times), None for plain seconds.
    times : ndarray, shape (m,)
        [s] since ``epoch`` (or plain seconds), increasing.
    lat, lon : ndarray, shape (m,), or None
        WGS84 latitude and longitude [deg] (longitude in [−180, 180]).
    east, north : ndarray, shape (m,), or None
        Local-frame position [m].
    course : ndarray, shape (m,)
        Course over ground as reported by the file (NMEA RMC) [rad], clockwise from North;
        NaN where the file gives none. Kept for display: the own ship's course at the
        bearing times is computed from the positions (:mod:`tmaplan.io.recording`).
    speed : ndarray, shape (m,)
        Speed over ground as reported (NMEA RMC) [m/s]; NaN where none.
    lines : ndarray of int, shape (m,)
        The file's line of each fix.
    """

    source: str
    epoch: dt.datetime | None
    times: np.ndarray
    lat: np.ndarray | None = None
    lon: np.ndarray | None = None
    east: np.ndarray | None = None
    north: np.ndarray | None = None
    course: np.ndarray
    speed: np.ndarray
    lines: np.ndarray

    @property
    def geographic(self) -> bool:
        """Whether the fixes are latitude/longitude (else local east/north)."""
        return self.lat is not None

    def select(self, keep: np.ndarray) -> NavTrack:
        """The fixes where the boolean mask ``keep`` (shape (m,)) holds."""
        def sub(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[keep]
        return dataclasses.replace(self, times=self.times[keep], lat=sub(self.lat),
                                   lon=sub(self.lon), east=sub(self.east),
                                   north=sub(self.north), course=self.course[keep],
                                   speed=self.speed[keep], lines=self.lines[keep])


def finish_nav(nav: NavTrack, *, gap: float | None = None) -> NavTrack:
    """The checks every navigation reader applies (see the module's doc).

    Parameters
    ----------
    nav : NavTrack
        The fixes in file order.
    gap : float, optional
        Gap threshold [s] (default ``max(10 s, 5 × the median interval)``).

    Returns
    -------
    NavTrack
        Without the fixes at a repeated time.

    Raises
    ------
    DataError
        A time going backwards; fewer than two fixes.
    """
    check_not_backwards(nav.times, nav.lines, nav.epoch, source=nav.source)
    dup = np.zeros(nav.times.size, bool)
    dup[1:] = np.diff(nav.times) == 0
    if dup.any():
        i = int(np.argmax(dup))
        n = int(dup.sum())
        warn(f"{nav.source}: {n} fix{'es' if n > 1 else ''} at the time of the fix before "
             f"(first {format_time(nav.times[i], nav.epoch)} at line {nav.lines[i]}) dropped;"
             " the first fix at each time kept")
        nav = nav.select(~dup)
    if nav.times.size < 2:
        raise DataError(nav.source, f"expected at least 2 own-ship fixes at different times, "
                        f"received {nav.times.size}", field="fixes", received=nav.times.size)
    warn_gaps(nav.times, nav.lines, nav.epoch, source=nav.source, what="the navigation",
              gap=gap, done="positions interpolated linearly across them")
    return nav


def check_latlon(lat: np.ndarray, lon: np.ndarray, lines: np.ndarray, *, source: str,
                 names: tuple[str, str] = ("column 'lat_deg'", "column 'lon_deg'")
                 ) -> np.ndarray:
    """Check latitudes in [−90, 90] and longitudes in [−180, 360]; return the longitudes in
    [−180, 180].

    Parameters
    ----------
    lat, lon : ndarray, shape (m,)
        [deg].
    lines : ndarray of int, shape (m,)
    source : str
    names : (str, str)
        The two values as the file calls them (for the message).

    Raises
    ------
    DataError
        The first value out of its interval, naming the line, the column and the value.
    """
    for name, v, lo, hi in ((names[0], lat, -90.0, 90.0), (names[1], lon, -180.0, 360.0)):
        bad = (v < lo) | (v > hi)
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(source, f"{name}: expected degrees in [{lo:g}, {hi:g}], "
                            f"received {float(v[i])!r}", int(lines[i]) or None, name,
                            float(v[i]))
    return np.where(lon > 180.0, lon - 360.0, lon)


def fixes_to_write(times: ArrayLike, lat: ArrayLike, lon: ArrayLike, start: dt.datetime
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fixes a track writer writes (:func:`tmaplan.io.gpx.write_gpx`,
    :func:`tmaplan.io.nmea.write_nmea`), once ``start`` is checked to be aware.

    Parameters
    ----------
    times, lat, lon : array_like, shape (m,)
        Times [s] after ``start``; latitudes and longitudes [deg].
    start : datetime.datetime
        Aware time of ``times == 0``.

    Returns
    -------
    times, lat, lon : ndarray, shape (m,)
        Flat float arrays [s], [deg], [deg].

    Raises
    ------
    ArgumentError
        ``start`` without a time zone.
    """
    if start.utcoffset() is None:
        raise ArgumentError("start", "an aware datetime (with a time zone)", start)
    t = np.asarray(times, float).ravel()
    la, lo = np.asarray(lat, float).ravel(), np.asarray(lon, float).ravel()
    return t, la, lo


def read_nav_csv(path: str | Path, *, gap: float | None = None) -> NavTrack:
    """Read an own-ship CSV (``time,lat_deg,lon_deg`` or ``time,east_m,north_m``).

    Parameters
    ----------
    path : str or Path
    gap : float, optional
        Gap threshold [s] (:func:`finish_nav`).

    Returns
    -------
    NavTrack

    Raises
    ------
    DataError
        As :func:`tmaplan.io.read_bearings` for the table's faults; a latitude or longitude
        out of range; neither column pair; the faults of :func:`finish_nav`.
    """
    src = str(path)
    t = read_table(path, required=("time",),
                   one_of=(("lat_deg", "lon_deg"), ("east_m", "north_m")), what="own-ship fix")
    geo = t.has("lat_deg") or t.has("lon_deg")
    if geo and (t.has("east_m") or t.has("north_m")):
        warn(f"{src}: both lat_deg/lon_deg and east_m/north_m columns: latitude/longitude read,"
             " east_m/north_m ignored")
    stamps = parse_stamps(t.text("time"), t.lines, source=src)
    nan = np.full(len(t.rows), np.nan)
    nav = NavTrack(source=src, epoch=stamps.epoch, times=stamps.seconds, course=nan,
                   speed=nan.copy(), lines=t.lines)
    if geo:
        lat, lon = t.numbers("lat_deg"), t.numbers("lon_deg")
        nav = dataclasses.replace(nav, lat=lat,
                                  lon=check_latlon(lat, lon, t.lines, source=src))
    else:
        nav = dataclasses.replace(nav, east=t.numbers("east_m"), north=t.numbers("north_m"))
    return finish_nav(nav, gap=gap)


def write_ownship_csv(path: str | Path, times: ArrayLike, lat: ArrayLike, lon: ArrayLike, *,
                      start: dt.datetime | None = None) -> Path:
    """Write an own-ship CSV ``time,lat_deg,lon_deg`` that :func:`read_nav_csv` reads back
    exactly (``repr`` floats).

    Parameters
    ----------
    path : str or Path
    times : array_like, shape (m,)
        [s] after ``start`` (plain seconds without it).
    lat, lon : array_like, shape (m,)
        [deg].
    start : datetime.datetime, optional
        Aware time of ``times == 0``; ISO 8601 UTC times with it.

    Returns
    -------
    Path
    """
    t = np.asarray(times, float).ravel()
    cols = [[time_text(x, start) for x in t],
            [repr(float(x)) for x in np.asarray(lat, float).ravel()],
            [repr(float(x)) for x in np.asarray(lon, float).ravel()]]
    return write_csv(path, ["time", "lat_deg", "lon_deg"], cols)

