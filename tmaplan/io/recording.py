"""Bearings and own-ship navigation on one clock and one plane: a :class:`Recording`.

* **Time origin**: ``t = 0`` is the own ship's first fix; :attr:`Recording.start` keeps its
  absolute UTC time (or, for plain-second files, :attr:`Recording.start_seconds` its value on
  the files' clock), so outputs can show absolute times (:meth:`Recording.time_text`). Both
  files must use the same kind of time (ISO 8601 or plain seconds).
* **Plane**: the azimuthal equidistant projection centred on the own ship's first fix
  (:class:`~tmaplan.io.frame.LocalFrame`), or on ``origin`` when given; x = East, y = North,
  metres. A navigation file in local ``east_m,north_m`` keeps its own frame (no latitude or
  longitude unless ``origin`` gives the latitude/longitude of its (0, 0)).
* **Own ship at the bearing times** (:func:`ownship_at`): the position is interpolated linearly
  between the fixes (in the plane); the velocity is the one of that straight piece, i.e. the
  mean velocity between the two fixes around the bearing time (at a fix, the piece ending
  there; at the first fix, the first piece); course and speed are the velocity's. The course
  and speed an RMC sentence reports are kept in :attr:`Recording.nav` but not used, so that
  every kind of navigation file gives the own ship's state the same way, consistent with its
  positions. With fixes on the bearing times (``simulate --export``) the positions are the
  fixes and the velocity is the simulation's mean velocity over the step
  (``ObserverTrack.mean_velocity``).
* **Bearings outside the navigation's span** are dropped with a warning (how many, per
  contact, and the span); a contact left without bearings is left out (warned); none left at
  all is an error.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import DataError
from tmaplan.geometry import course_speed
from tmaplan.io.bearings import BearingLog, ContactBearings, read_bearings
from tmaplan.io.faults import warn
from tmaplan.io.frame import LocalFrame
from tmaplan.io.nav import NavTrack
from tmaplan.io.navigation import read_nav
from tmaplan.io.times import format_time

__all__ = ["OwnshipState", "RecordedContact", "Recording", "align", "ownship_at", "read_recording"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class OwnshipState:
    """The own ship at given times (tmaplan's convention: x = East, y = North).

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s] since the recording's origin.
    position : ndarray, shape (n, 2)
        [east, north] [m].
    velocity : ndarray, shape (n, 2)
        [v_east, v_north] [m/s] (the mean velocity between the fixes around each time).
    course : ndarray, shape (n,)
        [rad], clockwise from North, in (−π, π] (0 when the own ship does not move).
    speed : ndarray, shape (n,)
        [m/s].
    lat, lon : ndarray, shape (n,), or None
        [deg] (WGS84); None without a geographic frame.
    """

    times: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    course: np.ndarray
    speed: np.ndarray
    lat: np.ndarray | None
    lon: np.ndarray | None


@dataclasses.dataclass(frozen=True, kw_only=True)
class RecordedContact:
    """One contact's bearings with the own ship's state at each.

    Attributes
    ----------
    name : str
    times : ndarray, shape (n,)
        [s] since the recording's origin.
    bearing : ndarray, shape (n,)
        True bearing [rad], clockwise from North, in (−π, π].
    sigma : ndarray, shape (n,)
        [rad].
    lines : ndarray of int, shape (n,)
        The bearings file's line of each bearing.
    ownship : OwnshipState
        At ``times``.
    """

    name: str
    times: np.ndarray
    bearing: np.ndarray
    sigma: np.ndarray
    lines: np.ndarray
    ownship: OwnshipState


@dataclasses.dataclass(frozen=True, kw_only=True)
class Recording:
    """Recorded bearings and own-ship navigation, aligned (module doc).

    Attributes
    ----------
    bearings_source, nav_source : str
        The two files.
    start : datetime.datetime or None
        UTC time of ``t = 0`` (the first fix); None for plain-second files.
    start_seconds : float
        Plain-second files: the files' time of ``t = 0`` [s]; 0 otherwise.
    frame : LocalFrame or None
        The plane; None for a local-frame navigation file without ``origin``.
    nav : NavTrack
        The fixes, times since ``t = 0``, with ``east``/``north`` [m] and, with a frame,
        ``lat``/``lon`` [deg].
    contacts : tuple of RecordedContact
        In the order of the bearings file.
    """

    bearings_source: str
    nav_source: str
    start: dt.datetime | None
    start_seconds: float
    frame: LocalFrame | None
    nav: NavTrack
    contacts: tuple[RecordedContact, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The contacts' names."""
        return tuple(c.name for c in self.contacts)

    def contact(self, name: str) -> RecordedContact:
        """The contact ``name`` (KeyError if there is none)."""
        for c in self.contacts:
            if c.name == name:
                return c
        raise KeyError(name)

    def time_text(self, t: float) -> str:
        """Time ``t`` [s since the origin] as the files write it (ISO 8601 UTC, or the files'
        seconds)."""
        if self.start is None:
            return format_time(t + self.start_seconds, None)
        return format_time(t, self.start)


