"""Estimators: particle filter (+ bearings-only initialisation), batch ML, range-only filter.

Entry points: :func:`run` (one estimator on one run → :class:`Track`) and :func:`monte_carlo`.
"""

from __future__ import annotations

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
    RangeOnlyState,
    range_only_predict,
    range_only_update,
    single_point_prior,
)
from tmaplan.estimators.range_only_gm import (
    MixtureConfig,
    RangeOnlyMixture,
    mixture_from_gaussian,
    mixture_predict,
    mixture_update,
    reduce_mixture,
)
from tmaplan.estimators.runner import (
    ESTIMATORS,
    MonteCarloResult,
    Track,
    measurement_batches,
    monte_carlo,
    run,
    run_prior,
)

__all__ = [
    "ESTIMATORS",
    "BearingsInit",
    "DegeneracyWarning",
    "GvM2",
    "MLEConfig",
    "MLEResult",
    "Measurement",
    "MixtureConfig",
    "MonteCarloResult",
    "PFConfig",
    "PFState",
    "ParticleFilter",
    "RMPFit",
    "RangeOnlyConfig",
    "RangeOnlyMixture",
    "RangeOnlyState",
    "TMAData",
    "Track",
    "acceptance_threshold",
    "dirac_mixture",
    "fisher_information",
    "fit_rmp",
    "gvm2_from_gaussian",
    "initialise_from_bearings",
    "measurement_batches",
    "mixture_from_gaussian",
    "mixture_predict",
    "mixture_update",
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
    "single_point_prior",
    "state_track",
    "systematic_resample",
    "tma_data",
    "update",
]
