"""NMEA 0183 own-ship navigation: ``RMC`` and ``GGA`` sentences (through pynmea2).

Reading (:func:`read_nmea`):

* every sentence's checksum is verified (pynmea2); a sentence with a bad or missing checksum
  is skipped, and the skipped sentences are counted in one warning (with their first lines);
  so are the lines that are not NMEA sentences and the sentences without a valid fix (RMC
  status ``V``, GGA quality 0, an empty position). Other sentence types (GSV, VTG, ...) are
  ignored: they carry no fix;
* an RMC sentence carries the UTC date and time, a GGA sentence only the time of day. A GGA
  takes the date of the nearest RMC before it (else after it), one day more or less when the
  two times of day are more than 12 h apart (a midnight between them); without any RMC the
  first GGA's date is the ``date`` argument, and a time of day more than 12 h earlier than the
  fix before is the next day (midnight rollover);
* an RMC and a GGA at the same time are one fix (the RMC's position, course and speed);
* the times of day are read to the microsecond from the sentence's text (``hhmmss.sss``).

Writing (:func:`write_nmea`): one RMC then one GGA per fix, with checksums (pynmea2), times to
the millisecond and positions to 1e-7 minute of arc (0.2 mm), every sentence within the
standard's 82 characters.
"""

from __future__ import annotations

import datetime as dt
import functools
import re
from pathlib import Path

import numpy as np
import pynmea2
from numpy.typing import ArrayLike

from tmaplan.errors import DataError
from tmaplan.io.faults import warn
from tmaplan.io.nav import NavTrack, check_latlon, finish_nav, fixes_to_write
from tmaplan.io.table import read_text
from tmaplan.io.times import UTC
from tmaplan.units import KNOT

__all__ = ["read_nmea", "write_nmea"]

_DAY = 86400.0
_TIME = re.compile(r"^(\d{2})(\d{2})(\d{2}(?:\.\d+)?)$")


def _time_of_day(text: str) -> float | None:
    """``hhmmss[.sss]`` as seconds of the day, None if malformed."""
    m = _TIME.match(text.strip())
    if not m:
        return None
    h, mi, s = int(m.group(1)), int(m.group(2)), float(m.group(3))
    if h > 23 or mi > 59 or s >= 61.0:
        return None
    return h * 3600.0 + mi * 60.0 + round(s * 1e6) / 1e6


@functools.lru_cache(maxsize=256)
def _date(text: str) -> dt.date:
    """An RMC date ``ddmmyy`` (ValueError if malformed); cached: a log repeats its dates."""
    return dt.datetime.strptime(text, "%d%m%y").date()


def _fix(msg: pynmea2.NMEASentence) -> tuple[float, dt.date | None, float, float, float,
                                                  float] | str:
    """(time of day [s], date or None, lat [deg], lon [deg], course [rad], speed [m/s]) of an
    RMC or GGA sentence, or why it is skipped (``"unreadable"`` or ``"no fix"``)."""
    data = msg.data
    tod = _time_of_day(data[0]) if data else None
    if tod is None:
        return "unreadable"
    rmc = msg.sentence_type == "RMC"
    if len(data) < (9 if rmc else 6):
        return "unreadable"
    if (data[1] != "A") if rmc else (data[5].strip() in ("", "0")):
        return "no fix"
    if not (data[1 + rmc] and data[3 + rmc]):
        return "no fix"
    if data[2 + rmc] not in ("N", "S") or data[4 + rmc] not in ("E", "W"):
        return "unreadable"
    try:
        lat, lon = float(msg.latitude), float(msg.longitude)
        date = _date(data[8]) if rmc and data[8] else None
        sog = float(data[6]) * KNOT if rmc and data[6] else np.nan
        cog = np.deg2rad(float(data[7])) if rmc and data[7] else np.nan
    except ValueError:
        return "unreadable"
    return tod, date, lat, lon, float(cog), float(sog)


