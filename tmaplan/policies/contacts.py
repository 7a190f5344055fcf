"""Policies for several contacts: the joint plan and the baselines a practitioner would fly.

Role: issue 40's policies (DESIGN.md §6), by command-line name (``compare --policies``;
:data:`CONTACTS_MANOEUVRES`), chosen by :func:`tmaplan.policies.parse.parse_policy` when the
scenario holds several contacts. Every one is an ordinary manoeuvre policy (one controller
steering one own ship), computed offline from the contacts' priors:

* ``planned``: the joint plan (:class:`tmaplan.planning.contacts.ContactsPlanner`, objective
  ``all-contacts-time-to-accuracy``, the default for N > 1);
* ``nearest-contact``: the single-contact plan (``expected-time-to-accuracy``, the plan
  ``planned`` flies for one contact) of the contact nearest by prior mean range;
* ``heaviest-contact``: the single-contact plan of the contact of largest weight (the first
  of equal weights);
* ``planned:NAME``: the single-contact plan of contact ``NAME``;
* ``alternate``: each contact's best single turn (the baseline grid for its own
  ``expected-time-to-accuracy``), flown in turn: from the earliest of those turns' times to
  the end of the horizon, 2·N legs of equal length, leg i on contact (i mod N)'s course;
* ``single-turn``: the single turn of the baseline grid (angles 30°…180° both ways, start
  ¼…¾ of the horizon) of lowest aggregate objective (``all-contacts-time-to-accuracy``);
* ``straight``: hold the initial course;
* ``receding``: the joint plan, re-planned every ``planning.replan_interval`` on all the
  contacts' posteriors (:class:`ContactsReceding`; each re-plan one IPOPT solve of the joint
  NLP warm-started from the previous plan, its horizon the planner's from the re-plan time).

Pings: ``+no-ping``, ``+uniform`` (a ping ranges every contact within ``max_range``), or
``+scheduled`` / ``+scheduled-terminal``: the ping budget's one schedule for all the contacts
(:func:`tmaplan.planning.schedule_contact_pings`, the weighted mean of the contacts' mean or
terminal range bounds) along the track the manoeuvre nominally flies, computed once.
The other single-contact manoeuvres (``zigzag``, the other ``receding-*``, the tactics) are
refused for N > 1 with one line.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from tmaplan.caching import LRUCache
from tmaplan.errors import (
    ArgumentError,
    InfeasibleError,
    PlanningError,
    SolverError,
    finite_real,
    warn_field,
)
from tmaplan.planning.baselines import Baseline, course_program_track, evaluate_baselines
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import (
    ContactSet,
    ContactsPlan,
    ContactsPlanner,
    warn_if_saturated,
)
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.multi_objectives import ContactBeliefs
from tmaplan.planning.ping_contacts import schedule_contact_pings
from tmaplan.policies.base import (
    CLOSED_LOOP_OBJECTIVE,
    Action,
    BeliefView,
    Controller,
    initial_course,
    turn_limits,
)
from tmaplan.policies.combine import MANOEUVRES, Combined, best_single_turn
from tmaplan.policies.manoeuvres import (
    CourseSchedule,
    Planned,
    SingleTurn,
    Straight,
    TurnRatePlayback,
    offline_plan,
)
from tmaplan.policies.pings import NoPing, ScheduledPings, UniformPings, resolve_ping_budget
from tmaplan.policies.receding import multi_start_replan
from tmaplan.simulate import ping_sensors

if TYPE_CHECKING:
    from tmaplan.models.observer import ObserverTrack
    from tmaplan.planning.contacts import ContactsPlanner
    from tmaplan.scenario import Scenario

__all__ = ["CONTACTS_MANOEUVRES", "CONTACTS_PINGS", "Alternate", "ContactsBeliefView",
           "ContactsReceding", "check_contacts_policy", "contact_plan", "contacts_planner",
           "heaviest_contact", "joint_baselines", "joint_contacts_plan", "joint_plan",
           "nearest_contact", "parse_contacts_policy", "shared_schedule", "single_turn_all"]

#: Manoeuvres of a several-contact problem by CLI name (``planned:NAME`` names a contact).
CONTACTS_MANOEUVRES = ("planned", "nearest-contact", "heaviest-contact", "alternate",
                       "single-turn", "straight", "receding")
#: Ping policies of a several-contact problem.
CONTACTS_PINGS = ("no-ping", "uniform", "scheduled", "scheduled-terminal")


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsBeliefView(BeliefView):
    """What a controller sees with several contacts: every contact's belief.

    The inherited fields are the first contact's belief (so a single-contact controller flown
    here reads a belief, never the truth); ``contacts`` holds them all.

    Attributes
    ----------
    contacts : mapping of str to BeliefView
        Each contact's belief, in ``scenario.contacts`` order.
    """

    contacts: Mapping[str, BeliefView] = dataclasses.field(default_factory=dict)

    @classmethod
    def of(cls, beliefs: Mapping[str, BeliefView]) -> ContactsBeliefView:
        """The view of ``beliefs`` (one per contact, the first giving the inherited fields;
        ``alarms`` is the sum over the contacts)."""
        first = next(iter(beliefs.values()))
        fields = {f.name: getattr(first, f.name) for f in dataclasses.fields(BeliefView)}
        fields["alarms"] = sum(b.alarms for b in beliefs.values())
        return cls(**fields, contacts=dict(beliefs))


def nearest_contact(scenario: Scenario) -> str:
    """Name of the contact nearest by prior mean range (the range of its prior's mean
    relative position, :meth:`tmaplan.planning.Belief.mean_range`; the first of equals).

    Contacts within 1 % of the least range get a :class:`ScenarioWarning` naming them: the
    choice between them is then no tactical choice (a sampled prior's mean moves by about
    that much with its seed: two uniform 5–25 km priors read 14976 and 15008 m).
    """

    ranges = {n: Belief.from_prior(v).mean_range() for n, v in scenario.contact_views().items()}
    order = sorted(ranges, key=lambda n: ranges[n])
    near = [n for n in order if ranges[n] <= ranges[order[0]] * 1.01]
    return _first_of_equals("nearest-contact", "equally near by prior mean range (within 1 %)",
                            near, ", ".join(f"{ranges[n]:.0f} m" for n in near))


def heaviest_contact(scenario: Scenario) -> str:
    """Name of the contact of largest weight (the first of equal weights)."""
    best = max(c.weight for c in scenario.contacts)
    return _first_of_equals("heaviest-contact", "equally heavy",
                            [c.name for c in scenario.contacts if c.weight == best],
                            f"weight {best:g}")


def _first_of_equals(policy: str, what: str, names: list[str], value: str) -> str:
    """The first of ``names`` (the policy's choice), with a :class:`ScenarioWarning` naming
    them all when there are several: a choice between equals, said."""
    if len(names) > 1:
        warn_field("contacts", f"{policy}: contacts {', '.join(repr(n) for n in names)} are "
                   f"{what} ({value}): flying the plan for {names[0]!r}", stacklevel=3)
    return names[0]


#: Joint planners by scenario (their NLP built once), the 8 most recently used.
_PLANNERS: LRUCache[tuple[Scenario, bool], ContactsPlanner] = LRUCache(8)
#: Their solutions from the contacts' priors (deterministic), the 8 most recently used.
_PRIOR_PLANS: LRUCache[Scenario, ContactsPlan] = LRUCache(8)
#: The best baseline of each family on the joint objective (deterministic), likewise.
_BASELINES: LRUCache[Scenario, dict[str, Baseline]] = LRUCache(8)


def contacts_planner(scenario: Scenario, *, compiled: bool = False) -> ContactsPlanner:
    """The joint planner of ``scenario``'s contacts (``all-contacts-time-to-accuracy``), its
    NLP built once per scenario (cached, the 8 most recently used).

    Parameters
    ----------
    scenario : Scenario
    compiled : bool
        Its objective evaluated by the compiled kernels (``HeadingPlanner(compiled=True)``:
        the same values and gradients to rounding; the re-plans of :class:`ContactsReceding`).
    """
    if not isinstance(compiled, bool):
        raise ArgumentError("compiled", "True or False", compiled)
    key = (scenario, compiled)
    if key not in _PLANNERS:
        _PLANNERS[key] = ContactsPlanner(ContactSet.from_scenario(scenario),
                                         compiled=compiled)
    return _PLANNERS[key]


def joint_contacts_plan(scenario: Scenario) -> ContactsPlan:
    """The joint plan from the contacts' priors with each contact's expected time on it and
    on its own plan (:meth:`tmaplan.planning.contacts.ContactsPlanner.solve`; solved once per
    scenario, cached: ``planned``, the first plan of ``receding`` and ``demo`` share it).

    Warns
    -----
    SaturatedObjectiveWarning
        A contact not expected to be localised within the horizon on the joint plan (the
        min-max objective then cannot rank the plans), once per scenario.

    Raises
    ------
    SolverError
        The joint NLP converged from no start.
    """
    if scenario not in _PRIOR_PLANS:
        res = contacts_planner(scenario).solve()
        # as `tmaplan plan` does: a min-max objective that no plan can bring under the
        # horizon flies the least turning plan (said once, where the plan is made)
        warn_if_saturated(res.objective_name, res.expected_times,
                          float(res.plan.times[-1] - res.plan.times[0]))
        _PRIOR_PLANS[scenario] = res
    return _PRIOR_PLANS[scenario]


def joint_plan(scenario: Scenario) -> Any:
    """The joint heading plan (``HeadingPlan``) from the contacts' priors
    (:func:`joint_contacts_plan`, ``all-contacts-time-to-accuracy``).

    Raises
    ------
    SolverError
        The joint NLP converged from no start.
    """
    return joint_contacts_plan(scenario).plan


def contact_plan(scenario: Scenario, name: str) -> Any:
    """Contact ``name``'s own plan from its prior: the plan ``planned`` flies on its view
    (:func:`tmaplan.policies.manoeuvres.offline_plan`, :data:`CLOSED_LOOP_OBJECTIVE`)."""

    return offline_plan(scenario.contact_view(name), CLOSED_LOOP_OBJECTIVE)


def joint_baselines(scenario: Scenario) -> dict[str, Baseline]:
    """The baseline of each family of the grid (``straight``, ``single-turn``, ``zigzag``;
    :func:`tmaplan.planning.baselines.evaluate_baselines`) of lowest joint objective (the
    joint planner's evaluator, ``all-contacts-time-to-accuracy`` with its turn penalty, on the
    contacts' priors); evaluated once per scenario (cached: :func:`single_turn_all` and
    ``tmaplan demo P`` share it)."""
    if scenario not in _BASELINES:
        pl = contacts_planner(scenario)
        # the joint planner's evaluator reads the contacts' beliefs (ContactBeliefs) as a belief
        ev = pl.joint.evaluator(cast(Any, pl.contacts.beliefs()))
        _BASELINES[scenario] = {k: v[0] for k, v in
                                evaluate_baselines(pl.contacts.views[0], evaluator=ev).items()}
    return _BASELINES[scenario]


def single_turn_all(scenario: Scenario) -> SingleTurn:
    """The single turn of the baseline grid of lowest joint objective
    (:func:`joint_baselines`)."""
    return SingleTurn.from_baseline(joint_baselines(scenario)["single-turn"].params, scenario)


@dataclasses.dataclass(frozen=True, kw_only=True)
class Alternate:
    """Legs alternated between the contacts' best turns: from ``start`` [s] to the end of the
    horizon, ``2·len(angles)`` legs of equal length, leg i on the initial course plus
    ``angles[i mod len(angles)]`` [rad], turning at the maximum rate.

    Attributes
    ----------
    angles : tuple of float
        Course of each contact's leg from the initial course [rad], each in [−π, π].
    start : float
        Start of the first leg [s], in [t0, t0 + horizon).
    """

    angles: tuple[float, ...]
    start: float
    name: str = "alternate"

    def _schedule(self, scenario: Scenario) -> list[tuple[float, float]]:
        t0, end = scenario.time.t0, scenario.time.t0 + scenario.time.horizon
        t = finite_real("alternate.start", self.start, f"a time in [{t0:g}, {end:g}) s",
                        lower=t0)
        if t >= end or not self.angles:
            raise ArgumentError("alternate", "a start before the end of the horizon and one "
                                "angle per contact", (self.start, self.angles))
        for a in self.angles:
            if not (math.isfinite(a) and abs(a) <= math.pi):
                raise ArgumentError("alternate.angles", "angles in [−π, π] rad", self.angles)
        c0 = initial_course(scenario)
        n = 2 * len(self.angles)
        leg = (end - t) / n
        return [(t0, c0)] + [(t + i * leg, c0 + self.angles[i % len(self.angles)])
                             for i in range(n)]

    def controller(self, scenario: Scenario) -> Controller:
        """A controller following the alternating course schedule."""
        u_max, dt = turn_limits(scenario)
        return CourseSchedule(self._schedule(scenario), u_max, dt)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The own-ship track flown."""

        return course_program_track(scenario, [(t - scenario.time.t0, c)
                                               for t, c in self._schedule(scenario)[1:]])


def alternate(scenario: Scenario) -> Alternate:
    """:class:`Alternate` of the contacts' best single turns
    (:func:`tmaplan.policies.combine.best_single_turn` on each contact's view), from the
    earliest of them."""
    turns = [best_single_turn(v) for v in scenario.contact_views().values()]
    return Alternate(angles=tuple(float(t.angle) for t in turns),
                     start=min(float(t.time) for t in turns))


def check_contacts_policy(spec: str, scenario: Scenario) -> tuple[str, str | None, str | None]:
    """``(manoeuvre, ping, contact)`` of a several-contact policy name
    ``MANOEUVRE[+PING]`` (``planned:NAME``: ``contact`` NAME), checked before anything is
    computed.

    Raises
    ------
    PlanningError
        An unknown manoeuvre or ping policy (the message lists the valid ones).
    ArgumentError
        ``policy``: a contact that is not the scenario's, a single-contact manoeuvre
        (``receding``, ``zigzag``, ...), a ping policy without an active range sensor.
    """
    if not isinstance(spec, str):
        raise PlanningError(f"unknown policy {spec!r}: expected a name MANOEUVRE[+PING]")
    parts = spec.strip().split("+")
    man, _, contact = parts[0].partition(":")
    names = scenario.contact_names
    if contact or parts[0].endswith(":"):
        if man != "planned" or contact not in names:
            raise ArgumentError("policy", f"planned:NAME with NAME a contact of the problem "
                                f"({', '.join(names)})", spec, source=scenario.name)
    elif man in MANOEUVRES and man not in CONTACTS_MANOEUVRES:
        raise ArgumentError("policy", f"a manoeuvre for several contacts "
                            f"({', '.join(CONTACTS_MANOEUVRES)}, planned:NAME): {man} flies "
                            "for one contact", spec, source=scenario.name)
    if len(parts) > 2 or man not in CONTACTS_MANOEUVRES or (
            len(parts) == 2 and parts[1] not in CONTACTS_PINGS):
        raise PlanningError(f"unknown policy {spec!r} for several contacts: expected "
                            f"MANOEUVRE[+PING] with MANOEUVRE in {list(CONTACTS_MANOEUVRES)} "
                            f"or planned:NAME and PING in {list(CONTACTS_PINGS)}")
    ping = parts[1] if len(parts) == 2 else None
    if ping not in (None, "no-ping") and not ping_sensors(scenario):
        raise ArgumentError("policy", "no ping policy (+PING): there is no active range "
                            "sensor to ping with", spec, source=scenario.name)
    return man, ping, contact or None


def parse_contacts_policy(spec: str, scenario: Scenario) -> Any:
    """The policy (:class:`tmaplan.policies.Combined`, its plan computed) of a several-contact
    policy name (:func:`check_contacts_policy`)."""
    man, ping, contact = check_contacts_policy(spec, scenario)
    m: Any
    if contact is not None:
        m = Planned(plan=contact_plan(scenario, contact), name=f"planned:{contact}")
    elif man == "planned":
        m = Planned(objective="all-contacts-time-to-accuracy", plan=joint_plan(scenario))
    elif man == "nearest-contact":
        m = Planned(plan=contact_plan(scenario, nearest_contact(scenario)),
                    name="nearest-contact")
    elif man == "heaviest-contact":
        m = Planned(plan=contact_plan(scenario, heaviest_contact(scenario)),
                    name="heaviest-contact")
    elif man == "alternate":
        m = alternate(scenario)
    elif man == "single-turn":
        m = single_turn_all(scenario)
    elif man == "receding":
        m = ContactsReceding(first_plan=joint_contacts_plan(scenario))
    else:
        m = Straight()
    if ping in ("scheduled", "scheduled-terminal"):
        return Combined(manoeuvre=m, ping=shared_schedule(scenario, m, ping))
    return Combined(manoeuvre=m, ping=UniformPings() if ping == "uniform" else NoPing())


def shared_schedule(scenario: Scenario, manoeuvre: Any, name: str = "scheduled",
                    budget: int | None = None) -> ScheduledPings:
    """The ping policy ``+scheduled`` (``name`` ``scheduled-terminal``: the terminal range
    bound) of several contacts: one schedule of ``budget`` pings (default
    ``planning.ping_budget``) for all the contacts along ``manoeuvre``'s nominal track, the
    weighted mean of their range bounds (:func:`tmaplan.planning.schedule_contact_pings`,
    ``relaxed``; no certificate: the policy needs the steps only), a ping ranging every
    contact within ``max_range``.

    Parameters
    ----------
    scenario : Scenario
        Several contacts.
    manoeuvre : ManoeuvrePolicy
        Its offline parts computed (``nominal_track``).
    name : str
        ``scheduled`` or ``scheduled-terminal``.
    budget : int, optional
        Pings at most.

    Returns
    -------
    ScheduledPings
        With its ``steps`` (in [1, K]).
    """
    objective = "terminal-range-bound" if name == "scheduled-terminal" else "mean-range-bound"
    sched = schedule_contact_pings(ContactSet.from_scenario(scenario),
                                   budget=resolve_ping_budget(scenario, budget),
                                   method="relaxed", objective=objective,
                                   observer=manoeuvre.nominal_track(scenario),
                                   gap_reference="none")
    return ScheduledPings(objective=cast(Any, objective), name=name,
                          steps=tuple(int(k) for k in sched.schedule.steps))



@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsReceding:
    """Re-plan the joint plan on every contact's posterior (several contacts).

    Every ``replan_interval`` [s] (default ``planning.replan_interval``) the joint NLP
    (:class:`tmaplan.planning.contacts.ContactsPlanner`, the contacts' beliefs from their
    filters' particles, :meth:`tmaplan.planning.Belief.from_particles`) is solved from the
    own ship's state, warm-started from the previous plan; if that solve fails, from the
    other starts (``fallback_starts``); a re-plan that fails from every start keeps the
    previous plan (logged: ``t``, ``status``, ``success``, ``fell_back``, ``infeasible``,
    ``seconds``, as :class:`tmaplan.policies.Receding`).

    Attributes
    ----------
    first_plan : ContactsPlan, optional
        The plan from the priors (computed when None).
    replan_interval : float, optional
        [s], > 0.
    max_particles : int
        Particles kept per contact's belief.
    fallback_starts : bool
        A re-plan whose warm-started solve fails is solved again from the other starts of
        :func:`tmaplan.policies.receding.multi_start_replan` (logged ``fell_back``; the
        previous plan is kept only if none converges).
    fallback_tol : float, optional
        IPOPT's tolerance of the fallback solves (default 1e-4, the one-contact
        :class:`tmaplan.policies.Receding`'s ``full_tol``; None: the planner's 1e-7, which
        the warm-started solve uses). The stalled joint re-plans of ``three-contacts-screen``
        hit IPOPT's iteration limit at 1e-7 from every start.
    compiled : bool
        Evaluate the re-plans' objective by its compiled kernels
        (:func:`tmaplan.planning.compiled_objective.compiled_all_contacts_time`; the same
        values and gradients as the casadi graph to rounding, so IPOPT takes the same steps
        but for the last bits); False: the casadi graph, the path before (kept for the
        paired checks and the speed ratio, ``benchmarks/contacts_replans.py``). The plan
        from the priors is the graph's either way (``planned`` flies the same).
    """

    first_plan: Any = None
    replan_interval: float | None = None
    max_particles: int = 2000
    fallback_starts: bool = True
    fallback_tol: float | None = 1e-4
    compiled: bool = True
    name: str = "receding"

    def _interval(self, scenario: Scenario) -> float:
        pl = scenario.planning
        v = self.replan_interval if self.replan_interval is not None else (
            pl.replan_interval if pl is not None else None)
        if v is None:
            raise ArgumentError("planning.replan_interval", "a re-planning interval for the "
                                "receding policy", None, source=scenario.name)
        return finite_real("receding.replan_interval", v, "an interval > 0 [s]", lower=1e-9)

    def controller(self, scenario: Scenario) -> Controller:
        """A controller re-planning on the contacts' posteriors."""
        return _ContactsRecedingController(self, scenario)

    def nominal_track(self, scenario: Scenario) -> ObserverTrack:
        """The first plan's track."""
        first = self.first_plan if self.first_plan is not None else \
            joint_contacts_plan(scenario)
        return first.plan.observer


class _ContactsRecedingController:
    def __init__(self, policy: ContactsReceding, scenario: Scenario) -> None:

        self.policy, self.scenario = policy, scenario
        HeadingPlanner.check_tolerance(policy.fallback_tol, "receding.fallback_tol")
        self.interval = policy._interval(scenario)
        if not isinstance(policy.compiled, bool):
            raise ArgumentError("receding.compiled", "True or False", policy.compiled)
        self.planner = contacts_planner(scenario, compiled=policy.compiled)
        self.plan = policy.first_plan
        self.playback = None if self.plan is None else TurnRatePlayback(self.plan.plan, scenario)
        self.next_replan = scenario.time.t0 + self.interval  # the first plan is the priors'
        self.log: list[dict[str, Any]] = []

    def act(self, belief: BeliefView, t: float) -> Action:
        if t + 1e-9 >= self.next_replan or self.playback is None:
            self._replan(belief, t)
            self.next_replan = t + self.interval
        rate = self.playback.rate_at(t) if self.playback is not None else 0.0
        return Action(turn_rate=rate)

    def _replan(self, belief: BeliefView, t: float) -> None:


        t0 = time.perf_counter()
        views = getattr(belief, "contacts", None) or {"contact": belief}
        bel = ContactBeliefs(beliefs=tuple(
            Belief.from_particles(b.particles, b.weights, t=t,
                                  max_samples=self.policy.max_particles, assimilated=True)
            for b in views.values()), names=tuple(views))
        entry: dict[str, Any] = {"t": t}
        kw: dict[str, Any] = {"heading0": belief.heading, "position0": belief.position}
        try:
            try:
                plan, fell_back = self.planner.solve(bel, warm_start=self.plan,
                                                     raise_on_failure=True, **kw), False
            except (SolverError, InfeasibleError) as exc:  # (not a bad request)
                if self.plan is None or not self.policy.fallback_starts:
                    raise
                # the warm start did not converge: the one-contact policy's other starts
                # (mirror image, straight, turn early to either side) on the joint NLP
                plan, fell_back = self._fall_back(bel, exc, t0, **kw), True
                entry["start"] = plan.start
            self.plan = plan
            self.playback = TurnRatePlayback(plan.plan, self.scenario)
            entry.update(status=plan.plan.status, success=True, fell_back=fell_back)
        except PlanningError as exc:  # keep flying the previous plan
            entry.update(status=str(exc), success=False, fell_back=True,
                         infeasible=isinstance(exc, InfeasibleError))
        entry["seconds"] = time.perf_counter() - t0
        self.log.append(entry)

    def _fall_back(self, bel: ContactBeliefs, error: PlanningError, t0: float, *,
                   heading0: float, position0: np.ndarray) -> Any:
        """The best converged joint solve from :func:`multi_start_replan`'s other starts
        after the warm-started one failed with ``error`` (an error naming both failures if
        none converged, as :class:`tmaplan.policies.Receding`'s fallback)."""
        assert self.plan is not None  # (the caller's check)
        try:
            hp = multi_start_replan(self.planner.joint, bel, self.plan.plan, heading0=heading0,
                                    position0=position0, tol=self.policy.fallback_tol,
                                    warm=False)
        except PlanningError as again:
            if str(again) == str(error):  # refused before any solve (the same check)
                raise
            cls = InfeasibleError if isinstance(again, InfeasibleError) else PlanningError
            raise cls(f"{error}; then from the fallback starts: {again}") from error
        return self.planner.wrap(bel, hp, start=hp.message, t0=t0)
