"""The contacts of a scenario as the rules and messages see them: fields named per contact.

A file gives its contact either as a bare ``[target]``/``[prior]`` (one contact named
``"contact"``, :meth:`tmaplan.scenario.Contact.is_default`) or as ``[[contacts]]`` tables.
The rules written for one contact (:mod:`tmaplan.scenario.checks`, the prior's, the
plausibility limits) run on each contact's part of the scenario (:func:`contact_parts`); an
error on a ``target.…`` or ``prior.…`` field then names the contact's table,
``contacts[1].prior.range_std``, and the contact (:func:`in_contact`). The command line runs
its single-contact verbs per contact the same way.
"""

from __future__ import annotations

import types
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from tmaplan.errors import ScenarioError

__all__ = ["CONTACT_FIELDS", "contact_field", "contact_parts", "in_contact", "single_form",
           "weight_fractions"]

#: top-level fields of a file that belong to a contact (the rest is shared)
CONTACT_FIELDS = ("target", "prior")


def single_form(s: Any) -> bool:
    """Whether scenario ``s`` is written with a bare ``[target]``/``[prior]``: one contact,
    named ``"contact"``, weight 1, the scenario's required accuracy."""
    return len(s.contacts) == 1 and s.contacts[0].is_default


def contact_field(s: Any, i: int, field: str) -> str:
    """The file path of ``field`` (``"target.course"``, ``"prior"``) of contact ``i`` of
    scenario ``s``: itself in the single form, else ``"contacts[i].target.course"``; a shared
    field (``"observer.…"``) is returned as is."""
    head = field.split(".", 1)[0].split("[", 1)[0]
    if single_form(s) or head not in CONTACT_FIELDS:
        return field
    return f"contacts[{i}].{field}"


@contextmanager
def in_contact(s: Any, i: int, source: str | None = None) -> Iterator[None]:
    """Re-raise a :class:`ScenarioError` on a contact field raised inside as the error of
    contact ``i`` of ``s``: the field as :func:`contact_field` writes it and the contact's name
    after the expected value (unchanged in the single form); ``source``, if given, replaces
    the error's source (the file, where the error came from a renamed view)."""
    try:
        yield
    except ScenarioError as exc:
        field = contact_field(s, i, exc.field)
        if field == exc.field:
            raise
        raise ScenarioError(field, f"{exc.expected} (contact '{s.contacts[i].name}')",
                            exc.received, source=exc.source if source is None else source
                            ) from None


def contact_parts(s: Any) -> Iterator[tuple[int, Any]]:
    """``(i, part)`` per contact: ``part`` has the contact's ``target`` and ``prior`` and the
    scenario's other fields (``observer``, ``sensors``, ``faults``, ``time``, …), what the
    one-contact rules read (no validation: cheap, for the checks at load time)."""
    shared = {name: getattr(s, name) for name in ("name", "time", "observer", "sensors",
                                                  "planning", "estimation", "faults")}
    for i, c in enumerate(s.contacts):
        yield i, types.SimpleNamespace(**shared, target=c.target, prior=c.prior)


def weight_fractions(weights: Sequence[float]) -> tuple[float, ...]:
    """Each contact's share ``w_c / Σ w`` [-] of the weights ``w`` (> 0, finite): the weights
    of the weighted means (``weighted-time-to-accuracy``, the shared ping schedule's
    objective, the campaigns' ``weighted_time_to_accuracy``). Scaled by the largest weight
    first, so that weights near the float limit (two of 1e308) do not overflow the sum into
    inf and every mean into NaN."""
    top = max(float(w) for w in weights)
    scaled = [float(w) / top for w in weights]
    total = sum(scaled)
    return tuple(w / total for w in scaled)