def ownship_at(times: ArrayLike, east: ArrayLike, north: ArrayLike, t: ArrayLike, *,
               frame: LocalFrame | None = None) -> OwnshipState:
    """The own ship's state at times ``t`` from its fixes (module doc).

    Parameters
    ----------
    times : array_like, shape (m,), m >= 2
        Fix times [s], increasing.
    east, north : array_like, shape (m,)
        Fix positions [m].
    t : array_like, shape (n,)
        Times [s] in ``[times[0], times[-1]]``.
    frame : LocalFrame, optional
        Gives the latitude/longitude of the states.

    Returns
    -------
    OwnshipState
    """
    tf = np.asarray(times, float)
    p = np.column_stack([np.asarray(east, float), np.asarray(north, float)])
    tq = np.asarray(t, float).ravel()
    seg = np.clip(np.searchsorted(tf, tq, side="left"), 1, tf.size - 1)
    v = (p[seg] - p[seg - 1]) / (tf[seg] - tf[seg - 1])[:, None]
    pos = np.column_stack([np.interp(tq, tf, p[:, 0]), np.interp(tq, tf, p[:, 1])])
    course, speed = course_speed(v)
    lat = lon = None
    if frame is not None:
        lat, lon = frame.to_latlon(pos[:, 0], pos[:, 1])
    return OwnshipState(times=tq, position=pos, velocity=v, course=np.asarray(course),
                        speed=np.asarray(speed), lat=lat, lon=lon)


def align(bearings: BearingLog, nav: NavTrack, *,
          origin: tuple[float, float] | None = None) -> Recording:
    """Put bearings and navigation on one clock and one plane (module doc).

    Parameters
    ----------
    bearings : BearingLog
    nav : NavTrack
    origin : (float, float), optional
        (latitude, longitude) [deg] of the plane's centre; default the first fix (a local-
        frame navigation: the latitude/longitude of its (0, 0)).

    Returns
    -------
    Recording

    Raises
    ------
    DataError
        The files mix ISO 8601 and plain-second times; no bearing within the navigation's
        span.
    """
    if (bearings.epoch is None) != (nav.epoch is None):
        kinds = ("plain seconds", "ISO 8601 times") if bearings.epoch is None else (
            "ISO 8601 times", "plain seconds")
        raise DataError(bearings.source, f"times are {kinds[0]} but the navigation's "
                        f"({nav.source}) are {kinds[1]}: expected the same kind in both files",
                        field="time")
    t0 = float(nav.times[0])
    start: dt.datetime | None = None
    if nav.epoch is not None and bearings.epoch is not None:
        start = nav.epoch + dt.timedelta(microseconds=round(t0 * 1e6))
        shift, start_seconds = (bearings.epoch - start) / dt.timedelta(seconds=1), 0.0
    else:
        shift, start_seconds = -t0, t0
    nav_t = nav.times - t0
    frame: LocalFrame | None = None
    lat: np.ndarray | None
    lon: np.ndarray | None
    if nav.lat is not None and nav.lon is not None:
        lat0, lon0 = origin if origin is not None else (nav.lat[0], nav.lon[0])
        frame = LocalFrame(lat0=float(lat0), lon0=float(lon0))
        east, north = frame.to_local(nav.lat, nav.lon)
        lat, lon = nav.lat, nav.lon
    elif nav.east is not None and nav.north is not None:
        east, north = nav.east, nav.north
        lat = lon = None
        if origin is not None:
            frame = LocalFrame(lat0=float(origin[0]), lon0=float(origin[1]))
            lat, lon = frame.to_latlon(east, north)
    else:  # pragma: no cover - every reader sets one pair
        raise ValueError("a NavTrack has latitude/longitude or east/north")
    nav_local = dataclasses.replace(nav, epoch=start, times=nav_t, east=east, north=north,
                                    lat=lat, lon=lon)
    contacts = _within_span(bearings, [c.times + shift for c in bearings.contacts], nav_t,
                            start, start_seconds)
    out = tuple(RecordedContact(name=c.name, times=tc, bearing=c.bearing, sigma=c.sigma,
                                lines=c.lines,
                                ownship=ownship_at(nav_t, east, north, tc, frame=frame))
                for c, tc in contacts)
    return Recording(bearings_source=bearings.source, nav_source=nav.source, start=start,
                     start_seconds=start_seconds, frame=frame, nav=nav_local, contacts=out)


