"""Planning objectives over several contacts: one own-ship plan, one belief block per contact.

Role: the objectives of issue 40 (DESIGN.md §6), each selectable by name
(:data:`tmaplan.scenario.names.CONTACTS_OBJECTIVE_NAMES`). They are
:class:`tmaplan.planning.objectives.Objective` objects, so the heading planner
(:class:`tmaplan.planning.HeadingPlanner`) builds ONE NLP with the own ship's controls shared
and one parameter block per contact (:class:`ContactsLayout`: each block is a one-contact
:class:`ParamLayout`, so the NLP is built once and re-solved for new beliefs); the cost of
an evaluation grows linearly with the number of contacts N.

Per contact c and belief draw i, ``s_cki`` is the smooth "not yet localised" indicator of
``expected-time-to-accuracy`` at step k (:func:`tmaplan.planning.objectives.not_localised_graph`:
the draw's relative range CRLB against the contact's required accuracy τ_c, lecadre1997
eq. 64–65), and ``E[T_c] = dt·Σ_k mean_i s_cki`` its expected time to accuracy
(:func:`tmaplan.planning.objectives.expected_time_of`). The objectives [s], each plus the turn
penalty of ``expected-time-to-accuracy`` (:func:`horizon_turn_penalty`):

* ``all-contacts-time-to-accuracy`` (the default for N > 1): the expected time until *every*
  contact is localised, ``dt·Σ_k mean_i [1 − Π_c (1 − s_cki)]``, draws paired by index
  across contacts (the contacts' priors are independent; each contact's draws are shuffled by
  a permutation keyed by its name before pairing, so that two priors sampled with the same
  seed are not paired quantile by quantile);
* ``weighted-time-to-accuracy``: ``Σ_c w_c E[T_c] / Σ_c w_c``;
* ``worst-contact``: ``max_c E[T_c]`` as a min-max: the planner adds an epigraph variable t
  and minimises t subject to ``E[T_c] ≤ t`` (:meth:`ContactsObjective.epigraph_terms`).

For one contact each of them is ``expected-time-to-accuracy`` (the same terms).

With pings (``plan --pings K``, :mod:`tmaplan.planning.joint_contacts`), the objective is
instead the weighted mean of a one-contact closed-form bound [m] (:class:`ContactsBoundObjective`),
each contact's block informed by the pings in its reach (:meth:`ContactsLayout.vector` with
per-contact ping weights).
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from tmaplan.errors import ArgumentError, PlanningError, is_integer
from tmaplan.models.target import ncv_matrices
from tmaplan.planning.objectives import (
    PING_OBJECTIVES,
    Objective,
    ParamLayout,
    PlanContext,
    expected_time_of,
    horizon_turn_penalty,
    make_objective,
    not_localised_graph,
)
from tmaplan.scenario.contacts import weight_fractions
from tmaplan.scenario.names import (
    CONTACTS_OBJECTIVE_NAMES,
    DEFAULT_CONTACTS_OBJECTIVE,
    DEFAULT_REQUIRED_ACCURACY,
)

if TYPE_CHECKING:
    from tmaplan.planning.belief import Belief

__all__ = [
    "CONTACTS_OBJECTIVE_NAMES",
    "DEFAULT_CONTACTS_OBJECTIVE",
    "DEFAULT_REQUIRED_ACCURACY",
    "ContactBeliefs",
    "ContactsBoundObjective",
    "ContactsLayout",
    "ContactsObjective",
    "contacts_bound_objective",
    "contacts_objective",
    "pairing_permutation",
]



def pairing_permutation(name: str, n: int) -> np.ndarray:
    """Fixed permutation (n,) of a contact's belief draws, keyed by its ``name`` (so the
    pairing does not depend on the contacts' order; see the module docstring)."""
    return np.random.default_rng(zlib.crc32(name.encode("utf-8"))).permutation(n)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactBeliefs:
    """The beliefs of several contacts at one time, the planner's ``belief`` for N contacts.

    Attributes
    ----------
    beliefs : tuple of Belief
        One relative-state belief per contact, all at the same time ``t`` [s] and relative
        to the same own-ship state.
    names : tuple of str
        The contacts' names (same order).
    """

    beliefs: tuple[Belief, ...]
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.beliefs) < 1 or len(self.beliefs) != len(self.names):
            raise ArgumentError("beliefs", f"one belief per contact ({len(self.names)})",
                                len(self.beliefs))
        ts = {float(b.t) for b in self.beliefs}
        if len(ts) != 1:
            raise PlanningError(f"contact beliefs at different times {sorted(ts)} s: plan "
                                "from beliefs at one time")
        if len({bool(b.assimilated) for b in self.beliefs}) != 1:
            raise PlanningError("contact beliefs: some hold the measurements at t and some "
                                "do not (Belief.assimilated)")

    @property
    def t(self) -> float:
        """Time of the beliefs [s]."""
        return float(self.beliefs[0].t)

    @property
    def assimilated(self) -> bool:
        """Whether the beliefs hold the measurements at ``t`` (:attr:`Belief.assimilated`)."""
        return bool(self.beliefs[0].assimilated)

    @property
    def mean(self) -> np.ndarray:
        """Mean relative state (4,) of the nearest contact by mean range [m, m, m/s, m/s]."""
        return self.beliefs[int(np.argmin([b.mean_range() for b in self.beliefs]))].mean

    def mean_range(self) -> float:
        """Range of the nearest contact's mean relative position [m]."""
        return float(min(b.mean_range() for b in self.beliefs))


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsLayout:
    """Parameter vector of N contacts: N one-contact :class:`ParamLayout` blocks, in order.

    :meth:`slices` are those of the first block (what a one-contact reader such as the
    planner's reported range bound sees); :meth:`block` gives contact c's slice and
    :meth:`mean_offsets` each contact's mean (the planner's keep-out).
    """

    n_steps: int
    n_samples: int
    n_contacts: int

    def __post_init__(self) -> None:
        if not is_integer(self.n_contacts, 1):
            raise ArgumentError("n_contacts", "an integer >= 1", self.n_contacts)

    @property
    def one(self) -> ParamLayout:
        """The layout of one contact's block."""
        return ParamLayout(n_steps=self.n_steps, n_samples=self.n_samples)

    @property
    def size(self) -> int:
        """Length of p."""
        return self.n_contacts * self.one.size

    def slices(self) -> dict[str, slice]:
        """Name -> slice of the first contact's block."""
        return self.one.slices()

    def mean_offsets(self) -> tuple[int, ...]:
        """Offsets in p of each contact's mean relative state ``E X_0`` (the planner keeps
        out of every contact's estimate)."""
        return tuple(self.block(c).start for c in range(self.n_contacts))

    def block(self, c: int) -> slice:
        """Slice of contact c's block in p."""
        n = self.one.size
        return slice(c * n, (c + 1) * n)

    def vector(self, belief: ContactBeliefs, bearing: np.ndarray, ping: np.ndarray | None = None,
               weight: np.ndarray | None = None) -> np.ndarray:
        """Numeric p: each contact's :meth:`ParamLayout.vector` (the shared bearing
        information and step weights (K+1,); the ping weights shared, shape (K+1,), or each
        contact's, shape (N, K+1): a ping informs only the contacts in its reach), its draws
        permuted by :func:`pairing_permutation` (N > 1)."""
        if len(belief.beliefs) != self.n_contacts:
            raise ArgumentError("beliefs", f"{self.n_contacts} contact beliefs",
                                len(belief.beliefs))
        pings: list[np.ndarray | None] = [ping] * self.n_contacts
        if ping is not None and np.ndim(ping) == 2:
            if np.shape(ping) != (self.n_contacts, self.n_steps + 1):
                raise ArgumentError("ping", f"shape ({self.n_steps + 1},) or "
                                    f"({self.n_contacts}, {self.n_steps + 1})", np.shape(ping))
            pings = list(np.asarray(ping, float))
        one = self.one
        smp = one.slices()["samples"]
        out = []
        for b, name, u in zip(belief.beliefs, belief.names, pings, strict=True):
            v = one.vector(b, bearing, u, weight)
            if self.n_contacts > 1 and self.n_samples > 1:
                perm = pairing_permutation(name, self.n_samples)
                v[smp] = v[smp].reshape(self.n_samples, 4)[perm].reshape(-1)
            out.append(v)
        return np.concatenate(out)


