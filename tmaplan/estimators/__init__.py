"""Estimators: particle filter (+ bearings-only initialisation), batch ML, range-only filter.

Interfaces: :class:`Filter` (recursive filters, driven by the one loop :func:`drive`) and
:class:`Estimator` (what :func:`run` runs). Entry points: :func:`run` (one estimator on one
run → :class:`Track`) and :func:`monte_carlo` (:mod:`tmaplan.evaluation.tracking`).
"""

from __future__ import annotations

from typing import Any

from tmaplan.estimators.applicability import (
    APPLICABILITY,
    Applicability,
    applicable_estimators,
    check_applicable,
)
from tmaplan.estimators.filter import Filter, FilterRun, FilterState, drive
from tmaplan.estimators.gvm_moments import (
    GvM2,
    dirac_mixture,
    gvm2_from_gaussian,
    moments_grid,
    moments_series,
)
from tmaplan.estimators.init_bearings import (
    BearingsInit,
    RMPFit,
    fit_rmp,
    initialise_from_bearings,
)
from tmaplan.estimators.mle import (
    MLEConfig,
    MLEResult,
    TMAData,
    acceptance_threshold,
    fisher_information,
    mle,
    state_track,
    tma_data,
)
from tmaplan.estimators.particle_filter import (
    DegeneracyWarning,
    Measurement,
    ParticleFilter,
    PFConfig,
    PFState,
    predict,
    systematic_resample,
    update,
)
from tmaplan.estimators.range_only import (
    RangeOnlyConfig,
    RangeOnlyFilter,
    RangeOnlyState,
    from_gaussian,
    range_only_predict,
    range_only_update,
    reduce_mixture,
    single_point_prior,
)
from tmaplan.estimators.runner import (
    ESTIMATORS,
    Estimator,
    FilterEstimator,
    MLEEstimator,
    Track,
    estimator_for,
    run,
    run_prior,
    seed_bearings,
)
from tmaplan.simulate import measurement_batches


def __getattr__(name: str) -> Any:
    # The Monte Carlo evaluation sits in the evaluation layer above (it imports this package).
    if name in ("monte_carlo", "MonteCarloResult"):
        from tmaplan.evaluation import tracking

        return getattr(tracking, name)
    raise AttributeError(f"module 'tmaplan.estimators' has no attribute {name!r}")


__all__ = [
    "APPLICABILITY",
    "ESTIMATORS",
    "Applicability",
    "BearingsInit",
    "DegeneracyWarning",
    "Estimator",
    "Filter",
    "FilterEstimator",
    "FilterRun",
    "FilterState",
    "GvM2",
    "MLEConfig",
    "MLEEstimator",
    "MLEResult",
    "Measurement",
    "MonteCarloResult",
    "PFConfig",
    "PFState",
    "ParticleFilter",
    "RMPFit",
    "RangeOnlyConfig",
    "RangeOnlyFilter",
    "RangeOnlyState",
    "TMAData",
    "Track",
    "acceptance_threshold",
    "applicable_estimators",
    "check_applicable",
    "dirac_mixture",
    "drive",
    "estimator_for",
    "fisher_information",
    "fit_rmp",
    "from_gaussian",
    "gvm2_from_gaussian",
    "initialise_from_bearings",
    "measurement_batches",
    "mle",
    "moments_grid",
    "moments_series",
    "monte_carlo",
    "predict",
    "range_only_predict",
    "range_only_update",
    "reduce_mixture",
    "run",
    "run_prior",
    "seed_bearings",
    "single_point_prior",
    "state_track",
    "systematic_resample",
    "tma_data",
    "update",
]
