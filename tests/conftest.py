"""Shared fixtures."""

from __future__ import annotations

import os

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)


# The planning tests share the `default` problem and its prior belief (built once per module).
@pytest.fixture(scope="module")
def default():
    from tmaplan.scenario import load_problem

    return load_problem("default")


@pytest.fixture(scope="module")
def prior(default):
    from tmaplan.planning.belief import Belief

    return Belief.from_prior(default)
