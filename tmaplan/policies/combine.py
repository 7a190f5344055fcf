"""Combining a manoeuvre and a ping policy; the best baseline manoeuvres; CLI policy names."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from tmaplan.caching import LRUCache
from tmaplan.errors import ArgumentError, PlanningError
from tmaplan.models.sensors import default_ping_budget
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
from tmaplan.policies.contacts import check_contacts_policy, parse_contacts_policy
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
from tmaplan.simulate import ping_sensors

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["MANOEUVRES", "PINGS", "Combined", "best_single_turn", "best_zigzag",
           "check_policy", "parse_policy"]


# --------------------------------------------------------------------------------------------
# combination and parsing
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
    p = _best_baselines(scenario)["single-turn"]
    return SingleTurn(angle=float(p["angle"]), time=scenario.time.t0 + float(p["time"]))


def best_zigzag(scenario: Scenario) -> Zigzag:
    """The best zig-zag of the baseline grid (legs ⅛…⅓ of the horizon, 60°…120° total)."""
    best = _best_baselines(scenario)
    if "zigzag" not in best:
        raise PlanningError(f"{scenario.name}: no zig-zag of the baseline grid (legs ⅛…⅓ of the "
                            f"horizon) lasts one time step of {scenario.time.dt:g} s; a horizon "
                            "of at least 3 steps is needed")
    p = best["zigzag"]
    return Zigzag(leg_duration=float(p["leg_duration"]), angle=0.5 * float(p["angle"]),
                  start=scenario.time.t0)


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


def check_policy(spec: str, scenario: Scenario) -> tuple[str, str | None]:
    """The manoeuvre and ping names of a CLI policy name ``manoeuvre[+ping]``, checked against
    the scenario before anything is computed: the one check behind :func:`parse_policy` and
    ``tmaplan compare``'s up-front check of ``--policies``.

    Raises
    ------
    PlanningError
        For an unknown name (the message lists the valid ones).
    ArgumentError
        ``policy``: a ping policy (any but ``no-ping``) on a problem that cannot ping in the
        closed loop: without an active range sensor (:func:`tmaplan.simulate.ping_sensors`),
        or with no pings to spend (``planning.ping_budget`` 0 or no ``[planning]`` table:
        the CLI's ping policies spend the scenario's budget). The same refusal for every
        ping policy: a uniform or adaptive policy would silently never ping.
    """
    if len(scenario.contacts) > 1:  # several contacts: their own policies

        man, ping, _ = check_contacts_policy(spec, scenario)
        return man, ping
    if not isinstance(spec, str):  # (None.strip() was an AttributeError)
        raise PlanningError(f"unknown policy {spec!r}: expected a name MANOEUVRE[+PING]")
    parts = spec.strip().split("+")
    if len(parts) > 2 or parts[0] not in MANOEUVRES or (len(parts) == 2
                                                        and parts[1] not in PINGS):
        raise PlanningError(f"unknown policy {spec!r}: expected MANOEUVRE[+PING] with MANOEUVRE "
                            f"in {sorted(MANOEUVRES)} and PING in {sorted(PINGS)}")
    ping = parts[1] if len(parts) == 2 else None
    if ping in (None, "no-ping"):
        return parts[0], ping
    if not ping_sensors(scenario):
        raise ArgumentError("policy", "no ping policy (+PING): there is no range sensor to "
                            "ping with (add a [[sensors]] kind = 'range' with active = true, "
                            f"or fly {parts[0]} without +{ping})", spec, source=scenario.name)
    pl = scenario.planning
    if default_ping_budget(scenario) == 0:
        raise ArgumentError("policy", "no ping policy (+PING): the problem has no pings to "
                            "spend (planning.ping_budget is "
                            f"{'0' if pl is not None else 'not set: no [planning] table'}; "
                            f"or fly {parts[0]} without +{ping})", spec, source=scenario.name)
    return parts[0], ping


def parse_policy(spec: str, scenario: Scenario) -> Combined:
    """Policy from a CLI name: ``manoeuvre[+ping]``, e.g. ``receding+scheduled``.

    Manoeuvres (:data:`MANOEUVRES`): straight, single-turn and zigzag (the best of the
    baseline grids of :mod:`tmaplan.planning.baselines` for :data:`CLOSED_LOOP_OBJECTIVE`),
    planned, receding (an IPOPT solve at every re-plan, warm-started from the previous
    plan), receding-realtime (real-time iteration, a full IPOPT re-solve when the optimum
    moved far: 5–12 times faster, the default before), receding-rti (real-time-iteration
    steps only: no full re-solve when the optimum moves far; a rejected step still falls
    back to IPOPT), receding-multistart (IPOPT re-plans from five starts), receding-sqp
    (re-plans solved to IPOPT's tolerance by a condensed quasi-Newton SQP), leg-turn-leg,
    lead-lag. Several contacts: :mod:`tmaplan.policies.contacts` (``planned`` the joint plan,
    ``nearest-contact``, ``heaviest-contact``, ``alternate``, ``single-turn``, ``straight``).
    Pings (:data:`PINGS`): no-ping, uniform,
    scheduled (offline schedule minimising the mean range bound over the horizon),
    scheduled-terminal (minimising the terminal range bound), adaptive.

    Raises
    ------
    PlanningError
        For an unknown name (the message lists the valid ones).
    ArgumentError
        A ping policy on a problem without a range sensor (:func:`check_policy`).
    """
    if len(scenario.contacts) > 1:  # several contacts: tmaplan.policies.contacts

        return parse_contacts_policy(spec, scenario)
    manoeuvre, ping = check_policy(spec, scenario)
    return Combined(manoeuvre=MANOEUVRES[manoeuvre](scenario),
                    ping=PINGS[ping]() if ping is not None else NoPing())
