"""The particle filter's fused numba launches (issue 42) against the unfused ones.

A numba prediction is computed lazily (:class:`tmaplan.estimators.pf_numba.PredictedState`):
when the update comes first, the prediction and the log-weights run in one launch
(``_fused_kernel``); when the particles are read first, the prediction runs alone and the
update as before. Both orders give the same bits, step after step, with resampling (one
launch for the indices and the gather, against the two kernels of before).
"""

from __future__ import annotations

import dataclasses
import pickle
from typing import Any

import numpy as np
import pytest

from tmaplan.estimators import Measurement, ParticleFilter, PFConfig, PFState
from tmaplan.estimators import pf_numba as nb


def _cloud(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.multivariate_normal([3000.0, -8000.0, 2.0, -3.0],
                                   np.diag([2e6, 3e6, 4.0, 9.0]), n)


_MEAS = [Measurement(kind="bearing", value=2.8, sigma=0.05),
         Measurement(kind="bearing", value=-3.13, sigma=0.08),
         Measurement(kind="range", value=8500.0, sigma=900.0)]


def _steps(variant: str, n: int, clutter: float, read_first: bool, steps: int = 6
           ) -> list[tuple[np.ndarray, ...]]:
    """``steps`` predict/update pairs; ``read_first``: read the predicted particles before
    the update (the unfused path)."""
    pf = ParticleFilter(PFConfig(n_particles=n, dt=10.0, q=1e-3, variant=variant,  # type: ignore[arg-type]
                                 bearing_clutter=clutter, kernel="numba"))
    rng = np.random.default_rng(3)
    st = pf.from_particles(_cloud(n))
    out = []
    for k in range(steps):
        st = pf.predict(st, np.array([0.1 * k, -0.2]), rng)
        assert isinstance(st, nb.PredictedState) and nb.pending(st) is not None
        if read_first:
            assert st.particles.shape == (n, 4)
            assert nb.pending(st) is None
        st = pf.update(st, _MEAS[: 1 + k % 3], rng)
        out.append((st.particles.copy(), st.log_weights.copy(), st.weights.copy(),
                    np.array([st.ess, float(st.resampled)])))
    return out


@pytest.mark.parametrize(("variant", "n", "clutter"), [
    ("bootstrap", 1500, 0.0),  # the serial build
    ("bootstrap", nb.BLOCK * 9 + 5, 0.05),  # parallel, a partial last block
    ("resample-move", nb.BLOCK * 9 + 5, 0.0),
    ("regularised", nb.BLOCK * 9 + 5, 0.0),
])
def test_fused_update_equals_the_unfused_path_bit_for_bit(variant: str, n: int,
                                                          clutter: float) -> None:
    fused = _steps(variant, n, clutter, read_first=False)
    unfused = _steps(variant, n, clutter, read_first=True)
    assert any(s[3][1] for s in fused)  # some steps resampled
    for a, b in zip(fused, unfused):
        for x, y in zip(a, b):
            assert np.array_equal(x, y)


def test_the_fused_path_runs_one_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    n = nb.BLOCK * 9 + 5
    pf = ParticleFilter(PFConfig(n_particles=n, dt=10.0, q=1e-3, kernel="numba"))
    st = pf.predict(pf.from_particles(_cloud(n)), None, np.random.default_rng(1))

    class Fail:  # the prediction's own launch fails; the serial build stays callable (the
        # serial path runs the two serial kernels one after the other: no launch to save)
        ser = nb._predict_kernel.ser

        def __call__(self, *args: Any) -> None:
            raise AssertionError("the prediction ran on its own")

    monkeypatch.setattr(nb, "_predict_kernel", Fail())
    new = pf.update(st, _MEAS, np.random.default_rng(2))
    assert nb.pending(st) is None and st.particles.shape == (n, 4)
    assert np.isfinite(new.log_weights).all()
    # a π-ambiguous bearing needs the particles first: the prediction runs on its own
    st = pf.predict(new, None, np.random.default_rng(3))
    with pytest.raises(AssertionError, match="on its own"):
        pf.update(st, [Measurement(kind="bearing", value=1.0, sigma=0.1, ambiguity="pi")],
                  np.random.default_rng(4))


def test_a_pending_prediction_behaves_as_a_state() -> None:
    n = 3000
    pf = ParticleFilter(PFConfig(n_particles=n, dt=10.0, q=1e-3, kernel="numba"))
    st0 = pf.from_particles(_cloud(n))
    eager = nb.predict_rows(np.ascontiguousarray(_cloud(n).T), 10.0,
                            (1.0, 0.0, 1.0), np.zeros(2), np.random.default_rng(9))
    assert eager.shape == (4, n)
    st = pf.predict(st0, None, np.random.default_rng(5))
    copy = pickle.loads(pickle.dumps(st))  # pickled before the particles are computed
    assert isinstance(st, PFState) and nb.pending(copy) is not None
    moved = dataclasses.replace(st, ess=1.0)  # reads the particles
    assert np.array_equal(moved.particles, st.particles) and moved.ess == 1.0
    assert st.particles is st.particles  # computed once
    assert np.array_equal(copy.particles, st.particles)
    np.testing.assert_allclose(st.mean, st.particles.mean(axis=0), rtol=1e-12)
    assert "PredictedState" in repr(st)


@pytest.mark.parametrize("n", [1, 2, 1000, nb.PARALLEL_MIN + 3])
def test_resampling_with_the_gather_equals_the_two_kernels(n: int) -> None:
    rng = np.random.default_rng(n)
    A = np.ascontiguousarray(_cloud(n, 4).T)
    for _ in range(3):
        w = rng.exponential(size=n) ** 3
        w /= w.sum()
        u = float(rng.random())
        idx, B = nb.resample(w, u, A)
        ref = nb.systematic(w, u)
        assert np.array_equal(idx, ref) and B is not None
        assert np.array_equal(B, A[:, ref])
        assert np.array_equal(B, nb.gather(A, ref, None, None))
    assert nb.resample(w, u, None)[1] is None
