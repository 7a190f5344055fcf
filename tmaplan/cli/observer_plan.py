"""``--observer-plan FILE`` of ``track`` and ``simulate``: fly a plan (docs/recordings.md).

The file is a plan's JSON (``tmaplan plan P --json PLAN.json``: its ``observer`` track,
checked against the problem as ``schedule --observer-plan`` checks it) or a leg table
(``legs.csv``, :func:`tmaplan.io.read_legs_csv`). The plan becomes the scenario's
``observer.turn_rates`` (the mean turn rate over each step, at the scenario's speed), so the
simulation, the estimators and the bounds all fly it; after the plan's end the own ship holds
its course.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from tmaplan.cli.schedule import START_TOLERANCE, read_observer_plan
from tmaplan.errors import ArgumentError
from tmaplan.geometry import course_speed
from tmaplan.io.plans import read_legs_csv, step_turn_rates
from tmaplan.models.target import initial_velocity
from tmaplan.scenario import Scenario

__all__ = ["with_observer_plan"]


def with_observer_plan(scenario: Scenario, path: str | Path) -> Scenario:
    """The scenario whose own ship flies the plan in ``path`` (module doc).

    Parameters
    ----------
    scenario : Scenario
    path : str or Path
        ``*.json``: a plan's JSON; otherwise a leg table CSV.

    Returns
    -------
    Scenario

    Raises
    ------
    ArgumentError
        (``--observer-plan``) A plan of another problem or grid, a leg table whose first
        course is not the problem's initial course, a turn rate above the problem's
        ``observer.turn_rate_max``; :class:`~tmaplan.errors.DataError`: the leg table's faults.
    """

    grid = scenario.time
    K, dt = grid.n_steps, float(grid.dt)
    src = str(path)
    if Path(path).suffix.lower() == ".json":
        track = read_observer_plan(path, scenario)
        rates = np.diff(np.unwrap(track.heading)) / dt
    else:
        legs, _ = read_legs_csv(path)
        course0 = float(course_speed(initial_velocity(scenario.observer))[0])
        dc = abs((legs[0].course - course0 + np.pi) % (2 * np.pi) - np.pi)
        if dc > START_TOLERANCE["course"]:
            raise ArgumentError("--observer-plan", f"a leg table starting on the problem's "
                                f"initial course {np.degrees(course0) % 360:.4g}°",
                                f"{np.degrees(legs[0].course):.4g}°", source=src)
        rates = step_turn_rates(legs, dt, K)
    u = np.zeros(K)
    u[:min(K, rates.size)] = rates[:K]
    limit = scenario.observer.turn_rate_max
    if limit is not None:
        top = float(np.max(np.abs(u))) if u.size else 0.0
        if top > limit * (1 + 1e-6):
            raise ArgumentError("--observer-plan", f"turn rates within the problem's "
                                f"observer.turn_rate_max {np.degrees(limit):.4g}°/s",
                                f"{np.degrees(top):.4g}°/s", source=src)
        u = np.clip(u, -limit, limit)  # the solver's round-off
    obs = dataclasses.replace(scenario.observer, legs=(), turn_rates=tuple(float(x) for x in u))
    return scenario.replace(observer=obs)