@dataclasses.dataclass(frozen=True)
class ContactsObjective(Objective):
    """An objective over N contacts (see the module docstring), minimised [s].

    Build with :func:`contacts_objective`. Not composable with ``+``/``*`` (its parameter
    vector has one block per contact).

    Attributes
    ----------
    kind : str
        One of :data:`CONTACTS_OBJECTIVE_NAMES`.
    q : tuple of float
        Each contact's NCV process noise intensity [m²/s³].
    accuracies : tuple of float
        Each contact's required relative range accuracy τ_c (dimensionless, in (0, 1)).
    weights : tuple of float
        Each contact's weight (> 0).
    width : float
        Relative width of the logistic indicator.
    turn_weight : float
        Weight of the turn penalty.
    """

    kind: str = DEFAULT_CONTACTS_OBJECTIVE
    q: tuple[float, ...] = ()
    accuracies: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()
    width: float = 0.25
    turn_weight: float = 0.02

    def __add__(self, other: Objective) -> Objective:
        raise ArgumentError("objective", "a one-contact objective (an objective over several "
                            "contacts is not composable)", self.name)

    def __mul__(self, w: float) -> Objective:
        raise ArgumentError("objective", "a one-contact objective (an objective over several "
                            "contacts is not composable)", self.name)

    __rmul__ = __mul__

    @property
    def n_contacts(self) -> int:
        """N."""
        return len(self.q)

    def param_layout(self, n_steps: int) -> ContactsLayout:  # type: ignore[override]
        """One block per contact (:class:`ContactsLayout`)."""
        return ContactsLayout(n_steps=n_steps, n_samples=self.layout_samples,
                              n_contacts=self.n_contacts)

    def contexts(self, ctx: PlanContext) -> list[PlanContext]:
        """One-contact contexts (each its block of p, its NCV matrices), cached in ``ctx``."""
        if "contacts" not in ctx.cache:
            lay = ctx.layout
            if not isinstance(lay, ContactsLayout) or lay.n_contacts != self.n_contacts:
                raise PlanningError(f"objective {self.name}: built for {self.n_contacts} "
                                    f"contacts, given a parameter layout {lay!r}")
            out = []
            for c, q in enumerate(self.q):
                A, Q = ncv_matrices(ctx.dt, float(q))
                out.append(dataclasses.replace(ctx, A=A, Q=Q, p=ctx.p[lay.block(c)],
                                               layout=lay.one, cache={}))
            ctx.cache["contacts"] = out
        return list(ctx.cache["contacts"])

    def indicators(self, ctx: PlanContext) -> list[Any]:
        """Each contact's "not yet localised" indicator s_c (K+1, n_samples)."""
        key = "contacts_sig"
        if key not in ctx.cache:
            ctx.cache[key] = [not_localised_graph(cc, tau, self.width) for cc, tau in
                              zip(self.contexts(ctx), self.accuracies, strict=True)]
        return list(ctx.cache[key])

    def expected_times(self, ctx: PlanContext) -> list[Any]:
        """Each contact's expected time to accuracy E[T_c] [s] (casadi scalars; by the
        compiled kernel where ``ctx.compiled``)."""
        if ctx.compiled:
            from tmaplan.planning.compiled_objective import (  # deferred: numba is slow to import
                compiled_expected_time,
            )

            return [self._keep(ctx, cc, compiled_expected_time(cc, tau, self.width))
                    for cc, tau in zip(self.contexts(ctx), self.accuracies, strict=True)]
        return [expected_time_of(cc, s) for cc, s in
                zip(self.contexts(ctx), self.indicators(ctx), strict=True)]

    @staticmethod
    def _keep(ctx: PlanContext, cc: PlanContext, expr: Any) -> Any:
        """``expr``, its compiled callbacks (in the one-contact context ``cc``) kept in
        ``ctx``'s, which the planner keeps alive as long as its solvers."""
        ctx.cache.setdefault("callbacks", []).extend(cc.cache.pop("callbacks", []))
        return expr

    def combined(self, ctx: PlanContext) -> Any:
        """The contacts' term [s] (casadi scalar; 0 for ``worst-contact``, whose value the
        epigraph variable carries)."""
        import casadi as ca  # deferred: casadi is slow to import (the CLI's start-up)

        if self.kind == "worst-contact":
            return ca.DM(0.0)
        if self.kind == "weighted-time-to-accuracy":
            return sum(f * e for f, e in zip(weight_fractions(self.weights),
                                             self.expected_times(ctx), strict=True))
        if len(self.q) == 1:  # exactly the terms of expected-time-to-accuracy
            return self.expected_times(ctx)[0]
        if ctx.compiled:
            from tmaplan.planning.compiled_objective import (  # deferred: numba is slow to import
                compiled_all_contacts_time,
            )

            lay = cast(ContactsLayout, ctx.layout)  # (contexts() checked it)
            return compiled_all_contacts_time(
                ctx, self.contexts(ctx), [lay.block(c) for c in range(self.n_contacts)],
                list(self.accuracies), self.width)
        sigs = self.indicators(ctx)
        localised = 1 - sigs[0]
        for s in sigs[1:]:
            localised = localised * (1 - s)
        return expected_time_of(self.contexts(ctx)[0], 1 - localised)

    def expression(self, ctx: PlanContext) -> Any:
        """casadi scalar (minimised): :meth:`combined` plus the turn penalty (``terms``)."""
        return self.combined(ctx) + super().expression(ctx)

    def epigraph_terms(self, ctx: PlanContext) -> list[Any]:
        """``worst-contact``: the terms E[T_c] of the epigraph constraints ``E[T_c] ≤ t``."""
        return self.expected_times(ctx) if self.kind == "worst-contact" else []


