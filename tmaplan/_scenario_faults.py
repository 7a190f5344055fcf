"""Cross-field validation of a scenario's ``[faults]`` table (:mod:`tmaplan.models.faults`).

The per-value rules (probabilities in [0, 1], a wild-bearing spread in (0, π], a bias within
±π/2, units) are in the dataclass annotations; this module checks what they cannot: dropout
windows with ``end > start`` inside the horizon, and target manoeuvres inside the horizon, in
time order, each changing something and giving a course one way only. Every rule raises
:class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received value.
"""

from __future__ import annotations

from typing import Any

from tmaplan.errors import ScenarioError

__all__ = ["check_faults"]


def check_faults(faults: Any, grid: Any, source: str | None) -> None:
    """Validate ``faults`` against the time grid; raise ScenarioError on the first violation.

    Parameters
    ----------
    faults : Faults
    grid : TimeGrid
    source : str or None
        File or problem name for the message.
    """
    t0, t1 = float(grid.t0), float(grid.t0 + grid.horizon)
    for i, d in enumerate(faults.dropouts):
        f = f"faults.dropouts[{i}]"
        if d.end <= d.start:
            raise ScenarioError(f"{f}.end", f"> start = {d.start} s", d.end, source=source)
        if not t0 <= d.start <= t1:
            raise ScenarioError(f"{f}.start", f"within the horizon [{t0}, {t1}] s", d.start,
                                source=source)
    last = t0
    for i, m in enumerate(faults.target_manoeuvres):
        f = f"faults.target_manoeuvres[{i}]"
        if not t0 < m.time <= t1:
            raise ScenarioError(f"{f}.time", f"within the horizon ({t0}, {t1}] s", m.time,
                                source=source)
        if i and m.time <= last:
            raise ScenarioError(f"{f}.time", f"> {last} s (manoeuvres in time order)", m.time,
                                source=source)
        last = m.time
        if m.course is not None and m.course_change is not None:
            raise ScenarioError(f"{f}.course", "either 'course' or 'course_change', not both",
                                {"course": m.course, "course_change": m.course_change},
                                source=source)
        if m.course is None and m.course_change is None and m.speed is None:
            raise ScenarioError(f"{f}.course_change", "'course_change', 'course' or 'speed'",
                                None, source=source)
