"""tmaplan — sensor management and observer-trajectory planning for target motion analysis.

The front door: the handful of names a user starts from, each defined once in the package
named below and exported here (loaded on first use, so that ``import tmaplan`` and the command
line start fast — PEP 562 ``__getattr__``):

- load a problem: :func:`load`, :func:`load_problem`, :class:`Scenario`;
- simulate: the module :mod:`tmaplan.simulate` (its function ``simulate``);
- plan: :func:`plan_heading`, and for several contacts :func:`plan_contacts`;
- schedule pings: :func:`schedule_pings`, :func:`schedule_contact_pings`;
- compare policies: :class:`CampaignSpec`, :func:`run_campaign`;
- recorded data: :func:`read_recording`;
- the errors: :class:`TmaplanError` and its subclasses, :class:`ScenarioWarning`.
"""

from __future__ import annotations

import importlib
from typing import Any

from tmaplan.version import __version__

#: Every name of the front door and the module that defines it (one each).
FRONT_DOOR: dict[str, str] = {
    "load": "tmaplan.scenario",
    "load_problem": "tmaplan.scenario",
    "Scenario": "tmaplan.scenario",
    "plan_heading": "tmaplan.planning",
    "plan_contacts": "tmaplan.planning",
    "schedule_pings": "tmaplan.planning",
    "schedule_contact_pings": "tmaplan.planning",
    "CampaignSpec": "tmaplan.evaluation.campaigns",
    "run_campaign": "tmaplan.evaluation.campaigns",
    "read_recording": "tmaplan.io",
    "TmaplanError": "tmaplan.errors",
    "ArgumentError": "tmaplan.errors",
    "ScenarioError": "tmaplan.errors",
    "DataError": "tmaplan.errors",
    "PlanningError": "tmaplan.errors",
    "InfeasibleError": "tmaplan.errors",
    "SolverError": "tmaplan.errors",
    "EstimationError": "tmaplan.errors",
    "ObservabilityError": "tmaplan.errors",
    "ScenarioWarning": "tmaplan.errors",
}

__all__ = ["FRONT_DOOR", "__version__", *sorted(FRONT_DOOR)]


def __getattr__(name: str) -> Any:
    """The front door's names, imported from their package on first use."""
    if name in FRONT_DOOR:
        value = getattr(importlib.import_module(FRONT_DOOR[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'tmaplan' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(FRONT_DOOR))
