"""Joint heading and ping plan for a closed-form PCRB objective (block-coordinate descent).

Alternates (i) the heading OCP with the ping steps fixed (they enter the closed form as ping
weights, :class:`tmaplan.planning.heading.HeadingPlanner` ``ping_steps``) and (ii) the ping
schedule on the planned track (:func:`tmaplan.planning.pings.schedule_pings`), starting from
the pingless heading plan, until the ping steps repeat. Each block is solved for the *same*
objective, so the objective never increases from one block to the next (up to solver
tolerance); the result is a coordinate-wise optimum, not a certified joint optimum.
"""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, Any, Literal

from tmaplan.errors import ArgumentError, PlanningError, is_integer
from tmaplan.models.sensors import default_ping_budget
from tmaplan.planning.belief import Belief
from tmaplan.planning.heading import HeadingPlan, HeadingPlanner
from tmaplan.planning.pings import PingSchedule, schedule_pings

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["JOINT_OBJECTIVES", "JointPlan", "plan_joint"]

#: Heading objective -> ping-scheduling objective of the same quantity.
JOINT_PING_OBJECTIVE = {
    "range-bound": "terminal-range-bound", "terminal-range-bound": "terminal-range-bound",
    "mean-range-bound": "mean-range-bound", "mean-position-bound": "mean-position-bound"}

JOINT_OBJECTIVES: tuple[str, ...] = tuple(sorted(JOINT_PING_OBJECTIVE))
"""Heading objectives that :func:`plan_joint` and ``plan_joint_ocp`` plan pings with."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class JointPlan:
    """Headings and pings planned together.

    Attributes
    ----------
    heading : HeadingPlan
        Final heading plan (with the final pings in its objective).
    pings : PingSchedule
        Final schedule on the final track.
    objective : float
        Objective of the pair [m].
    history : tuple of float
        Objective after each block.
    iterations : int
        Heading/ping rounds.
    seconds : float
    """

    heading: HeadingPlan
    pings: PingSchedule
    objective: float
    history: tuple[float, ...]
    iterations: int
    seconds: float


def plan_joint(scenario: Scenario, *, budget: int | None = None,
               objective: Literal["range-bound", "mean-range-bound",
                                  "mean-position-bound"] = "mean-range-bound",
               ping_method: Literal["exact", "relaxed", "greedy"] = "relaxed",
               belief: Belief | None = None, max_rounds: int = 4,
               **planner_kw: Any) -> JointPlan:
    """Plan headings and at most ``budget`` pings (default ``planning.ping_budget``).

    Extra keyword arguments go to :class:`HeadingPlanner` (horizon, control_interval, ...).

    Raises
    ------
    ArgumentError
        ``budget`` not an integer >= 0 (a bool or a float was truncated), ``max_rounds`` not
        an integer >= 1.
    PlanningError
        Unsupported objective; infeasible heading or ping requests (see the two planners).
    """
    t0 = time.perf_counter()
    if objective not in JOINT_PING_OBJECTIVE:
        raise PlanningError(f"joint objective: expected one of "
                            f"{sorted(JOINT_PING_OBJECTIVE)}, received {objective!r}")
    if budget is not None and not is_integer(budget, 0):
        raise ArgumentError("budget", "an integer >= 0 (None: planning.ping_budget)", budget)
    if not is_integer(max_rounds, 1):  # 0 rounds left no schedule to return
        raise ArgumentError("max_rounds", "an integer >= 1", max_rounds)
    budget = int(budget if budget is not None else default_ping_budget(scenario))
    bel = belief if belief is not None else Belief.from_prior(scenario)
    planner = HeadingPlanner(scenario, objective=objective, **planner_kw)
    plan = planner.solve(bel)
    history = [plan.objective]
    steps: list[int] = []
    sched: PingSchedule | None = None
    stale = False  # the heading plan changed after the last schedule
    rounds = 0

    def reschedule() -> PingSchedule:
        return schedule_pings(scenario, budget=budget, method=ping_method,
                              objective=JOINT_PING_OBJECTIVE[objective],  # type: ignore[arg-type]
                              observer=plan.observer, belief=bel, gap_reference="none")

    for rounds in range(1, max_rounds + 1):  # noqa: B007 - rounds is reported
        sched = reschedule()
        stale = False
        history.append(sched.objective)
        new = sched.steps.tolist()
        if new == steps:
            break
        steps = new
        plan2 = planner.solve(bel, warm_start=plan, ping_steps=steps)
        if plan2.objective <= sched.objective + 1e-9 * max(1.0, abs(sched.objective)):
            plan, stale = plan2, True
        # a rejected heading block leaves the pair (plan, sched): its objective is the
        # schedule's, not the kept plan's (computed with the pings it was solved with)
        history.append(plan.objective if stale else sched.objective)
    if sched is None or stale:
        # stopped at max_rounds after a heading re-solve: the pings returned are scheduled
        # on the heading plan returned, not on the one before it
        sched = reschedule()
        history.append(sched.objective)
    return JointPlan(heading=plan, pings=sched, objective=sched.objective,
                     history=tuple(history), iterations=rounds,
                     seconds=time.perf_counter() - t0)
