"""Shared fixtures."""

from __future__ import annotations

import importlib.util
import os
import signal
from pathlib import Path

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

# The property tests draw their examples from a seed fixed per test (a red CI is a defect to
# reproduce, not chance); TMAPLAN_HYPOTHESIS=explore draws fresh examples on every run.
settings.register_profile("fixed", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("TMAPLAN_HYPOTHESIS", "fixed"))

# A suite started in the background (`make test &`, `nohup`) inherits SIGINT ignored, and Python
# then installs no KeyboardInterrupt handler: Ctrl-C as a terminal delivers it, which the
# interrupt tests send, would be lost. Give the tests Python's own handler, as in a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


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


@pytest.fixture(scope="module")
def short(default):
    """`default` cut to 36 steps (9 min): small enough to enumerate every ping schedule."""
    import dataclasses

    return default.replace(time=dataclasses.replace(default.time, horizon=540.0))


@pytest.fixture(scope="module")
def short_prior(short):
    from tmaplan.planning.belief import Belief

    return Belief.from_prior(short)


@pytest.fixture
def one_line_error(capsys):
    """``one_line_error(argv)``: run the CLI, which must exit 1 with a one-line error and no
    traceback; returns that line."""
    from tmaplan.cli import main

    def run(argv):
        rc = main(argv)
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 1, (argv, err)
        assert len(err) == 1 and "Traceback" not in err[0], err
        return err[0]

    return run


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
