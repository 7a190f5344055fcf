"""``benchmarks/value_of_information.py`` on one run: the clairvoyant plan sees the truth.

The clairvoyant plan is solved from the offline plan among its starts, so on the objective
evaluated at the run's true initial state it can only be better than the offline plan; and
that objective is not the prior's (the draws really are the truth)."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from tmaplan.experiments import random_problems
from tmaplan.scenario import load_problem


def test_clairvoyant_plan_is_optimal_at_the_truth(benchmark_script):
    bench = benchmark_script("value_of_information")
    bench._init("bow-closing", None, 500)
    row = bench._run((11, 0))
    plan = bench._STATE["plan"]
    assert row["clairvoyant_objective"] is not None
    assert row["clairvoyant_objective"] <= row["planned_objective_at_truth"] + 1e-6
    # the truth's objective differs from the prior's (all draws at one state)
    assert abs(row["planned_objective_at_truth"] - plan.objective) > 1.0
    for name in ("planned", "clairvoyant"):
        assert row[name] is None or np.isfinite(row[name])


def test_waiting_reproduces_the_clairvoyant_gain_and_charges_each_minute(benchmark_script):
    """``--waiting`` on a run whose contact draws right (seed 9, run 3): the clairvoyant
    plan turns to starboard first, where the offline plan turns to port; with no hold the
    gain is at least the clairvoyant plan's (it is one of the shapes), and every minute of
    holding course before the decision costs objective."""
    bench = benchmark_script("value_of_information")
    bench._init("bow-closing", None, 200)
    row = bench._wait((9, 3))
    clair = bench._run((9, 3))   # the same truth
    g = np.array(row["hold_gain"])
    assert row["clairvoyant_side"] == 1.0 and row["bearing_rate"] > 0.0
    assert bench._STATE["plan"].observer.heading[8] < bench._STATE["plan"].observer.heading[0]
    # (the shapes are re-integrated step by step: equal to the plans' tracks within 1 s)
    assert g[0] <= clair["clairvoyant_objective"] - clair["planned_objective_at_truth"] + 1.0
    assert g[0] < -30.0                       # something to win at t0 ...
    assert np.all(np.diff(g) > 0.0)           # ... and less after each minute of holding


def test_turn_rates_re_integrate_a_plan_that_crosses_south(benchmark_script):
    """The offline plan of ``bow-closing`` turns through 180°, where the wrapped heading
    jumps by 2π: its turn rates stay within the limit and re-integrate to the same track."""
    from tmaplan.models.observer import turn_rate_track

    bench = benchmark_script("value_of_information")
    bench._init("bow-closing", None, 200)
    tr, sc = bench._STATE["plan"].observer, bench._STATE["sc"]
    assert np.any(np.abs(np.diff(tr.heading)) > np.pi)      # it does cross ±180°
    u = bench.turn_rates(tr, sc.time.dt)
    assert np.max(np.abs(u)) <= bench._STATE["planner"].u_max * (1 + 1e-6)   # (IPOPT bounds)
    again = turn_rate_track(tr.position[0], tr.heading[0], float(tr.speed[0]), u, sc.time.dt,
                            tr.times[0])
    np.testing.assert_allclose(again.position, tr.position, atol=1e-6)


def test_family_names_the_problem_of_planning_general(benchmark_script, monkeypatch, capsys):
    # --family SEED:I flies problem I of planning_general.py --seed SEED (the same draw)
    bench = benchmark_script("value_of_information")
    assert bench._problem("default", (2028, 3)) == random_problems(
        load_problem("default"), 12, seed=2028)[3]
    assert bench._problem("bow-closing", None) == load_problem("bow-closing")
    monkeypatch.setattr(bench, "ProcessPoolExecutor",
                        lambda *a, **k: pytest.fail("work started"))
    for bad in ("2028", "2028:-1", "a:1", "1:2:3"):
        monkeypatch.setattr(sys, "argv", ["value_of_information.py", "--family", bad])
        with pytest.raises(SystemExit):
            bench.main()
        assert f"--family: SEED:I, two integers >= 0, got '{bad}'" in capsys.readouterr().err
