"""Combining a manoeuvre and a ping policy; the best baseline manoeuvres; the policies by CLI
name (:data:`MANOEUVRES`, :data:`PINGS`; a name is parsed by :mod:`tmaplan.policies.parse`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from tmaplan.caching import LRUCache
from tmaplan.errors import PlanningError
from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.policies.base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    CourseSteering,
    ManoeuvrePolicy,
    Policy,
)
from tmaplan.policies.manoeuvres import (
    Planned,
    SingleTurn,
    Straight,
    Zigzag,
    offline_plan,
)
from tmaplan.policies.pings import (
    AdaptivePings,
    NoPing,
    ScheduledPings,
    UniformPings,
    offline_schedule,
    resolve_ping_budget,
)
from tmaplan.policies.receding import Receding
from tmaplan.policies.tactics import LeadLag, LegTurnLeg

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["MANOEUVRES", "PINGS", "Combined", "best_single_turn", "best_zigzag"]


# --------------------------------------------------------------------------------------------
# combination
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class Combined:
    """A manoeuvre policy and a ping policy acting together."""

    manoeuvre: ManoeuvrePolicy
    ping: Policy = dataclasses.field(default_factory=NoPing)

    @property
    def name(self) -> str:
        """``manoeuvre`` or ``manoeuvre+ping``."""
        return self.manoeuvre.name if isinstance(self.ping, NoPing) else \
            f"{self.manoeuvre.name}+{self.ping.name}"

    def controller(self, scenario: Scenario) -> Controller:
        """Controller taking the turn rate of one and the ping of the other."""
        return _Both(self.manoeuvre.controller(scenario), self.ping.controller(scenario))

    def resolve(self, scenario: Scenario) -> Combined:
        """The same policy with its offline parts computed (the heading plan of
        :class:`Planned`, the real-time iteration model or the first plan of
        :class:`Receding`, the schedule of
        :class:`ScheduledPings` along the track the manoeuvre nominally flies), so that the
        controllers of all runs share them."""
        man, ping = self.manoeuvre, self.ping
        if isinstance(man, Planned) and man.plan is None:
            man = dataclasses.replace(man, plan=offline_plan(scenario, man.objective))
        if isinstance(man, Receding):
            man = man.resolve(scenario)
        if isinstance(ping, ScheduledPings) and ping.steps is None:
            steps = offline_schedule(scenario, resolve_ping_budget(scenario, ping.budget),
                                     ping.method, ping.objective, man.nominal_track(scenario))
            ping = dataclasses.replace(ping, steps=tuple(int(s) for s in steps))
        return Combined(manoeuvre=man, ping=ping)


class _Both:
    def __init__(self, m: Controller, p: Controller) -> None:
        self.m, self.p = m, p

    @property
    def log(self) -> list[dict[str, Any]]:
        return getattr(self.m, "log", [])

    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=self.m.act(belief, t).turn_rate, ping=self.p.act(belief, t).ping)

    def offset_courses(self, angle: float) -> None:
        """Offset the manoeuvre's courses by ``angle`` [rad] if it steers to courses
        (:class:`CourseSteering`; a turn-rate programme needs nothing)."""
        if isinstance(self.m, CourseSteering):
            self.m.offset_courses(angle)


#: The baselines' best parameters by scenario, the 32 most recently used.
_BASELINE_CACHE: LRUCache[Scenario, dict[str, Any]] = LRUCache(32)


def _best_baselines(scenario: Scenario) -> dict[str, Any]:
    key = scenario
    if key not in _BASELINE_CACHE:
        res = evaluate_baselines(scenario, CLOSED_LOOP_OBJECTIVE)
        _BASELINE_CACHE[key] = {k: v[0].params for k, v in res.items()}
    return _BASELINE_CACHE[key]


def best_single_turn(scenario: Scenario) -> SingleTurn:
    """The single course change with the best :data:`CLOSED_LOOP_OBJECTIVE` from the prior,
    over the grid of :func:`tmaplan.planning.baselines.evaluate_baselines` (angles 30°…180°
    both ways, start times ¼…¾ of the horizon)."""
    return SingleTurn.from_baseline(_best_baselines(scenario)["single-turn"], scenario)


def best_zigzag(scenario: Scenario) -> Zigzag:
    """The best zig-zag of the baseline grid (legs ⅛…⅓ of the horizon, 60°…120° total)."""
    best = _best_baselines(scenario)
    if "zigzag" not in best:
        raise PlanningError(f"{scenario.name}: no zig-zag of the baseline grid (legs ⅛…⅓ of the "
                            f"horizon) lasts one time step of {scenario.time.dt:g} s; a horizon "
                            "of at least 3 steps is needed")
    return Zigzag.from_baseline(best["zigzag"], scenario)


#: The manoeuvre policies by CLI name (``compare --policies MANOEUVRE[+PING]``): a new
#: manoeuvre policy is named here.
MANOEUVRES: dict[str, Callable[[Scenario], ManoeuvrePolicy]] = {
    "straight": lambda sc: Straight(),
    "single-turn": best_single_turn,
    "zigzag": best_zigzag,
    "planned": lambda sc: Planned(),
    "receding": lambda sc: Receding(),
    "receding-multistart": lambda sc: Receding(solver="multi-start",
                                               name="receding-multistart"),
    "receding-realtime": lambda sc: Receding(solver="real-time", name="receding-realtime"),
    "receding-rti": lambda sc: Receding(solver="real-time", full_above=float("inf"),
                                        name="receding-rti"),
    "receding-sqp": lambda sc: Receding(solver="sqp", name="receding-sqp"),
    "receding-ipopt": lambda sc: Receding(solver="ipopt", name="receding-ipopt"),
    "leg-turn-leg": lambda sc: LegTurnLeg(),
    "lead-lag": lambda sc: LeadLag(),
}
#: The ping policies by CLI name: a new ping policy is named here.
PINGS: dict[str, Callable[[], Policy]] = {
    "no-ping": NoPing,
    "uniform": UniformPings,
    "scheduled": ScheduledPings,
    "scheduled-terminal": lambda: ScheduledPings(objective="terminal-range-bound",
                                                 name="scheduled-terminal"),
    "adaptive": AdaptivePings,
}