def read_nmea(path: str | Path, *, gap: float | None = None,
              date: dt.date | None = None) -> NavTrack:
    """Read own-ship fixes from NMEA 0183 ``RMC`` and ``GGA`` sentences (module doc).

    Parameters
    ----------
    path : str or Path
    gap : float, optional
        Gap threshold [s] (:func:`tmaplan.io.nav.finish_nav`).
    date : datetime.date, optional
        UTC date of the first fix, needed only when no RMC sentence gives one.

    Returns
    -------
    NavTrack
        Geographic, with the RMC's course and speed over ground (NaN for GGA-only fixes).

    Raises
    ------
    DataError
        No RMC or GGA fix; GGA only and no ``date``; a time going backwards; fewer than two
        fixes; a latitude or longitude out of range.
    """
    src = str(path)
    skipped: dict[str, list[int]] = {"bad or missing checksum": [], "unreadable": [],
                                     "no fix": []}
    recs: list[tuple[int, bool, float, dt.date | None, float, float, float, float]] = []
    for ln, raw in enumerate(read_text(path).splitlines(), 1):
        s = raw.strip()
        if not s:
            continue
        try:
            msg = pynmea2.parse(s, check=True)
        except pynmea2.ChecksumError:
            skipped["bad or missing checksum"].append(ln)
            continue
        except pynmea2.SentenceTypeError:
            continue  # a sentence type pynmea2 does not know carries no RMC/GGA fix
        except pynmea2.ParseError:
            skipped["unreadable"].append(ln)
            continue
        if getattr(msg, "sentence_type", None) not in ("RMC", "GGA"):
            continue
        fix = _fix(msg)
        if isinstance(fix, str):
            skipped[fix].append(ln)
            continue
        recs.append((ln, msg.sentence_type == "RMC", *fix))
    for why, lines in skipped.items():
        if lines:
            first = ", ".join(str(x) for x in lines[:5]) + (", ..." if len(lines) > 5 else "")
            s = "s" if len(lines) > 1 else ""
            what = {"bad or missing checksum": f"sentence{s} with a bad or missing checksum",
                    "unreadable": f"unreadable line{s}", "no fix": f"sentence{s} without a "
                    "valid fix (RMC status V, GGA quality 0 or no position)"}[why]
            warn(f"{src}: {len(lines)} {what} skipped (line{'s' if len(lines) > 1 else ''} "
                 f"{first})")
    if not recs:
        raise DataError(src, "no RMC or GGA sentence with a valid fix (expected NMEA 0183 "
                        "own-ship navigation)", field="sentences")
    days = _days(recs, date, src)
    line = np.array([r[0] for r in recs], int)
    is_rmc = np.array([r[1] for r in recs], bool)
    tod = np.array([r[2] for r in recs])
    secs = (days - days[0]) * _DAY + (tod - tod[0])
    lat = np.array([r[4] for r in recs])
    lon = check_latlon(lat, np.array([r[5] for r in recs]), line, source=src,
                       names=("latitude", "longitude"))
    course = np.array([r[6] for r in recs])
    speed = np.array([r[7] for r in recs])
    # an RMC and a GGA at one time are one fix: the RMC's
    drop = np.zeros(len(recs), bool)
    for i in range(1, len(recs)):  # pairs of sentences, in file order
        if secs[i] == secs[i - 1] and is_rmc[i] != is_rmc[i - 1] and not drop[i - 1] and (
                i < 2 or secs[i - 2] != secs[i]):
            drop[i - 1 if is_rmc[i] else i] = True
    keep = ~drop
    day0 = dt.date.fromordinal(int(days[0]))
    epoch = dt.datetime.combine(day0, dt.time(0, 0), tzinfo=UTC) + dt.timedelta(
        microseconds=round(tod[0] * 1e6))
    nav = NavTrack(source=src, epoch=epoch, times=secs[keep], lat=lat[keep], lon=lon[keep],
                   course=course[keep], speed=speed[keep], lines=line[keep])
    return finish_nav(nav, gap=gap)


