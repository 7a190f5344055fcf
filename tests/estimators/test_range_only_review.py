"""Review of the range-only filter (tmaplan.estimators.range_only): the predictive range
density of every mode, and the refusal of invalid settings and measurements."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import multivariate_normal

from tmaplan.errors import ArgumentError
from tmaplan.estimators import (
    RangeOnlyConfig,
    from_gaussian,
    range_only_update,
    reduce_mixture,
    single_point_prior,
)

X = np.array([3000.0, 4000.0, 1.0, -1.0])
P = np.diag([300.0**2, 200.0**2, 1.0, 1.0])
P[0, 1] = P[1, 0] = 1.5e4


def _log_p_r(r: float, s: float) -> float:
    """log ∫ N(r b(θ); x̂, P_pos + s²I) r dθ by adaptive quadrature."""
    d = multivariate_normal(X[:2], P[:2, :2] + s * s * np.eye(2))
    val, _ = quad(lambda t: d.pdf(r * np.array([np.cos(t), np.sin(t)])) * r,
                  -np.pi, np.pi, limit=200, points=[np.arctan2(X[1], X[0])])
    return float(np.log(val))


@pytest.mark.parametrize("mode", ["mixture", "moments", "dirac"])
def test_every_mode_reports_the_predictive_range_density(mode):
    # RangeOnlyState.log_likelihood is documented as log p(r_k | r_1:k−1); the moment and
    # Dirac modes left it at 0.0.
    r, s = 5150.0, 20.0
    post = range_only_update(from_gaussian(X, P), r, s,
                             RangeOnlyConfig(dt=1.0, q=0.0, mode=mode))
    assert post.log_likelihood == pytest.approx(_log_p_r(r, s), abs=1e-6)


@pytest.mark.parametrize(("field", "value"), [
    ("max_components", "3"), ("max_components", True), ("max_components", 2.7),
    ("max_sectors", 0), ("n_points", 0), ("n_moments", 0), ("series_terms", -1),
    ("tail", 0.7), ("tail", -0.1), ("prune", 2.0), ("prune", float("nan")),
    ("dt", float("inf")), ("q", float("inf")), ("sagitta", float("inf")),
])
def test_config_refuses_invalid_settings(field, value):
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        RangeOnlyConfig(**{"dt": 60.0, "q": 0.01, field: value})


@pytest.mark.parametrize("mode", ["mixture", "moments", "dirac"])
@pytest.mark.parametrize(("field", "r", "s"), [
    ("r", float("nan"), 10.0),  # was silently skipped like a negative range
    ("sigma_r", 5100.0, 0.0),
    ("sigma_r", 5100.0, -10.0),  # mixture: "array is too big"; moments: squared away
    ("sigma_r", 5100.0, float("nan")),
])
def test_update_refuses_invalid_measurements(mode, field, r, s):
    cfg = RangeOnlyConfig(dt=1.0, q=0.0, mode=mode)
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        range_only_update(from_gaussian(X, P), r, s, cfg)


def test_non_positive_range_still_skips_the_update():
    st = from_gaussian(X, P)
    assert range_only_update(st, -3.0, 10.0, RangeOnlyConfig(dt=1.0, q=0.0)) is st


def test_reduce_mixture_refuses_an_empty_target():
    gm = range_only_update(from_gaussian(X, P), 5150.0, 5.0, RangeOnlyConfig(dt=1.0, q=0.0))
    assert gm.n_components > 1
    with pytest.raises(ArgumentError, match="field 'max_components'"):
        reduce_mixture(gm, 0)  # returned a mixture of no component
    with pytest.raises(ArgumentError, match="field 'prune'"):
        reduce_mixture(gm, 2, prune=2.0)  # pruned every component


@pytest.mark.parametrize(("field", "kw"), [
    ("r0", {"r0": float("nan")}), ("r0", {"r0": -1e4}),
    ("sigma_r", {"sigma_r": -10.0}), ("velocity_std", {"velocity_std": float("nan")}),
    ("velocity_mean", {"velocity_mean": np.zeros(3)}),
])
def test_single_point_prior_refuses_invalid_input(field, kw):
    args = dict(r0=1e4, bearing0=0.7, sigma_r=10.0, sigma_bearing=0.01,
                velocity_mean=np.zeros(2), velocity_std=3.0)
    args.update(kw)
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        single_point_prior(**args)
