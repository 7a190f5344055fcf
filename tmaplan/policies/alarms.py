"""Closed-loop reaction to the consistency monitor's alarms: pings on demand.

After an unmodelled target manoeuvre the bearings alone cannot reveal the new range rate while
the own ship holds its leg (bearings-only observability needs an own-ship manoeuvre,
lecadre1997; a range measurement removes the need, brehard2005, eq. 43), and an offline ping
schedule pings only when it says. :class:`AlarmResponse` lets the closed loop answer a monitor
alarm (:mod:`tmaplan.estimators.consistency`) with ``pings`` pings of its own: the first at the
next step, the others ``spacing`` apart, each one honouring the scenario's minimum ping spacing
and forbidden windows. They come from a declared allowance ``extra_pings`` on top of the
scenario's ``planning.ping_budget``: once alarm pings were spent, the policy's own pings are
refused when the total would exceed budget + allowance, so the total never exceeds it. A run
without alarm behaves exactly as without the response.

:class:`AlarmResponder` wraps the policy's controller for one run; the closed loop
(:func:`tmaplan.evaluation.closed_loop.run_closed_loop`) tells it the monitor's alarm count
through :attr:`tmaplan.policies.BeliefView.alarms`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from tmaplan.errors import ArgumentError
from tmaplan.policies._base import Action, BeliefView, Controller

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["AlarmResponder", "AlarmResponse"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class AlarmResponse:
    """How the closed loop answers a monitor alarm.

    Attributes
    ----------
    pings : int
        Pings requested per alarm (the first at the next step), >= 1.
    extra_pings : int
        Pings allowed per run on top of the scenario's ping budget for alarm responses, >= 0
        (0: alarm pings only while the budget lasts, and then they take the place of the
        policy's last ones).
    spacing : float, optional
        Time between the pings of one response [s] (default: the scenario's
        ``planning.ping_min_spacing``, at least one step).
    """

    pings: int = 2
    extra_pings: int = 2
    spacing: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.pings, int) or isinstance(self.pings, bool) or self.pings < 1:
            raise ArgumentError("alarm_response.pings", "an integer >= 1", self.pings)
        if (not isinstance(self.extra_pings, int) or isinstance(self.extra_pings, bool)
                or self.extra_pings < 0):
            raise ArgumentError("alarm_response.extra_pings", "an integer >= 0",
                                self.extra_pings)
        if self.spacing is not None and not self.spacing > 0:
            raise ArgumentError("alarm_response.spacing", "a time > 0 [s]", self.spacing)

    def wrap(self, controller: Controller, scenario: Scenario) -> AlarmResponder:
        """The per-run controller: ``controller`` plus the alarm pings."""
        return AlarmResponder(controller, self, scenario)


class AlarmResponder:
    """A controller that adds alarm pings to another one (module docstring).

    Attributes
    ----------
    alarm_pings : list of int
        Steps of the pings it added.
    """

    def __init__(self, inner: Controller, response: AlarmResponse, scenario: Scenario) -> None:
        pl = scenario.planning
        self.inner = inner
        self.dt = float(scenario.time.dt)
        self.min_spacing = float(pl.ping_min_spacing) if pl is not None else 0.0
        self.forbidden = tuple(pl.ping_forbidden) if pl is not None else ()
        self.cap = (int(pl.ping_budget) if pl is not None else 0) + response.extra_pings
        self.spacing = max(response.spacing if response.spacing is not None
                           else self.min_spacing, self.dt)
        self.per_alarm = response.pings
        self.seen = 0
        self.pending: list[float] = []  # earliest times of requested pings [s]
        self.last = float("-inf")
        self.alarm_pings: list[int] = []

    @property
    def log(self) -> list[dict[str, object]]:
        """The inner controller's re-planning log (empty if it keeps none)."""
        return list(getattr(self.inner, "log", []))

    def act(self, belief: BeliefView, t: float) -> Action:
        """The inner action, with a ping added when an alarm asks for one and the allowance
        lasts, and the policy's ping refused once alarm pings used up budget + allowance."""
        act = self.inner.act(belief, t)
        t_next = t + self.dt
        if belief.alarms > self.seen:
            self.seen = belief.alarms
            self.pending = [t_next + i * self.spacing for i in range(self.per_alarm)]
        room = belief.pings_used < self.cap
        if act.ping:
            if self.alarm_pings and not room:
                return dataclasses.replace(act, ping=False)
            self.last = t_next
            self._drop_due(t_next)
            return act
        if (room and self.pending and self.pending[0] <= t_next + 1e-9
                and t_next - self.last >= self.min_spacing - 1e-9
                and not any(a <= t_next <= b for a, b in self.forbidden)):
            self.last = t_next
            self._drop_due(t_next)
            self.alarm_pings.append(belief.step + 1)
            return dataclasses.replace(act, ping=True)
        return act

    def _drop_due(self, t_next: float) -> None:
        """A ping at ``t_next`` serves the first pending request due by then."""
        if self.pending and self.pending[0] <= t_next + 1e-9:
            self.pending.pop(0)