def _days(recs: list[tuple[int, bool, float, dt.date | None, float, float, float, float]],
          date: dt.date | None, src: str) -> np.ndarray:
    """The date (proleptic ordinal) of every record (module doc: RMC dates, GGA rollover)."""
    dated = [i for i, r in enumerate(recs) if r[3] is not None]
    if dated:
        i0 = dated[0]
        d0 = recs[i0][3]
        assert d0 is not None  # a dated record
        ref_day, ref_tod = d0.toordinal(), recs[i0][2]
        # the records before the first dated one: backwards from it
        out = np.empty(len(recs))
        for i in range(i0, -1, -1):  # rollover is sequential
            out[i] = ref_day = ref_day + _rollover(ref_tod, recs[i][2])
            ref_tod = recs[i][2]
        start = i0 + 1
        ref_day, ref_tod = int(out[i0]), recs[i0][2]
    elif date is not None:
        out = np.empty(len(recs))
        out[0], start = date.toordinal(), 1
        ref_day, ref_tod = date.toordinal(), recs[0][2]
    else:
        raise DataError(src, "no RMC sentence with a date: GGA sentences give only the time "
                        "of day (expected RMC sentences, or the date of the first fix given)",
                        field="date")
    for i in range(start, len(recs)):  # rollover is sequential
        d = recs[i][3]
        if d is not None:
            ref_day = d.toordinal()
        else:
            ref_day += _rollover(ref_tod, recs[i][2])
        out[i], ref_tod = ref_day, recs[i][2]
    return out


def _rollover(ref_tod: float, tod: float) -> int:
    """Days to add to the reference's date for a time of day ``tod`` that follows (or, going
    backwards, precedes) the reference's ``ref_tod``: ±1 across midnight (more than 12 h
    apart), else 0."""
    if tod - ref_tod < -_DAY / 2:
        return 1
    if tod - ref_tod > _DAY / 2:
        return -1
    return 0


def _dm(value: float, width: int) -> tuple[str, bool]:
    """Degrees as NMEA ``d..dmm.mmmmmmm`` (``width`` digits of degrees) and whether it is
    negative."""
    units = round(abs(value) * 60 * 10**7)
    deg, rem = divmod(units, 60 * 10**7)
    return f"{deg:0{width}d}{rem // 10**7:02d}.{rem % 10**7:07d}", value < 0


def write_nmea(path: str | Path, times: ArrayLike, lat: ArrayLike, lon: ArrayLike, *,
               start: dt.datetime, course: ArrayLike | None = None,
               speed: ArrayLike | None = None, talker: str = "GP") -> Path:
    """Write own-ship fixes as NMEA 0183, one ``RMC`` and one ``GGA`` sentence per fix, that
    :func:`read_nmea` reads back (to 1 ms and 0.2 mm; module doc).

    Parameters
    ----------
    path, times, lat, lon, start
        As for :func:`tmaplan.io.gpx.write_gpx`.
    course : array_like, shape (m,), optional
        Course over ground [rad], clockwise from North (RMC); empty fields without it.
    speed : array_like, shape (m,), optional
        Speed over ground [m/s] (RMC, written in knots); empty fields without it.
    talker : str
        Talker ID (``GP``: GPS).

    Returns
    -------
    Path
    """
    t, la, lo = fixes_to_write(times, lat, lon, start)
    cog = None if course is None else np.rad2deg(np.mod(np.asarray(course, float), 2 * np.pi))
    sog = None if speed is None else np.asarray(speed, float) / KNOT
    base = start.astimezone(UTC)
    out = []
    for i in range(t.size):  # one pair of sentences per fix
        when = base + dt.timedelta(milliseconds=round(t[i] * 1000))
        hms = f"{when:%H%M%S}.{when.microsecond // 1000:03d}"
        lat_s, south = _dm(la[i], 2)
        lon_s, west = _dm(lo[i], 3)
        pos = (lat_s, "S" if south else "N", lon_s, "W" if west else "E")
        rmc = pynmea2.RMC(talker, "RMC", (
            hms, "A", *pos, "" if sog is None else f"{sog[i]:.3f}",
            "" if cog is None else f"{cog[i] % 360.0:.2f}", f"{when:%d%m%y}", "", "", "A"))
        gga = pynmea2.GGA(talker, "GGA", (hms, *pos, "1", "08", "1.0", "0.0", "M", "0.0", "M",
                                          "", ""))
        out += [str(rmc), str(gga)]
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text("\r\n".join(out) + "\r\n", encoding="ascii")
    return p
