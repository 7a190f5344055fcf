"""The truth of a simulated recording: ``truth.json``, written by ``simulate --export``.

Keys (SI units, angles in radians, latitude/longitude in degrees, arrays per time)::

    reference: {time, lat, lon, projection}   # t = 0 (UTC) and the plane's centre
    times: [...]                               # [s] since reference.time
    utc: [...]                                 # the same, ISO 8601 UTC
    contacts: {name: {east, north, v_east, v_north, course, speed, lat, lon}}
    ownship: {east, north, lat, lon}
    ... and whatever the writer adds (the problem's name, the seed, ...)

The plane is the one the readers build (:mod:`tmaplan.io.recording`): the azimuthal
equidistant projection centred on the own ship's first fix, with ``t = 0`` at that fix.
``east``, ``north``, ``v_east``, ``v_north`` are the plane's; ``course`` is true (clockwise
from true north at the contact's position, :meth:`LocalFrame.true_azimuth`), as a recording's
bearings and ``advise``'s courses.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import DataError
from tmaplan.geometry import course_speed
from tmaplan.io.frame import LocalFrame
from tmaplan.io.table import read_text
from tmaplan.io.times import UTC, format_time, parse_utc

__all__ = ["Truth", "read_truth", "write_truth"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Truth:
    """A ``truth.json``.

    Attributes
    ----------
    start : datetime.datetime
        UTC time of ``times == 0``.
    frame : LocalFrame
    times : ndarray, shape (n,)
        [s].
    contacts : dict of str to ndarray, shape (n, 4)
        Each contact's true ``[east, north, v_east, v_north]`` [m, m/s].
    ownship : ndarray, shape (n, 2)
        The own ship's true [east, north] [m].
    extra : dict
        The file's other keys.
    """

    start: dt.datetime
    frame: LocalFrame
    times: np.ndarray
    contacts: dict[str, np.ndarray]
    ownship: np.ndarray
    extra: dict[str, Any]


def _floats(a: np.ndarray) -> list[float]:
    return [float(x) for x in a]


def write_truth(path: str | Path, *, times: ArrayLike, start: dt.datetime, frame: LocalFrame,
                contacts: Mapping[str, ArrayLike], ownship: ArrayLike,
                extra: Mapping[str, Any] | None = None) -> Path:
    """Write ``truth.json`` (module doc); :func:`read_truth` reads it back exactly.

    Parameters
    ----------
    path : str or Path
    times : array_like, shape (n,)
        [s] after ``start``.
    start : datetime.datetime
        Aware time of ``times == 0``.
    frame : LocalFrame
        The plane of the positions.
    contacts : mapping of str to array_like, shape (n, 4)
        Each contact's ``[east, north, v_east, v_north]`` [m, m/s].
    ownship : array_like, shape (n, 2)
        [east, north] [m].
    extra : mapping, optional
        More keys (JSON-ready).

    Returns
    -------
    Path
    """
    t = np.asarray(times, float).ravel()
    start = start.astimezone(UTC)
    out: dict[str, Any] = {
        "reference": {"time": format_time(0.0, start), "lat": frame.lat0, "lon": frame.lon0,
                      "projection": frame.projection},
        "times": _floats(t), "utc": [format_time(x, start) for x in t], "contacts": {}}
    for name, x in contacts.items():
        s = np.asarray(x, float).reshape(t.size, 4)
        course, speed = course_speed(s[:, 2:])
        course = frame.true_azimuth(s[:, 0], s[:, 1], course)  # true, as a recording's
        lat, lon = frame.to_latlon(s[:, 0], s[:, 1])
        out["contacts"][name] = {
            "east": _floats(s[:, 0]), "north": _floats(s[:, 1]), "v_east": _floats(s[:, 2]),
            "v_north": _floats(s[:, 3]), "course": _floats(np.atleast_1d(course)),
            "speed": _floats(np.atleast_1d(speed)), "lat": _floats(lat), "lon": _floats(lon)}
    o = np.asarray(ownship, float).reshape(t.size, 2)
    lat, lon = frame.to_latlon(o[:, 0], o[:, 1])
    out["ownship"] = {"east": _floats(o[:, 0]), "north": _floats(o[:, 1]), "lat": _floats(lat),
                      "lon": _floats(lon)}
    out.update(dict(extra or {}))
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")
    return p


def read_truth(path: str | Path) -> Truth:
    """Read a ``truth.json`` (module doc).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    Truth

    Raises
    ------
    DataError
        Not JSON, or a key missing.
    """
    src = str(path)
    try:
        d = json.loads(read_text(path))
        ref = d["reference"]
        start = parse_utc(ref["time"])
        if start is None:
            raise DataError(src, "key 'reference.time': expected an ISO 8601 time with a zone,"
                            f" received {ref['time']!r}", field="reference.time")
        t = np.asarray(d["times"], float)
        contacts = {name: np.column_stack([np.asarray(c[k], float) for k in
                                           ("east", "north", "v_east", "v_north")])
                    for name, c in d["contacts"].items()}
        own = np.column_stack([np.asarray(d["ownship"][k], float) for k in ("east", "north")])
        frame = LocalFrame(lat0=float(ref["lat"]), lon0=float(ref["lon"]))
    except json.JSONDecodeError as exc:
        raise DataError(src, f"expected JSON: {exc}", exc.lineno, "json") from None
    except KeyError as exc:
        raise DataError(src, f"missing key {exc.args[0]!r} (expected a truth.json written by "
                        "tmaplan simulate --export)", field=str(exc.args[0])) from None
    extra = {k: v for k, v in d.items()
             if k not in ("reference", "times", "utc", "contacts", "ownship")}
    return Truth(start=start, frame=frame, times=t, contacts=contacts, ownship=own,
                 extra=extra)
