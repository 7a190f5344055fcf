"""Closed-loop reaction to the consistency monitor's alarms: pings on demand.

After an unmodelled target manoeuvre the bearings alone cannot reveal the new range rate while
the own ship holds its leg (bearings-only observability needs an own-ship manoeuvre,
lecadre1997; a range measurement removes the need, brehard2005, eq. 43), and an offline ping
schedule pings only when it says. :class:`AlarmResponse` lets the closed loop answer a monitor
alarm (:mod:`tmaplan.estimators.consistency`) with ``pings`` pings of its own: the first at the
next step, the others ``spacing`` apart, each one honouring the scenario's minimum ping spacing
and forbidden windows. They come from a declared allowance ``extra_pings`` on top of the
scenario's ``planning.ping_budget``: once alarm pings were spent, the policy's own pings are
refused when the total would exceed budget + allowance, so the total never exceeds it. A ping
the policy asks for within the minimum spacing after an alarm ping is **deferred**, not
dropped: the operator holds the policy's ping (a scheduled one was budgeted for the
information it brings) until the spacing and the forbidden windows allow it, and then flies
it; deferred pings queue in order, each one the minimum spacing after the previous ping, count
in the budget when flown, and are refused like the policy's own once the cap is reached (one
still held at the end of the run is not flown). A run without alarm behaves exactly as
without the response.

It may also (``turn`` > 0) answer with an **own-ship manoeuvre**: a turn by ``turn`` at the
maximum turn rate, to the side that changes the own velocity across the believed line of sight
most (the bearing rate then changes with the range, which makes the post-manoeuvre track
observable, lecadre1997). The policy does not turn back afterwards: a policy that replays turn
rates (straight, planned, receding) resumes them, its headings offset by the turn (its rates
during the turn are not flown); a policy that steers to courses
(:class:`tmaplan.policies.CourseSteering`: single turn, zig-zag, leg–turn–leg, lead–lag) has
every course it holds or will hold offset by the turn, step by step as it is made. A course
such a tactic decides later from the belief (the doctrine's beam, the lead and lag offsets
from the line of sight) is decided from the heading then flown.

:class:`AlarmResponder` wraps the policy's controller for one run; the closed loop
(:func:`tmaplan.evaluation.closed_loop.run_closed_loop`) tells it the monitor's alarm count
through :attr:`tmaplan.policies.BeliefView.alarms`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from tmaplan.errors import ArgumentError, ScenarioError, as_real, finite_real
from tmaplan.models.sensors import default_ping_budget
from tmaplan.policies.base import Action, BeliefView, Controller, CourseSteering

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["AlarmResponder", "AlarmResponse"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class AlarmResponse:
    """How the closed loop answers a monitor alarm.

    Attributes
    ----------
    pings : int
        Pings requested per alarm (the first at the next step), >= 0 (0 only with a
        ``turn``).
    extra_pings : int
        Pings allowed per run on top of the scenario's ping budget for alarm responses, >= 0
        (0: alarm pings only while the budget lasts, and then they take the place of the
        policy's last ones).
    spacing : float, optional
        Time between the pings of one response [s], finite and > 0 (default: the scenario's
        ``planning.ping_min_spacing``, at least one step).
    turn : float
        Own-ship turn per alarm [rad], in [0, π] (0: none; needs
        ``observer.turn_rate_max``).
    """

    pings: int = 2
    extra_pings: int = 2
    spacing: float | None = None
    turn: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.pings, int) or isinstance(self.pings, bool) or self.pings < 0:
            raise ArgumentError("alarm_response.pings", "an integer >= 0", self.pings)
        if not 0.0 <= as_real(self.turn) <= math.pi:  # (NaN, a bool or a string fail)
            raise ArgumentError("alarm_response.turn", "an angle in [0, π] [rad]", self.turn)
        if self.pings == 0 and self.turn == 0.0:
            raise ArgumentError("alarm_response.pings", "pings >= 1 or a turn > 0",
                                (self.pings, self.turn))
        if (not isinstance(self.extra_pings, int) or isinstance(self.extra_pings, bool)
                or self.extra_pings < 0):
            raise ArgumentError("alarm_response.extra_pings", "an integer >= 0",
                                self.extra_pings)
        if self.spacing is not None:
            # (inf: the first ping of a response would be due at 0·inf = NaN, never)
            finite_real("alarm_response.spacing", self.spacing, "a finite time > 0 [s]",
                        lower=0.0, strict=True)

    def wrap(self, controller: Controller, scenario: Scenario) -> AlarmResponder:
        """The per-run controller: ``controller`` plus the alarm pings
        (:class:`AlarmResponder`, which raises as documented there)."""
        return AlarmResponder(controller, self, scenario)


class AlarmResponder:
    """A controller that adds alarm pings to another one (module docstring).

    Attributes
    ----------
    alarm_pings : list of int
        Steps of the pings it added.
    deferred_pings : list of int
        Steps at which the policy asked for a ping that was deferred (it came within the
        minimum spacing after an alarm ping or a deferred one).

    Raises
    ------
    ScenarioError
        A response ``turn`` > 0 on a scenario without ``observer.turn_rate_max`` (the turn
        would silently never be made).
    """

    def __init__(self, inner: Controller, response: AlarmResponse, scenario: Scenario) -> None:
        if response.turn > 0 and not scenario.observer.turn_rate_max:
            raise ScenarioError("observer.turn_rate_max", "a turn-rate limit for the alarm "
                                "response's turn (alarm_response.turn > 0)",
                                scenario.observer.turn_rate_max, source=scenario.name)
        pl = scenario.planning
        self.inner = inner
        self.dt = float(scenario.time.dt)
        self.min_spacing = float(pl.ping_min_spacing) if pl is not None else 0.0
        self.forbidden = tuple(pl.ping_forbidden) if pl is not None else ()
        self.cap = default_ping_budget(scenario) + response.extra_pings
        self.spacing = max(response.spacing if response.spacing is not None
                           else self.min_spacing, self.dt)
        self.per_alarm = response.pings
        self.turn = float(response.turn)
        self.u_max = float(scenario.observer.turn_rate_max or 0.0)
        self.turn_left = 0.0  # signed heading change still to make [rad]
        self.seen = 0
        self.pending: list[float] = []  # earliest times of requested pings [s]
        self.last = float("-inf")  # time of the last ping [s]
        self.last_own = float("-inf")  # time of the last alarm or deferred ping [s]
        self.deferred = 0  # the policy's pings held back, not yet flown
        self.alarm_pings: list[int] = []
        self.deferred_pings: list[int] = []

    @property
    def log(self) -> list[dict[str, object]]:
        """The inner controller's re-planning log (empty if it keeps none)."""
        return list(getattr(self.inner, "log", []))

    def act(self, belief: BeliefView, t: float) -> Action:
        """The inner action, with a ping added when an alarm asks for one and the allowance
        lasts, the policy's ping deferred when it comes within the minimum spacing after an
        alarm ping, and refused once alarm pings used up budget + allowance."""
        act = self.inner.act(belief, t)
        t_next = t + self.dt
        if belief.alarms > self.seen:
            self.seen = belief.alarms
            self.pending = [t_next + i * self.spacing for i in range(self.per_alarm)]
            if self.turn > 0 and self.u_max > 0:
                self.turn_left = self._side(belief) * self.turn
        if self.turn_left != 0.0:
            u = float(np.clip(self.turn_left / self.dt, -self.u_max, self.u_max))
            self.turn_left = 0.0 if abs(u * self.dt) >= abs(self.turn_left) - 1e-12 \
                else self.turn_left - u * self.dt
            act = dataclasses.replace(act, turn_rate=u)
            if isinstance(self.inner, CourseSteering):  # or it would steer back
                self.inner.offset_courses(u * self.dt)
        room = belief.pings_used < self.cap
        if self.alarm_pings and not room:
            self.deferred = 0  # the cap binds for good: pings are only ever added
        if act.ping:
            if self.alarm_pings and not room:
                return dataclasses.replace(act, ping=False)
            if t_next - self.last_own < self.min_spacing - 1e-9:
                self.deferred += 1
                self.deferred_pings.append(belief.step + 1)
                return dataclasses.replace(act, ping=False)
            self.last = t_next
            self._drop_due(t_next)
            return act
        free = (room and t_next - self.last >= self.min_spacing - 1e-9
                and not any(a <= t_next <= b for a, b in self.forbidden))
        if free and self.deferred:
            self.deferred -= 1
        elif free and self.pending and self.pending[0] <= t_next + 1e-9:
            self.alarm_pings.append(belief.step + 1)
        else:
            return act
        self.last = self.last_own = t_next
        self._drop_due(t_next)
        return dataclasses.replace(act, ping=True)

    def _side(self, belief: BeliefView) -> float:
        """+1 (starboard) or −1: the turn that changes the own velocity across the believed
        line of sight (the particles' mean bearing) most."""
        m = np.asarray(belief.weights) @ np.asarray(belief.particles)[:, :2]
        rel = belief.heading - math.atan2(float(m[0]), float(m[1]))
        gain = [abs(math.sin(rel + s * self.turn) - math.sin(rel)) for s in (1.0, -1.0)]
        return 1.0 if gain[0] >= gain[1] else -1.0

    def _drop_due(self, t_next: float) -> None:
        """A ping at ``t_next`` serves the first pending request due by then."""
        if self.pending and self.pending[0] <= t_next + 1e-9:
            self.pending.pop(0)
