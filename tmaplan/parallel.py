"""Worker processes shared by the steps of one job.

A job such as ``tmaplan demo`` or ``tmaplan compare`` first solves the offline plan's
multi-start on worker processes, then runs the Monte Carlo campaign on worker processes.
Spawning a worker costs about 2 s (Python, numpy, scipy, casadi and tmaplan imported), so
:func:`process_pool` starts the workers once, at the beginning of the job, and sets them
importing the modules of their tasks at once (they do so while the main process parses, plans
and resolves), and both steps use the same pool. This module is generic (it sits at the bottom
layer): the caller names the modules to import (``warm_up``), usually its own.

Large inputs shared by every task of a step (a campaign's resolved policies: offline plans,
schedules, Hessian models) are shipped to each worker once: :class:`SharedPayload` writes
them to a temporary file, and :func:`call_with_payload` unpickles the file once per worker
process and keeps it for the step's later tasks. Processes only: two casadi solvers on Python
threads of one process corrupt each other's memory (docs/findings.md).

Interrupts: the workers ignore SIGINT (a Ctrl-C on the terminal reaches every process of the
group; they are even started ignoring it), and the main process, interrupted, stops them at
once (:meth:`WorkerPool.stop`: their running tasks are lost, never returned as results).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import pickle
import signal
import tempfile
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor
from multiprocessing import get_context
from typing import Any

from tmaplan.errors import ArgumentError
from tmaplan.interrupts import ignoring_sigint

__all__ = ["SharedPayload", "WorkerPool", "call_with_payload", "close_pool", "closing_pool",
           "process_pool", "worker_signals"]


def worker_signals() -> None:
    """A worker process's initializer: SIGINT ignored (the main process handles it and stops
    its workers), SIGTERM back to its default action (a worker forked from a process with
    the command line's handlers would otherwise raise, and print, instead of ending)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


class WorkerPool(ProcessPoolExecutor):
    """A :class:`~concurrent.futures.ProcessPoolExecutor` that an interrupt stops at once.

    Used as a context manager, it waits for its tasks on a normal exit or an error, as a
    ``ProcessPoolExecutor`` does, and stops its workers (:meth:`stop`) on a
    :class:`KeyboardInterrupt`.
    """

    def stop(self) -> None:
        """Stop now: pending tasks cancelled, the worker processes terminated (their running
        tasks are lost: their futures end in ``BrokenProcessPool``, never in a result)."""
        procs = list((getattr(self, "_processes", None) or {}).values())
        manager = getattr(self, "_executor_manager_thread", None)
        self.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            if p.is_alive():
                p.terminate()
        for p in procs:
            p.join()
        if manager is not None:  # it notices the workers gone, fails their futures, ends
            manager.join()

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> bool | None:
        if exc_type is not None and issubclass(exc_type, KeyboardInterrupt):
            self.stop()
            return None
        return super().__exit__(exc_type, exc, tb)


@contextlib.contextmanager
def closing_pool(pool: Executor | None) -> Iterator[Executor | None]:
    """Close ``pool`` when the block ends (:func:`close_pool`): at once if a
    :class:`KeyboardInterrupt` ends it."""
    interrupted = False
    try:
        yield pool
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        close_pool(pool, interrupted=interrupted)


def close_pool(pool: Executor | None, *, interrupted: bool) -> None:
    """Shut ``pool`` down: wait for its running tasks (pending ones cancelled), or after an
    interrupt stop it at once (:meth:`WorkerPool.stop`). None: nothing to do."""
    if pool is None:
        return
    if interrupted and isinstance(pool, WorkerPool):
        pool.stop()
    else:
        pool.shutdown(wait=True, cancel_futures=True)


def _warm_up(modules: tuple[str, ...]) -> None:
    """Import ``modules``, what a worker's tasks need (run once per worker, at the pool's
    start)."""
    for name in modules:
        importlib.import_module(name)


def process_pool(workers: int, *, warm_up: Sequence[str] = ()) -> WorkerPool:
    """A pool of ``workers`` spawned processes, already importing ``warm_up`` when returned.

    The workers ignore SIGINT from their start; an interrupt of the main process stops them
    (:meth:`WorkerPool.stop`, :func:`close_pool`).

    Parameters
    ----------
    workers : int
        Worker processes (>= 1).
    warm_up : sequence of str
        Modules each worker imports at once (those of its tasks, e.g. the caller's
        ``__name__``: what they import comes with them).

    Returns
    -------
    WorkerPool
        The caller shuts it down (``with process_pool(n) as pool: ...``, or
        :func:`close_pool`).
    """
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ArgumentError("workers", "an integer >= 1", workers)
    with ignoring_sigint():  # the workers are born ignoring it (a Ctrl-C while they import)
        pool = WorkerPool(max_workers=workers, mp_context=get_context("spawn"),
                          initializer=worker_signals)
        for _ in range(workers):  # one task per worker: the pool spawns them all now
            pool.submit(_warm_up, tuple(warm_up))
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

