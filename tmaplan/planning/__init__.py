"""Observer planning: heading OCP (casadi), active-ping scheduling, joint plans, baselines.

See :mod:`tmaplan.planning.heading`, :mod:`tmaplan.planning.pings`,
:mod:`tmaplan.planning.joint`, :mod:`tmaplan.planning.joint_ocp`,
:mod:`tmaplan.planning.baselines`,
:mod:`tmaplan.planning.objectives` and :mod:`tmaplan.planning.belief`; several contacts:
:mod:`tmaplan.planning.contacts`, :mod:`tmaplan.planning.multi_objectives`,
:mod:`tmaplan.planning.ping_contacts`, :mod:`tmaplan.planning.joint_contacts`.
"""

from __future__ import annotations

from tmaplan.planning.baselines import (
    Baseline,
    BearingRatePlan,
    baseline_objectives,
    bearing_rate_plan,
    evaluate_baselines,
    single_turn_track,
    straight_track,
    zigzag_track,
)
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import ContactSet, ContactsPlan, ContactsPlanner, plan_contacts
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner, plan_heading
from tmaplan.planning.joint import JointPlan, plan_joint
from tmaplan.planning.joint_contacts import ContactsJointPlan, plan_contacts_joint
from tmaplan.planning.joint_ocp import JointOCPResult, plan_joint_ocp
from tmaplan.planning.objectives import (
    OBJECTIVE_NAMES,
    PING_OBJECTIVES,
    Objective,
    ObjectiveEvaluator,
    logdet,
    make_objective,
    position_bound,
    range_bound,
    turn_penalty,
)
from tmaplan.planning.ping_contacts import ContactsPingSchedule, schedule_contact_pings
from tmaplan.planning.pings import (
    PingEvaluator,
    PingSchedule,
    max_pings,
    ping_candidates,
    schedule_pings,
    uniform_ping_steps,
)

__all__ = [
    "OBJECTIVE_NAMES",
    "PING_OBJECTIVES",
    "Baseline",
    "BearingRatePlan",
    "Belief",
    "ContactSet",
    "ContactsJointPlan",
    "ContactsPingSchedule",
    "ContactsPlan",
    "ContactsPlanner",
    "HeadingPlan",
    "HeadingPlanner",
    "JointOCPResult",
    "JointPlan",
    "Objective",
    "ObjectiveEvaluator",
    "PingEvaluator",
    "PingSchedule",
    "baseline_objectives",
    "bearing_rate_plan",
    "evaluate_baselines",
    "logdet",
    "make_objective",
    "max_pings",
    "ping_candidates",
    "plan_contacts",
    "plan_contacts_joint",
    "plan_heading",
    "plan_joint",
    "plan_joint_ocp",
    "position_bound",
    "range_bound",
    "schedule_contact_pings",
    "schedule_pings",
    "single_turn_track",
    "straight_track",
    "turn_penalty",
    "uniform_ping_steps",
    "zigzag_track",
]
