"""Checks of the output paths of every ``tmaplan`` verb (``--out DIR``, ``--json PATH``), before
any work starts.

Two stages, one place: :func:`check_out_dir` / :func:`check_json_path` are the argparse types
of the flags (what the path itself says: ``--out`` not an existing file, ``--json`` not an
existing directory, neither under a regular file, whose "directory" could never be
created); :func:`check_outputs` runs with the scenario (``preflight``) and checks what
needs the file system or the verb's inputs: the directory that would hold the output exists
or can be created there (a file can be created in its nearest existing ancestor), ``--json``
does not name an input of the verb (the problem file, ``--observer-plan``) nor an existing
file that is not a JSON document (a scenario, a figure: overwriting it would lose what the
user wrote; a previous JSON output may be overwritten).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path
from typing import Any, NoReturn

from tmaplan.errors import ArgumentError

__all__ = ["check_json_path", "check_out_dir", "check_outputs", "fail"]

#: Largest existing ``--json`` target parsed in full to tell a JSON document (a larger one
#: must begin with ``{"`` or ``[`` and end with ``}`` or ``]``).
JSON_PARSE_LIMIT = 64 * 2**20


#: Verbs with ``--no-figure`` that write to ``--out`` all the same (their report and runs;
#: a plan's leg table and track).
ALWAYS_WRITE_OUT = frozenset({"rank-costs", "plan", "advise"})


def _regular_file_above(path: Path) -> Path | None:
    """The ancestor of ``path`` that exists and is not a directory (a regular file), if any:
    nothing can be created under it."""
    for parent in path.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def fail(constraint: str, received: Any) -> NoReturn:
    """The argparse-type error of every ``tmaplan`` flag: ``must be …, received …``."""
    raise argparse.ArgumentTypeError(f"must be {constraint}, received {received}")


def check_out_dir(text: str) -> str:
    """Type of ``--out``: a directory (created when needed), not an existing file nor a path
    under one."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        fail("a directory", f"{text!r} (an existing file)")
    above = _regular_file_above(path)
    if above is not None:
        fail("a directory that exists or can be created", f"{text!r} (under the existing "
              f"file {str(above)!r})")
    return text


def check_json_path(text: str) -> str:
    """Type of ``--json``: ``-`` (stdout) or a file path, not an existing directory nor a path
    under an existing file."""
    if text == "-":
        return text
    path = Path(text)
    if path.is_dir():
        fail("a file path or '-' (stdout)", f"{text!r} (an existing directory)")
    above = _regular_file_above(path)
    if above is not None:
        fail("a file path in a directory that exists or can be created",
              f"{text!r} (under the existing file {str(above)!r})")
    return text


def _unwritable(directory: Path) -> str | None:
    """Why no file can be created in ``directory`` (or in the directory that would be created
    there: its nearest existing ancestor), else None. Probed by creating and removing a
    temporary file (permissions alone do not tell: root may write anywhere but not in
    ``/proc``)."""
    probe = directory
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    try:
        fd, name = tempfile.mkstemp(prefix=".tmaplan-probe-", dir=probe)
    except OSError as exc:
        return f"cannot create files in {str(probe)!r}: {exc.strerror or exc}"
    os.close(fd)
    os.unlink(name)
    return None


def _is_json_document(path: Path) -> bool:
    """Whether the existing file ``path`` holds a JSON document (an empty file holds nothing
    to lose and counts as one)."""
    size = path.stat().st_size
    if size == 0:
        return True
    try:
        with path.open("rb") as f:
            if size <= JSON_PARSE_LIMIT:
                json.loads(f.read().decode("utf-8"))
                return True
            head = f.read(4096).decode("utf-8", errors="replace").lstrip()
            f.seek(-4096, os.SEEK_END)
            tail = f.read().decode("utf-8", errors="replace").rstrip()
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return (head.startswith('{"') and tail.endswith("}")) or (
        head.startswith("[") and tail.endswith("]"))


def check_outputs(args: argparse.Namespace, source: str | None = None) -> None:
    """The output paths, with the file system and the verb's inputs (see the module
    docstring); ``source``: the verb's problem, if any, for the message. Raises
    :class:`~tmaplan.errors.ArgumentError` naming ``--json`` or ``--out``.

    ``--out`` is checked only when the verb writes there: its figures unless
    ``--no-figure``; a report and stored runs always (the verbs without ``--no-figure``, and
    ``rank-costs``, :data:`ALWAYS_WRITE_OUT`).
    """
    def error(flag: str, expected: str, received: Any) -> ArgumentError:
        return ArgumentError(flag, expected, received, source=source)

    out = getattr(args, "json", None)
    if out is not None and out != "-":
        target = Path(out).resolve()
        for what, value in (("problem file", getattr(args, "problem", None)),
                            ("--observer-plan file", getattr(args, "observer_plan", None))):
            if value is not None and Path(value).is_file() and Path(value).resolve() == target:
                raise error("--json", f"a path other than the {what} it would overwrite", out)
        path = Path(out)
        if path.is_file() and not _is_json_document(path):
            raise error("--json", "a new file or a previous JSON output to overwrite (this "
                        "file exists and is not JSON: it is never overwritten)", out)
        # an existing target that can be opened for writing needs no probe: a previous
        # output, or a pipe or device (`--json >(jq .)` is /dev/fd/63, `--json /dev/null`)
        why = None if path.exists() and os.access(path, os.W_OK) else _unwritable(path.parent)
        if why is not None:
            raise error("--json", f"a file path in a directory that exists or can be created "
                        f"({why})", out)
    directory = getattr(args, "out", None)
    writes = getattr(args, "verb", None) in ALWAYS_WRITE_OUT or not getattr(args, "no_figure",
                                                                           False)
    if directory is not None and writes:
        why = _unwritable(Path(directory))
        if why is not None:
            raise error("--out", f"a directory that exists or can be created ({why})",
                        directory)