@dataclasses.dataclass(frozen=True)
class ContactsBoundObjective(ContactsObjective):
    """The weighted mean over N contacts of a one-contact closed-form bound objective [m].

    ``Σ_c w_c f_c / Σ_c w_c`` with f_c the objective :attr:`bound` (``mean-range-bound``,
    ``terminal-range-bound`` or ``mean-position-bound``: the closed-form PCRB of brehard2005,
    :func:`tmaplan.planning.objectives.range_bound` / ``position_bound``) on contact c's
    parameter block (:meth:`ContactsObjective.contexts`: its belief, its NCV process noise,
    the pings that reach it): the objective of the shared ping scheduler
    (:class:`tmaplan.planning.ping_contacts.ContactsPingEvaluator`) as a heading objective.
    No turn penalty (as the one-contact bound objectives). Build with
    :func:`contacts_bound_objective`.

    Attributes
    ----------
    bound : Objective or None
        The one-contact objective f (the same for every contact).
    """

    bound: Objective | None = None

    def combined(self, ctx: PlanContext) -> Any:
        """``Σ_c w_c f(ctx_c) / Σ_c w_c`` [m] (casadi scalar)."""
        if self.bound is None:
            raise PlanningError(f"objective {self.name}: no one-contact bound objective")
        f = self.bound
        return sum(w * f.expression(cc) for w, cc in zip(weight_fractions(self.weights),
                                                         self.contexts(ctx), strict=True))


