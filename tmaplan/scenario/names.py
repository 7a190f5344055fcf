"""The names a scenario file may give that the layers above implement: the one list of each.

The scenario schema validates ``planning.objective`` against :data:`OBJECTIVE_NAMES`; the
planner builds each of them (:func:`tmaplan.planning.objectives.make_objective`, which imports
this list, and ``tests/test_architecture.py`` checks that its table builds every name). A new
cost functional adds its name here and its constructor there (docs/architecture.md).
"""

from __future__ import annotations

from typing import Literal, get_args

__all__ = ["CONTACTS_OBJECTIVE_NAMES", "DEFAULT_CONTACT", "DEFAULT_CONTACTS_OBJECTIVE",
           "DEFAULT_OBJECTIVE", "DEFAULT_REQUIRED_ACCURACY", "OBJECTIVE_NAMES",
           "ContactsObjectiveName", "ObjectiveName"]

#: Names accepted by :func:`tmaplan.planning.objectives.make_objective` (heading objectives;
#: the scenario's ``planning.objective`` and ``tmaplan plan --objective``).
ObjectiveName = Literal["logdet", "range-bound", "position-bound", "mean-range-bound",
                        "terminal-range-bound", "mean-position-bound", "terminal-position-bound",
                        "relative-range-bound", "mean-relative-range-bound",
                        "relative-range-crlb", "mean-relative-range-crlb", "time-to-accuracy",
                        "expected-time-to-accuracy"]
OBJECTIVE_NAMES: tuple[str, ...] = get_args(ObjectiveName)
#: Default heading objective (``tmaplan plan``, ``planning.objective``, the closed-loop
#: ``planned``/``receding`` policies): the one whose ranking of manoeuvres agrees best with the
#: Monte Carlo time to accuracy of the filter (``tmaplan rank-costs``, docs/findings.md).
DEFAULT_OBJECTIVE = "expected-time-to-accuracy"

#: Name of the one contact of a file that gives a bare ``[target]``/``[prior]``.
DEFAULT_CONTACT = "contact"
#: Relative range accuracy [-] at which a contact counts as localised unless the scenario
#: (``planning.required_accuracy``) or the contact (``required_accuracy``) says otherwise.
DEFAULT_REQUIRED_ACCURACY = 0.1
#: Objectives of a plan for several contacts at once (issue 40, DESIGN.md §6;
#: :func:`tmaplan.planning.multi_objectives.contacts_objective` builds each): the expected time
#: until every contact is localised, the weighted mean of the contacts' expected times, and the
#: worst contact's expected time (min-max through an epigraph variable).
ContactsObjectiveName = Literal["all-contacts-time-to-accuracy", "weighted-time-to-accuracy",
                                "worst-contact"]
CONTACTS_OBJECTIVE_NAMES: tuple[str, ...] = get_args(ContactsObjectiveName)
#: Default objective of a plan for several contacts.
DEFAULT_CONTACTS_OBJECTIVE = "all-contacts-time-to-accuracy"
