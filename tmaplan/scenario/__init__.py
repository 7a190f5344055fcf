"""Scenarios: frozen dataclasses, TOML load/dump, validation.

A scenario holds the time grid, the target's motion model (and prior), the observer's initial
state, constraints and scripted manoeuvres, the sensors and optional planning settings; one or
several contacts (:class:`Contact`, a file's ``[target]``/``[prior]`` or its ``[[contacts]]``
tables, :mod:`~tmaplan.scenario.contacts`). Files are
TOML; every dimensional value may be a plain SI number or a string with a unit (``"12 kn"``,
``"3.5 km"``, ``"45 deg"``, ``"10 min"``), see :mod:`tmaplan.units`.

Load -> dump -> load is the identity (SI values, ``repr`` floats). Every invalid value raises
:class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received value.

The package sits below the motion models (docs/architecture.md, "Layers"), by role:
:mod:`~tmaplan.scenario.schema` (the dataclasses; the sensors in
:mod:`~tmaplan.scenario.sensors`, the ``[faults]`` table in :mod:`~tmaplan.scenario.faults`,
the field types in :mod:`~tmaplan.scenario.quantities`), :mod:`~tmaplan.scenario.names` (the
names a file may give that the layers above implement: the objectives),
:mod:`~tmaplan.scenario.checks` (the rules across fields; the prior's in
:mod:`~tmaplan.scenario.prior_checks`, the plausibility limits and warnings in
:mod:`~tmaplan.scenario.plausible`, bare numbers in :mod:`~tmaplan.scenario.bare`) and
:mod:`~tmaplan.scenario.io` (TOML and the built-in problems). The rules that need the motion
model run above it: :func:`tmaplan.models.checks.check_scenario`.
"""

from __future__ import annotations

from tmaplan.scenario.faults import Faults
from tmaplan.scenario.io import (
    dump,
    from_dict,
    list_problems,
    load,
    load_problem,
    loads,
    problems_dir,
    save,
    to_dict,
)
from tmaplan.scenario.schema import (
    Contact,
    Estimation,
    Observer,
    ObserverLeg,
    Planning,
    Prior,
    Scenario,
    Target,
    TargetLeg,
    TimeGrid,
    measurement_steps,
)
from tmaplan.scenario.sensors import BearingSensor, FrequencySensor, RangeSensor, Sensor

__all__ = [
    "BearingSensor",
    "Contact",
    "Estimation",
    "Faults",
    "FrequencySensor",
    "Observer",
    "ObserverLeg",
    "Planning",
    "Prior",
    "RangeSensor",
    "Scenario",
    "Sensor",
    "Target",
    "TargetLeg",
    "TimeGrid",
    "dump",
    "from_dict",
    "list_problems",
    "load",
    "load_problem",
    "loads",
    "measurement_steps",
    "problems_dir",
    "save",
    "to_dict",
]