def contacts_bound_objective(name: str, *, q: Sequence[float],
                             weights: Sequence[float] | None = None) -> ContactsBoundObjective:
    """The weighted mean over contacts of the closed-form objective ``name`` [m]
    (:class:`ContactsBoundObjective`).

    Parameters
    ----------
    name : str
        One of :data:`tmaplan.planning.objectives.PING_OBJECTIVES`.
    q : sequence of float, length N
        Each contact's NCV process noise intensity [m²/s³].
    weights : sequence of float, length N, optional
        Contact weights > 0 (default 1 each).

    Raises
    ------
    ArgumentError
        An unknown name, lengths that differ, a weight that is not finite and > 0.
    """
    if name not in PING_OBJECTIVES:
        raise ArgumentError("objective", f"one of {', '.join(PING_OBJECTIVES)}", name)
    qs = tuple(float(v) for v in q)
    ws = tuple(1.0 for _ in qs) if weights is None else tuple(float(v) for v in weights)
    if not qs or len(ws) != len(qs):
        raise ArgumentError("contacts", "one q and weight per contact (>= 1)",
                            (len(qs), len(ws)))
    for i, w in enumerate(ws):
        if not (math.isfinite(w) and w > 0):
            raise ArgumentError(f"weights[{i}]", "a finite weight > 0", w)
    return ContactsBoundObjective(name, (), None, kind=name, q=qs,
                                  accuracies=(DEFAULT_REQUIRED_ACCURACY,) * len(qs),
                                  weights=ws, turn_weight=0.0,
                                  bound=make_objective(name))


