"""Estimators: particle filter (+ bearings-only initialisation), batch ML, range-only filter.

Interfaces: :class:`Filter` (recursive filters, driven by the one loop :func:`drive`) and
:class:`Estimator` (what :func:`run` runs). Entry point: :func:`run` (one estimator on one run
→ :class:`Track`); an estimator over Monte Carlo runs against its bound is
:func:`tmaplan.evaluation.tracking.monte_carlo`, in the evaluation layer above.
"""

from __future__ import annotations

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
