"""Time stamps of recorded data: ISO 8601 with a zone, or plain seconds.

A file's times are either all absolute (ISO 8601 with a zone, ``Z`` or ``±hh:mm``; the zones
may differ from row to row, every time is normalised to UTC) or all plain seconds (on a clock
of the recording's own). :class:`Stamps` keeps them as float seconds since an epoch: the first
row's UTC time for absolute times (so the float keeps microseconds over days), none for plain
seconds.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from collections.abc import Sequence

import numpy as np

from tmaplan.errors import ArgumentError, DataError

__all__ = ["UTC", "Stamps", "format_time", "parse_stamps", "parse_utc", "time_text"]

UTC = dt.UTC

_EXPECTED = "an ISO 8601 time with a zone (Z or ±hh:mm, e.g. 2024-06-01T12:00:05Z) or seconds"


@dataclasses.dataclass(frozen=True, kw_only=True)
class Stamps:
    """The time stamps of one file.

    Attributes
    ----------
    epoch : datetime.datetime or None
        UTC time of ``seconds == 0`` (absolute times; the first row's time), None for plain
        seconds.
    seconds : ndarray, shape (n,)
        [s] since ``epoch`` (absolute times) or as written (plain seconds).
    """

    epoch: dt.datetime | None
    seconds: np.ndarray


def parse_utc(text: str) -> dt.datetime | None:
    """``text`` as an aware UTC datetime (ISO 8601 with a zone), None if it is not one.

    Parameters
    ----------
    text : str
        E.g. ``"2024-06-01T12:00:05Z"``, ``"2024-06-01T14:00:05+02:00"``.

    Returns
    -------
    datetime.datetime or None
        In UTC; None when ``text`` is not ISO 8601, carries no zone or is out of the years
        1 to 9999 in UTC.
    """
    try:
        t = dt.datetime.fromisoformat(text.strip())
    except ValueError:
        return None
    if t.tzinfo is None or t.utcoffset() is None:
        return None
    try:
        return t.astimezone(UTC)
    except OverflowError:  # a zone that moves it out of years 1-9999
        return None


def _seconds(text: str) -> float | None:
    """``text`` as finite seconds, None if it is not a number."""
    try:
        v = float(text)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def parse_stamps(cells: Sequence[str], lines: Sequence[int] | np.ndarray, *, source: str,
                 column: str = "time") -> Stamps:
    """Parse a time column: all ISO 8601 with a zone, or all plain seconds (the first row
    decides which).

    Parameters
    ----------
    cells : sequence of str, length n >= 1
        The column's text, row by row.
    lines : sequence of int, length n
        The file's line number of each row (for the messages).
    source : str
        The file (for the messages).
    column : str
        The column's name (for the messages).

    Returns
    -------
    Stamps

    Raises
    ------
    DataError
        A cell that is neither, a time without a zone, or a file that mixes the two kinds,
        naming the file, the line, the column and the value.
    """
    first = cells[0].strip()
    if _seconds(first) is not None:
        out = np.empty(len(cells))
        for i, c in enumerate(cells):
            v = _seconds(c)
            if v is None:
                what = ("seconds, as the first row's time" if parse_utc(c) is not None
                        else _EXPECTED)
                raise DataError(source, f"column '{column}': expected {what}, received "
                                f"{c!r}", lines[i], column, c)
            out[i] = v
        return Stamps(epoch=None, seconds=out)
    stamps: list[dt.datetime] = []
    for i, c in enumerate(cells):
        t = parse_utc(c)
        if t is None:
            if _seconds(c) is not None and stamps:
                what = "an ISO 8601 time with a zone, as the first row's time"
            elif _naive(c):
                what = "a time zone (Z or ±hh:mm): a time without one is ambiguous"
            else:
                what = _EXPECTED
            raise DataError(source, f"column '{column}': expected {what}, received {c!r}",
                            lines[i], column, c)
        stamps.append(t)
    epoch = stamps[0]
    one = dt.timedelta(microseconds=1)
    micros = np.array([(t - epoch) // one for t in stamps], dtype=np.int64)
    return Stamps(epoch=epoch, seconds=micros / 1e6)


def _naive(text: str) -> bool:
    """Whether ``text`` is an ISO 8601 time without a zone."""
    try:
        return dt.datetime.fromisoformat(text.strip()).tzinfo is None
    except ValueError:
        return False


def format_time(seconds: float, epoch: dt.datetime | None) -> str:
    """One time as written in the files and messages: ISO 8601 UTC (``Z``; microseconds
    only when not whole seconds) after ``epoch``, or ``repr`` seconds without one.

    Parameters
    ----------
    seconds : float
        [s] since ``epoch`` (or plain seconds).
    epoch : datetime.datetime or None
        Aware UTC time of ``seconds == 0``.

    Returns
    -------
    str
    """
    if epoch is None:
        return repr(float(seconds))
    t = (epoch + dt.timedelta(seconds=float(seconds))).astimezone(UTC)
    spec = "microseconds" if t.microsecond else "seconds"
    return t.replace(tzinfo=None).isoformat(timespec=spec) + "Z"


def time_text(seconds: float, start: dt.datetime | None) -> str:
    """A time as the writers write it: ISO 8601 UTC ``seconds`` after the aware time
    ``start`` (:func:`format_time`), or ``repr`` seconds without ``start``."""
    if start is not None and start.utcoffset() is None:
        raise ArgumentError("start", "an aware datetime (with a time zone)", start)
    return format_time(seconds, start.astimezone(UTC) if start is not None else None)
