"""Command line flags are honest: a flag that has no effect is refused, not ignored; a value
given twice is refused; output paths are checked before any work and --json never overwrites
what the user wrote; help states every default; errors name the flag or the field."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from tmaplan.cli import _build_parser, main
from tmaplan.cli.args import PLAN_STARTS
from tmaplan.cli.preflight import preflight
from tmaplan.scenario import load_problem, problems_dir


def _args(argv):
    parser, _, _ = _build_parser()
    return parser.parse_args(argv)


def _copy(tmp_path, name, old, new, file="my.toml"):
    text = (problems_dir() / f"{name}.toml").read_text(encoding="utf-8")
    assert old in text
    f = tmp_path / file
    f.write_text(text.replace(old, new, 1), encoding="utf-8")
    return f


def _refused_up_front(one_line_error, argv, tmp_path, *texts):
    line = one_line_error([*argv, "--out", str(tmp_path / "o")])
    for t in texts:
        assert t in line, line
    assert not (tmp_path / "o").exists()  # refused before any work
    return line


# ------------------------------------------------------------------ 1. plan --starts
@pytest.mark.parametrize(("extra", "texts"), [
    # the direct plan without pings starts from the manoeuvres whatever --starts: 1, 4 and 7
    # gave the same plan, and the figure was named _7starts
    (["--starts", "7"], ["field '--starts'", "only with --transcription bang-bang (at most 4)",
                         "--pings K (at most 7"]),
    (["--starts", "4"], ["field '--starts'", "only with --transcription bang-bang"]),
    # bang-bang has 4 built-in guesses: --starts 64 ran 4
    (["--transcription", "bang-bang", "--starts", "5"],
     ["field '--starts'", "at most 4 with --transcription bang-bang"]),
    (["--transcription", "bang-bang", "--starts", "64"], ["--starts must be <= 7"]),
    (["--pings", "2", "--objective", "range-bound", "--starts", "8"], ["--starts must be <= 7"]),
])
def test_plan_starts_refused_where_it_has_no_effect(tmp_path, extra, texts, one_line_error):
    _refused_up_front(one_line_error, ["plan", "default", "--horizon", "10 min", *extra],
                      tmp_path, *texts)


def test_plan_starts_limits_are_the_planners_built_in_guesses():
    from tmaplan.planning.heading import HeadingPlanner

    sc = load_problem("default")
    for tr, n in PLAN_STARTS.items():
        planner = HeadingPlanner(sc, horizon=600.0, transcription=tr, n_starts=64)
        assert len(planner._guesses(0.0, 3.0)) == n, tr
    # where --starts applies it passes the preflight
    for argv in (["--transcription", "bang-bang", "--starts", "4"],
                 ["--pings", "2", "--objective", "range-bound", "--starts", "7"],
                 ["--pings", "2", "--objective", "range-bound", "--transcription",
                  "bang-bang", "--starts", "1"], []):
        preflight(_args(["plan", "default", "--horizon", "10 min", *argv]), sc)


def test_plan_starts_is_honoured_and_named(tmp_path, capsys, monkeypatch):
    from tmaplan.planning.heading import HeadingPlanner

    counts = []
    guesses = HeadingPlanner._guesses

    def spy(self, *a, **k):
        out = guesses(self, *a, **k)
        counts.append(len(out))
        return out

    monkeypatch.setattr(HeadingPlanner, "_guesses", spy)
    assert main(["plan", "default", "--horizon", "10 min", "--transcription", "bang-bang",
                 "--starts", "2", "--out", str(tmp_path), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert counts == [2]
    assert Path(d["figure"]).name.endswith("_h10min_bang-bang_2starts.png")


# ------------------------------------------------------------------ 2. ping policies
@pytest.mark.parametrize("ping", ["uniform", "adaptive", "scheduled", "scheduled-terminal"])
def test_every_ping_policy_needs_a_range_sensor(tmp_path, ping, one_line_error):
    # +uniform and +adaptive ran with 0 pings and exit 0; +scheduled was refused
    _refused_up_front(one_line_error, ["compare", "gordon1993-bot", "--runs", "1",
                                       "--particles", "20", "--policies",
                                       f"straight,straight+{ping}"],
                      tmp_path, "field '--policies'", "no range sensor to ping with",
                      f"'straight+{ping}'")


def test_parse_policy_refuses_pings_without_a_range_sensor():
    from tmaplan.errors import ArgumentError
    from tmaplan.policies import parse_policy
    from tmaplan.policies.parse import check_policy

    sc = load_problem("gordon1993-bot")
    for spec in ("straight+uniform", "straight+adaptive", "straight+scheduled"):
        with pytest.raises(ArgumentError, match="no range sensor to ping with"):
            parse_policy(spec, sc)
    assert parse_policy("straight+no-ping", sc).name == "straight"
    assert check_policy("straight+uniform", load_problem("default")) == ("straight", "uniform")
    # a passive range sensor cannot ping (sharma2024: range-only, passive)
    with pytest.raises(ArgumentError, match="no range sensor to ping with"):
        check_policy("straight+uniform", load_problem("sharma2024-range-only"))
    # an active sensor but no budget: no [planning] table (brehard2005-s1), or a budget of 0
    for spec in ("straight+uniform", "straight+adaptive"):
        with pytest.raises(ArgumentError, match=r"planning\.ping_budget is not set"):
            check_policy(spec, load_problem("brehard2005-s1"))
    sc = load_problem("default")
    sc = sc.replace(planning=dataclasses.replace(sc.planning, ping_budget=0))
    with pytest.raises(ArgumentError, match=r"planning\.ping_budget is 0"):
        check_policy("planned+uniform", sc)


# ------------------------------------------------------------------ 3./4. output paths
def test_out_and_json_under_a_file_are_refused_before_any_work(tmp_path, capsys,
                                                               one_line_error):
    f = tmp_path / "my.toml"
    f.write_text("x = 1\n", encoding="utf-8")
    line = one_line_error(["track", "ristic-bot-moderate", "--runs", "1", "--particles", "50",
                           "--out", str(f / "sub")])
    assert "--out must be a directory" in line and "under the existing file" in line
    line = one_line_error(["simulate", "default", "--json", str(f / "out.json"), "--out",
                           str(tmp_path / "o")])
    assert "--json must be a file path" in line and "under the existing file" in line
    assert not (tmp_path / "o").exists() and capsys.readouterr().out == ""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs /proc")
def test_unwritable_output_directories_are_refused(tmp_path, capsys, one_line_error):
    line = one_line_error(["simulate", "default", "--json", "/proc/x.json", "--out",
                           str(tmp_path / "o")])
    assert "field '--json'" in line and "cannot create files in '/proc'" in line
    line = one_line_error(["simulate", "default", "--out", "/proc/figs"])
    assert "field '--out'" in line and "cannot create files in '/proc'" in line
    assert not (tmp_path / "o").exists() and capsys.readouterr().out == ""
    # --no-figure: --out is not written, so not checked
    assert main(["simulate", "default", "--out", "/proc/figs", "--no-figure", "--json",
                 "-"]) == 0


def test_json_never_overwrites_a_file_that_is_not_json(tmp_path, capsys, one_line_error):
    mine = tmp_path / "mine.toml"
    text = (problems_dir() / "bow-closing.toml").read_text(encoding="utf-8")
    mine.write_text(text, encoding="utf-8")
    png = tmp_path / "fig.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    for target in (mine, png):
        line = one_line_error(["simulate", "default", "--no-figure", "--json", str(target)])
        assert "field '--json'" in line and "is not JSON" in line
    line = one_line_error(["problems", "--json", str(mine)])  # a verb without a problem
    assert "field '--json'" in line
    assert mine.read_text(encoding="utf-8") == text
    # a previous JSON output (and an empty file) is overwritten
    prev = tmp_path / "out.json"
    prev.write_text('{"problem": "other"}\n', encoding="utf-8")
    empty = tmp_path / "empty.json"
    empty.touch()
    for target in (prev, empty):
        assert main(["simulate", "default", "--no-figure", "--json", str(target)]) == 0
        assert json.loads(target.read_text(encoding="utf-8"))["problem"] == "default"
    capsys.readouterr()


# ------------------------------------------------------------------ 5. schedule options
@pytest.mark.parametrize(("extra", "flag"), [
    (["--method", "greedy", "--workers", "3", "--time-limit", "5"], "--time-limit"),
    (["--method", "greedy", "--workers", "3"], "--workers"),
    (["--method", "relaxed", "--workers", "2", "--time-limit", "3"], "--time-limit"),
    (["--method", "relaxed", "--workers", "2"], "--workers"),
    (["--time-limit", "3"], "--time-limit"),  # relaxed by default
    (["--method", "exact", "--objective", "mean-position-bound", "--workers", "2"],
     "--workers"),
])
def test_schedule_refuses_options_its_method_does_not_read(tmp_path, extra, flag,
                                                           one_line_error):
    line = _refused_up_front(one_line_error, ["schedule", "default", *extra], tmp_path,
                             f"field '{flag}'", "only with --method exact")
    assert "it is not used by --method" in line


def test_schedule_exact_takes_its_options():
    sc = load_problem("default")
    preflight(_args(["schedule", "default", "--method", "exact", "--workers", "2",
                     "--time-limit", "5"]), sc)
    preflight(_args(["schedule", "default", "--method", "exact", "--objective",
                     "mean-position-bound", "--time-limit", "5"]), sc)
    assert _args(["schedule", "default"]).time_limit is None  # 600 s when used


# ------------------------------------------------------------------ 6. duplicates
@pytest.mark.parametrize(("argv", "texts"), [
    # --ping-steps 3,3 ran with "1 pings"; --plans logdet,logdet was accepted
    (["bound", "default", "--ping-steps", "3,3"], ["--ping-steps must be distinct steps",
                                                   "3 is repeated"]),
    (["rank-costs", "default", "--plans", "logdet,logdet"],
     ["field '--plans'", "logdet is repeated"]),
    (["compare", "default", "--policies", "straight,zigzag,straight", "--runs", "1"],
     ["field '--policies'", "straight is repeated"]),
])
def test_repeated_values_are_refused_naming_them(tmp_path, argv, texts, one_line_error):
    _refused_up_front(one_line_error, argv, tmp_path, *texts)


# ------------------------------------------------------------------ 7. help defaults
def test_help_states_every_default():
    _, _, parsers = _build_parser()
    missing = []
    for verb, p in parsers.items():
        for a in p._actions:
            if not a.option_strings or a.help == argparse.SUPPRESS \
                    or a.default in (None, False, argparse.SUPPRESS):
                continue
            shown = f"{a.default:g}" if isinstance(a.default, float) else str(a.default)
            if "default" not in (a.help or "") or shown not in a.help:
                missing.append(f"{verb} {a.option_strings[0]} (default {shown})")
    assert not missing, missing
    helps = {(v, a.option_strings[0]): a.help for v, p in parsers.items()
             for a in p._actions if a.option_strings}
    assert "(default 20)" in helps["track", "--runs"]
    assert "default monte-carlo" in helps["bound", "--method"]
    assert "default relaxed" in helps["schedule", "--method"]
    assert "default mean-range-bound" in helps["schedule", "--objective"]
    assert "default straight,single-turn,zigzag" in helps["compare", "--policies"]
    assert "(default 1)" in helps["compare", "--workers"]
    assert "(default 1)" in helps["rank-costs", "--workers"]


# ------------------------------------------------------------------ 8. errors name the field
def test_schedule_spacing_error_names_the_flag_or_the_field(tmp_path, one_line_error):
    _refused_up_front(one_line_error, ["schedule", "default", "--min-spacing", "200 min"],
                      tmp_path, "field '--min-spacing'", "at most 1 fit",
                      "the 4 pings of planning.ping_budget")
    _refused_up_front(one_line_error, ["schedule", "default", "--budget", "3",
                                       "--min-spacing", "30 min"],
                      tmp_path, "field '--min-spacing'", "the 3 pings of --budget",
                      "at most 2 fit")
    f = _copy(tmp_path, "default", 'ping_min_spacing = "2 min"', 'ping_min_spacing = "200 min"')
    _refused_up_front(one_line_error, ["schedule", str(f)], tmp_path,
                      "field 'planning.ping_min_spacing'", "at most 1 fit")


def test_track_turn_direction_names_the_flag(tmp_path, one_line_error):
    # the MLE said field 'turn_direction' after the set-up
    _refused_up_front(one_line_error, ["track", "ristic-bot-moderate", "--estimator", "mle",
                                       "--turn-direction", "clockwise", "--runs", "1"],
                      tmp_path, "field '--turn-direction'", "'constant-turn'", "'ncv'")


# ------------------------------------------------------------------ 9. --observer-plan start
def _plan_file(tmp_path, sc):
    from tmaplan.models.observer import observer_track

    tr = observer_track(sc.observer, sc.time)
    obs = {k: np.asarray(getattr(tr, k)).tolist() for k in
           ("times", "position", "velocity", "mean_velocity", "heading", "speed")}
    f = tmp_path / "plan.json"
    f.write_text(json.dumps({"problem": sc.name, "observer": obs}), encoding="utf-8")
    return f


def test_observer_plan_must_start_from_the_scenarios_own_ship(tmp_path, one_line_error):
    from tmaplan.cli.schedule import read_observer_plan
    from tmaplan.errors import ArgumentError

    sc = load_problem("default")
    plan = _plan_file(tmp_path, sc)
    assert read_observer_plan(plan, sc).times.shape == (sc.n_steps + 1,)
    for change, field in (({"position": (3000.0, 0.0)}, "observer.position"),
                          ({"course": np.radians(20.0)}, "course"),
                          ({"speed": 4.0, "speed_min": 4.0, "speed_max": 4.0}, "speed")):
        other = sc.replace(observer=dataclasses.replace(sc.observer, **change))
        with pytest.raises(ArgumentError, match=f"--observer-plan.*{field}"):
            read_observer_plan(plan, other)
    # a scenario also named `default` whose own ship starts elsewhere: refused up front
    f = _copy(tmp_path, "default", "position = [0.0, 0.0]", "position = [3000.0, 0.0]")
    _refused_up_front(one_line_error, ["schedule", str(f), "--observer-plan", str(plan)],
                      tmp_path, "field '--observer-plan'", "observer.position (3000, 0) m",
                      "observer.position[0] = (0, 0) m in the plan")


# ------------------------------------------------------------------ compare: nobody localised
def _far(tmp_path, name):
    """``name`` with its contacts at 60 km and prior ranges 90-150 km over 5 min: no policy
    localises any of them (at 10 %) by the horizon (with the truth below the prior's ranges,
    no chance estimate of a small cloud comes within 10 % of it)."""
    text = (problems_dir() / f"{name}.toml").read_text(encoding="utf-8")
    for old, new in (('horizon = "45 min"', 'horizon = "5 min"'),
                     ('["8.485 km", "8.485 km"]', '["42.43 km", "42.43 km"]'),
                     ('["-9.899 km", "9.899 km"]', '["-42.43 km", "42.43 km"]'),
                     ('range_min = "5 km"', 'range_min = "90 km"'),
                     ('range_max = "25 km"', 'range_max = "150 km"')):
        text = text.replace(old, new)
    f = tmp_path / f"far-{name}.toml"
    f.write_text(text, encoding="utf-8")
    return f


@pytest.mark.parametrize(("name", "metrics"), [
    ("default", ["time_to_accuracy"]),
    ("two-contacts-crossing", ["time_to_accuracy_all", "weighted_time_to_accuracy"])])
def test_compare_says_a_difference_nobody_localised_is_undetermined(tmp_path, capsys, name,
                                                                    metrics):
    """Neither policy localised in any run: the paired difference of the times to accuracy
    (both censored at the horizon + dt) read ``0 [0, 0]`` min, like a decided tie."""
    f = _far(tmp_path, name)
    assert main(["compare", str(f), "--policies", "straight,single-turn", "--runs", "2",
                 "--particles", "200", "--truth", "scenario", "--out", str(tmp_path / "o"),
                 "--json", str(tmp_path / "c.json")]) == 0
    out = capsys.readouterr().out
    data = json.loads((tmp_path / "c.json").read_text())
    for metric in metrics:
        (d,) = [d for d in data["differences"] if d["metric"] == metric]
        assert d["both_censored"] == d["n"] == 2, d  # the existing keys kept
        assert {"mean", "ci_low", "ci_high", "level", "n"} <= set(d)
    assert all(d["both_censored"] == 0 for d in data["differences"]
               if "time" not in d["metric"])
    lines = [ln for ln in out.splitlines() if ln.startswith("straight − single-turn, ")]
    assert len(lines) == len(metrics), out
    assert all(ln.endswith("undetermined: neither policy localised in any of the 2 paired runs")
               for ln in lines), lines
    report = (Path(data["report"])).read_text(encoding="utf-8")
    assert "undetermined: no policy localised in any of the 2 paired runs" in report
