"""Recycled arrays of the particle filter's numba kernels (:mod:`tmaplan.estimators.pf_buffers`).

Memory is reused once no array sees it, never while one does (a view, a transpose, a state
kept by the caller); the pool stays within its bound.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest

from tmaplan.estimators import pf_buffers

N = 100_000  # 800 kB of float64: pooled


@pytest.fixture(autouse=True)
def _fresh_pool(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pf_buffers, "_SLOTS", [])


def test_memory_is_reused_once_nothing_sees_it() -> None:
    a = pf_buffers.empty(N)
    addr = a.ctypes.data
    assert a.shape == (N,) and a.dtype == float and a.flags.writeable and a.flags.c_contiguous
    assert addr % 64 == 0
    del a
    b = pf_buffers.empty(N)
    assert b.ctypes.data == addr
    c = pf_buffers.empty(N)  # b alive: other memory
    assert c.ctypes.data != addr
    assert pf_buffers.pooled_bytes() == 2 * N * 8


@pytest.mark.parametrize("keep", ["transpose", "slice", "view of a view", "reshape"])
def test_memory_seen_by_a_view_is_not_handed_out(keep: str) -> None:
    a = pf_buffers.empty((4, N // 4))
    a[...] = 1.0
    views = {"transpose": lambda x: x.T, "slice": lambda x: x[1:, ::3],
             "view of a view": lambda x: x.T[5:].T, "reshape": lambda x: x.reshape(-1)}
    v = views[keep](a)
    addr = a.ctypes.data
    del a
    gc.collect()
    b = pf_buffers.empty((4, N // 4))
    assert b.ctypes.data != addr
    b[...] = 2.0
    assert np.all(v == 1.0)
    del v
    assert pf_buffers.empty((4, N // 4)).ctypes.data == addr  # now free


def test_other_sizes_and_types_and_small_arrays() -> None:
    a = pf_buffers.empty(N, np.intp)
    assert a.dtype == np.intp and a.shape == (N,)
    addr = a.ctypes.data
    del a
    assert pf_buffers.empty(2 * N).ctypes.data != addr  # another size: a new buffer
    small = pf_buffers.empty(10)
    assert small.base is None and pf_buffers.pooled_bytes() == 3 * N * 8


def test_the_pool_stays_within_its_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(pf_buffers, "MAX_BYTES", 3 * N * 8)
    a = pf_buffers.empty(N)
    b = pf_buffers.empty(2 * N)
    c = pf_buffers.empty(N)  # no room while a and b live: a plain array
    assert c.base is None and pf_buffers.pooled_bytes() == 3 * N * 8
    del b
    d = pf_buffers.empty(N)  # b's buffer (free, another size) dropped to make room
    assert d.base is not None and pf_buffers.pooled_bytes() == 2 * N * 8
    assert a.ctypes.data != d.ctypes.data


def test_states_kept_by_the_caller_are_not_overwritten() -> None:
    # the filter's arrays come from the pool: a state the caller keeps keeps its particles,
    # log-weights and weights while later steps run
    from tmaplan.estimators import Measurement, ParticleFilter, PFConfig

    pf = ParticleFilter(PFConfig(n_particles=N, dt=10.0, q=1e-3, variant="bootstrap",
                                 kernel="numba"))
    rng = np.random.default_rng(3)
    st = pf.from_particles(rng.normal([3000.0, 4000.0, 1.0, -2.0], [500.0, 500.0, 2.0, 2.0],
                                      (N, 4)))
    kept = []
    for k in range(6):
        st = pf.update(pf.predict(st, None, rng),
                       [Measurement(kind="bearing", value=0.64 + 0.01 * k, sigma=0.01)], rng)
        kept.append((st, st.particles.copy(), st.log_weights.copy(), st.weights.copy()))
    assert any(s.resampled for s, *_ in kept) and any(not s.resampled for s, *_ in kept)
    for s, x, lw, w in kept:
        assert np.array_equal(s.particles, x) and np.array_equal(s.log_weights, lw)
        assert np.array_equal(s.weights, w)


def test_few_free_buffers_of_one_size_are_kept() -> None:
    kept = [pf_buffers.empty(N) for _ in range(pf_buffers.MAX_FREE + 5)]  # a burst
    assert pf_buffers.pooled_bytes() == (pf_buffers.MAX_FREE + 5) * N * 8
    del kept
    a = pf_buffers.empty(N)  # reuses one, drops the free ones beyond MAX_FREE
    assert pf_buffers.pooled_bytes() == pf_buffers.MAX_FREE * N * 8
    assert a.base is not None


def test_the_most_recently_used_free_buffer_is_handed_out() -> None:
    a, b = pf_buffers.empty(N), pf_buffers.empty(N)  # b handed out last
    addr_b = b.ctypes.data
    del a, b
    assert pf_buffers.empty(N).ctypes.data == addr_b  # likeliest in the cache
