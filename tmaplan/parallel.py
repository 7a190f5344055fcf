"""Worker processes shared by the steps of one job.

A job such as ``tmaplan demo`` or ``tmaplan compare`` first solves the offline plan's
multi-start on worker processes, then runs the Monte Carlo campaign on worker processes.
Spawning a worker costs about 2 s (Python, numpy, scipy, casadi and tmaplan imported), so
:func:`process_pool` starts the workers once, at the beginning of the job, and sets them
importing at once (they do so while the main process parses, plans and resolves), and both
steps use the same pool.

Large inputs shared by every task of a step (a campaign's resolved policies: offline plans,
schedules, Hessian models) are shipped to each worker once: :class:`SharedPayload` writes
them to a temporary file, and :func:`call_with_payload` unpickles the file once per worker
process and keeps it for the step's later tasks. Processes only: two casadi solvers on Python
threads of one process corrupt each other's memory (docs/findings.md).
"""

from __future__ import annotations

import os
import pickle
import tempfile
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any

from tmaplan.errors import ArgumentError

__all__ = ["SharedPayload", "call_with_payload", "process_pool"]


def _warm_up() -> None:
    """Import what a worker's tasks need (run once per worker, at the pool's start)."""
    import casadi  # noqa: F401

    import tmaplan.evaluation.closed_loop
    import tmaplan.planning.heading
    import tmaplan.policies  # noqa: F401


def process_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` spawned processes, already importing tmaplan when returned.

    Parameters
    ----------
    workers : int
        Worker processes (>= 1).

    Returns
    -------
    concurrent.futures.ProcessPoolExecutor
        The caller shuts it down (``with process_pool(n) as pool: ...``).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ArgumentError("workers", "an integer >= 1", workers)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"))
    for _ in range(workers):  # one task per worker: the pool spawns them all now
        pool.submit(_warm_up)
    return pool


class SharedPayload:
    """A picklable object written once to a temporary file for the tasks of one step.

    Use as a context manager; the file is removed on exit (and at once if the payload cannot
    be written, e.g. is not picklable: the error is raised). Pass :attr:`path` to
    :func:`call_with_payload`.

    Parameters
    ----------
    payload : object
        Anything picklable.
    """

    def __init__(self, payload: Any) -> None:
        fd, self.path = tempfile.mkstemp(prefix="tmaplan-payload-", suffix=".pkl")
        try:
            with os.fdopen(fd, "wb") as fh:
                pickle.dump(payload, fh, protocol=pickle.HIGHEST_PROTOCOL)
        except BaseException:  # not picklable, disk full: no file is left behind
            os.remove(self.path)
            raise

    def __enter__(self) -> SharedPayload:
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            os.remove(self.path)
        except FileNotFoundError:  # pragma: no cover - removed by someone else
            pass


_LOADED: dict[str, Any] = {}


def call_with_payload(fn: Callable[..., Any], path: str, *args: Any) -> Any:
    """``fn(payload, *args)`` with the payload of :class:`SharedPayload` ``path``, unpickled
    once per process (a worker keeps the last one only)."""
    if path not in _LOADED:
        with open(path, "rb") as fh:
            payload = pickle.load(fh)
        _LOADED.clear()
        _LOADED[path] = payload
    return fn(_LOADED[path], *args)