def contacts_objective(name: str, *, q: Sequence[float], accuracies: Sequence[float],
                       weights: Sequence[float] | None = None, samples: int = 128,
                       width: float = 0.25, turn_weight: float = 0.02) -> ContactsObjective:
    """The objective ``name`` (:data:`CONTACTS_OBJECTIVE_NAMES`) over N contacts.

    Parameters
    ----------
    name : str
        ``all-contacts-time-to-accuracy``, ``weighted-time-to-accuracy`` or ``worst-contact``.
    q : sequence of float, length N
        Each contact's NCV process noise intensity [m²/s³] (its ``target.q``).
    accuracies : sequence of float, length N
        Required relative range accuracy of each contact, in (0, 1).
    weights : sequence of float, length N, optional
        Contact weights > 0 (default 1 each); read by ``weighted-time-to-accuracy``.
    samples : int
        Belief draws per contact (``expected-time-to-accuracy``'s 128 by default).
    width, turn_weight : float
        As :func:`tmaplan.planning.objectives.expected_time_to_accuracy`.

    Returns
    -------
    ContactsObjective
        For N = 1, the terms of ``expected-time-to-accuracy`` at the contact's accuracy.

    Raises
    ------
    ArgumentError
        An unknown name, lengths that differ, an accuracy outside (0, 1), a weight that is
        not finite and > 0, ``samples`` < 1, ``width`` <= 0.
    """
    if name not in CONTACTS_OBJECTIVE_NAMES:
        raise ArgumentError("objective", f"one of {', '.join(CONTACTS_OBJECTIVE_NAMES)}", name)
    qs = tuple(float(v) for v in q)
    acc = tuple(float(v) for v in accuracies)
    ws = tuple(1.0 for _ in qs) if weights is None else tuple(float(v) for v in weights)
    if not qs or len(acc) != len(qs) or len(ws) != len(qs):
        raise ArgumentError("contacts", "one q, accuracy and weight per contact (>= 1)",
                            (len(qs), len(acc), len(ws)))
    for i, a in enumerate(acc):
        if not 0 < a < 1:
            raise ArgumentError(f"accuracies[{i}]", "in (0, 1)", a)
    for i, w in enumerate(ws):
        if not (math.isfinite(w) and w > 0):
            raise ArgumentError(f"weights[{i}]", "a finite weight > 0", w)
    if not is_integer(samples, 1):
        raise ArgumentError("samples", ">= 1", samples)
    if not width > 0:
        raise ArgumentError("width", "> 0", width)
    terms: tuple[tuple[float, Any], ...] = ()
    if turn_weight > 0:
        terms = ((float(turn_weight), horizon_turn_penalty),)
    return ContactsObjective(name, terms, int(samples), kind=name, q=qs, accuracies=acc,
                             weights=ws, width=float(width), turn_weight=float(turn_weight))
