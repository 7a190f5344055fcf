"""Bearings CSV: ``time,bearing_deg,sigma_deg,contact`` (docs/recordings.md).

* ``time``: ISO 8601 with a zone (``Z`` or ``±hh:mm``; zones may differ between rows, all are
  normalised to UTC) or plain seconds (all rows alike).
* ``bearing_deg``: true bearing, clockwise from North, degrees. Values in [−360, 720) wrap
  silently (signed bearings, or a log that unwraps across North); values outside it wrap too,
  with a warning (they are unusual for bearings in degrees). Read as radians in (−π, π].
* ``sigma_deg`` (optional): the bearing's standard deviation, degrees, > 0 and < 180. Absent:
  the reader's ``sigma_deg`` argument (default 1°, with a warning unless given); an empty cell
  takes it too, with a warning.
* ``contact`` (optional): the contact's name; one file holds several contacts. Absent: one
  contact named ``"contact"``.

Columns may come in any order. Rows of a contact must not go backwards in time (an error);
rows of different contacts may interleave or follow one another. A row repeated exactly
(same contact, time, bearing and sigma) is dropped with a warning; two different bearings of
one contact at the same time are both kept, with a warning (as two sensors' measurements).
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import DataError
from tmaplan.geometry import wrap_angle
from tmaplan.io.faults import check_not_backwards, warn, warn_gaps, warn_if_radians
from tmaplan.io.table import Table, csv_text, read_table, write_csv
from tmaplan.io.times import format_time, parse_stamps, time_text

__all__ = ["BearingLog", "ContactBearings", "read_bearings", "write_bearings"]

#: The contact's name when the file has no ``contact`` column.
DEFAULT_CONTACT = "contact"
#: Default bearing standard deviation [deg] when the file has no ``sigma_deg`` column.
DEFAULT_SIGMA_DEG = 1.0
#: Bearings in degrees outside this interval are wrapped with a warning.
_SILENT_WRAP = (-360.0, 720.0)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactBearings:
    """The bearings of one contact, in time order as written.

    Attributes
    ----------
    name : str
        The contact's name.
    times : ndarray, shape (n,)
        [s] since the file's epoch (:attr:`BearingLog.epoch`), or plain seconds.
    bearing : ndarray, shape (n,)
        True bearing [rad], clockwise from North, in (−π, π].
    sigma : ndarray, shape (n,)
        Standard deviation [rad], > 0.
    lines : ndarray of int, shape (n,)
        The file's line of each bearing.
    """

    name: str
    times: np.ndarray
    bearing: np.ndarray
    sigma: np.ndarray
    lines: np.ndarray

    def select(self, keep: np.ndarray) -> ContactBearings:
        """The bearings where the boolean mask ``keep`` (shape (n,)) holds."""
        return dataclasses.replace(self, times=self.times[keep], bearing=self.bearing[keep],
                                   sigma=self.sigma[keep], lines=self.lines[keep])


@dataclasses.dataclass(frozen=True, kw_only=True)
class BearingLog:
    """A bearings file.

    Attributes
    ----------
    source : str
        The file.
    epoch : datetime.datetime or None
        UTC time of ``times == 0`` (the first row's time) for ISO times; None for plain
        seconds.
    contacts : tuple of ContactBearings
        In the order of their first row.
    """

    source: str
    epoch: dt.datetime | None
    contacts: tuple[ContactBearings, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The contacts' names."""
        return tuple(c.name for c in self.contacts)

    def contact(self, name: str) -> ContactBearings:
        """The bearings of contact ``name`` (KeyError if there is none)."""
        for c in self.contacts:
            if c.name == name:
                return c
        raise KeyError(name)


def read_bearings(path: str | Path, *, sigma_deg: float | None = None,
                  gap: float | None = None) -> BearingLog:
    """Read a bearings CSV (the format in the module's doc and docs/recordings.md).

    Parameters
    ----------
    path : str or Path
    sigma_deg : float, optional
        Standard deviation [deg] of the bearings without one (no ``sigma_deg`` column, or an
        empty cell); default 1°, with a warning saying so.
    gap : float, optional
        Gap threshold [s] of each contact's bearings (default: ``max(10 s, 5 × the median
        interval)``, :mod:`tmaplan.io.faults`); longer intervals are warned.

    Returns
    -------
    BearingLog

    Raises
    ------
    DataError
        A missing file, an empty file, a wrong separator, a missing column, a non-numeric
        value, a bad time, a sigma not in (0, 180) degrees, an empty contact name, a contact's
        time going backwards: one line naming the file, the line and the column.
    """
    src = str(path)
    t = read_table(path, required=("time", "bearing_deg"), optional=("sigma_deg", "contact"),
                   what="bearing")
    stamps = parse_stamps(t.text("time"), t.lines, source=src)
    deg = t.numbers("bearing_deg")
    warn_if_radians(deg, source=src, column="bearing_deg")
    odd = (deg < _SILENT_WRAP[0]) | (deg >= _SILENT_WRAP[1])
    if odd.any():
        i = int(np.argmax(odd))
        warn(f"{src}: {int(odd.sum())} bearing_deg value{'s' if odd.sum() > 1 else ''} outside "
             f"[{_SILENT_WRAP[0]:g}, {_SILENT_WRAP[1]:g}) (first {deg[i]:g} at line "
             f"{t.lines[i]}) wrapped to the circle")
    bearing = wrap_angle(np.deg2rad(deg))
    sigma = _sigma(t, sigma_deg, src)
    names = t.text("contact") if t.has("contact") else [DEFAULT_CONTACT] * len(t.rows)
    for i, name in enumerate(names):
        if not name:
            raise DataError(src, "column 'contact': expected a contact's name, received ''",
                            int(t.lines[i]), "contact", "")
    order = list(dict.fromkeys(names))
    label = np.asarray(names, dtype=object)
    contacts = []
    for name in order:
        m = label == name
        c = ContactBearings(name=name, times=stamps.seconds[m], bearing=bearing[m],
                            sigma=sigma[m], lines=t.lines[m])
        what = f"contact '{name}': " if t.has("contact") else ""
        check_not_backwards(c.times, c.lines, stamps.epoch, source=src, what=what)
        c = _duplicates(c, stamps.epoch, src, what)
        warn_gaps(c.times, c.lines, stamps.epoch, source=src,
                  what=f"the bearings of contact '{name}'" if what else "the bearings", gap=gap,
                  done="no bearing there")
        contacts.append(c)
    return BearingLog(source=src, epoch=stamps.epoch, contacts=tuple(contacts))


def _sigma(t: Table, sigma_deg: float | None, src: str) -> np.ndarray:
    """The bearings' standard deviations [rad] (see :func:`read_bearings`)."""
    default = DEFAULT_SIGMA_DEG if sigma_deg is None else float(sigma_deg)
    if not t.has("sigma_deg"):
        if sigma_deg is None:
            warn(f"{src}: no sigma_deg column: every bearing's standard deviation taken as "
                 f"{default:g}°")
        return np.full(len(t.rows), np.deg2rad(default))
    s = t.numbers("sigma_deg", empty=np.nan)
    empty = np.isnan(s)
    if empty.any():
        warn(f"{src}: {int(empty.sum())} empty sigma_deg cell{'s' if empty.sum() > 1 else ''} "
             f"(first at line {t.lines[int(np.argmax(empty))]}) taken as {default:g}°")
        s = np.where(empty, default, s)
    bad = (s <= 0) | (s >= 180)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataError(src, f"column 'sigma_deg': expected a standard deviation in (0, 180) "
                        f"degrees, received {t.text('sigma_deg')[i]!r}", int(t.lines[i]),
                        "sigma_deg", t.text("sigma_deg")[i])
    return np.deg2rad(s)


def _duplicates(c: ContactBearings, epoch: dt.datetime | None, src: str,
                what: str) -> ContactBearings:
    """``c`` without its exactly repeated rows (warned); several different bearings at one
    time are kept (warned)."""
    same_t = np.flatnonzero(np.diff(c.times) == 0) + 1
    if not same_t.size:
        return c
    repeat = np.zeros(c.times.size, bool)
    repeat[same_t] = (c.bearing[same_t] == c.bearing[same_t - 1]) & (
        c.sigma[same_t] == c.sigma[same_t - 1])
    if repeat.any():
        n = int(repeat.sum())
        warn(f"{src}: {what}{n} repeated row{'s' if n > 1 else ''} (same time and bearing as the"
             f" row before; first at line {c.lines[int(np.argmax(repeat))]}) dropped")
        c = c.select(~repeat)
    many = np.flatnonzero(np.diff(c.times) == 0)
    if many.size:
        i = int(many[0])
        n = np.unique(c.times[many]).size
        warn(f"{src}: {what}{n} time{'s' if n > 1 else ''} with several different bearings "
             f"(first {format_time(c.times[i], epoch)}, lines {c.lines[i]} and "
             f"{c.lines[i + 1]}): all kept, as independent measurements")
    return c


def write_bearings(path: str | Path, times: ArrayLike, bearing: ArrayLike, *,
                   sigma: ArrayLike | None = None, contact: Sequence[str] | str | None = None,
                   start: dt.datetime | None = None) -> Path:
    """Write a bearings CSV that :func:`read_bearings` reads back exactly.

    Parameters
    ----------
    path : str or Path
    times : array_like, shape (n,)
        [s] after ``start`` (or plain seconds without it).
    bearing : array_like, shape (n,)
        True bearing [rad], clockwise from North; written in degrees in [0, 360).
    sigma : array_like, shape (n,) or (), optional
        Standard deviation [rad]; no ``sigma_deg`` column without it.
    contact : str or sequence of str, optional
        The contact of every row (one name) or of each row; no ``contact`` column without it.
    start : datetime.datetime, optional
        Aware time of ``times == 0``: times are written as ISO 8601 UTC; plain seconds without
        it.

    Returns
    -------
    Path
        The file written. Floats are written with ``repr`` (round trip exact).
    """
    t = np.asarray(times, float).ravel()
    deg = np.rad2deg(np.mod(np.asarray(bearing, float).ravel(), 2 * np.pi))
    deg = np.where(deg >= 360.0, 0.0, deg)
    cols: list[list[str]] = [[time_text(x, start) for x in t], [repr(float(x)) for x in deg]]
    header = ["time", "bearing_deg"]
    if sigma is not None:
        s = np.broadcast_to(np.rad2deg(np.asarray(sigma, float)), t.shape)
        cols.append([repr(float(x)) for x in s])
        header.append("sigma_deg")
    if contact is not None:
        names = [contact] * t.size if isinstance(contact, str) else list(contact)
        cols.append([csv_text(str(n)) for n in names])
        header.append("contact")
    return write_csv(path, header, cols)
