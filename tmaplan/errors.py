"""Exception hierarchy of tmaplan.

Every error a user can trigger subclasses both :class:`TmaplanError` and a built-in
exception, so ``except ValueError`` keeps working for callers that do not know tmaplan.
Messages name the offending field, the expected value and the received value.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "EstimationError",
    "ObservabilityError",
    "PlanningError",
    "ScenarioError",
    "SolverError",
    "TmaplanError",
    "UnitError",
]


class TmaplanError(Exception):
    """Base class of every error raised on purpose by tmaplan."""


class ScenarioError(TmaplanError, ValueError):
    """A scenario (file, dict or dataclass) is invalid.

    Parameters
    ----------
    field
        Dotted path of the offending field, e.g. ``"sensors[0].sigma"``.
    expected
        What a valid value looks like, e.g. ``"> 0"``.
    received
        The value that was given.
    source
        Where the scenario came from (file name or problem name), if known.
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


class UnitError(ScenarioError):
    """A quantity has an unknown unit or a unit of the wrong dimension."""


class ObservabilityError(TmaplanError, ValueError):
    """The requested quantity is not observable (singular or ill-conditioned information)."""


class EstimationError(TmaplanError, RuntimeError):
    """An estimator failed (degenerate weights that could not be recovered, no convergence)."""


class PlanningError(TmaplanError, RuntimeError):
    """A planning request is infeasible or its solver did not converge."""


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
        extra = f": {message}" if message else ""
        super().__init__(f"solver {solver} did not converge (status {status!r}){extra}")
