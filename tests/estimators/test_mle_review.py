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


# ------------------------------------------------- the MLE's bound on an unobservable track
def test_information_covariance_is_the_crlb_and_refuses_a_singular_fim():
    from tmaplan.bounds.batch_fim import true_parameters
    from tmaplan.bounds.crlb import crlb, information_covariance
    from tmaplan.errors import ObservabilityError

    sc = load_problem("clavard2013-halfturn-cw")
    sim = simulate(sc, None)
    data = tma_data(sc, sim.measurements, sim.observer, frequencies=0)
    cov = information_covariance(data, true_parameters(sc, data.track, data.n_lines))
    # the same inverse as the `crlb` verb's, computed through its own path
    np.testing.assert_allclose(cov, crlb(sc, frequencies=0).covariance, rtol=1e-8)
    # `default`'s own ship flies one straight leg: bearings alone do not give the range
    sc = load_problem("default")
    sim = simulate(sc, None)
    data = tma_data(sc, sim.measurements, sim.observer)
    with pytest.raises(ObservabilityError, match="not observable"):
        information_covariance(data, true_parameters(sc, data.track, data.n_lines))


def test_track_mle_refuses_an_unobservable_scenario_before_the_runs(one_line_error):
    # it used to run and print a 368 000 km "bound" (a numerically inverted singular FIM)
    line = one_line_error(["track", "default", "--estimator", "mle", "--runs", "2",
                           "--no-figure"])
    assert "Fisher information is singular" in line and "not observable" in line, line
