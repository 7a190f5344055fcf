"""Checks of a receding controller's re-plan log that hold on any conforming machine.

Whether one IPOPT re-plan converges depends on the numerical path (the CPU's instruction set,
the BLAS kernels): the tests assert what the controller owes on every machine instead, that
each re-plan either succeeded or is logged as failed with its reason, and that the re-plans
routed to a given solver say so whether they converged or not.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import Any

import numpy as np


def assert_replans_accounted(log: Sequence[dict[str, Any]], times: Sequence[float] | None, *,
                             multi_start: Collection[int] = ()) -> None:
    """Each re-plan of ``log`` at its time converged or is reported as not converged.

    Parameters
    ----------
    log : sequence of dict
        ``ClosedLoopResult.replans`` (the controller's log).
    times : sequence of float or None
        The re-plan times [s] the schedule asks for (the schedule is not solver-dependent);
        None: any increasing times.
    multi_start : collection of int
        Indices of the re-plans asked to run the multi-start: a converged one names the start
        that won (``start``), a failed one says the multi-start failed; no other has a
        ``start``.
    """
    t = [e["t"] for e in log]
    if times is None:
        assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0), t
    else:
        assert t == list(times), t
    for i, e in enumerate(log):
        assert isinstance(e["success"], bool), e
        assert isinstance(e["status"], str) and e["status"], e  # the solver's status or reason
        assert np.isfinite(e["seconds"]) and e["seconds"] >= 0, e
        if e["success"]:
            assert isinstance(e.get("solver"), str) and e["solver"], e
        if i in multi_start:
            if e["success"]:
                assert e["start"].startswith("multi-start: "), e
            else:
                assert "multi-start" in e["status"], e
        else:  # a re-plan that fell back names the fallback start it flew (issue 38)
            assert "start" not in e or e.get("fell_back"), e
