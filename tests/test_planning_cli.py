"""``tmaplan plan`` and ``tmaplan schedule`` (DESIGN §4 JSON contract)."""

from __future__ import annotations

import json

import pytest

from tmaplan.cli import main


def test_plan_json_and_figure(tmp_path, capsys):
    out = tmp_path / "plan.json"
    rc = main(["plan", "default", "--horizon", "1800", "--starts", "2", "--out",
               str(tmp_path), "--json", str(out)])
    assert rc == 0
    d = json.loads(out.read_text())
    for key in ("times", "heading", "turn_rate", "switch_times", "objective", "baselines",
                "solver"):
        assert key in d
    assert set(d["baselines"]) == {"straight", "single-turn", "zigzag"}
    assert d["objective"] < min(d["baselines"].values())
    assert d["solver"]["status"] in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
    assert d["times"][-1] - d["times"][0] == pytest.approx(1800.0)
    assert len(d["turn_rate"]) == len(d["times"]) - 1
    # named by problem and objective (a plan of another objective does not overwrite it)
    assert d["figure"] == str(tmp_path / f"default_plan_{d['objective_name']}.png")
    assert (tmp_path / f"default_plan_{d['objective_name']}.png").stat().st_size > 10_000


def test_schedule_json_stdout(tmp_path, capsys):
    rc = main(["schedule", "default", "--budget", "3", "--method", "greedy", "--out",
               str(tmp_path), "--json", "-"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    for key in ("ping_times", "objective", "lower_bound", "gap", "no_ping_objective",
                "uniform_objective", "solver"):
        assert key in d
    assert {"status", "seconds"} <= set(d["solver"])
    assert d["lower_bound"] <= d["objective"]
    assert d["gap"] == pytest.approx((d["objective"] - d["lower_bound"]) / d["objective"])
    assert d["solver"]["status"] in ("optimal", "feasible")
    assert len(d["ping_times"]) == 3
    assert d["objective"] < d["uniform_objective"] < d["no_ping_objective"]
    assert (tmp_path / "default_schedule.png").exists()


def test_schedule_error_is_one_line(capsys):
    rc = main(["schedule", "default", "--budget", "1000", "--no-figure", "--json", "-"])
    assert rc == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "budget" in err[0]
