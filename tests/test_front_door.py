"""The front door (issue 39, item 5): ``tmaplan`` exports the names a user starts from, each
defined once in the package it names, loaded on first use so the command line starts fast."""

from __future__ import annotations

import subprocess
import sys

import pytest

import tmaplan


@pytest.mark.parametrize("name", sorted(tmaplan.FRONT_DOOR))
def test_every_front_door_name_is_its_package_object(name):
    import importlib

    package = importlib.import_module(tmaplan.FRONT_DOOR[name])
    obj = getattr(tmaplan, name)
    assert obj is getattr(package, name)
    assert name in tmaplan.__all__ and name in dir(tmaplan)
    # defined in that package (or one of its modules), not re-exported from elsewhere
    assert getattr(obj, "__module__", "").startswith(tmaplan.FRONT_DOOR[name])


def test_an_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'plan_everything'"):
        tmaplan.plan_everything  # noqa: B018


def test_importing_tmaplan_loads_no_heavy_dependency():
    code = ("import sys, tmaplan; heavy = [m for m in ('casadi', 'cvxpy', 'numba', 'pyproj', "
            "'matplotlib', 'scipy') if m in sys.modules]; print(heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]", out


def test_the_front_door_runs_the_three_jobs_entry_points():
    s = tmaplan.load_problem("default")
    assert isinstance(s, tmaplan.Scenario)
    with pytest.raises(tmaplan.ScenarioError):
        tmaplan.load("no-such-problem-anywhere")


def test_no_verb_module_imports_matplotlib_scipy_stats_or_pint():
    """Each verb's module imports only what it computes with: matplotlib when it draws,
    ``scipy.stats`` where a test statistic is used, pint for a unit outside
    :data:`tmaplan.units.COMMON_UNITS`. So every refusal comes in about a second
    (``benchmarks/refusals.py``), not after the figures' imports."""
    import subprocess

    from tmaplan.cli import VERBS

    code = ("import importlib, sys; heavy = ('matplotlib', 'scipy.stats', 'pint'); "
            f"bad = {{}}\nfor m in {sorted(VERBS.values())!r}:\n"
            "    importlib.import_module('tmaplan.cli.' + m)\n"
            "    got = [h for h in heavy if h in sys.modules]\n"
            "    if got: bad[m] = got; break\n"
            "print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "{}", out
