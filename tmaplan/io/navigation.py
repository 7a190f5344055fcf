"""Own-ship navigation of any supported kind, told by its content: :func:`read_nav` reads a
CSV file (:mod:`tmaplan.io.nav`), NMEA 0183 (:mod:`tmaplan.io.nmea`) or GPX
(:mod:`tmaplan.io.gpx`) into one :class:`~tmaplan.io.nav.NavTrack`. It sits above the three
readers, which share the track and its checks from :mod:`tmaplan.io.nav`.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from tmaplan.io.gpx import read_gpx
from tmaplan.io.nav import NavTrack, read_nav_csv
from tmaplan.io.nmea import read_nmea
from tmaplan.io.table import read_text

__all__ = ["read_nav"]


def _kind(path: str | Path) -> str:
    """``"gpx"``, ``"nmea"`` or ``"csv"``: the file's kind from its first character that is
    not blank (``<``: GPX; ``$`` or ``!``: NMEA; else CSV)."""
    text = read_text(path).lstrip()
    if text.startswith("<"):
        return "gpx"
    if text[:1] in ("$", "!"):
        return "nmea"
    return "csv"


def read_nav(path: str | Path, *, gap: float | None = None,
             date: dt.date | None = None) -> NavTrack:
    """Read own-ship navigation of any supported kind, told by its content: a file starting
    with ``<`` is GPX, with ``$`` (or ``!``) NMEA 0183, anything else CSV.

    Parameters
    ----------
    path : str or Path
    gap : float, optional
        Gap threshold [s] (:func:`tmaplan.io.nav.finish_nav`).
    date : datetime.date, optional
        NMEA only: the UTC date of the first fix when the file has no RMC sentence
        (:func:`tmaplan.io.nmea.read_nmea`).

    Returns
    -------
    NavTrack
    """
    kind = _kind(path)
    if kind == "gpx":
        return read_gpx(path, gap=gap)
    if kind == "nmea":
        return read_nmea(path, gap=gap, date=date)
    return read_nav_csv(path, gap=gap)
