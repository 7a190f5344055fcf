"""Active pings shared by several contacts: one budget, one set of ping times (issue 40).

Role: ``schedule`` for a :class:`tmaplan.planning.contacts.ContactSet`. One ping ranges
every contact in reach, so the schedule is chosen once for all contacts:

* each contact c has its one-contact :class:`tmaplan.planning.PingEvaluator` (the closed-form
  PCRB of brehard2005 on the fixed own-ship track, its view and belief) and a reach mask
  ``reach_ck``: a ping at step k informs contact c when its predicted range
  ``r̂_ck = sqrt(E r_ck²)`` (the range of the bound, DESIGN.md §4) is within the range
  sensor's ``max_range`` (None: unlimited);
* the objective is the weighted mean ``Σ_c w_c f_c(u ∘ reach_c) / Σ_c w_c`` of the contacts'
  objectives [m] (a weighted sum: the same minimiser), each monotone in the pings, so the
  sum is too and "every remaining candidate pinged" stays a valid bound;
* the certificate is the convex relaxation of :mod:`tmaplan.planning.ping_relaxation` with
  one block of step LMIs per contact in the shared weights u (a sum of per-contact convex
  terms: its optimum is below every feasible schedule's objective), and ``exact``
  enumerates (plain, or best-first branch and bound) unless the relaxation has already
  certified a gap ≤ 1e-3 (:func:`tmaplan.planning.pings.certified_schedule`, the one search
  of every scheduler).
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, PlanningError, finite_real, is_integer
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.planning.multi_objectives import ContactBeliefs
from tmaplan.planning.pings import (
    PingEvaluator,
    PingSchedule,
    certified_schedule,
    max_pings,
    ping_candidates,
    schedule_pings,
)
from tmaplan.scenario import RangeSensor
from tmaplan.scenario.contacts import weight_fractions

if TYPE_CHECKING:
    from tmaplan.planning.belief import Belief
    from tmaplan.planning.contacts import ContactSet
    from tmaplan.scenario import Scenario

__all__ = ["ContactsPingEvaluator", "ContactsPingSchedule", "PingReachWarning",
           "check_ping_budget", "ping_max_range", "ping_reach", "schedule_contact_pings"]


class PingReachWarning(UserWarning):
    """Fewer pings are scheduled than the budget because no contact is within the range
    sensor's ``max_range`` at enough candidate steps (a ping out of every contact's reach
    informs nobody and reveals the own ship)."""


def ping_reach(scenario: Scenario, max_range: float | Literal["sensor"] | None) -> float | None:
    """The reach of a ping [m] asked as ``max_range`` ("sensor": :func:`ping_max_range`;
    None: unlimited), checked.

    Raises
    ------
    ArgumentError
        ``max_range`` not a finite range > 0 m (nor "sensor" or None).
    """
    reach_m = ping_max_range(scenario) if isinstance(max_range, str) and \
        max_range == "sensor" else max_range
    if reach_m is not None:
        reach_m = finite_real("max_range", reach_m, "a range > 0 m (None: unlimited)",
                              lower=0.0)
        if reach_m <= 0:
            raise ArgumentError("max_range", "a range > 0 m (None: unlimited)", reach_m)
    return reach_m


def check_ping_budget(scenario: Scenario, times: np.ndarray, budget: int,
                      **constraints: Any) -> tuple[np.ndarray, int]:
    """The candidate ping steps on a track of step times ``times`` (K+1,) [s] and the gap
    between pings [steps] (:func:`tmaplan.planning.ping_search.ping_candidates`, with its
    ``constraints``), after checking that ``budget`` pings fit in them.

    Raises
    ------
    PlanningError
        More pings than fit in the candidate steps with the minimum spacing.
    """
    cand, gap, spacing = ping_candidates(scenario, times, **constraints)
    if int(budget) > max_pings(cand, gap):
        raise PlanningError(f"budget K = {budget} pings cannot be met: at most "
                            f"{max_pings(cand, gap)} fit in the {cand.size} candidate "
                            f"steps with min_spacing {spacing:g} s")
    return cand, gap


def ping_max_range(scenario: Scenario) -> float | None:
    """``max_range`` [m] of the range sensor that pings (the first one), None: unlimited
    (no such field, or a sensor without one)."""
    for s in scenario.sensors:
        if isinstance(s, RangeSensor):
            v = getattr(s, "max_range", None)
            return None if v is None else float(v)
    return None


class ContactsPingEvaluator:
    """The shared-ping objective of several contacts on one own-ship track.

    Parameters
    ----------
    contacts : ContactSet
    observer : ObserverTrack
    beliefs : ContactBeliefs
        Each contact's belief at the track's first instant.
    objective : str
        One of :data:`tmaplan.planning.PING_OBJECTIVES`, for every contact.
    max_range : float, optional
        Reach of a ping [m] (None: unlimited).

    Attributes
    ----------
    parts : tuple of (PingEvaluator, float, ndarray)
        Per contact: its evaluator, its normalised weight ``w_c/Σw`` and its reach mask
        (K+1,) bool (read by the relaxation).
    """

    def __init__(self, contacts: ContactSet, observer: ObserverTrack, beliefs: ContactBeliefs,
                 objective: str = "mean-range-bound", max_range: float | None = None) -> None:
        contacts.require_process_noise()
        evs = [PingEvaluator(v, observer, b, objective)
               for v, b in zip(contacts.views, beliefs.beliefs, strict=True)]
        reach = [np.ones(ev.K + 1, bool) if max_range is None else
                 np.sqrt(np.asarray(ev.engine.er2, float)) <= float(max_range) for ev in evs]
        self.parts = tuple((ev, w, r) for ev, w, r in zip(
            evs, weight_fractions(contacts.weights), reach, strict=True))
        self.names = contacts.names
        ev0 = evs[0]
        self.objective, self.K, self.dt, self.times = ev0.objective, ev0.K, ev0.dt, ev0.times

    def evaluate_each(self, U: np.ndarray) -> np.ndarray:
        """Each contact's objective (N, S) [m] of schedules U (S, K+1), pings out of a
        contact's reach removed."""
        U = np.atleast_2d(np.asarray(U, float))
        return np.stack([ev.evaluate(U * r[None, :]) for ev, _, r in self.parts])

    def evaluate(self, U: np.ndarray) -> np.ndarray:
        """Objective (S,) [m]: the contacts' weighted mean."""
        w = np.array([p[1] for p in self.parts])
        return w @ self.evaluate_each(U)

    def per_step(self, U: np.ndarray) -> np.ndarray:
        """Weighted mean over the contacts of the bound per step (S, K+1) [m]."""
        U = np.atleast_2d(np.asarray(U, float))
        return np.sum([w * ev.per_step(U * r[None, :]) for ev, w, r in self.parts], axis=0)

    def schedules(self, sets: Sequence[Sequence[int]]) -> np.ndarray:
        """0/1 matrix (S, K+1) of ping-step sets (:meth:`PingEvaluator.schedules`)."""
        return self.parts[0][0].schedules(sets)

    def value(self, steps: Sequence[int]) -> float:
        """Objective of one schedule [m]."""
        return float(self.evaluate(self.schedules([steps]))[0])


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsPingSchedule:
    """A shared ping schedule and what it gives each contact.

    Attributes
    ----------
    schedule : PingSchedule
        The schedule, its objective (the contacts' weighted mean [m]), certified
        ``lower_bound``, ``gap`` and ``status`` (``bound``: the weighted mean per step).
    names : tuple of str
    objectives : dict of str to float
        Each contact's objective with the schedule [m].
    no_ping_objectives : dict of str to float
        Each contact's objective without pings [m].
    bounds : dict of str to ndarray
        Each contact's range bound per step (K+1,) [m].
    reach : dict of str to ndarray
        Each contact's reach mask (K+1,) bool: the steps where a ping informs it.
    pings_in_reach : dict of str to int
        The schedule's pings that inform each contact.
    """

    __repr__ = short_repr

    schedule: PingSchedule
    names: tuple[str, ...]
    objectives: dict[str, float]
    no_ping_objectives: dict[str, float]
    bounds: dict[str, np.ndarray]
    reach: dict[str, np.ndarray]
    pings_in_reach: dict[str, int]

    @classmethod
    def of(cls, ev: ContactsPingEvaluator, sched: PingSchedule) -> ContactsPingSchedule:
        """``sched`` (its steps on ``ev``'s track) with each contact's values from ``ev``."""
        U = ev.schedules([sched.steps.tolist()])
        each = ev.evaluate_each(U)[:, 0]
        none = ev.evaluate_each(np.zeros((1, ev.K + 1)))[:, 0]
        names = ev.names
        return cls(
            schedule=sched, names=names,
            objectives={n: float(v) for n, v in zip(names, each, strict=True)},
            no_ping_objectives={n: float(v) for n, v in zip(names, none, strict=True)},
            bounds={n: p[0].per_step(U * p[2][None, :])[0] for n, p in zip(names, ev.parts,
                                                                            strict=True)},
            reach={n: p[2].copy() for n, p in zip(names, ev.parts, strict=True)},
            pings_in_reach={n: int(p[2][sched.steps].sum()) for n, p in zip(names, ev.parts,
                                                                             strict=True)})

    def contacts_json(self) -> dict[str, dict[str, Any]]:
        """The per-contact values of ``tmaplan schedule --json`` (DESIGN.md §6, ``contacts:
        {name: {...}}``): ``objective``, ``no_ping_objective`` [m], ``bound`` per step [m],
        ``pings_in_reach`` and ``reach`` (per step, bool)."""
        return {n: {"objective": self.objectives[n],
                    "no_ping_objective": self.no_ping_objectives[n],
                    "bound": self.bounds[n], "pings_in_reach": self.pings_in_reach[n],
                    "reach": self.reach[n]} for n in self.names}


