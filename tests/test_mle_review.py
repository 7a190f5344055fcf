"""Input checks of the batch MLE (tmaplan.estimators.mle)."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.estimators import MLEConfig, mle, tma_data
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate


@pytest.mark.parametrize(("field", "value"), [
    ("frequencies", -1),  # tma_data's slice [:, :-1] silently dropped the last line
    ("frequencies", 1.5),
    ("model", "cv"),
    ("n_starts", True),
    ("gn_iterations", -1),
    ("max_nfev", 0),
    ("grid_courses", 0),  # an IndexError inside mle
    ("grid_ranges", ()),  # an IndexError inside mle
    ("grid_ranges", (2e3, -4e3)),
    ("grid_speeds", (float("nan"),)),
    ("grid_turn_rates", (0.0, 0.01)),  # ρ = v/|ω| infinite
    ("ambiguity_margin", float("nan")),
])
def test_config_refuses_invalid_settings(field, value):
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        MLEConfig(**{field: value})


def test_initial_must_match_the_model():
    sc = load_problem("ristic-bot-moderate")
    sim = simulate(sc, np.random.default_rng(3))
    d = tma_data(sc, sim.measurements, sim.observer)
    ok = mle(d, MLEConfig(n_starts=1))
    assert mle(d, initial=ok.params).status == "converged"
    with pytest.raises(ArgumentError, match="field 'initial'"):
        mle(d, initial=np.r_[ok.params, 1.0])  # was a numpy broadcasting error
    with pytest.raises(ArgumentError, match="field 'initial'"):
        mle(d, initial=np.full(4, np.nan))  # was "SVD did not converge"
