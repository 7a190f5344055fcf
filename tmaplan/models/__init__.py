"""Motion and measurement models: target, observer, sensors (all vectorised)."""

from __future__ import annotations

from tmaplan.models.observer import ObserverTrack, observer_track, turn_rate_track
from tmaplan.models.sensors import (
    bearing_loglik,
    doppler_frequency,
    range_loglik,
    range_rate,
)
from tmaplan.models.target import (
    constant_turn_state,
    ncv_matrices,
    target_track,
)

__all__ = [
    "ObserverTrack",
    "bearing_loglik",
    "constant_turn_state",
    "doppler_frequency",
    "ncv_matrices",
    "observer_track",
    "range_loglik",
    "range_rate",
    "target_track",
    "turn_rate_track",
]
