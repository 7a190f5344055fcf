"""Tactical policies behind one interface (:class:`Policy`): ``controller(scenario).act(belief,
t) -> Action``.

A policy is a frozen dataclass (its parameters) satisfying :class:`Policy` (manoeuvres also
:class:`ManoeuvrePolicy`). For one closed-loop run it makes a
:class:`Controller` (``policy.controller(scenario)``), the only place where per-run state lives
(the current plan, pings used, the last re-plan time). Manoeuvre policies command a turn rate
over the next step; ping policies decide whether to ping at the next step; :class:`Combined`
joins one of each.

Manoeuvre policies: :class:`Straight`, :class:`SingleTurn`, :class:`Zigzag`, :class:`Planned`
(offline heading plan from the prior), :class:`Receding` (re-plans on the particle filter's
posterior every ``replan_interval``); practitioner tactics (:mod:`tmaplan.policies.tactics`):
:class:`LegTurnLeg` (bearing-rate doctrine) and :class:`LeadLag`. Ping policies:
:class:`NoPing`, :class:`UniformPings`, :class:`ScheduledPings` (offline schedule),
:class:`AdaptivePings` (ping when the filter's relative range uncertainty calls for it).
:class:`AlarmResponse` adds pings on the consistency monitor's alarms to any policy.
"""

from __future__ import annotations

from tmaplan.policies.alarms import AlarmResponder, AlarmResponse
from tmaplan.policies.base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    CourseSteering,
    ManoeuvrePolicy,
    Policy,
)
from tmaplan.policies.combine import Combined, best_single_turn, best_zigzag
from tmaplan.policies.manoeuvres import Planned, SingleTurn, Straight, Zigzag
from tmaplan.policies.parse import parse_policy
from tmaplan.policies.pings import AdaptivePings, NoPing, ScheduledPings, UniformPings
from tmaplan.policies.receding import Receding
from tmaplan.policies.tactics import LeadLag, LegTurnLeg

__all__ = [
    "CLOSED_LOOP_OBJECTIVE",
    "Action",
    "AdaptivePings",
    "AlarmResponder",
    "AlarmResponse",
    "BeliefView",
    "Combined",
    "Controller",
    "CourseSteering",
    "LeadLag",
    "LegTurnLeg",
    "ManoeuvrePolicy",
    "NoPing",
    "Planned",
    "Policy",
    "Receding",
    "ScheduledPings",
    "SingleTurn",
    "Straight",
    "UniformPings",
    "Zigzag",
    "best_single_turn",
    "best_zigzag",
    "parse_policy",
]