def _within_reach(ev: ContactsPingEvaluator, cand: np.ndarray, gap: int, budget: int,
                  reach_m: float | None) -> tuple[np.ndarray, int]:
    """The candidate steps where a ping reaches at least one contact, and the budget that
    fits in them (with a :class:`PingReachWarning` when it is less than ``budget``).

    A ping at a step where no contact is in reach informs nobody (its information is zero
    for every contact) and reveals the own ship: dropping it leaves every contact's
    objective unchanged and keeps the spacing, so the optimum over these candidates with
    the budget that fits in them is the optimum over all candidates, and a lower bound of
    the one is a lower bound of the other.
    """
    reachable = np.any([p[2] for p in ev.parts], axis=0)
    kept = cand[reachable[cand]]
    fits = max_pings(kept, gap)
    if fits < budget:
        reach = "unlimited" if reach_m is None else f"{reach_m:g} m"
        where = "at none" if kept.size == 0 else f"at only {kept.size}"
        warnings.warn(f"ping_budget: {budget} pings asked, but a contact is within the ping's "
                      f"reach ({reach}) {where} of the {cand.size} candidate steps along this "
                      f"track: {fits} scheduled (a ping out of every contact's reach only "
                      "reveals the own ship)", PingReachWarning, stacklevel=3)
    return kept, min(budget, fits)


