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
    Re-plans that ended without a new plan because the solver did not converge: every solve
    tried stopped at IPOPT's iteration limit or failed (any error of the planner but an
    infeasible problem). The own ship flies on the previous plan (straight before the first).
``fell_back``
    Re-plans whose first solve did not give the plan, so that the controller used a fallback:
    another solve (the fallback starts of :class:`~tmaplan.policies.Receding`, or the IPOPT
    solve of a rejected real-time-iteration step) or, when that failed too, the previous plan.
    Every re-plan that ended without a new plan fell back.

``total − converged − not_converged`` (:attr:`ReplanCounts.infeasible`, not a key of the
JSON) re-plans ended without a new plan because no plan satisfies the constraints
(:class:`tmaplan.errors.InfeasibleError`: the target estimate already inside the keep-out
range, or IPOPT finding the problem infeasible from every start): not a failure to converge.
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


def replan_flags(log: Sequence[Mapping[str, Any]]) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray]:
    """Per re-plan of a controller's log: whether it converged, fell back, was infeasible.

    Parameters
    ----------
    log : sequence of dict
        Re-planning log (:attr:`~tmaplan.evaluation.closed_loop.ClosedLoopRun.replans`): an
        entry's ``success`` says it converged; its ``fell_back`` (default: not ``success``)
        that the controller used a fallback; its ``infeasible`` (default False) that it
        ended without a plan because no plan satisfies the constraints.

    Returns
    -------
    converged, fell_back, infeasible : ndarray of bool, shape (n_replans,)
    """
    ok = np.array([bool(e["success"]) for e in log], dtype=bool)
    back = np.array([bool(e.get("fell_back", not e["success"])) for e in log], dtype=bool)
    bad = np.array([bool(e.get("infeasible", False)) for e in log], dtype=bool)
    return ok, back, bad & ~ok


@dataclasses.dataclass(frozen=True, kw_only=True)
class ReplanCounts:
    """Re-plans of a policy, counted (module docstring).

    Attributes
    ----------
    total, converged, not_converged, fell_back : int
        Re-plans attempted, ended with a converged plan, ended without one as the solver did
        not converge, and that used a fallback
        (``converged + not_converged <= total``, ``total − converged <= fell_back <= total``).
    """

    total: int = 0
    converged: int = 0
    not_converged: int = 0
    fell_back: int = 0

    @classmethod
    def count(cls, runs: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray]]
              ) -> ReplanCounts:
        """Sum over runs of ``(converged, fell_back, infeasible)`` flags
        (:func:`replan_flags`)."""
        total = ok = back = bad = 0
        for converged, fell_back, infeasible in runs:
            c, f = np.asarray(converged, bool), np.asarray(fell_back, bool)
            i = np.asarray(infeasible, bool) & ~c
            total, ok = total + c.size, ok + int(c.sum())
            back, bad = back + int((f | ~c).sum()), bad + int(i.sum())
        return cls(total=total, converged=ok, not_converged=total - ok - bad, fell_back=back)

    @property
    def infeasible(self) -> int:
        """Re-plans that ended without a plan as no plan satisfies the constraints
        (``total − converged − not_converged``)."""
        return self.total - self.converged - self.not_converged

    @property
    def not_converged_share(self) -> float:
        """``not_converged / total`` (0 without re-plans)."""
        return self.not_converged / self.total if self.total else 0.0

    def to_json(self) -> dict[str, int]:
        """``{total, converged, not_converged, fell_back}`` (DESIGN §4)."""
        return dataclasses.asdict(self)

    def text(self) -> str:
        """One phrase for tables: ``"37 re-plans, 1 not converged (2.7 %), 3 fell back"``
        (and ``", 2 infeasible"`` before the last if there were)."""
        if not self.total:
            return "no re-plans"
        bad = f", {self.infeasible} infeasible" if self.infeasible else ""
        return (f"{self.total} re-plans, {self.not_converged} not converged "
                f"({100 * self.not_converged_share:.1f} %){bad}, {self.fell_back} fell back")


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
