"""The rules of a scenario that need its motion model, checked when a scenario is loaded for use.

:mod:`tmaplan.scenario` validates everything a scenario's own values say (it sits below the
models and imports none of them); what only the motion model can tell is checked here, one
layer up, by :func:`check_scenario`, which the command line runs on every scenario it loads
(:func:`tmaplan.cli.main`), before any verb's work:

* an observer leg flown with a turn rate must not start before the previous leg's turn has
  ended (:func:`tmaplan.models.observer.observer_track` integrates the turns; a leg starting
  inside one could not start at its start).

The same model refuses such a scenario wherever it builds the track (a simulation, a bound,
a planner); :func:`check_scenario` says so at once, naming the field. Suspicious but legal
scenarios that need the motion model are warned by :mod:`tmaplan.models.plausibility`.
"""

from __future__ import annotations

from tmaplan.models.observer import observer_track
from tmaplan.scenario import Scenario

__all__ = ["check_scenario"]


def check_scenario(scenario: Scenario, *, source: str | None = None) -> None:
    """Refuse a scenario that breaks a rule of the module notes.

    Parameters
    ----------
    scenario : Scenario
        Validated by :mod:`tmaplan.scenario` (loaded, or built by ``Scenario.replace``).
    source : str, optional
        File or problem name for the message (default: the scenario's name).

    Raises
    ------
    ScenarioError
        Naming the field, the expected and the received value.
    """
    o = scenario.observer
    if any(leg.turn_rate is not None for leg in o.legs):
        observer_track(o, scenario.time, source=scenario.name if source is None else source)
