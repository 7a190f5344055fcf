"""One own-ship heading plan for several contacts (issue 40, DESIGN.md §6).

Role: the planner's side of several contacts. Its input is a :class:`ContactSet`: one
one-contact scenario ("view") per contact — the same own ship, sensors, time grid and
planning settings, each with its contact's target and prior — plus each contact's name,
weight and required accuracy. Every single-contact machine runs per contact on its view;
:class:`ContactsPlanner` builds ONE heading NLP
(:class:`tmaplan.planning.HeadingPlanner`) with the own ship's controls shared and one belief
block per contact (:mod:`tmaplan.planning.multi_objectives`), built once and re-solved.

Multi-start: the plan of each contact alone (``expected-time-to-accuracy`` at its required
accuracy, its own planner) and the built-in turn-rate programs are the candidate starts of the
joint NLP, screened by the joint objective (for ``worst-contact`` the largest contact's value);
the best converged solution is kept. The min-max (``worst-contact``) is solved from its best
start only, the next one tried if that solve fails (its epigraph NLP costs about twice the
iterations per start of the other objectives; docs/results/multi-contact-planning-time.md).
With one contact the plan is today's ``expected-time-to-accuracy`` plan (the same planner,
bit for bit).
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from tmaplan.bounds.closed_form import require_process_noise
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, InfeasibleError, SolverError, is_integer
from tmaplan.models.observer import ObserverTrack, turn_rate_track
from tmaplan.planning.belief import Belief
from tmaplan.planning.feasibility import check_start_keep_out
from tmaplan.planning.heading import HeadingPlanner
from tmaplan.planning.multi_objectives import (
    CONTACTS_OBJECTIVE_NAMES,
    DEFAULT_CONTACTS_OBJECTIVE,
    DEFAULT_REQUIRED_ACCURACY,
    ContactBeliefs,
    contacts_objective,
)
from tmaplan.planning.objectives import ObjectiveEvaluator, expected_time_to_accuracy

if TYPE_CHECKING:
    from tmaplan.planning.heading_plan import HeadingPlan
    from tmaplan.scenario import Scenario

__all__ = ["JOINT_STARTS", "WORST_CONTACT_IPOPT", "ContactSet", "ContactsPlan",
           "ContactsPlanner", "SaturatedObjectiveWarning", "check_contacts_start",
           "plan_contacts",
           "warn_if_saturated"]

#: IPOPT options of the ``worst-contact`` joint NLP (under the caller's ``solver_options``):
#: without second-order corrections (``max_soc`` 0): with the limited-memory Hessian they
#: drifted along the active epigraph constraints where the contacts' times tie (227 IPOPT
#: iterations instead of 74 on the three contacts of benchmarks/multi_contact_plan.py).
WORST_CONTACT_IPOPT: dict[str, Any] = {"acceptable_tol": 1e-4, "acceptable_iter": 5,
                                       "max_soc": 0}

#: Default ``joint_starts`` of :class:`ContactsPlanner` per objective: the screened starts
#: solved (at least two are tried while none converged).
JOINT_STARTS: dict[str, int] = {"all-contacts-time-to-accuracy": 2,
                                "weighted-time-to-accuracy": 2, "worst-contact": 1}


class SaturatedObjectiveWarning(UserWarning):
    """A min-max joint objective (``all-contacts-time-to-accuracy``, ``worst-contact``) whose
    latest contact is not expected to be localised within the horizon on the joint plan: it
    then scores every plan at about the horizon and cannot rank them by what they localise."""


def warn_if_saturated(objective: str, times: Mapping[str, float], horizon: float) -> None:
    """Warn (:class:`SaturatedObjectiveWarning`, one line) when ``objective`` takes the latest
    contact's time and contacts' expected times to accuracy ``times`` [s] on the joint plan
    reach the plan's ``horizon`` [s]: with two contacts localised at 25 min and one never
    within 30 min, every plan scores about 30 min plus its turn penalty, and the least turning
    plan wins (on a five-contact problem the joint plan flew straight, localising none, where
    each contact's own plan localised four of five)."""
    if objective not in ("all-contacts-time-to-accuracy", "worst-contact"):
        return
    late = [n for n, t in times.items() if t >= horizon]
    if late:
        names = ", ".join(f"'{n}'" for n in late)
        warnings.warn(f"{objective}: on the joint plan {len(late)} of {len(times)} contacts "
                      f"({names}) are not expected to be localised within the "
                      f"{horizon / 60:.4g} min horizon, so the objective (the latest "
                      "contact's time) is about the horizon on every plan and cannot rank "
                      "them by what they localise; --objective weighted-time-to-accuracy or "
                      "a longer --horizon scores the contacts that can be localised",
                      SaturatedObjectiveWarning, stacklevel=2)


def _shared(view: Scenario, field: str) -> Any:
    """A view's ``field`` as the contacts share it (``planning`` without the contact's
    ``required_accuracy``, which :meth:`Scenario.contact_view` writes there)."""
    value = getattr(view, field)
    if field == "planning" and value is not None:
        return dataclasses.replace(value, required_accuracy=None)
    return value


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactSet:
    """Several contacts seen from one own ship: the planners' input for N contacts.

    Attributes
    ----------
    views : tuple of Scenario
        One one-contact scenario per contact (``scenario.contact_view(name)``): its target and
        prior; the observer, sensors, time grid and planning settings shared (checked).
    names : tuple of str
        Unique, non-empty contact names.
    weights : tuple of float
        Contact weights > 0 (dimensionless; default 1 each).
    required_accuracies : tuple of float
        Relative range accuracy each contact must reach, in (0, 1) (default
        :data:`tmaplan.scenario.names.DEFAULT_REQUIRED_ACCURACY`, 10 %).

    Notes
    -----
    Build it from a several-contact scenario with :meth:`from_scenario`, or directly from
    one-contact scenarios sharing one own ship.
    """

    __repr__ = short_repr

    views: tuple[Scenario, ...]
    names: tuple[str, ...]
    weights: tuple[float, ...] = ()
    required_accuracies: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        n = len(self.views)
        if n < 1 or len(self.names) != n:
            raise ArgumentError("contacts", "one name per view (at least one contact)",
                                (n, len(self.names)))
        if not self.weights:
            object.__setattr__(self, "weights", (1.0,) * n)
        if not self.required_accuracies:
            object.__setattr__(self, "required_accuracies", (DEFAULT_REQUIRED_ACCURACY,) * n)
        object.__setattr__(self, "views", tuple(self.views))
        object.__setattr__(self, "names", tuple(str(v) for v in self.names))
        object.__setattr__(self, "weights", tuple(float(w) for w in self.weights))
        object.__setattr__(self, "required_accuracies",
                           tuple(float(a) for a in self.required_accuracies))
        seen: set[str] = set()
        for name in self.names:
            if not name or name in seen:
                raise ArgumentError("contacts.name", "unique non-empty names", name)
            seen.add(name)
        for name, w, a in zip(self.names, self.weights, self.required_accuracies,
                              strict=False):
            if not (math.isfinite(w) and w > 0):
                raise ArgumentError(f"contacts[{name}].weight", "a finite weight > 0", w)
            if not 0 < a < 1:
                raise ArgumentError(f"contacts[{name}].required_accuracy", "in (0, 1)", a)
        if len(self.weights) != n or len(self.required_accuracies) != n:
            raise ArgumentError("contacts", "one weight and one required accuracy per contact",
                                (len(self.weights), len(self.required_accuracies)))
        v0 = self.views[0]
        for name, v in zip(self.names[1:], self.views[1:], strict=True):
            for field in ("time", "observer", "sensors", "planning"):
                # a view's planning holds its contact's required accuracy: not shared
                if _shared(v, field) != _shared(v0, field):
                    raise ArgumentError(f"contacts[{name}].{field}", f"the {field} of the "
                                        f"other contacts (one own ship)", getattr(v, field))

    def require_process_noise(self) -> None:
        """Refuse a contact without process noise (the closed-form bound of every planner and
        scheduler needs q > 0), naming ``contacts[i].target.q`` and the contact (one contact:
        ``target.q``); :func:`tmaplan.bounds.closed_form.require_process_noise`."""
        for i, (name, view) in enumerate(zip(self.names, self.views, strict=True)):
            if len(self.views) == 1:
                require_process_noise(view)
            else:
                require_process_noise(view, f"contacts[{i}].target.q", f" (contact '{name}')")

    def __len__(self) -> int:
        return len(self.views)

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> ContactSet:
        """The contacts of a scenario: ``scenario.contacts`` with their one-contact views
        (``scenario.contact_view(name)``), weights and required accuracies (a contact's own,
        else the scenario's)."""
        views = tuple(scenario.contact_view(c.name) for c in scenario.contacts)
        return cls(views=views, names=scenario.contact_names,
                   weights=tuple(float(c.weight) for c in scenario.contacts),
                   required_accuracies=tuple(float(v.required_accuracy) for v in views))

    def beliefs(self, given: ContactBeliefs | Sequence[Belief] | None = None,
                ) -> ContactBeliefs:
        """The contacts' beliefs: ``given`` (one per contact, in order; checked), default
        each contact's prior (:meth:`tmaplan.planning.Belief.from_prior` of its view)."""
        if given is None:
            return ContactBeliefs(beliefs=tuple(Belief.from_prior(v) for v in self.views),
                                  names=self.names)
        bel = given if isinstance(given, ContactBeliefs) else ContactBeliefs(
            beliefs=tuple(given), names=self.names)
        if bel.names != self.names:
            raise ArgumentError("beliefs", f"beliefs of the contacts {list(self.names)}",
                                list(bel.names))
        return bel


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsPlan:
    """A heading plan for several contacts.

    Attributes
    ----------
    plan : HeadingPlan
        The joint plan (its ``objective`` the combined objective [s]; its ``range_bound``
        the first contact's).
    objective_name : str
    names : tuple of str
    expected_times : dict of str to float
        Each contact's expected time to its required accuracy on the joint plan [s]
        (``expected-time-to-accuracy`` without the turn penalty).
    alone : dict of str to HeadingPlan
        Each contact's own plan (a start of the joint NLP; empty for one contact).
    alone_times : dict of str to float
        Each contact's expected time on its own plan [s].
    start : str
        The start the kept solution came from: ``"alone:<name>"``, ``"straight"``,
        ``"built-in <i>"`` (:meth:`HeadingPlanner.start_programs`), ``"built-in"`` (the
        planner's own multi-start), ``"warm"`` (a re-plan) or ``"multi-start: <start>"`` (a
        re-plan's fallback, :meth:`wrap`).
    seconds : float
        Wall time of the whole plan, the contacts' own plans included [s].
    solves : tuple of (str, int, str)
        Each solve of the joint NLP in order: its start (as ``start``), IPOPT iterations and
        return status (one entry per start tried; the contacts' own plans not included).
    """

    __repr__ = short_repr

    plan: HeadingPlan
    objective_name: str
    names: tuple[str, ...]
    expected_times: dict[str, float]
    alone: dict[str, HeadingPlan]
    alone_times: dict[str, float]
    start: str
    seconds: float
    solves: tuple[tuple[str, int, str], ...] = ()

    @property
    def objective(self) -> float:
        """The joint plan's objective [s]."""
        return float(self.plan.objective)

    def contacts_json(self) -> dict[str, dict[str, float]]:
        """The per-contact values of ``tmaplan plan --json`` (DESIGN.md §6, ``contacts:
        {name: {...}}``): ``expected_time_to_accuracy`` on the joint plan [s], and
        ``alone_expected_time_to_accuracy`` / ``alone_objective`` of the contact's own plan
        [s] (absent for one contact)."""
        out: dict[str, dict[str, float]] = {}
        for name in self.names:
            d = {"expected_time_to_accuracy": float(self.expected_times[name])}
            if name in self.alone:
                d["alone_expected_time_to_accuracy"] = float(self.alone_times[name])
                d["alone_objective"] = float(self.alone[name].objective)
            out[name] = d
        return out


class ContactsPlanner:
    """One heading NLP for the contacts of a :class:`ContactSet`, built once, re-solved.

    Parameters
    ----------
    contacts : ContactSet
    objective : str, optional
        One of :data:`CONTACTS_OBJECTIVE_NAMES` (default ``all-contacts-time-to-accuracy``).
    samples : int
        Belief draws per contact (128, as ``expected-time-to-accuracy``).
    alone_starts : int
        Starts of each contact's own plan: the built-in turn-rate programs
        (:meth:`HeadingPlanner.start_programs`) of lowest value of the contact's objective.
    joint_starts : int, optional
        Starts of the joint NLP solved: of the contacts' own plans and the built-in programs,
        the ones of lowest joint objective (each evaluated once; the multi-start adds the plan
        of each contact alone to the candidates). While none converged, the next ones are
        tried, two starts at least. Default :data:`JOINT_STARTS` (2; 1 for ``worst-contact``).
    **planner_kw
        :class:`HeadingPlanner` options shared by the joint and the contacts' own planners
        (``horizon``, ``control_interval``, ``transcription``, ``n_starts``, ...); the
        ``worst-contact`` joint NLP adds :data:`WORST_CONTACT_IPOPT` under the caller's
        ``solver_options``.

    Notes
    -----
    The keep-out range holds from every contact's estimate (its mean propagated at constant
    velocity); ping steps given to :meth:`solve` inform every contact (the reach of a ping,
    ``RangeSensor.max_range``, is modelled by the ping scheduler,
    :mod:`tmaplan.planning.ping_contacts`, on a fixed track, and by the headings and pings
    planned together, :mod:`tmaplan.planning.joint_contacts`).
    """

    def __init__(self, contacts: ContactSet, *, objective: str | None = None,
                 samples: int = 128, alone_starts: int = 1, joint_starts: int | None = None,
                 **planner_kw: Any) -> None:
        name = DEFAULT_CONTACTS_OBJECTIVE if objective is None else objective
        if name not in CONTACTS_OBJECTIVE_NAMES:
            raise ArgumentError("objective", f"one of {', '.join(CONTACTS_OBJECTIVE_NAMES)}",
                                name)
        contacts.require_process_noise()
        self.contacts, self.objective_name = contacts, name
        acc = contacts.required_accuracies
        self.single = len(contacts) == 1
        if self.single:  # today's expected-time-to-accuracy planner, unchanged
            obj: Any = expected_time_to_accuracy(acc[0], samples)
        else:
            obj = contacts_objective(name, q=[v.target.q for v in contacts.views],
                                     accuracies=acc, weights=contacts.weights, samples=samples)
        joint_kw = dict(planner_kw)
        if name == "worst-contact" and not self.single:
            # where the contacts' times tie the min-max converges slowly: no second-order
            # corrections, and 1e-4 accepted after 5 such iterations (WORST_CONTACT_IPOPT)
            joint_kw["solver_options"] = {**WORST_CONTACT_IPOPT,
                                          **(planner_kw.get("solver_options") or {})}
        self.joint = HeadingPlanner(contacts.views[0], objective=obj, **joint_kw)
        alone_kw = {**planner_kw, "n_starts": alone_starts}
        self.alone = () if self.single else tuple(
            HeadingPlanner(v, objective=expected_time_to_accuracy(a, samples), **alone_kw)
            for v, a in zip(contacts.views, acc, strict=True))
        self._samples = int(samples)
        if joint_starts is None:
            joint_starts = JOINT_STARTS[name]
        if not (is_integer(alone_starts, 1) and is_integer(joint_starts, 1)):
            raise ArgumentError("alone_starts/joint_starts", "integers >= 1",
                                (alone_starts, joint_starts))
        self.alone_starts, self.joint_starts = int(alone_starts), int(joint_starts)

    @staticmethod
    def _screen(planner: HeadingPlanner, ev: ObjectiveEvaluator, programs: list[np.ndarray],
                n: int, kw: dict[str, Any]) -> list[np.ndarray]:
        """The ``n`` turn-rate programs (u/u_max, (n_intervals,)) of lowest objective ``ev``
        on their tracks from the start state (cheap: one evaluation each, no solve)."""
        hd0, spd0, p0 = planner.start_state(kw["heading0"], kw["speed0"], kw["position0"])
        vals = []
        for u in programs:
            om = np.repeat(np.asarray(u, float) * planner.u_max, planner.m)
            val = ev(turn_rate_track(p0, hd0, spd0, om, planner.dt))[0]
            vals.append(val if np.isfinite(val) else np.inf)
        order = np.argsort(vals, kind="stable")[: max(1, int(n))]
        return [programs[i] for i in order]

    def expected_times(self, beliefs: ContactBeliefs,
                       plans: Sequence[HeadingPlan]) -> list[dict[str, float]]:
        """Each contact's expected time to its required accuracy [s] on each plan's track
        (``expected-time-to-accuracy`` without the turn penalty)."""
        return [{n: t for n, (t, _) in o.items()}
                for o in self.per_contact(beliefs, [p.observer for p in plans])]

    def per_contact(self, beliefs: ContactBeliefs, tracks: Sequence[ObserverTrack],
                    ) -> list[dict[str, tuple[float, np.ndarray]]]:
        """Each contact's expected time to its required accuracy [s] and closed-form range
        bound per step (K+1,) [m] (brehard2005, DESIGN.md §4) on each own-ship track
        (:class:`ObjectiveEvaluator` of ``expected-time-to-accuracy`` without the turn
        penalty, on the contact's view and belief): one dict ``{name: (time, bound)}`` per
        track, in order."""
        j = self.joint
        out: list[dict[str, tuple[float, np.ndarray]]] = [{} for _ in tracks]
        for v, b, name, a in zip(self.contacts.views, beliefs.beliefs, self.contacts.names,
                                 self.contacts.required_accuracies, strict=True):
            ev = ObjectiveEvaluator(v, expected_time_to_accuracy(a, self._samples,
                                                                 turn_weight=0.0),
                                    n_steps=j.K, belief=b, turn_rate_max=j.u_max,
                                    until_end=j.until_end)
            for o, track in zip(out, tracks, strict=True):
                o[name] = ev(track)
        return out

    def solve(self, beliefs: ContactBeliefs | Sequence[Belief] | None = None, *,
              heading0: float | None = None, position0: np.ndarray | None = None,
              speed0: float | None = None, tol: float | None = None,
              raise_on_failure: bool = True,
              warm_start: ContactsPlan | None = None) -> ContactsPlan:
        """Plan for the contacts' beliefs (default their priors).

        Parameters
        ----------
        beliefs : ContactBeliefs or sequence of Belief, optional
            One belief per contact, in the order of the :class:`ContactSet`.
        heading0, position0, speed0, tol, raise_on_failure
            As :meth:`HeadingPlanner.solve`.
        warm_start : ContactsPlan, optional
            A previous plan of this planner (a receding-horizon re-plan): the joint NLP is
            solved from it alone (:meth:`HeadingPlanner.solve`'s ``warm_start``), without the
            contacts' own plans.

        Raises
        ------
        SolverError
            The joint NLP did not converge from any start (unless ``raise_on_failure`` is
            False: then returned with ``plan.success`` False).
        """
        t0 = time.perf_counter()
        cs = self.contacts
        bel = cs.beliefs(beliefs)
        kw: dict[str, Any] = {"heading0": heading0, "position0": position0, "speed0": speed0,
                              "tol": tol}
        if self.single:
            plan = self.joint.solve(bel.beliefs[0], raise_on_failure=raise_on_failure,
                                    warm_start=None if warm_start is None else
                                    warm_start.plan, **kw)
            start = "built-in" if warm_start is None else "warm"
            return ContactsPlan(plan=plan, objective_name=self.objective_name, names=cs.names,
                                expected_times=self.expected_times(bel, [plan])[0], alone={},
                                alone_times={}, start=start, seconds=time.perf_counter() - t0,
                                solves=((start, plan.iterations, plan.status),))
        j = self.joint
        check_contacts_start(j, bel)
        if warm_start is not None or j.transcription != "direct":
            # a re-plan from the previous plan; or the bang-bang transcription, whose starts
            # are not turn-rate programs: its built-in ones only
            alone: dict[str, HeadingPlan] = {}
            alone_times: dict[str, dict[str, float]] = {}
            best = j.solve(cast(Any, bel), raise_on_failure=False, warm_start=None if
                           warm_start is None else warm_start.plan, **kw)
            start = "built-in" if warm_start is None else "warm"
            solves = [(start, best.iterations, best.status)]
        else:
            alone = {name: p.solve(b, raise_on_failure=False, starts=self._screen(
                p, p.evaluator(b), p.start_programs(), self.alone_starts, kw), **kw)
                for name, p, b in zip(cs.names, self.alone, bel.beliefs, strict=True)}
            alone_times = dict(zip(alone, self.expected_times(bel, list(alone.values())),
                                   strict=True))
            cands = {f"alone:{n}": np.clip(p.turn_rate / max(j.u_max, 1e-12), -1, 1)
                     for n, p in alone.items() if p.success}
            cands.update({"straight" if i == 0 else f"built-in {i}": u
                          for i, u in enumerate(j.start_programs())})
            # the planner reads the beliefs' t, assimilated, mean and mean_range(), and its
            # layout (ContactsLayout) packs one block per contact
            labels = {id(u): lab for lab, u in cands.items()}
            best, start, solves = None, "built-in", []
            dominant = self._dominant_own_plan(bel, alone, alone_times, kw)
            if dominant is not None:  # the min-max's optimum, certified: no NLP to solve
                name, best = dominant
                start = f"alone:{name} (dominant)"
                solves.append((start, best.iterations, best.status))
                keep = []
            else:
                keep = self._screen(j, j.evaluator(cast(Any, bel)), list(cands.values()),
                                    max(self.joint_starts, 2), kw)
            for i, u in enumerate(keep):
                if i >= self.joint_starts and best is not None and best.success:
                    break  # the next start only while none converged
                p = j.solve(cast(Any, bel), starts=[u], raise_on_failure=False, **kw)
                solves.append((labels[id(u)], p.iterations, p.status))
                if best is None or (p.success, -p.objective) > (best.success, -best.objective):
                    best, start = p, labels[id(u)]
        assert best is not None
        if not best.success and raise_on_failure:
            raise SolverError("ipopt", best.status, f"heading plan for {len(cs)} contacts "
                              f"({self.objective_name}) did not converge from any of "
                              f"{len(solves)} start(s)")
        return ContactsPlan(plan=best, objective_name=self.objective_name, names=cs.names,
                            expected_times=self.expected_times(bel, [best])[0], alone=alone,
                            alone_times={n: t[n] for n, t in alone_times.items()},
                            start=start, seconds=time.perf_counter() - t0,
                            solves=tuple(solves))

    def _dominant_own_plan(self, bel: ContactBeliefs, alone: Mapping[str, HeadingPlan],
                           alone_times: Mapping[str, Mapping[str, float]], kw: dict[str, Any],
                           ) -> tuple[str, HeadingPlan] | None:
        """``worst-contact``: a contact's own plan on which that contact is the latest, as a
        plan of the joint NLP, or None.

        ``max_c E[T_c](x) + pen(x) ≥ E[T_c](x) + pen(x) ≥ E[T_c](x_c) + pen(x_c)`` for every
        plan x, x_c contact c's own plan (its ``expected-time-to-accuracy`` optimum, the same
        draws and turn penalty). Where c is the latest contact on x_c (``E[T_c'](x_c) ≤
        E[T_c](x_c)`` for every c') and x_c keeps out of every contact, the two sides meet
        at x_c: it is the min-max's optimum (as far as x_c is c's; a KKT point of the
        epigraph NLP with multiplier 1 on c's constraint), which IPOPT's limited-memory
        epigraph NLP can fail to find from that very start (contacts with different
        required accuracies; docs/several-contacts.md).
        """
        if self.objective_name != "worst-contact" or not alone:
            return None
        j = self.joint
        names = [n for n, p in alone.items() if p.success]
        times = [alone_times[n] for n in names]
        hd0, spd0, p0 = j.start_state(kw["heading0"], kw["speed0"], kw["position0"])
        P = np.concatenate([j.parameter_vector(cast(Any, bel), ()), [hd0, spd0, 1.0, 1.0]])
        _, _, lbg, ubg = j.bounds(hd0)
        tol = 1e-6 * (1.0 + np.abs(np.where(np.isfinite(ubg), ubg, lbg)))
        for name, t in zip(names, times, strict=True):
            if t[name] < max(t.values()):
                continue
            u = np.clip(alone[name].turn_rate / max(j.u_max, 1e-12), -1, 1)
            x = j.with_epigraph_start(j.decision_vector(u, hd0, spd0), P)
            outs = j.plan_function(x, P)  # the plan's outputs and, last, the constraints
            g = np.asarray(outs[-1]).reshape(-1)
            if not (np.all(g <= ubg + tol) and np.all(g >= lbg - tol)):
                continue  # inside another contact's keep-out range
            own = alone[name]
            warm = {"x": x, "lam_x": np.zeros_like(x), "lam_g": np.zeros(lbg.size),
                    "sign": 1.0, "shape": (j.transcription, j.n, j.n_arcs), "scale": 1.0}
            return name, j.make_plan(
                x, P, bel.t, p0, spd0, own.status, True, own.iterations, own.seconds, warm,
                f"{name}'s own plan: the latest contact on it, so the worst-contact optimum "
                "(no joint solve)", evaluated=outs)
        return None

    def wrap(self, beliefs: ContactBeliefs | Sequence[Belief] | None, plan: HeadingPlan, *,
             start: str, t0: float) -> ContactsPlan:
        """A joint solution found outside :meth:`solve` (a re-plan's fallback start,
        :func:`tmaplan.policies.receding.multi_start_replan` on :attr:`joint`) as a
        :class:`ContactsPlan`: each contact's expected time on it, no own plans.

        Parameters
        ----------
        beliefs : ContactBeliefs or sequence of Belief, optional
            As :meth:`solve`.
        plan : HeadingPlan
            A converged solution of :attr:`joint`.
        start : str
            The start it came from.
        t0 : float
            ``time.perf_counter()`` when the re-plan began [s].
        """
        bel = self.contacts.beliefs(beliefs)
        return ContactsPlan(plan=plan, objective_name=self.objective_name,
                            names=self.contacts.names,
                            expected_times=self.expected_times(bel, [plan])[0], alone={},
                            alone_times={}, start=start, seconds=time.perf_counter() - t0,
                            solves=((start, plan.iterations, plan.status),))


def check_contacts_start(planner: HeadingPlanner, beliefs: ContactBeliefs) -> None:
    """Refuse, before any solve, a start inside the keep-out range of a contact's estimate
    (``planner``'s keep-out range, turn rate and speed; the joint start keeps out of each).

    Raises
    ------
    InfeasibleError
        Naming the contact (:func:`tmaplan.planning.feasibility.check_start_keep_out`).
    """
    for name, b in zip(beliefs.names, beliefs.beliefs, strict=True):
        try:
            check_start_keep_out(b, keep_out=planner.keep_out, u_max=planner.u_max,
                                 speed_choice=planner.speed_choice, times=planner.times)
        except InfeasibleError as exc:
            raise InfeasibleError(f"contact '{name}': {exc}") from None


def plan_contacts(contacts: ContactSet, *, beliefs: ContactBeliefs | Sequence[Belief] | None
                  = None, objective: str | None = None, **kw: Any) -> ContactsPlan:
    """Plan for several contacts with a fresh :class:`ContactsPlanner` (keyword arguments:
    its options and :class:`HeadingPlanner`'s; ``heading0``, ``position0``, ``speed0``,
    ``tol``, ``raise_on_failure`` go to :meth:`ContactsPlanner.solve`)."""
    solve_kw = {k: kw.pop(k) for k in ("heading0", "position0", "speed0", "tol",
                                       "raise_on_failure", "warm_start") if k in kw}
    return ContactsPlanner(contacts, objective=objective, **kw).solve(beliefs, **solve_kw)
