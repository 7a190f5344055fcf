"""Own-ship headings and shared pings planned together for several contacts (issue 40).

Role: ``plan --pings K`` for a :class:`tmaplan.planning.contacts.ContactSet`. ONE objective,
the weighted mean over the contacts of a one-contact closed-form ping objective
(``mean-range-bound``, ``terminal-range-bound`` or ``mean-position-bound``; the closed-form
PCRB of brehard2005), ``Σ_c w_c f_c(track, u ∘ reach_c) / Σ_c w_c``, where a ping at step k
informs contact c only when the contact is within the range sensor's ``max_range`` there
(``reach_ck``, :mod:`tmaplan.planning.ping_contacts`), is minimised by block-coordinate
descent, as :func:`tmaplan.planning.joint.plan_joint` does for one contact:

* start: the heading plan of this objective without pings (the planner's multi-start);
* ping block: :func:`tmaplan.planning.ping_contacts.schedule_contact_pings` on the planned
  track (the reach of that track);
* heading block: ONE heading NLP over the shared own-ship controls
  (:class:`tmaplan.planning.HeadingPlanner` with a
  :class:`tmaplan.planning.multi_objectives.ContactsBoundObjective`, built once and re-solved
  with parameters), each contact's block informed by the ping steps at which that contact was
  in reach on the current track. The reach changes with the track, so a heading block is
  kept only if the objective re-evaluated with the reach of its own track does not increase;

until the ping steps repeat or ``max_rounds`` heading blocks. The best pair seen is kept, so
the result is never above the first schedule on the pingless plan, itself at most that
plan's objective (pings only inform). The certificate is the shared scheduler's
``lower_bound``/``gap`` on the final track: a valid lower bound over every schedule of at
most ``budget`` pings on *that* track, not over the headings (the pair is a coordinate-wise
optimum, not a certified joint optimum).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, PlanningError, is_integer
from tmaplan.models.sensors import default_ping_budget
from tmaplan.planning.contacts import ContactSet, check_contacts_start
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.joint import JOINT_OBJECTIVES, JOINT_PING_OBJECTIVE
from tmaplan.planning.joint_ocp import with_own_pings
from tmaplan.planning.multi_objectives import (
    ContactBeliefs,
    ContactsLayout,
    contacts_bound_objective,
)
from tmaplan.planning.ping_contacts import (
    ContactsPingEvaluator,
    ContactsPingSchedule,
    check_ping_budget,
    ping_reach,
    schedule_contact_pings,
)

if TYPE_CHECKING:
    from tmaplan.planning.belief import Belief
    from tmaplan.planning.heading_plan import HeadingPlan

__all__ = ["ContactsJointPlan", "ContactsReachPlanner", "plan_contacts_joint"]

#: Relative tolerance of "the objective did not increase" (the NLP's own tolerance).
ACCEPT_TOLERANCE = 1e-9


class ContactsReachPlanner(HeadingPlanner):
    """A :class:`HeadingPlanner` of a several-contact objective whose ping steps inform each
    contact only where it is in :attr:`reach` (the heading block of
    :func:`plan_contacts_joint`).

    Attributes
    ----------
    reach : ndarray of bool, shape (N, K+1), or None
        Contact c is informed by a ping at step k iff ``reach[c, k]``; None: every contact at
        every step (:class:`HeadingPlanner`'s shared pings). Set it with :meth:`solve_reach`.
    """

    reach: np.ndarray | None = None

    def parameter_vector(self, belief: Any, ping_steps: Sequence[int]) -> np.ndarray:
        """:meth:`HeadingPlanner.parameter_vector` with each contact's pings masked by its
        :attr:`reach` (:meth:`tmaplan.planning.multi_objectives.ContactsLayout.vector` with
        per-contact ping weights)."""
        p = super().parameter_vector(belief, ping_steps)  # checks the steps
        if self.reach is None:
            return p
        lay = self.layout
        if not isinstance(lay, ContactsLayout):
            raise PlanningError(f"ping reach per contact: the objective {self.objective.name} "
                                "is not over several contacts")
        one = lay.one.slices()  # the first block: the shared bearing, ping, weight
        return lay.vector(belief, p[one["bearing"]], p[one["ping"]][None, :] * self.reach,
                          p[one["weight"]])

    def solve_reach(self, belief: ContactBeliefs, reach: np.ndarray | None,
                    **kw: Any) -> HeadingPlan:
        """:meth:`HeadingPlanner.solve` with the ping reach ``reach`` (N, K+1) bool."""
        if reach is not None:
            n = len(belief.beliefs)
            if np.shape(reach) != (n, self.K + 1):
                raise ArgumentError("reach", f"shape ({n}, {self.K + 1}): contacts × plan "
                                    "steps", np.shape(reach))
        self.reach = None if reach is None else np.asarray(reach, float)
        try:
            return self.solve(belief, **kw)  # type: ignore[arg-type]
        finally:
            self.reach = None


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsJointPlan:
    """Headings and shared pings planned together for several contacts.

    Attributes
    ----------
    heading : HeadingPlan
        Final heading plan (its ``objective`` with the pings and reach it was solved with,
        which need not be the final ones: read :attr:`objective`).
    pings : ContactsPingSchedule
        The shared schedule on the final track, exact reach: its ``schedule.objective`` is
        :attr:`objective`, its ``schedule.lower_bound`` / ``gap`` the certificate (a lower
        bound over the pings on that track, not over the headings).
    objective : float
        Weighted mean over the contacts of the ping objective of the pair [m].
    start_objective : float
        Of the pingless start (the heading plan of this objective without pings) [m].
    objective_name : str
        The one-contact ping objective (``mean-range-bound``, ...).
    history : tuple of float
        Objective after each block [m] (start, schedule, heading block, ..., certificate).
    rounds : int
        Heading blocks solved (kept or rejected).
    seconds : float
        Wall time [s].
    status : str
        The certificate's status (``optimal``: gap ≤ 1e-3; ``feasible``; ``time limit``
        with ``ping_method="exact"``; ``no bound``).
    """

    __repr__ = short_repr

    heading: HeadingPlan
    pings: ContactsPingSchedule
    objective: float
    start_objective: float
    objective_name: str
    history: tuple[float, ...]
    rounds: int
    seconds: float
    status: str


def plan_contacts_joint(contacts: ContactSet, *, budget: int | None = None,
                        objective: str = "mean-range-bound",
                        ping_method: Literal["exact", "relaxed", "greedy"] = "relaxed",
                        beliefs: ContactBeliefs | Sequence[Belief] | None = None,
                        max_range: float | Literal["sensor"] | None = "sensor",
                        max_rounds: int = 4, **planner_kw: Any) -> ContactsJointPlan:
    """Plan the own ship's headings and at most ``budget`` pings shared by ``contacts``.

    Parameters
    ----------
    contacts : ContactSet
    budget : int, optional
        Pings for all contacts together (default the first view's ``planning.ping_budget``).
    objective : str
        One of :data:`tmaplan.planning.joint.JOINT_OBJECTIVES` (``range-bound`` is
        ``terminal-range-bound``), for every contact; weighted by the contacts' weights.
    ping_method : {"exact", "relaxed", "greedy"}
        The ping block's search (:func:`schedule_contact_pings`).
    beliefs : ContactBeliefs or sequence of Belief, optional
        One per contact (default their priors).
    max_range : float, None or "sensor"
        Reach of a ping [m] (:func:`schedule_contact_pings`; "sensor": the range sensor's).
    max_rounds : int
        At most this many heading blocks.
    **planner_kw
        :class:`HeadingPlanner` options (``horizon``, ``control_interval``,
        ``transcription``, ``n_starts``, ...).

    Returns
    -------
    ContactsJointPlan

    Raises
    ------
    ArgumentError
        An objective that is not a ping objective; ``budget`` not an integer >= 0, or > 0
        without a range sensor; ``max_rounds`` not an integer >= 1; ``max_range`` not > 0
        (all before any solve).
    PlanningError
        More pings than fit in the plan's candidate steps with the minimum spacing (before
        any solve).
    InfeasibleError
        The start inside a contact's keep-out range (naming the contact).
    SolverError
        The pingless heading plan did not converge (a later heading block that does not
        converge is rejected, not used).
    """
    t0 = time.perf_counter()
    if objective not in JOINT_PING_OBJECTIVE:
        raise ArgumentError("objective", f"one of {', '.join(JOINT_OBJECTIVES)}", objective)
    if budget is not None and not is_integer(budget, 0):
        raise ArgumentError("budget", "an integer >= 0 (None: planning.ping_budget)", budget)
    if not is_integer(max_rounds, 1):
        raise ArgumentError("max_rounds", "an integer >= 1", max_rounds)
    contacts.require_process_noise()
    v0 = contacts.views[0]
    budget = int(budget if budget is not None else default_ping_budget(v0))
    reach_m = ping_reach(v0, max_range)
    name = JOINT_PING_OBJECTIVE[objective]
    bel = contacts.beliefs(beliefs)
    planner = ContactsReachPlanner(v0, objective=contacts_bound_objective(
        name, q=[v.target.q for v in contacts.views], weights=contacts.weights), **planner_kw)
    # refused before the first solve: no range sensor, more pings than fit
    if budget > 0 and planner.ping_scale == 0.0:
        raise ArgumentError("budget", "0: the scenario has no range sensor to ping with",
                            budget)
    check_ping_budget(v0, bel.t + planner.times, budget)
    check_contacts_start(planner, bel)

    def schedule(plan: HeadingPlan, reference: Literal["auto", "none"]) -> ContactsPingSchedule:
        return schedule_contact_pings(contacts, budget=budget, method=ping_method,
                                      objective=name, observer=plan.observer, beliefs=bel,
                                      max_range=reach_m, gap_reference=reference)

    plan = planner.solve_reach(bel, None)  # the pingless start; raises if it failed
    start = plan.objective
    history = [start]
    # the best pair seen: (track, its ping steps, the objective with the track's own reach)
    best: tuple[HeadingPlan, list[int], float] | None = None
    steps: list[int] | None = None
    rounds = 0
    while True:
        sched = schedule(plan, "none")
        new = sched.schedule.steps.tolist()
        value = sched.schedule.objective
        history.append(value)
        if best is None or value < best[2]:
            best = (plan, new, value)
        if new == steps or rounds >= max_rounds or budget == 0:
            break
        steps, rounds = new, rounds + 1
        reach = np.array([sched.reach[n] for n in contacts.names])
        trial = planner.solve_reach(bel, reach, warm_start=plan, ping_steps=steps,
                                    raise_on_failure=False)
        if trial.success:  # the objective with the reach of the trial's own track
            exact = ContactsPingEvaluator(contacts, trial.observer, bel, name,
                                          reach_m).value(steps)
            if exact <= value + ACCEPT_TOLERANCE * max(1.0, abs(value)):
                plan = trial
                history.append(exact)
                if exact < best[2]:  # (the next schedule on it may not find these steps)
                    best = (trial, steps, exact)
                continue
        history.append(value)  # rejected: the next schedule would be this one again
        break
    plan, own, value = best
    cert = schedule(plan, "auto")  # the certificate on the final track
    if value < cert.schedule.objective:  # the pair's own pings are better: cert's bound
        ev = ContactsPingEvaluator(contacts, plan.observer, bel, name, reach_m)
        sched = ContactsPingSchedule.of(ev, with_own_pings(
            cert.schedule, ev, own))  # type: ignore[arg-type]
    else:
        sched = cert
    history.append(sched.schedule.objective)
    return ContactsJointPlan(heading=plan, pings=sched, objective=sched.schedule.objective,
                             start_objective=start, objective_name=name,
                             history=tuple(history), rounds=rounds,
                             seconds=time.perf_counter() - t0, status=sched.schedule.status)