def _within_span(bearings: BearingLog, times: list[np.ndarray], nav_t: np.ndarray,
                 start: dt.datetime | None, start_seconds: float
                 ) -> list[tuple[ContactBearings, np.ndarray]]:
    """The contacts' bearings within ``[nav_t[0], nav_t[-1]]`` (the others dropped, warned)."""
    def text(t: float) -> str:
        return format_time(t, start) if start is not None else format_time(t + start_seconds,
                                                                            None)
    span = f"{text(nav_t[0])} to {text(nav_t[-1])}"
    kept, notes, gone, total = [], [], [], 0
    for c, t in zip(bearings.contacts, times, strict=True):
        before, after = t < nav_t[0], t > nav_t[-1]
        n_out = int(before.sum() + after.sum())
        if n_out:
            total += n_out
            notes.append(f"contact '{c.name}': {int(before.sum())} before, "
                         f"{int(after.sum())} after")
        keep = ~(before | after)
        if keep.any():
            kept.append((c.select(keep), t[keep]))
        else:
            gone.append(c.name)
    if not kept:
        first = min(float(t[0]) for t in times)
        last = max(float(t[-1]) for t in times)
        raise DataError(bearings.source, f"no bearing within the navigation's span {span} "
                        f"(the bearings run from {text(first)} to {text(last)})",
                        field="time")
    if total:
        warn(f"{bearings.source}: {total} bearing{'s' if total > 1 else ''} outside the "
             f"navigation's span {span} dropped ({'; '.join(notes)})"
             + (f"; left out contact{'s' if len(gone) > 1 else ''} without bearings: "
                f"{', '.join(gone)}" if gone else ""))
    return kept


def read_recording(bearings: str | Path, nav: str | Path, *, sigma_deg: float | None = None,
                   origin: tuple[float, float] | None = None, gap: float | None = None,
                   date: dt.date | None = None) -> Recording:
    """Read a bearings file and an own-ship navigation file and :func:`align` them.

    Parameters
    ----------
    bearings : str or Path
        Bearings CSV (:func:`tmaplan.io.read_bearings`).
    nav : str or Path
        Own-ship CSV, NMEA 0183 or GPX (:func:`tmaplan.io.read_nav`).
    sigma_deg : float, optional
        Bearing standard deviation [deg] where the file gives none (default 1°, warned).
    origin : (float, float), optional
        (latitude, longitude) [deg] of the plane's centre (default: the first fix).
    gap : float, optional
        Gap threshold [s] of both files (default: ``max(10 s, 5 × the median interval)`` of
        each series).
    date : datetime.date, optional
        UTC date of the first fix of an NMEA file without RMC sentences.

    Returns
    -------
    Recording
    """
    log = read_bearings(bearings, sigma_deg=sigma_deg, gap=gap)
    track = read_nav(nav, gap=gap, date=date)
    return align(log, track, origin=origin)
