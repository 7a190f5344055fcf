"""How a closed-loop policy's re-plans ended: converged, not converged, fell back.

A re-planning controller (:class:`tmaplan.policies.Receding`) logs one entry per re-plan
(:attr:`tmaplan.evaluation.closed_loop.ClosedLoopRun.replans`); a campaign counts them per
policy (:class:`ReplanCounts`, the ``replans`` of ``tmaplan compare``'s JSON, DESIGN §4):

``total``
    Re-plans attempted: one every ``replan_interval`` and one at each consistency alarm.
``converged``
    Re-plans that ended with a new plan from a successful solve (IPOPT at its tolerance, or
    an accepted step of the real-time iteration), which the own ship flies from then on.
``not_converged``
    ``total − converged``: re-plans that ended without a new plan (every solve tried stopped
    at its iteration limit or failed, the problem was infeasible, the estimate was inside the
    keep-out range); the own ship flies on the previous plan (straight before the first).
``fell_back``
    Re-plans whose first solve did not give the plan, so that the controller used a fallback:
    another solve (the fallback starts of :class:`~tmaplan.policies.Receding`, or the IPOPT
    solve of a rejected real-time-iteration step) or, when that failed too, the previous plan.
    Every re-plan not converged fell back; ``fell_back − not_converged`` re-plans were
    rescued by a fallback solve.

A policy that never re-plans counts zeros. Above :data:`NOT_CONVERGED_WARNING` of its
re-plans not converged, a campaign warns (:class:`ReplanWarning`).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["NOT_CONVERGED_WARNING", "ReplanCounts", "ReplanWarning", "replan_cell",
           "replan_flags", "warn_not_converged"]

#: Share of a policy's re-plans not converged above which a campaign warns.
NOT_CONVERGED_WARNING = 0.01


class ReplanWarning(RuntimeWarning):
    """More than :data:`NOT_CONVERGED_WARNING` of a policy's re-plans did not converge: its
    own ship flew a kept plan that often, and the comparison says less about the policy."""


def replan_flags(log: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray]:
    """Per re-plan of a controller's log: whether it converged and whether it fell back.

    Parameters
    ----------
    log : sequence of dict
        Re-planning log (:attr:`~tmaplan.evaluation.closed_loop.ClosedLoopRun.replans`): an
        entry's ``success`` says it converged; its ``fell_back`` (default: not ``success``)
        that the controller used a fallback.

    Returns
    -------
    converged, fell_back : ndarray of bool, shape (n_replans,)
    """
    ok = np.array([bool(e["success"]) for e in log], dtype=bool)
    back = np.array([bool(e.get("fell_back", not e["success"])) for e in log], dtype=bool)
    return ok, back


@dataclasses.dataclass(frozen=True, kw_only=True)
class ReplanCounts:
    """Re-plans of a policy, counted (module docstring).

    Attributes
    ----------
    total, converged, not_converged, fell_back : int
        Re-plans attempted, ended with a converged plan, ended without one, and that used a
        fallback (``not_converged <= fell_back <= total``).
    """

    total: int = 0
    converged: int = 0
    not_converged: int = 0
    fell_back: int = 0

    @classmethod
    def count(cls, runs: Iterable[tuple[np.ndarray, np.ndarray]]) -> ReplanCounts:
        """Sum over runs of ``(converged, fell_back)`` flags (:func:`replan_flags`)."""
        total = ok = back = 0
        for converged, fell_back in runs:
            c, f = np.asarray(converged, bool), np.asarray(fell_back, bool)
            total, ok, back = total + c.size, ok + int(c.sum()), back + int((f | ~c).sum())
        return cls(total=total, converged=ok, not_converged=total - ok, fell_back=back)

    @property
    def not_converged_share(self) -> float:
        """``not_converged / total`` (0 without re-plans)."""
        return self.not_converged / self.total if self.total else 0.0

    def to_json(self) -> dict[str, int]:
        """``{total, converged, not_converged, fell_back}`` (DESIGN §4)."""
        return dataclasses.asdict(self)

    def text(self) -> str:
        """One phrase for tables: ``"37 re-plans, 1 not converged (2.7 %), 3 fell back"``."""
        if not self.total:
            return "no re-plans"
        return (f"{self.total} re-plans, {self.not_converged} not converged "
                f"({100 * self.not_converged_share:.1f} %), {self.fell_back} fell back")


def warn_not_converged(counts: Mapping[str, ReplanCounts]) -> None:
    """One :class:`ReplanWarning` naming every policy with more than
    :data:`NOT_CONVERGED_WARNING` of its re-plans not converged (none if there is none).

    Parameters
    ----------
    counts : mapping of str to ReplanCounts
        Per policy name.
    """
    over = [f"{name} {c.not_converged} of {c.total} ({100 * c.not_converged_share:.1f} %)"
            for name, c in counts.items() if c.not_converged_share > NOT_CONVERGED_WARNING]
    if over:
        warnings.warn(f"re-plans not converged above {100 * NOT_CONVERGED_WARNING:g} %: "
                      f"{'; '.join(over)}; the own ship kept its previous plan there "
                      "(docs/cli.md, 'Re-plans')", ReplanWarning, stacklevel=2)


def replan_cell(counts: ReplanCounts) -> str:
    """The console tables' re-plan cell (``tmaplan compare``, ``tmaplan demo``): two spaces
    and :meth:`ReplanCounts.text`, or "" for a policy that does not re-plan."""
    return f"  {counts.text()}" if counts.total else ""
