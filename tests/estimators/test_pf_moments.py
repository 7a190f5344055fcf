"""The compiled innovation moments of a bearing over a cloud
(:func:`tmaplan.estimators.pf_moments.bearing_moments`) against numpy's formula, and the
monitor's innovation choosing them for the compiled kernels' clouds only."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tmaplan.estimators.consistency import innovation
from tmaplan.estimators.particle_filter import PFState
from tmaplan.estimators.pf_kernels import particle_rows
from tmaplan.estimators.pf_moments import bearing_moments
from tmaplan.geometry import wrap_angle
from tmaplan.simulate import Measurement


def _numpy_moments(X, w, z):
    d = wrap_angle(z - np.arctan2(X[:, 0], X[:, 1]))
    nu = float(w @ d)
    return nu, float(w @ (d - nu) ** 2)


def _cloud(rng, n, spread):
    """n particles around a random bearing, ``spread`` [rad] wide, 1-30 km away."""
    b = rng.uniform(-math.pi, math.pi) + rng.uniform(-spread, spread, n)
    r = rng.uniform(1e3, 3e4, n)
    X = np.column_stack([r * np.sin(b), r * np.cos(b), rng.normal(0, 5, (n, 2))])
    w = rng.random(n)
    return np.asfortranarray(X), w / w.sum()


@pytest.mark.parametrize("n", [1, 2, 7, 3000, 20_000])
@pytest.mark.parametrize("spread", [0.01, 1.0, math.pi])
def test_the_compiled_moments_equal_numpys(n, spread):
    rng = np.random.default_rng(n + int(100 * spread))
    for _ in range(5):
        X, w = _cloud(rng, n, spread)
        z = rng.uniform(-math.pi, math.pi)
        nu, var = bearing_moments(particle_rows(X), w, z)
        ref_nu, ref_var = _numpy_moments(X, w, z)
        assert abs(nu - ref_nu) <= 1e-12 and abs(var - ref_var) <= 1e-12 * max(1.0, ref_var)


def test_residuals_across_the_wrap():
    """Particles just either side of the bearing opposite z: residuals ±(π − ε), whose mean
    is about 0 and whose variance about π² (a wrong wrap gives 2π-sized residuals)."""
    z = math.radians(10.0)
    eps = np.array([1e-3, -1e-3, 2e-3, -2e-3])
    b = z + math.pi + eps
    X = np.column_stack([1e4 * np.sin(b), 1e4 * np.cos(b), np.zeros((4, 2))])
    w = np.full(4, 0.25)
    nu, var = bearing_moments(particle_rows(X), w, z)
    ref = _numpy_moments(X, w, z)
    assert abs(nu - ref[0]) <= 1e-12 and abs(var - ref[1]) <= 1e-12
    assert abs(nu) < 1e-12 and abs(var - (math.pi - 1.5e-3) ** 2) < 1e-5


def test_innovation_uses_them_for_compiled_clouds_only(monkeypatch):
    import tmaplan.estimators.pf_moments as pm

    calls = []
    monkeypatch.setattr(pm, "bearing_moments",
                        lambda *a: calls.append(1) or bearing_moments(*a))
    rng = np.random.default_rng(3)
    X, w = _cloud(rng, 3000, 0.3)
    lw = np.log(w)
    numpy_state = PFState(step=0, particles=X, log_weights=lw, ess=1.0, kernel="numpy")
    numba_state = dataclasses.replace(numpy_state, kernel="numba")
    bearing = Measurement(kind="bearing", value=0.4, sigma=0.02)
    ref_nu, ref_var = _numpy_moments(X, numpy_state.weights, 0.4)
    nu, S = innovation(numpy_state, bearing)  # numpy's formula, bit for bit
    assert (nu, S) == (ref_nu, 0.02**2 + ref_var)
    assert not calls
    nu2, S2 = innovation(numba_state, bearing)
    assert calls and abs(nu2 - nu) <= 1e-12 and abs(S2 - S) <= 1e-12
    # a π-ambiguous bearing and a range keep numpy's formula whatever the kernel
    for m in (Measurement(kind="bearing", value=0.4, sigma=0.02, ambiguity="pi"),
              Measurement(kind="range", value=9e3, sigma=50.0)):
        assert innovation(numba_state, m) == innovation(numpy_state, m)
    assert len(calls) == 1


def test_edge_clouds_as_numpys():
    """A particle exactly at the own ship (numpy: ``arctan2(0, 0) = 0``, residual ``wrap(z)``)
    and one at an infinite distance (numpy: a finite residual) give numpy's moments in the
    monitor's innovation (the compiled pass: NaN for the latter, numpy's formula then)."""
    z = 2.9
    bearing = Measurement(kind="bearing", value=z, sigma=0.02)
    for bad in ([0.0, 0.0], [np.inf, 3e3], [-2e3, -np.inf]):
        X = np.asfortranarray([[*bad, 0.0, 0.0], [1e3, 2e3, 0.0, 0.0], [-4e3, 1e3, 0.0, 0.0]])
        w = np.array([0.5, 0.3, 0.2])
        state = PFState(step=0, particles=X, log_weights=np.log(w), ess=1.0, kernel="numba")
        nu, S = innovation(state, bearing)
        ref = _numpy_moments(X, state.weights, z)
        assert abs(nu - ref[0]) <= 1e-12 and abs(S - 0.02**2 - ref[1]) <= 1e-12, (bad, nu, ref)
        finite = np.isfinite(X).all()
        assert np.isfinite(bearing_moments(particle_rows(X), w, z)).all() == finite


@pytest.mark.parametrize(("A", "w"), [(np.zeros((1, 3)), np.ones(3)),
                                      (np.zeros((4, 3)), np.ones(2)),
                                      (np.zeros(3), np.ones(3)),
                                      (np.zeros((4, 3)), np.ones((3, 1)))])
def test_shapes_are_checked(A, w):
    from tmaplan.errors import ArgumentError

    with pytest.raises(ArgumentError, match="bearing_moments"):
        bearing_moments(A, w, 0.1)
