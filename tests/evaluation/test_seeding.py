"""The one seeding rule (tmaplan.evaluation.seeding): run i's seed is the i-th child of the
root, whatever the number of runs; the closed-loop streams are its three children."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.evaluation.seeding import root_rng, run_seed, run_seeds, run_streams


def _draws(ss: np.random.SeedSequence) -> np.ndarray:
    return np.random.default_rng(ss).random(8)


@pytest.mark.parametrize("seed", [0, 7, 2**40 + 3])
def test_run_seeds_are_the_roots_spawned_children(seed):
    children = np.random.SeedSequence(seed).spawn(6)
    for a, b in zip(children, run_seeds(seed, 6), strict=True):
        np.testing.assert_array_equal(_draws(a), _draws(b))
    # a run's seed does not depend on the number of runs nor on the first run asked for
    np.testing.assert_array_equal(_draws(run_seeds(seed, 2, first=4)[1]), _draws(children[5]))
    np.testing.assert_array_equal(_draws(run_seed(seed, 3)), _draws(children[3]))
    assert not np.array_equal(_draws(run_seed(seed, 3)), _draws(run_seed(seed, 4)))


def test_the_closed_loop_streams_are_the_run_seeds_three_children():
    st = run_streams(5, 2)
    kids = run_seed(5, 2).spawn(3)
    for a, b in zip((st.truth, st.noise, st.filter), kids, strict=True):
        np.testing.assert_array_equal(_draws(a), _draws(b))
    assert len({tuple(_draws(s)) for s in (st.truth, st.noise, st.filter)}) == 3


def test_the_root_generator_is_default_rng_of_the_seed():
    np.testing.assert_array_equal(root_rng(11).random(8), np.random.default_rng(11).random(8))
