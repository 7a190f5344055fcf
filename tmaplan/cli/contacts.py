"""Several contacts on the command line: the one place that says which verbs take them.

A verb module that handles a several-contact scenario declares ``SEVERAL_CONTACTS``:
``"per-contact"`` (``crlb``, ``bound``, ``track``: the single-contact machinery runs on each
contact's view, :meth:`tmaplan.scenario.Scenario.contact_view`, through
:func:`run_per_contact`; the JSON holds ``contacts: {name: {...the one-contact keys...}}`` and
the console prints each contact's block; each contact's runs use the same seeds, common random
numbers) or ``"joint"`` (``simulate``: its ``run`` takes the whole scenario).
:func:`refuse_several` refuses the other verbs with one line (never running them silently on
the first contact), so a verb is lifted by setting its flag. A one-contact scenario runs
exactly as before.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import re
import sys
import warnings
from collections.abc import Callable, Iterator
from typing import Any

from tmaplan.errors import ArgumentError, ScenarioError, ScenarioWarning, TmaplanError
from tmaplan.scenario import Scenario, load
from tmaplan.scenario.contacts import contact_field, in_contact

__all__ = ["per_contact", "preflight_per_contact", "refuse_several", "require_priors",
           "run_per_contact", "scenario_of", "takes_several"]


def takes_several(module: Any) -> bool:
    """Whether the verb ``module`` handles several contacts (its ``SEVERAL_CONTACTS``)."""
    return getattr(module, "SEVERAL_CONTACTS", None) in ("per-contact", "joint")


def per_contact(module: Any) -> bool:
    """Whether the verb ``module`` runs per contact (``SEVERAL_CONTACTS = "per-contact"``)."""
    return getattr(module, "SEVERAL_CONTACTS", None) == "per-contact"


def refuse_several(verb: str, module: Any, scenario: Scenario,
                   verbs: dict[str, Any] | None = None) -> None:
    """Raise :class:`ScenarioError` when ``scenario`` has several contacts and the verb does
    not handle them (``verbs``: name -> module of every verb, to list those that do)."""
    if len(scenario.contacts) < 2 or takes_several(module):
        return
    able = sorted(v for v, m in (verbs or {}).items() if takes_several(m))
    also = f" ({', '.join(able)} do)" if able else ""
    raise ScenarioError("contacts", f"one contact: tmaplan {verb} does not handle several "
                        f"contacts yet{also}", list(scenario.contact_names),
                        source=scenario.name)


def scenario_of(args: argparse.Namespace) -> Scenario:
    """The scenario a verb's ``run`` works on: the contact's view when :func:`run_per_contact`
    runs it, else the problem ``args.problem`` (loaded)."""
    view = getattr(args, "contact_view", None)
    return view if view is not None else load(args.problem)


def _view(scenario: Scenario, name: str) -> Scenario:
    """Contact ``name``'s view, named ``<problem>-<contact>`` (its figures' file names)."""
    return dataclasses.replace(scenario.contact_view(name), name=f"{scenario.name}-{name}")


@contextlib.contextmanager
def _warnings_name(scenario: Scenario, i: int) -> Iterator[None]:
    """Re-issue the :class:`ScenarioWarning` s raised inside on contact ``i``'s view as
    :func:`in_contact` re-raises its errors: a contact field as its table
    (``contacts[1].prior…``), and the contact's name after the text (a warning on a shared
    field, ``planning.keep_out_range``, otherwise did not say whose prior it was about)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ScenarioWarning)
        yield
    name = scenario.contacts[i].name
    for w in caught:
        text = str(w.message)
        if issubclass(w.category, ScenarioWarning) and f"(contact '{name}')" not in text:
            m = re.match(r"(.*?field ')([^']+)(': )(.*)$", text)
            if m is not None:
                head, field, sep, rest = m.groups()
                body, cut, received = rest.rpartition(", received ")
                rest = (f"{body} (contact '{name}'){cut}{received}" if cut else
                        f"{rest} (contact '{name}')")
                text = f"{head}{contact_field(scenario, i, field)}{sep}{rest}"
        warnings.warn_explicit(text, w.category, w.filename, w.lineno)


