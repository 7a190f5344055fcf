"""``tmaplan plan`` and ``tmaplan schedule`` (DESIGN §4 JSON contract)."""

from __future__ import annotations

import json

import pytest

from tmaplan.cli import main


def test_plan_json_and_figure(tmp_path, capsys):
    out = tmp_path / "plan.json"
    rc = main(["plan", "default", "--horizon", "1800", "--out",
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
    # named by problem, objective and the settings given (another plan does not overwrite it)
    name = f"default_plan_{d['objective_name']}_h30min.png"
    assert d["figure"] == str(tmp_path / name)
    assert (tmp_path / name).stat().st_size > 10_000


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


def test_plan_figure_names_every_setting_away_from_its_default():
    """Plans of other settings into the same --out do not overwrite each other's figure; the
    default plan keeps its short name."""
    from tmaplan.cli.plan import figure_name

    obj = "expected-time-to-accuracy"
    assert figure_name("default", obj) == f"default_plan_{obj}.png"
    assert figure_name("default", obj, 2) == f"default_plan_{obj}_2pings.png"
    names = {figure_name("default", obj, **kw) for kw in (
        {}, {"horizon": 1800.0}, {"horizon": 1500.0}, {"control_interval": 60.0},
        {"control_interval": 90.0}, {"transcription": "bang-bang"}, {"starts": 8})}
    assert len(names) == 7
    assert figure_name("default", obj, horizon=1800.0, control_interval=90.0,
                       transcription="bang-bang") == \
        f"default_plan_{obj}_h30min_ci90s_bang-bang.png"
    assert figure_name("default", obj, 3, joint="alternating", ping_stride=2) == \
        f"default_plan_{obj}_3pings_alternating_stride2.png"
    # joint settings name nothing without pings (they are not used there)
    assert figure_name("default", obj, joint="alternating") == f"default_plan_{obj}.png"
