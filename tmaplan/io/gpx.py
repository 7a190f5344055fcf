"""GPX 1.1 own-ship tracks and plan tracks (through gpxpy).

Reading (:func:`read_gpx`): the points of every track (``<trk>``) and every segment
(``<trkseg>``), in document order, as one sequence of fixes; a gap between segments is a gap
like any other (warned when longer than the gap threshold). Every point needs a ``<time>``
(an error names the track, segment and point, and its line); a time without a zone is UTC, as
the GPX 1.1 schema says. Routes and waypoints are not tracks: a file without track points is
an error.

Writing (:func:`write_gpx`): one track, one segment by default (``breaks`` starts new
segments), ``repr`` latitudes and longitudes (exact) and times to the microsecond.
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path

import gpxpy
import gpxpy.gpx
import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import DataError
from tmaplan.io.nav import NavTrack, check_latlon, finish_nav, fixes_to_write
from tmaplan.io.table import read_text
from tmaplan.io.times import UTC

__all__ = ["read_gpx", "write_gpx"]

_TRKPT = re.compile(r"<(?:[A-Za-z_][\w.-]*:)?trkpt\b")


def _point_lines(text: str, n: int) -> np.ndarray:
    """The line of each of the ``n`` track points (the ``<trkpt`` tags in document order);
    zeros when the tags cannot be matched one to one."""
    starts = [m.start() for m in _TRKPT.finditer(text)]
    if len(starts) != n:
        return np.zeros(n, int)
    breaks = [m.start() for m in re.finditer("\n", text)]
    return 1 + np.searchsorted(np.asarray(breaks, int), np.asarray(starts, int))


def read_gpx(path: str | Path, *, gap: float | None = None) -> NavTrack:
    """Read own-ship fixes from the tracks of a GPX file (module doc).

    Parameters
    ----------
    path : str or Path
    gap : float, optional
        Gap threshold [s] (:func:`tmaplan.io.nav.finish_nav`).

    Returns
    -------
    NavTrack
        Geographic; no reported course or speed (NaN).

    Raises
    ------
    DataError
        Not GPX; no track point; a point without a time; a time going backwards; fewer than
        two fixes.
    """
    src = str(path)
    text = read_text(path)
    try:
        doc = gpxpy.parse(text)
    except Exception as exc:  # gpxpy raises GPXException and XML errors of several kinds
        raise DataError(src, f"expected a GPX file: {exc}".replace("\n", " "),
                        field="gpx") from None
    points = [(k, j, i, p) for k, trk in enumerate(doc.tracks)
              for j, seg in enumerate(trk.segments) for i, p in enumerate(seg.points)]
    if not points:
        others = (f" (it has {sum(len(r.points) for r in doc.routes)} route points and "
                  f"{len(doc.waypoints)} waypoints, which are not a track)"
                  if doc.routes or doc.waypoints else "")
        raise DataError(src, f"expected track points (<trk><trkseg><trkpt>), received none"
                        f"{others}", field="trkpt")
    lines = _point_lines(text, len(points))
    stamps: list[dt.datetime] = []
    for n, (k, j, i, p) in enumerate(points):
        if p.time is None:
            raise DataError(src, f"track {k + 1}, segment {j + 1}, point {i + 1}: expected a "
                            "<time>, received none", int(lines[n]) or None, "time")
        t = p.time if p.time.utcoffset() is not None else p.time.replace(tzinfo=UTC)
        stamps.append(t.astimezone(UTC))
    epoch = stamps[0]
    one = dt.timedelta(microseconds=1)
    secs = np.array([(t - epoch) // one for t in stamps], dtype=np.int64) / 1e6
    lat = np.array([p.latitude for *_, p in points], float)
    lon = check_latlon(lat, np.array([p.longitude for *_, p in points], float), lines,
                       source=src, names=("attribute 'lat'", "attribute 'lon'"))
    nan = np.full(len(points), np.nan)
    nav = NavTrack(source=src, epoch=epoch, times=secs, lat=lat, lon=lon, course=nan,
                   speed=nan.copy(), lines=lines)
    return finish_nav(nav, gap=gap)


def write_gpx(path: str | Path, times: ArrayLike, lat: ArrayLike, lon: ArrayLike, *,
              start: dt.datetime, name: str | None = None,
              breaks: ArrayLike | None = None) -> Path:
    """Write a GPX 1.1 track that :func:`read_gpx` reads back exactly (module doc).

    Parameters
    ----------
    path : str or Path
    times : array_like, shape (m,)
        [s] after ``start``.
    lat, lon : array_like, shape (m,)
        [deg].
    start : datetime.datetime
        Aware time of ``times == 0``.
    name : str, optional
        The track's ``<name>``.
    breaks : array_like of int, optional
        Indices of the points that start a new ``<trkseg>``.

    Returns
    -------
    Path
    """
    t, la, lo = fixes_to_write(times, lat, lon, start)
    cut = set(np.asarray(breaks if breaks is not None else [], int).tolist())
    doc = gpxpy.gpx.GPX()
    trk = gpxpy.gpx.GPXTrack(name=name)
    doc.tracks.append(trk)
    base = start.astimezone(UTC)
    seg = gpxpy.gpx.GPXTrackSegment()
    for i in range(t.size):  # one point per fix
        if i in cut and seg.points:
            trk.segments.append(seg)
            seg = gpxpy.gpx.GPXTrackSegment()
        when = base + dt.timedelta(microseconds=round(t[i] * 1e6))
        seg.points.append(gpxpy.gpx.GPXTrackPoint(latitude=float(la[i]), longitude=float(lo[i]),
                                                  time=when))
    trk.segments.append(seg)
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(doc.to_xml(version="1.1"), encoding="utf-8")
    return p