def preflight_per_contact(args: argparse.Namespace, scenario: Scenario,
                          preflight: Callable[[argparse.Namespace, Any], None]) -> None:
    """``preflight(args, view)`` of each contact's view; a scenario error on a contact field
    names the contact (:func:`tmaplan.scenario.contacts.in_contact`), e.g. a contact without
    the prior that the verb needs: ``field 'contacts[1].prior': expected a [prior] table: ...
    (contact 'bravo')``."""
    def check(i: int) -> None:
        preflight(argparse.Namespace(**vars(args), contact_of=(scenario, i)),
                  scenario.contact_view(scenario.contacts[i].name))

    for i, c in enumerate(scenario.contacts):
        try:
            with in_contact(scenario, i), _warnings_name(scenario, i):
                check(i)
        except ArgumentError as exc:  # a flag that does not suit this contact says whose
            if (exc.field.startswith("contacts") or not exc.field.startswith("-")
                    or _refused_by_all(check, len(scenario.contacts), exc)):
                raise
            raise ArgumentError(exc.field, f"{exc.expected} (contact '{c.name}')",
                                exc.received, source=exc.source) from None


def _refused_by_all(check: Callable[[int], None], n: int, exc: ArgumentError) -> bool:
    """Whether ``check(j)`` refuses every contact ``j`` with ``exc``'s very error: a flag
    against what the contacts share (``--budget`` over the steps of the horizon,
    ``--control-interval`` not whole in the planning horizon), not against one contact, so
    the error names no contact (it named the first). The checks run quietly."""
    for j in range(n):
        try:
            with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()):
                warnings.simplefilter("ignore")
                check(j)
        except ArgumentError as other:
            if str(other) != str(exc):
                return False
        else:
            return False
    return True


def require_priors(scenario: Scenario, why: str) -> None:
    """Refuse a several-contact scenario in which a contact has no prior, naming the contact
    (``field 'contacts[1].prior': expected a [prior] table: <why> (contact 'bravo')``): a
    joint verb (``plan``, ``schedule``) starts from every contact's prior."""
    for i, c in enumerate(scenario.contacts):
        if c.prior is None:
            with in_contact(scenario, i):
                raise ScenarioError("prior", f"a [prior] table: {why}", None,
                                    source=scenario.name)


def run_per_contact(module: Any, args: argparse.Namespace, scenario: Scenario
                    ) -> dict[str, Any]:
    """Run the verb ``module`` on each contact's view: ``{problem, contacts: {name:
    payload}}``; on the console a header line per contact before its output."""
    out: dict[str, Any] = {}
    check = getattr(module, "check_arguments", None)
    if check is not None:  # a bad flag refused before the first contact's header
        check(args)
    for i, c in enumerate(scenario.contacts):
        if args.json != "-":
            print(f"== {scenario.name}: contact {c.name} ({i + 1} of "
                  f"{len(scenario.contacts)}) ==", file=sys.stdout)
        sub = argparse.Namespace(**vars(args), contact_view=_view(scenario, c.name),
                                 contact=c, problem_scenario=scenario)
        try:
            with in_contact(scenario, i, source=scenario.name):
                payload = module.run(sub)
        except TmaplanError as exc:  # a failed computation says whose
            if isinstance(exc, ArgumentError) or not exc.args or not isinstance(exc.args[0],
                                                                                  str):
                raise
            exc.args = (f"contact '{c.name}': {exc.args[0]}", *exc.args[1:])
            raise
        if isinstance(payload, dict):
            payload.pop("problem", None)
        out[c.name] = payload
    return {"problem": scenario.name, "contacts": out}
