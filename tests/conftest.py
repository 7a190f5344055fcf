"""Shared fixtures."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

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


@pytest.fixture
def benchmark_script():
    """Load a script of ``benchmarks/`` by file name (they are not a package)."""
    def load(name: str):
        path = Path(__file__).parents[1] / "benchmarks" / f"{name}.py"
        spec = importlib.util.spec_from_file_location(f"benchmark_{name}", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod

    return load
