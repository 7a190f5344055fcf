"""Review of the particle filter: input validation and multi-line frequency measurements."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.estimators import Measurement, ParticleFilter, PFConfig, systematic_resample
from tmaplan.estimators.particle_filter import PFState


def _state(n: int = 200) -> tuple[ParticleFilter, PFState]:
    rng = np.random.default_rng(0)
    X = np.array([3000.0, 4000.0, 1.0, 1.0]) + rng.normal(0, [100, 100, 1, 1], (n, 4))
    pf = ParticleFilter(PFConfig(n_particles=n, dt=1.0, q=0.0))
    return pf, pf.from_particles(X)


def test_frequency_lines_with_one_std_each_are_assimilated() -> None:
    # simulate builds multi-line frequency measurements with sigma of shape (P,): the σ check
    # must not take the truth value of an array (it raised ValueError).
    pf, st = _state()
    m = Measurement(kind="frequency", value=np.array([100.0, 200.0]),
                    sigma=np.array([1.0, 2.0]))
    out = pf.update(st, [m], np.random.default_rng(1))
    assert out.freq_mean is not None and out.freq_mean.shape == (200, 2)
    assert np.isfinite(out.log_weights).all()
    with pytest.raises(ArgumentError, match=r"measurement\.sigma"):
        pf.update(st, [Measurement(kind="frequency", value=np.array([100.0, 200.0]),
                                   sigma=np.array([1.0, 0.0]))], np.random.default_rng(1))


@pytest.mark.parametrize("sigma", [0.0, -50.0, np.nan])
def test_ping_std_is_validated(sigma: float) -> None:
    # σ = 0 raised ZeroDivisionError and σ < 0 was silently used as |σ| by the progressive
    # correction; a plain range with the same σ is refused.
    pf, st = _state()
    m = Measurement(kind="range", value=5000.0, sigma=sigma, ping=True)
    with pytest.raises(ArgumentError, match=r"measurement\.sigma"):
        pf.update(st, [m], np.random.default_rng(1))


@pytest.mark.parametrize("m", [
    Measurement(kind="bearing", value=np.nan, sigma=0.01),
    Measurement(kind="range", value=np.inf, sigma=10.0),
    Measurement(kind="frequency", value=np.array([100.0, np.nan]), sigma=1.0),
])
def test_non_finite_measurement_value_is_refused(m: Measurement) -> None:
    # It was taken as a weight collapse: a DegeneracyWarning and a roughened cloud.
    pf, st = _state()
    with pytest.raises(ArgumentError, match=r"measurement\.value"):
        pf.update(st, [m], np.random.default_rng(1))


def test_ping_on_a_bearing_is_refused() -> None:
    # A bearing flagged as a ping was assimilated as a *range* by the progressive correction.
    pf, st = _state()
    m = Measurement(kind="bearing", value=0.6, sigma=0.01, ping=True)
    with pytest.raises(ArgumentError, match=r"measurement\.ping"):
        pf.update(st, [m], np.random.default_rng(1))


@pytest.mark.parametrize(("field", "value"), [
    ("dt", np.inf), ("dt", "60"), ("q", np.inf), ("bandwidth_scale", np.nan),
    ("bandwidth_scale", -1.0), ("roughening", np.nan), ("roughening", -0.2),
    ("move_scale", np.nan), ("degeneracy_ess", np.nan), ("move_steps", 1.5),
    ("move_steps", True),
])
def test_config_refuses_invalid_values(field: str, value: object) -> None:
    kw: dict[str, object] = {"n_particles": 100, "dt": 1.0, "q": 0.0, field: value}
    with pytest.raises(ArgumentError, match=field):
        PFConfig(**kw)  # type: ignore[arg-type]


def test_from_particles_validates_log_weights() -> None:
    pf = ParticleFilter(PFConfig(n_particles=10, dt=1.0, q=0.0))
    X = np.ones((10, 4))
    for lw in (np.zeros(5), np.full(10, np.nan), np.full(10, -np.inf),
               np.r_[np.inf, np.zeros(9)]):
        with pytest.raises(ArgumentError, match="log_weights"):
            pf.from_particles(X, log_weights=lw)
    with pytest.raises(ArgumentError, match="particles"):
        pf.from_particles(np.zeros((0, 4)))
    st = pf.from_particles(X, log_weights=np.r_[-np.inf, np.zeros(9)])
    assert st.weights[0] == 0.0 and abs(st.ess - 9.0) < 1e-9


def test_predict_and_from_gaussian_validate_vectors() -> None:
    pf, st = _state()
    rng = np.random.default_rng(2)
    for dv in (np.array([np.nan, 0.0]), np.zeros(3)):
        with pytest.raises(ArgumentError, match="dv"):
            pf.predict(st, dv, rng)
    with pytest.raises(ArgumentError, match="mean"):
        pf.from_gaussian(np.zeros(3), np.eye(4), rng)
    with pytest.raises(ArgumentError, match="cov"):
        pf.from_gaussian(np.zeros(4), -np.eye(4), rng)


def test_systematic_resample_of_unnormalised_log_weights() -> None:
    # exp(−1000) underflowed to 0: the CDF was NaN and every index 0.
    idx = systematic_resample(np.full(10, -1000.0), np.random.default_rng(0))
    np.testing.assert_array_equal(np.sort(idx), np.arange(10))
    with pytest.raises(ArgumentError, match="n"):
        systematic_resample(np.zeros(4), np.random.default_rng(0), n=0)
    with pytest.raises(ArgumentError, match="log_weights"):
        systematic_resample(np.full(4, np.nan), np.random.default_rng(0))
