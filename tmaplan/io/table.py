"""The one CSV reader of the recorded-data files (the stdlib :mod:`csv` module), with their
faults as one-line :class:`~tmaplan.errors.DataError` s: a missing file, an empty file, a
wrong separator, a missing column, a row of the wrong length, a non-numeric value.

Lines starting with ``#`` and blank lines are skipped; the first other line is the header;
column names are matched without case and surrounding blanks; a UTF-8 byte-order mark is
ignored.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tmaplan.errors import DataError
from tmaplan.io.faults import warn

__all__ = ["Table", "csv_text", "read_table", "read_text", "write_csv"]

#: Separators a CSV file is sometimes written with instead of a comma, in the order tried.
_OTHER_SEPARATORS = {";": "';'", "\t": "tab", "|": "'|'"}


@dataclasses.dataclass(frozen=True, kw_only=True)
class Table:
    """A CSV file's header and rows (text).

    Attributes
    ----------
    source : str
        The file, as given.
    header : tuple of str
        Column names, lower case, stripped.
    header_line : int
        The file's line of the header.
    rows : list of list of str
        One list of cells per data row.
    lines : ndarray of int, shape (n,)
        The file's line number of each row.
    """

    source: str
    header: tuple[str, ...]
    header_line: int
    rows: list[list[str]]
    lines: np.ndarray

    def has(self, name: str) -> bool:
        """Whether the table has column ``name``."""
        return name in self.header

    def text(self, name: str) -> list[str]:
        """The cells of column ``name`` (stripped)."""
        j = self.header.index(name)
        return [r[j].strip() for r in self.rows]

    def numbers(self, name: str, *, empty: float | None = None) -> np.ndarray:
        """Column ``name`` as finite floats, shape (n,).

        ``empty``: the value of an empty cell (None: an empty cell is an error).

        Raises
        ------
        DataError
            A cell that is not a finite number, naming the file, line, column and value.
        """
        cells = self.text(name)
        out = np.empty(len(cells))
        for i, c in enumerate(cells):
            if not c and empty is not None:
                out[i] = empty
                continue
            try:
                v = float(c)
            except ValueError:
                v = math.nan
            if not math.isfinite(v):
                raise DataError(self.source, f"column '{name}': expected a number, received "
                                f"{c!r}", int(self.lines[i]), name, c)
            out[i] = v
        return out


def read_text(path: str | Path) -> str:
    """The text of a recorded-data file (UTF-8, a byte-order mark dropped).

    Raises
    ------
    DataError
        No such file, not a file, or not UTF-8 text.
    """
    src = str(path)
    p = Path(path)
    if not p.is_file():
        raise DataError(src, "no such file" if not p.exists() else "not a file")
    try:
        return p.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataError(src, f"expected UTF-8 text, received a byte {exc.object[exc.start]:#04x}"
                        f" at offset {exc.start}") from None


def read_table(path: str | Path, *, required: Sequence[str],
               optional: Sequence[str] = (), one_of: Sequence[Sequence[str]] = (),
               what: str = "") -> Table:
    """Read a comma-separated file with a header.

    Parameters
    ----------
    path : str or Path
    required : sequence of str
        Columns that must be present (a missing one is an error naming it).
    optional : sequence of str
        Columns that may be present; any other column is ignored with a
        :class:`~tmaplan.io.faults.DataWarning`.
    one_of : sequence of sequences of str
        Groups of columns of which one must be present in full (the first group with a
        column in the header; a missing column of it is an error naming it); their columns
        are optional otherwise.
    what : str
        What the file holds (e.g. ``"bearings"``), for the messages.

    Returns
    -------
    Table

    Raises
    ------
    DataError
        An empty file, a header without commas that looks separated by something else, a
        missing or repeated column, a row with another number of cells than the header, no
        data row.
    """
    src = str(path)
    kept = [(i + 1, ln) for i, ln in enumerate(read_text(path).splitlines())
            if ln.strip() and not ln.lstrip().startswith("#")]
    if not kept:
        raise DataError(src, f"the file is empty (expected a header line and {what or 'data'}"
                        " rows)")
    head_line, head = kept[0]
    if "," not in head:
        for sep, name in _OTHER_SEPARATORS.items():
            if sep in head:
                raise DataError(src, f"expected comma-separated; the file looks {name}-"
                                "separated", head_line, "separator", sep)
    reader = csv.reader([ln for _, ln in kept])
    header = tuple(c.strip().lower() for c in next(reader))
    for name in header:
        if header.count(name) > 1:
            raise DataError(src, f"column '{name}' appears {header.count(name)} times in the "
                            "header", head_line, name)
    if one_of:
        group = next((g for g in one_of if any(c in header for c in g)), one_of[0])
        expected = " or ".join(",".join([*required, *g]) for g in one_of)
    else:
        group, expected = (), ",".join(required)
    for name in [*required, *group]:
        if name not in header:
            raise DataError(src, f"missing column '{name}' (expected the columns {expected};"
                            f" the header has {','.join(header)})", head_line, name)
    known = {*required, *optional, *(c for g in one_of for c in g)}
    extra = [c for c in header if c not in known]
    if extra:
        warn(f"{src}: ignored column{'s' if len(extra) > 1 else ''} "
             f"{', '.join(repr(c) for c in extra)} (read: "
             f"{', '.join(c for c in header if c not in extra)})")
    rows: list[list[str]] = []
    lines: list[int] = []
    for row in reader:
        line = kept[reader.line_num - 1][0]
        if len(row) != len(header):
            raise DataError(src, f"expected {len(header)} comma-separated values (as the "
                            f"header), received {len(row)}", line, "row", ",".join(row))
        rows.append(row)
        lines.append(line)
    if not rows:
        raise DataError(src, f"no data rows (only the header; expected {what or 'data'} rows)",
                        head_line)
    return Table(source=src, header=header, header_line=head_line, rows=rows,
                 lines=np.asarray(lines, int))


def csv_text(text: str) -> str:
    """``text`` as one CSV cell (quoted if it holds a comma, a quote, a line break or
    surrounding blanks)."""
    if any(ch in text for ch in ',"\n\r') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def write_csv(path: str | Path, header: Sequence[str], cols: Sequence[Sequence[str]]) -> Path:
    """Write a comma-separated file: the header line, then one row per index of ``cols``
    (columns of cell text, of equal lengths); the folder is made if needed."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    rows = [",".join(header), *(",".join(row) for row in zip(*cols, strict=True))]
    p.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return p
