"""Interrupts: SIGINT and SIGTERM stop the computation, and never pass for a failed solve.

casadi's IPOPT, bonmin, ``sqpmethod`` and ``qrqp`` poll for Ctrl-C between iterations: they
run Python's SIGINT handler, catch the :class:`KeyboardInterrupt` it raises, print
``WARNING("KeyboardInterruptException")`` and return a failed solve (IPOPT's status
``NonIpopt_Exception_Thrown``, bonmin's ``USER_INTERRUPT``; ``sqpmethod`` raises a
``RuntimeError``); SCS (through cvxpy) catches SIGINT with a handler of its own and reports a
failed solve. A caller that falls back on a failed solve (a re-plan keeps the previous plan, a
multi-start drops the start) would then quietly compute something else and finish with exit
status 0 (issue 38). Every solver call of tmaplan therefore runs inside :func:`solver_call`,
which raises :class:`Interrupted` when a signal arrived during the call, whatever the solver
returned (SCS: :func:`tmaplan.planning.ping_relaxation.solve_interruptibly` reads its status);
the fallbacks catch :class:`~tmaplan.errors.PlanningError` (or ``Exception``), never a
:class:`KeyboardInterrupt`, so the interrupt reaches the caller.

The ``tmaplan`` command handles SIGTERM as it does Ctrl-C (:func:`signals_interrupt`): both
raise :class:`Interrupted`, stop the verb at once (inside a solve too), keep what is
complete (a campaign's finished runs) and exit with status 130 (SIGINT or SIGTERM alike).
Worker processes ignore SIGINT, from their start (:func:`ignoring_sigint`,
:func:`tmaplan.parallel.worker_signals`): the main process stops them.
"""

from __future__ import annotations

import contextlib
import functools
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any, TextIO, TypeVar

__all__ = ["Interrupted", "as_interrupt", "checkpoint", "compiled_entry", "defer",
           "ignoring_sigint", "interruptible", "signals_interrupt", "solver_call"]

_F = TypeVar("_F", bound=Callable[..., Any])

#: What :func:`signals_interrupt` turns into :class:`Interrupted`.
SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A :class:`KeyboardInterrupt` raised by a signal (SIGINT, or SIGTERM under
    :func:`signals_interrupt`).

    Parameters
    ----------
    signum : int
        The signal received.
    detail : str, optional
        What was kept, e.g. ``"7 of 20 runs kept in out/campaign-…"`` (a campaign).
    resumable : bool
        Whether the same call (command) resumes from what was kept.
    """

    def __init__(self, signum: int = signal.SIGINT, detail: str | None = None,
                 resumable: bool = False) -> None:
        self.signum = int(signum)
        self.detail = detail
        self.resumable = resumable
        super().__init__(f"interrupted by {self.signal_name}"
                         + (f"; {detail}" if detail else ""))

    def __reduce__(self) -> tuple[Any, ...]:  # (pickled as built, not from its message)
        return type(self), (self.signum, self.detail, self.resumable)

    @property
    def signal_name(self) -> str:
        """``"SIGINT"``, ``"SIGTERM"``."""
        return signal.Signals(self.signum).name

    @property
    def exit_status(self) -> int:
        """130 for SIGINT and SIGTERM alike (the shell's status of an interrupted command; a
        script tells an interrupted run from a failed one by this one number)."""
        return 130


class _Received:
    """Signals received by :func:`_handler` in this process (a count, never reset), and an
    interrupt that Python ignored (:func:`interruptible`)."""

    count = 0
    last: int = signal.SIGINT
    swallowed: int | None = None
    hook: Any = None  # the unraisable hook :func:`interruptible` replaced


def _handler(signum: int, frame: FrameType | None) -> None:
    _Received.count += 1
    _Received.last = signum
    raise Interrupted(signum)


def _unraisable(args: Any) -> None:
    """``sys.unraisablehook`` under :func:`interruptible`: a KeyboardInterrupt raised where
    Python cannot raise it (a ``__del__``, a weakref or garbage-collector callback: the signal
    handler ran there) is kept for :func:`checkpoint`, not printed."""
    if isinstance(args.exc_value, KeyboardInterrupt):
        _Received.swallowed = getattr(args.exc_value, "signum", signal.SIGINT)
        return
    _Received.hook(args)


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Inside the block, an interrupt that Python itself would ignore is not lost.

    Python runs a signal handler between two bytecodes, possibly inside a ``__del__`` or a
    weakref callback of the garbage collector, where the :class:`KeyboardInterrupt` it raises
    is printed ("Exception ignored in ...") and dropped: the computation would go on. Inside
    the block it is kept instead, and :func:`checkpoint` raises it (the filter loop at every
    step, every solver call, a campaign before it stores a run, the command line before it
    ends). Nested blocks share the outermost one's.
    """
    if sys.unraisablehook is _unraisable:
        yield
        return
    _Received.hook, _Received.swallowed = sys.unraisablehook, None
    sys.unraisablehook = _unraisable
    try:
        yield
    finally:
        sys.unraisablehook = _Received.hook


