"""Evaluation layer: simulation in the loop, closed loop, estimator Monte Carlo, campaigns,
metrics.

* :mod:`~tmaplan.evaluation.closed_loop`: one run of a policy against a truth, the particle
  filter driven by the one filter loop (:func:`tmaplan.estimators.filter.drive`);
* :mod:`~tmaplan.evaluation.tracking`: an estimator over Monte Carlo runs against its bound;
* :mod:`~tmaplan.evaluation.campaigns`: paired policy comparisons (serial, processes, Dask),
  resumable (public as :mod:`tmaplan.experiments`);
* :mod:`~tmaplan.evaluation.records`: typed run records and the scenario hash;
* :mod:`~tmaplan.evaluation.metrics`: per-run metrics and paired differences.

Truth and measurements come from :mod:`tmaplan.simulate` only.
"""

from tmaplan.evaluation.campaigns import CampaignResult, CampaignSpec, run_campaign, run_one
from tmaplan.evaluation.closed_loop import ClosedLoopRun, run_closed_loop
from tmaplan.evaluation.metrics import (
    PairedDifference,
    RunMetrics,
    paired_difference,
    run_metrics,
    time_to_accuracy,
)
from tmaplan.evaluation.records import PolicyRun, RunRecord, scenario_hash
from tmaplan.evaluation.tracking import MonteCarloResult, monte_carlo

__all__ = [
    "CampaignResult",
    "CampaignSpec",
    "ClosedLoopRun",
    "MonteCarloResult",
    "PairedDifference",
    "PolicyRun",
    "RunMetrics",
    "RunRecord",
    "monte_carlo",
    "paired_difference",
    "run_campaign",
    "run_closed_loop",
    "run_metrics",
    "run_one",
    "scenario_hash",
    "time_to_accuracy",
]