def schedule_contact_pings(contacts: ContactSet, *, budget: int,
                           method: Literal["exact", "relaxed", "greedy"] = "relaxed",
                           objective: str = "mean-range-bound",
                           observer: ObserverTrack | None = None,
                           beliefs: ContactBeliefs | Sequence[Belief] | None = None,
                           max_range: float | Literal["sensor"] | None = "sensor",
                           min_spacing: float | None = None,
                           forbidden: Sequence[tuple[float, float]] = (),
                           candidate_steps: Sequence[int] | None = None,
                           max_enumerate: int = 50_000, time_limit: float = 30.0,
                           gap_reference: Literal["auto", "exact", "none"] = "auto",
                           ) -> ContactsPingSchedule:
    """Choose at most ``budget`` ping steps for all contacts at once (module docstring).

    Parameters
    ----------
    contacts : ContactSet
    budget : int
        Pings K for all contacts together.
    method, objective, min_spacing, forbidden, candidate_steps, max_enumerate, time_limit,
    gap_reference
        As :func:`tmaplan.planning.schedule_pings` (the constraints of the first contact's
        view, which all views share). ``max_enumerate``: ``exact`` enumerates every schedule
        when C(n, K) is at most this, else branch and bound within ``time_limit`` [s].
    observer : ObserverTrack, optional
        Default the scenario's scripted track.
    beliefs : ContactBeliefs or sequence of Belief, optional
        Default the contacts' priors.
    max_range : float, None or "sensor"
        Reach of a ping [m]; "sensor": the range sensor's ``max_range``
        (:func:`ping_max_range`); None: unlimited.

    Returns
    -------
    ContactsPingSchedule
        For one contact with unlimited reach, :func:`schedule_pings`' schedule unchanged.

    Raises
    ------
    ArgumentError, PlanningError
        As :func:`tmaplan.planning.schedule_pings`; ``max_range`` not > 0.
    """
    t_start = time.perf_counter()
    v0 = contacts.views[0]
    reach_m = ping_reach(v0, max_range)
    bel = contacts.beliefs(beliefs)
    obs = observer if observer is not None else observer_track(v0.observer, v0.time)
    common: dict[str, Any] = {"min_spacing": min_spacing, "forbidden": forbidden,
                              "candidate_steps": candidate_steps}
    ev = ContactsPingEvaluator(contacts, obs, bel, objective, reach_m)
    if len(contacts) == 1 and reach_m is None:  # today's scheduler, unchanged
        sched = schedule_pings(v0, budget=budget, method=method,
                               objective=objective,  # type: ignore[arg-type]
                               observer=obs, belief=bel.beliefs[0], max_enumerate=max_enumerate,
                               time_limit=time_limit, gap_reference=gap_reference, **common)
    else:
        if not is_integer(budget, 0):
            raise ArgumentError("budget", "an integer >= 0 (pings)", budget)
        if method not in ("exact", "relaxed", "greedy"):
            raise ArgumentError("method", "'exact', 'relaxed' or 'greedy'", method)
        if gap_reference not in ("auto", "exact", "none"):
            raise ArgumentError("gap_reference", "'auto', 'exact' or 'none'", gap_reference)
        cand, gap = check_ping_budget(v0, ev.times, int(budget), **common)
        cand, budget = _within_reach(ev, cand, gap, int(budget), reach_m)
        sched = certified_schedule(ev, cand, gap, int(budget), method=method,
                                   objective=objective, gap_reference=gap_reference,
                                   max_enumerate=max_enumerate, time_limit=time_limit,
                                   workers=None, t_start=t_start)
    return ContactsPingSchedule.of(ev, sched)
