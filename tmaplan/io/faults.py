"""Faults of recorded data that every reader checks the same way.

Errors (:class:`~tmaplan.errors.DataError`, one line naming the file and line) for what cannot
be read without a guess; :class:`DataWarning` (one line saying what was done) for what is
suspicious but readable. The CLI prints a warning as one line, ``tmaplan VERB: warning:
DataWarning: ...``.

* **Times going backwards**: an error naming the line and the two times.
* **Gaps**: an interval between consecutive times longer than the gap threshold is warned,
  with the number of gaps, the longest and where it starts. The threshold is the reader's
  ``gap`` argument [s]; by default (``gap=None``) ``max(10 s, 5 × the median interval)``.
* **Values that look like radians** in a degrees column: all of at least 3 values within
  ±2π and spread over more than 1 (a spread of more than 57° as radians, which is typical of
  bearings, and of more than 1° as degrees): warned; the values are read as degrees.
"""

from __future__ import annotations

import datetime as dt
import warnings

import numpy as np

from tmaplan.errors import DataError
from tmaplan.io.times import format_time

__all__ = [
    "DEFAULT_GAP_FACTOR",
    "DEFAULT_GAP_FLOOR",
    "DataWarning",
    "check_not_backwards",
    "gap_threshold",
    "warn_gaps",
    "warn_if_radians",
]

#: Default gap threshold: ``max(DEFAULT_GAP_FLOOR, DEFAULT_GAP_FACTOR × median interval)``.
DEFAULT_GAP_FACTOR = 5.0
DEFAULT_GAP_FLOOR = 10.0  # [s]


class DataWarning(UserWarning):
    """Recorded data were read with a repair or look suspicious; the message (one line) names
    the file and says what was done."""


def warn(message: str) -> None:
    """Issue ``message`` as a :class:`DataWarning` (one line)."""
    warnings.warn(message.replace("\n", " "), DataWarning, stacklevel=3)


def check_not_backwards(seconds: np.ndarray, lines: np.ndarray, epoch: dt.datetime | None,
                        *, source: str, what: str = "") -> None:
    """Raise if a time is earlier than the one before it.

    Parameters
    ----------
    seconds : ndarray, shape (n,)
        [s] since ``epoch``, in file order.
    lines : ndarray of int, shape (n,)
        The file's line of each time.
    epoch : datetime.datetime or None
        Absolute time of ``seconds == 0`` (for the message).
    source : str
        The file.
    what : str
        Prefix naming the series (e.g. ``"contact 'A': "``).

    Raises
    ------
    DataError
        At the first time going backwards, naming its line, its time and the time before it.
    """
    back = np.flatnonzero(np.diff(seconds) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise DataError(source, f"{what}time goes backwards: {format_time(seconds[i], epoch)} "
                        f"after {format_time(seconds[i - 1], epoch)} (line {lines[i - 1]})",
                        int(lines[i]), "time", format_time(seconds[i], epoch))


def gap_threshold(seconds: np.ndarray, gap: float | None) -> tuple[float, str]:
    """The gap threshold [s] of a series and how it was set (for the message).

    Parameters
    ----------
    seconds : ndarray, shape (n,)
        Non-decreasing times [s].
    gap : float or None
        The threshold [s]; None: ``max(10 s, 5 × the median interval)``.
    """
    if gap is not None:
        return float(gap), "given"
    steps = np.diff(seconds)
    steps = steps[steps > 0]
    median = float(np.median(steps)) if steps.size else 0.0
    thr = max(DEFAULT_GAP_FLOOR, DEFAULT_GAP_FACTOR * median)
    how = (f"{DEFAULT_GAP_FACTOR:g} × the median interval {median:g} s"
           if thr > DEFAULT_GAP_FLOOR else f"at least {DEFAULT_GAP_FLOOR:g} s")
    return thr, how


def warn_gaps(seconds: np.ndarray, lines: np.ndarray, epoch: dt.datetime | None, *,
              source: str, what: str, gap: float | None, done: str) -> int:
    """Warn (once per series) about the intervals longer than the gap threshold.

    Parameters
    ----------
    seconds : ndarray, shape (n,)
        Non-decreasing times [s] since ``epoch``.
    lines : ndarray of int, shape (n,)
    epoch : datetime.datetime or None
    source : str
        The file.
    what : str
        The series, e.g. ``"the navigation"`` or ``"contact 'A''s bearings"``.
    gap : float or None
        Threshold [s] (:func:`gap_threshold`).
    done : str
        What is done across a gap (e.g. ``"positions interpolated linearly across them"``).

    Returns
    -------
    int
        The number of gaps.
    """
    if seconds.size < 2:
        return 0
    thr, how = gap_threshold(seconds, gap)
    d = np.diff(seconds)
    at = np.flatnonzero(d > thr)
    if at.size:
        i = int(at[np.argmax(d[at])])
        n = at.size
        warn(f"{source}: {n} gap{'s' if n > 1 else ''} in {what} longer than {thr:g} s "
             f"({how}): the longest {d[i]:g} s from {format_time(seconds[i], epoch)} "
             f"(line {lines[i]}) to {format_time(seconds[i + 1], epoch)} (line {lines[i + 1]});"
             f" {done}")
    return int(at.size)


def warn_if_radians(values: np.ndarray, *, source: str, column: str) -> bool:
    """Warn when a degrees column looks like radians (see the module's doc).

    Parameters
    ----------
    values : ndarray, shape (n,)
        The column as written.
    source, column : str
        For the message.

    Returns
    -------
    bool
        Whether it warned.
    """
    v = np.asarray(values, float)
    if v.size >= 3 and np.all(np.abs(v) <= 2 * np.pi + 1e-9) and np.ptp(v) > 1.0:
        warn(f"{source}: all {v.size} values of column '{column}' lie within ±2π "
             f"([{v.min():.4g}, {v.max():.4g}]): they look like radians; read as degrees")
        return True
    return False
