"""Every closed-form user refuses a target without process noise up front, naming the field.

The closed-form bound of brehard2005 propagates the belief through the target's process noise
(eq. 16); with q = 0 its recursion inverted a singular matrix deep inside the planners'
graphs ("Singular matrix"). The library now refuses it before building anything, naming
``target.q`` (``contacts[i].target.q`` and the contact for one of several).
"""

from __future__ import annotations

import dataclasses

import pytest

from tmaplan.errors import ScenarioError
from tmaplan.planning import HeadingPlanner, schedule_contact_pings, schedule_pings
from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.planning.objectives import ObjectiveEvaluator
from tmaplan.scenario import load_problem


def _without_noise(scenario, name=None):
    if name is None:
        return scenario.replace(target=dataclasses.replace(scenario.target, q=0.0))
    cs = tuple(dataclasses.replace(c, target=dataclasses.replace(c.target, q=0.0))
               if c.name == name else c for c in scenario.contacts)
    return dataclasses.replace(scenario, contacts=cs)


@pytest.mark.parametrize("build", [
    lambda s: HeadingPlanner(s),
    lambda s: ObjectiveEvaluator(s),
    lambda s: schedule_pings(s, budget=1, method="greedy"),
])
def test_one_contact_without_process_noise_is_refused_naming_target_q(build):
    with pytest.raises(ScenarioError, match=r"field 'target\.q': expected > 0: the "
                       r"closed-form bound \(brehard2005\).*received 0\.0"):
        build(_without_noise(load_problem("default")))


@pytest.mark.parametrize("build", [
    lambda cs: ContactsPlanner(cs),
    lambda cs: schedule_contact_pings(cs, budget=1, method="greedy"),
])
def test_a_contact_of_several_without_process_noise_is_named(build):
    sc = _without_noise(load_problem("three-contacts-screen"), "bravo")
    with pytest.raises(ScenarioError, match=r"field 'contacts\[1\]\.target\.q'.*"
                       r"\(contact 'bravo'\), received 0\.0"):
        build(ContactSet.from_scenario(sc))


def test_a_constant_turn_target_is_refused_naming_its_model():
    """A constant-turn target has q = 0 by its schema (q > 0 is refused there): the refusal
    names ``target.model`` rather than advising a q > 0 that the file cannot take."""
    sc = load_problem("two-contacts-crossing")
    ct = load_problem("clavard2013-halfturn-cw").target
    one = sc.contact_view("alpha")
    with pytest.raises(ScenarioError, match=r"field 'target\.model': expected 'ncv' or "
                       r"'multi-leg': the closed-form bound.*received 'constant-turn'"):
        HeadingPlanner(dataclasses.replace(one, contacts=(dataclasses.replace(
            one.contacts[0], target=ct),)))
    cs = tuple(dataclasses.replace(c, target=ct) if c.name == "bravo" else c
               for c in sc.contacts)
    with pytest.raises(ScenarioError, match=r"field 'contacts\[1\]\.target\.model'.*"
                       r"\(contact 'bravo'\), received 'constant-turn'"):
        ContactsPlanner(ContactSet.from_scenario(dataclasses.replace(sc, contacts=cs)))
