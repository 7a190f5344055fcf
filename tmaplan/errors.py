"""Exception hierarchy of tmaplan.

Every error a user can trigger subclasses both :class:`TmaplanError` and a built-in
exception, so ``except ValueError`` keeps working for callers that do not know tmaplan.
Messages name the offending field, the expected value and the received value.
"""

from __future__ import annotations

import functools
import math
import pickle
import warnings
from typing import Any

import numpy as np

__all__ = [
    "ArgumentError",
    "DataError",
    "EstimationError",
    "InfeasibleError",
    "ObservabilityError",
    "PlanningError",
    "ScenarioError",
    "ScenarioWarning",
    "SolverError",
    "TmaplanError",
    "UnitError",
    "as_real",
    "finite_real",
    "is_integer",
    "is_whole_count",
    "warn_field",
    "whole_steps_text",
]


class TmaplanError(Exception):
    """Base class of every error raised on purpose by tmaplan."""


class ArgumentError(TmaplanError, ValueError):
    """A function argument, configuration value or command-line value is invalid.

    Parameters
    ----------
    field
        Name of the offending argument or flag, e.g. ``"samples"`` or ``"--runs"``.
    expected
        What a valid value looks like, e.g. ``">= 2"``.
    received
        The value that was given.
    source
        The scenario (file name or problem name) the value was used with, if any.
    """

    def __init__(
        self,
        field: str,
        expected: str,
        received: Any = None,
        *,
        source: str | None = None,
    ) -> None:
        self.field = field
        self.expected = expected
        self.received = received
        self.source = source
        where = f"{source}: " if source else ""
        super().__init__(f"{where}field '{field}': expected {expected}, received {received!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        # rebuilt from the fields (the default, the message as the only argument, failed to
        # unpickle: an error raised in a worker process broke the pool), with its attributes
        # (notes); a received value that does not pickle crosses as its repr
        received = self.received
        try:
            pickle.dumps(received)
        except Exception:  # any pickling failure: the repr still informs
            received = repr(received)
        return (functools.partial(type(self), source=self.source),
                (self.field, self.expected, received), {**self.__dict__, "received": received})


class ScenarioError(ArgumentError):
    """A scenario (file, dict or dataclass) is invalid: ``field`` is the dotted path of the
    offending scenario field, e.g. ``"sensors[0].sigma"``; ``source`` the file or problem name.

    The message names the field, the expected and the received value (see
    :class:`ArgumentError`, of which this is the scenario case).
    """


class ScenarioWarning(UserWarning):
    """Suspicious but legal input (a course of 400°, a contact outside its own prior, a
    turn rate few ships reach): the computation goes on. The message is one line naming the
    field, what is suspicious and the received value, as :class:`ScenarioError`'s; the
    command line prints it as ``tmaplan VERB: warning: ScenarioWarning: ...``
    (:func:`warn_field`)."""


def warn_field(field: str, text: str, *, source: str | None = None, stacklevel: int = 2
               ) -> None:
    """Issue a :class:`ScenarioWarning` ``"<source>: field '<field>': <text>"``: the one form
    of the warnings on a field's value (a refusal would be a :class:`ScenarioError`)."""
    where = f"{source}: " if source else ""
    warnings.warn(f"{where}field '{field}': {text}", ScenarioWarning, stacklevel=stacklevel + 1)


class UnitError(ScenarioError):
    """A quantity has an unknown unit or a unit of the wrong dimension."""


class DataError(ArgumentError):
    """A recorded data file (bearings, own-ship navigation, a plan's legs) is invalid.

    The message is one line, ``FILE:LINE: what is wrong`` (``FILE: ...`` when no line applies),
    naming the column or field, what was expected and the value found, e.g.
    ``bearings.csv:5: column 'bearing_deg': expected a number, received 'abc'``.

    Parameters
    ----------
    source
        The file (its path as given).
    message
        What is wrong (one line).
    line
        The file's line number (1-based), if the fault is on one line.
    field
        The column or field at fault (``"file"`` when the fault is the whole file's).
    received
        The value found, if any.
    """

    def __init__(self, source: str, message: str, line: int | None = None,
                 field: str = "file", received: Any = None) -> None:
        self.field = field
        self.expected = message
        self.received = received
        self.source = source
        self.line = line
        where = f"{source}:{line}" if line is not None else f"{source}"
        Exception.__init__(self, f"{where}: {message}".replace("\n", " "))

    def __reduce__(self) -> tuple[Any, ...]:
        # as ArgumentError.__reduce__ (the message is not the constructor's only argument)
        return (type(self), (self.source, self.expected, self.line, self.field,
                             None if self.received is None else str(self.received)),
                dict(self.__dict__))


class ObservabilityError(TmaplanError, ValueError):
    """The requested quantity is not observable (singular or ill-conditioned information)."""


class EstimationError(TmaplanError, RuntimeError):
    """An estimator failed (degenerate weights that could not be recovered, no convergence)."""


class PlanningError(TmaplanError, RuntimeError):
    """A planning request is infeasible or its solver did not converge."""


class InfeasibleError(PlanningError):
    """A planning request that no plan satisfies: constraints that cannot hold (the target
    estimate already inside the keep-out range), found before solving or reported infeasible
    by the solver."""


class SolverError(PlanningError):
    """A numerical solver returned a non-success status.

    Parameters
    ----------
    solver
        Solver name (``"ipopt"``, ``"bonmin"``, ``"clarabel"``, ...).
    status
        The solver's own status string.
    message
        Human-readable explanation.
    """

    def __init__(self, solver: str, status: str, message: str = "") -> None:
        self.solver = solver
        self.status = status
        self.detail = message
        extra = f": {message}" if message else ""
        super().__init__(f"solver {solver} did not converge (status {status!r}){extra}")

    def __reduce__(self) -> tuple[Any, ...]:
        # as ArgumentError.__reduce__: it crosses process boundaries
        return (type(self), (self.solver, self.status, self.detail), dict(self.__dict__))


def is_integer(value: Any, minimum: int) -> bool:
    """Whether ``value`` is an integer (Python or numpy, not a bool) >= ``minimum``: the one
    test behind the integer checks of user input (the caller raises its own error, naming
    the field)."""
    return bool(not isinstance(value, bool) and isinstance(value, (int, np.integer))
                and value >= minimum)


def is_whole_count(ratio: float) -> bool:
    """Whether ``ratio`` (an interval over its step, e.g. a horizon over the control interval)
    is a whole number >= 1 to round-off (1e-9 relative): the one test behind the scenario's,
    the planner's and the command line's "whole number of steps / intervals" rules."""
    return abs(ratio - round(ratio)) <= 1e-9 * max(1.0, ratio) and round(ratio) >= 1


def whole_steps_text(dt: float) -> str:
    """The expected value of a duration that must be whole steps of ``dt`` [s], worded once
    for the scenario's (``time.horizon``, ``planning.*_interval``), the re-planner's and the
    command line's errors (with :func:`is_whole_count`)."""
    return f"a whole number (>= 1) of steps of dt = {dt:g} s"


def as_real(value: Any) -> float:
    """``value`` as a float, NaN if it is not a real number (a bool, a string, None): the one
    conversion behind the real-valued checks of user input, so that the callers' finiteness
    tests refuse what ``float()`` would have accepted (``float("0.1")``, ``float(True)``) or
    raised on."""
    if isinstance(value, bool | np.bool_ | str | bytes):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def finite_real(field: str, value: Any, expected: str, *, lower: float = -math.inf,
                strict: bool = False, source: str | None = None) -> float:
    """``value`` as a finite float ``>= lower`` (``> lower`` if ``strict``), else
    :class:`ArgumentError` naming ``field``, ``expected`` and the received value: the one
    check behind the finite real arguments (through :func:`as_real`)."""
    v = as_real(value)
    if not (math.isfinite(v) and (v > lower if strict else v >= lower)):
        raise ArgumentError(field, expected, value, source=source)
    return v
