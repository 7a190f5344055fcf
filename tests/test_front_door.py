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
