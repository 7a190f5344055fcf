"""The result of a heading plan (:class:`HeadingPlan`), kept apart from the planner
(:mod:`tmaplan.planning.heading`, where it is re-exported) so that modules that only read
plans need not import the OCP."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tmaplan.display import short_repr
from tmaplan.models.observer import ObserverTrack

__all__ = ["HeadingPlan"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class HeadingPlan:
    """An optimal heading plan over the planning horizon.

    Attributes
    ----------
    times : ndarray, shape (n + 1,)
        Control nodes [s] (absolute).
    heading : ndarray, shape (n + 1,)
        Heading at the nodes [rad] (unwrapped, clockwise from North).
    turn_rate : ndarray, shape (n,)
        Mean turn rate per control interval [rad/s] (the control for "direct").
    speed : ndarray, shape (n,)
        Speed per control interval [m/s].
    switch_times : ndarray, shape (m,)
        Instants where the turn rate changes [s] (exact for "bang-bang", control nodes where
        it changes by more than 1 % of ω_max for "direct").
    observer : ObserverTrack
        The planned track on the scenario's dt grid over the horizon.
    objective : float
        Objective value (minimised; ``logdet`` reports −log det FIM).
    range_bound : ndarray, shape (K + 1,)
        Closed-form PCRB range bound along the plan [m].
    transcription : str
    status : str
        IPOPT return status of the best start.
    success : bool
    iterations : int
        IPOPT iterations summed over the starts.
    seconds : float
        Wall time of the solve [s].
    message : str
    solver : str
        What produced the plan: ``"ipopt"``, or ``"rti-qrqp"`` / ``"rti-osqp"`` for a
        real-time iteration step (:mod:`tmaplan.planning.rti`).
    """

    __repr__ = short_repr

    times: np.ndarray
    heading: np.ndarray
    turn_rate: np.ndarray
    speed: np.ndarray
    switch_times: np.ndarray
    observer: ObserverTrack
    objective: float
    range_bound: np.ndarray
    transcription: str
    status: str
    success: bool
    iterations: int
    seconds: float
    message: str = ""
    solver: str = "ipopt"
    warm: dict[str, Any] | None = dataclasses.field(default=None, repr=False, compare=False)