def checkpoint() -> None:
    """Raise the interrupt that Python ignored (:func:`interruptible`), if any; else nothing
    (a test of one attribute: cheap enough for every step of a loop).

    Raises
    ------
    Interrupted
        An interrupt was swallowed since the last checkpoint.
    """
    if _Received.swallowed is not None:
        signum, _Received.swallowed = _Received.swallowed, None
        raise Interrupted(signum)


def defer(exc: KeyboardInterrupt) -> None:
    """Keep an interrupt that Python code called back from C cannot raise through its caller
    (a ``casadi.Callback``: an exception there leaves casadi's buffer evaluation with a
    Python error set), for :func:`checkpoint` or the end of the enclosing :func:`solver_call`,
    which raises it once.

    Parameters
    ----------
    exc : KeyboardInterrupt
        The interrupt caught in the callback (an :class:`Interrupted` keeps its signal).
    """
    _Received.swallowed = getattr(exc, "signum", signal.SIGINT)


def as_interrupt(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt that ``exc`` is, or that it reports, or None.

    A signal handler that runs in Python code called back from C (numba's compiled code on
    its way out, numpy asking a casadi matrix for its array) raises the interrupt there, and
    the C code returns with it set: Python reports ``SystemError: ... returned a result with
    an exception set``, the interrupt chained as its cause (through further such
    ``SystemError`` errors). That error is the interrupt.

    Parameters
    ----------
    exc : BaseException
        An exception caught.

    Returns
    -------
    KeyboardInterrupt or None
        ``exc`` itself if it is one; the interrupt at the end of a chain of ``SystemError``
        causes; else None.
    """
    while isinstance(exc, SystemError) and exc.__cause__ is not None:
        exc = exc.__cause__
    return exc if isinstance(exc, KeyboardInterrupt) else None


def compiled_entry(fn: _F) -> _F:
    """``fn``, a compiled (numba) function called from Python, with an interrupt raised as
    itself.

    A compiled function that returns an array (or raises) calls back into Python on its way
    out (numba's ``_numba_unpickle`` fetches numpy's array type); Python runs a pending signal
    handler there, and numba reports the :class:`KeyboardInterrupt` the handler raises as
    ``SystemError: CPUDispatcher(...) returned a result with an exception set``, the interrupt
    chained as its cause. A Ctrl-C during the particle filter's compiled kernels came out as
    that ``SystemError`` (every one of 3508 SIGINTs sent during calls of one kernel, measured),
    and a campaign stopped with its traceback (:func:`as_interrupt`). The wrapper raises the
    interrupt itself (an :class:`Interrupted` keeps its signal); any other error passes
    unchanged. Every Python call of a compiled function of tmaplan goes through one (the
    function itself, or the Python function that calls its builds); compiled functions
    calling each other do not (no Python runs between them).

    Parameters
    ----------
    fn : callable
        A numba dispatcher (or any callable).
    """

    @functools.wraps(fn)
    def call(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except SystemError as exc:
            interrupt = as_interrupt(exc)
            if interrupt is None:
                raise
            raise interrupt from None

    return call  # type: ignore[return-value]


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def solver_call() -> Iterator[None]:
    """Run one solver call (casadi, cvxpy) so that a signal during it raises.

    A SIGINT (or under :func:`signals_interrupt` a SIGTERM) that arrives during the block
    raises :class:`Interrupted` when the block ends, whatever the solver returned or raised
    (the solver's error is chained); without a signal the block runs unchanged. When Python's
    default SIGINT handler is in place (a script, a notebook, a test), the block installs its
    own for its duration (main thread only: signals reach no other thread).

    Raises
    ------
    Interrupted
        A signal arrived during the block.
    """
    before = _Received.count
    borrowed = (_in_main_thread()
                and signal.getsignal(signal.SIGINT) is signal.default_int_handler)
    if borrowed:
        signal.signal(signal.SIGINT, _handler)
    try:
        yield
    except Exception as exc:
        if _Received.count != before:  # the solver turned the interrupt into an error
            _Received.swallowed = None  # (the same interrupt, if a callback deferred it)
            raise Interrupted(_Received.last) from exc
        raise
    finally:
        if borrowed:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    if _Received.count != before:  # the solver turned the interrupt into a failed solve
        _Received.swallowed = None  # (the same interrupt, if a callback deferred it)
        raise Interrupted(_Received.last)
    checkpoint()


class _WithoutInterruptWarning:
    """A text stream that forwards everything but casadi's
    ``WARNING("KeyboardInterruptException")`` lines (casadi writes them in pieces: a line
    starting with ``CasADi - `` is held until its newline)."""

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.held = ""

    def write(self, text: str) -> int:
        if not self.held and not text.startswith("CasADi - "):
            return self.stream.write(text)
        self.held += text
        if "\n" in self.held:
            line, _, rest = self.held.partition("\n")
            self.held = ""
            if "KeyboardInterruptException" not in line:
                self.stream.write(line + "\n")
            if rest:
                self.write(rest)
        return len(text)

    def flush(self) -> None:
        if self.held and not self.held.startswith("CasADi - "):
            self.stream.write(self.held)
            self.held = ""
        self.stream.flush()

    def close_line(self) -> None:
        """Write what is held (a casadi line without its newline), unless it is the
        interrupt's warning."""
        held, self.held = self.held, ""
        if held and "KeyboardInterruptException" not in held:
            self.stream.write(held)
        self.stream.flush()

    def __getattr__(self, name: str) -> Any:  # isatty, fileno, encoding, ...
        return getattr(self.stream, name)


@contextlib.contextmanager
def signals_interrupt() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Interrupted` inside the block (``tmaplan``'s verbs).

    In the main thread, the handlers of :data:`SIGNALS` are replaced for the block's
    duration (and restored after); casadi's warning about the interrupt it caught is left
    out of stderr (:class:`Interrupted` reports it); an interrupt that Python would ignore is
    kept (:func:`interruptible`). Elsewhere the block runs unchanged.
    """
    if not _in_main_thread():
        yield
        return
    old = {s: signal.signal(s, _handler) for s in SIGNALS}
    stderr = sys.stderr
    sys.stderr = _WithoutInterruptWarning(stderr)
    try:
        with interruptible():
            yield
    finally:
        filtered = sys.stderr
        sys.stderr = stderr
        if isinstance(filtered, _WithoutInterruptWarning):
            filtered.close_line()
        for s, h in old.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)


@contextlib.contextmanager
def ignoring_sigint() -> Iterator[None]:
    """SIGINT ignored inside the block, and held back until it ends (main thread; elsewhere
    unchanged): processes started in the block are born ignoring it (a Ctrl-C on the
    terminal reaches the whole process group; the worker processes leave it to the main
    process, which stops them), while a SIGINT for this process during the block is
    delivered when it ends."""
    if not _in_main_thread():
        yield
        return
    # blocked first: a SIGINT from now on stays pending (Linux keeps a blocked signal even
    # while its action is to ignore it), and is delivered when the handler is back
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old if old is not None else signal.SIG_DFL)
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)
