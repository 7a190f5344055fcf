"""``tmaplan advise``: recorded bearings and own-ship navigation in, each contact's solution
and the advice out (docs/recordings.md).

Modules: :mod:`~tmaplan.advice.problem` (a recorded contact on a time grid, the
:class:`~tmaplan.advice.problem.Platform` settings), :mod:`~tmaplan.advice.solution` (the ML
and particle-filter solutions, the observability verdict), :mod:`~tmaplan.advice.ekelund`
(Ekelund's range), :mod:`~tmaplan.advice.recommend` (the manoeuvre and the pings),
:mod:`~tmaplan.advice.joint` (several contacts: one manoeuvre and one ping schedule for all),
:mod:`~tmaplan.advice.report` (figures and page).
"""

from tmaplan.advice.ekelund import EkelundRange, ekelund_range
from tmaplan.advice.joint import JointAdvice, advise_contacts
from tmaplan.advice.problem import ContactProblem, Platform, contact_problem, read_platform
from tmaplan.advice.recommend import Advice, advise_contact
from tmaplan.advice.solution import ContactSolution, Estimate, contact_rng, solve_contact

__all__ = ["Advice", "ContactProblem", "ContactSolution", "EkelundRange", "Estimate",
           "JointAdvice", "Platform", "advise_contact", "advise_contacts", "contact_problem",
           "contact_rng", "ekelund_range", "read_platform", "solve_contact"]
