"""Command line: problems, simulate, errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.scenario import problems_dir


def test_problems_json_stdout(capsys):
    assert main(["problems", "--json", "-"]) == 0
    out = json.loads(capsys.readouterr().out)
    names = {p["name"] for p in out}
    assert {"default", "brehard2005-s2", "gordon1993-bot"} <= names
    assert all(set(p) == {"name", "description"} for p in out)


def test_simulate_writes_json_and_figure(tmp_path):
    js = tmp_path / "out.json"
    assert main(["simulate", "brehard2005-s2", "--seed", "1", "--json", str(js),
                 "--out", str(tmp_path)]) == 0
    d = json.loads(js.read_text())
    assert (tmp_path / "brehard2005-s2_geometry.png").stat().st_size > 10_000
    obs = np.array(d["observer"])
    t = np.array(d["times"])
    # the observer changes velocity at 1500 s and 4500 s (brehard2005 eq. 59)
    v = obs[:, 2:]
    changes = t[1:][np.any(np.abs(np.diff(v, axis=0)) > 1e-9, axis=1)]
    assert changes.tolist() == [1506.0, 4506.0]  # mean velocity over (t_{k−1}, t_k]


def test_same_seed_same_json(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    for p in (a, b):
        assert main(["simulate", "default", "--seed", "3", "--no-figure", "--json", str(p)]) == 0
    assert a.read_text() == b.read_text()


@pytest.mark.parametrize("arg", ["no-such-problem", "missing.toml"])
def test_bad_problem_is_one_line_error(arg, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", arg],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode != 0
    err = proc.stderr.strip()
    assert len(err.splitlines()) == 1, err
    assert arg in err and "brehard2005-s1" in err and "Traceback" not in err


def test_invalid_file_names_the_field(tmp_path):
    from tmaplan.scenario import problems_dir

    p = tmp_path / "bad.toml"
    text = (problems_dir() / "default.toml").read_text()
    p.write_text(text.replace('horizon = "45 min"', 'horizon = "44.9 min"', 1))
    proc = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", str(p)],
                          capture_output=True, text=True)
    assert proc.returncode != 0
    assert "time.horizon" in proc.stderr and "whole number" in proc.stderr


def test_debug_shows_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", "nope", "--debug"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode != 0 and "Traceback" in proc.stderr


def test_demo_writes_report(tmp_path, capsys):
    # a compare in the same --out first: both wrote <out>/report.html (and rmse.png, ...),
    # so the demo overwrote the compare's report; each now has its own directory
    cj = tmp_path / "compare.json"
    assert main(["compare", "default", "--policies", "straight", "--runs", "1", "--particles",
                 "100", "--out", str(tmp_path), "--json", str(cj)]) == 0
    compare_report = Path(json.loads(cj.read_text())["report"])
    # the demo at toy size: plan, schedule, compare every demo policy, report
    js = tmp_path / "demo.json"
    assert main(["demo", "--out", str(tmp_path), "--runs", "2", "--particles", "400",
                 "--workers", "1", "--json", str(js)]) == 0
    assert "tmaplan compare: default" in compare_report.read_text()  # not overwritten
    assert compare_report == tmp_path / "default_compare" / "report.html"
    assert json.loads(js.read_text())["report"] == str(tmp_path / "demo" / "report.html")
    text = (tmp_path / "demo" / "report.html").read_text()
    assert text.count("data:image/png;base64,") == 5  # plan, schedule, rmse, tracks, tta
    d = json.loads(js.read_text())
    from tmaplan.cli.demo import DEMO_POLICIES

    assert set(d["policies"]) == set(DEMO_POLICIES) and d["problem"] == "default"
    assert d["plan"]["objective"] < min(d["plan"]["baselines"].values())
    assert d["schedule"]["objective"] <= d["schedule"]["uniform_objective"]
    # issue 38: the stored decisive result first, labelled with its commands; this run
    # labelled illustrative; every key difference with its interval, undecided ones so named
    from tmaplan.headline import load_stored

    out = capsys.readouterr().out
    stored = load_stored()
    assert "Stored result of" in out and "median" not in out
    assert all(c.command in out and c.command in text for c in stored.campaigns)
    assert out.index("Stored result of") < out.index("This run (illustrative: 2 paired runs")
    assert "This run: illustrative (2 paired runs" in text
    assert d["stored"]["campaigns"] and d["key_differences"]
    for k in d["key_differences"]:
        assert k["n"] == 2 and np.isfinite([k["ci_low"], k["ci_high"]]).all()
        assert (k["decided"] or "not decided at 2 runs" in k["verdict"]
                or k["verdict"].startswith("undetermined: neither policy"))


@pytest.mark.parametrize("module", ["tmaplan.__main__", "tmaplan.cli.__main__"])
def test_importing_the_entry_point_does_not_run_the_cli(module, monkeypatch, capsys):
    """The API reference imports every module: ``python -m`` entry points run the CLI only
    as ``__main__`` (the docs build printed "invalid choice: 'html'" before)."""
    import importlib
    import sys

    monkeypatch.setattr(sys, "argv", ["sphinx-build", "-b", "html", "docs", "out"])
    monkeypatch.delitem(sys.modules, module, raising=False)
    importlib.import_module(module)  # SystemExit(2) if it ran the CLI
    assert capsys.readouterr().err == ""


# ----------------------------------------------------------------------------------------------
# From test_cli_review.py (folded in, issue 39):
# Command line review: ``--debug`` before the verb, ``--json`` never destroys an input, and
# bad arguments or scenario values refused up front with the flag or field named.
# ----------------------------------------------------------------------------------------------

def _problem_file(tmp_path, name="gordon1993-bot", old=None, new=None):
    text = (problems_dir() / f"{name}.toml").read_text(encoding="utf-8")
    if old is not None:
        assert old in text
        text = text.replace(old, new, 1)
    f = tmp_path / "my.toml"
    f.write_text(text, encoding="utf-8")
    return f


def test_debug_before_the_verb_shows_the_traceback(capsys):
    # `tmaplan --debug VERB` is in `tmaplan --help`; the verb's own --debug default used to
    # overwrite it, so the error was one line without a traceback
    with pytest.raises(Exception, match="nosuch"):
        main(["--debug", "simulate", "nosuch"])
    assert main(["simulate", "nosuch"]) == 1  # still one line without --debug


def test_json_never_overwrites_the_problem_file(tmp_path, monkeypatch, one_line_error):
    f = _problem_file(tmp_path)
    before = f.read_text(encoding="utf-8")
    for path in (str(f), str(tmp_path / "." / "my.toml")):
        line = one_line_error(["simulate", str(f), "--no-figure", "--json", path])
        assert "--json" in line and "problem file" in line
    monkeypatch.chdir(tmp_path)  # relative and absolute spellings of one file
    line = one_line_error(["simulate", "my.toml", "--no-figure", "--json", str(f)])
    assert "--json" in line
    assert f.read_text(encoding="utf-8") == before


def test_json_never_overwrites_the_observer_plan(tmp_path, one_line_error):
    plan = tmp_path / "plan.json"
    plan.write_text('{"problem": "default"}', encoding="utf-8")
    line = one_line_error(["schedule", "default", "--observer-plan", str(plan),
                                    "--no-figure", "--json", str(plan)])
    assert "--json" in line and "--observer-plan" in line
    assert plan.read_text(encoding="utf-8") == '{"problem": "default"}'


def test_json_directory_is_refused_before_any_work(tmp_path, capsys, one_line_error):
    line = one_line_error(["simulate", "default", "--no-figure", "--json",
                                    str(tmp_path)])
    assert "--json must be a file path" in line and "existing directory" in line
    assert capsys.readouterr().out == ""  # nothing ran


# ------------------------------------------------------------------ scenario files
@pytest.mark.parametrize("name", ["../../escape", "a/b", "a\\b", "", "  ", "..", "x\ny"])
def test_scenario_name_cannot_escape_the_output_folder(tmp_path, name, one_line_error):
    # figures are written to <out>/<name>_geometry.png etc.: "../../escape" wrote outside --out
    f = _problem_file(tmp_path, old='name = "gordon1993-bot"', new=f"name = {json.dumps(name)}")
    out = tmp_path / "o" / "p"
    line = one_line_error(["simulate", str(f), "--out", str(out)])
    assert "field 'name'" in line and "without '/'" in line
    assert list(tmp_path.rglob("*.png")) == []


def test_speed_max_below_speed_min_names_speed_max(tmp_path, one_line_error):
    # the error named observer.speed with an empty interval [3.09, 2.57] m/s
    f = _problem_file(tmp_path, "default", 'speed_max = "6 kn"', 'speed_max = "5 kn"')
    line = one_line_error(["simulate", str(f), "--no-figure"])
    assert "field 'observer.speed_max'" in line and ">= observer.speed_min" in line


def test_a_folder_named_like_a_builtin_problem_does_not_hide_it(tmp_path, capsys, monkeypatch,
                                                                one_line_error):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "gordon1993-bot").mkdir()  # e.g. an --out folder named after the problem
    assert main(["simulate", "gordon1993-bot", "--no-figure", "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["problem"] == "gordon1993-bot"
    # spelled as a path, it is a path: a folder is not a scenario file
    line = one_line_error(["simulate", "./gordon1993-bot/", "--no-figure"])
    assert "an existing .toml file" in line


# ------------------------------------------------------------------ flags named up front
FLAG_CASES = [
    # crlb named the library's 'frequencies', not the flag
    (["crlb", "default", "--frequencies", "5", "--no-figure"],
     ["field '--frequencies'", "0..0"]),
    # the scheduler said "budget K = 999 pings ..." without the flag
    (["schedule", "default", "--budget", "999", "--no-figure"],
     ["field '--budget'", "at most the 180 steps"]),
    # `plan default --pings 2` failed after the set-up with "objective: expected one of ..."
    (["plan", "default", "--pings", "2", "--no-figure"],
     ["field '--objective'", "with --pings, one of", "planning.objective"]),
    (["plan", "default", "--pings", "999", "--objective", "range-bound", "--no-figure"],
     ["field '--pings'", "at most the 180 steps"]),
    # an empty list ran the campaign and failed with "tuple index out of range"
    (["compare", "default", "--policies", ",", "--runs", "1", "--particles", "2"],
     ["field '--policies'", "one or more distinct"]),
    (["compare", "default", "--policies", "straight,straight", "--runs", "1"],
     ["field '--policies'"]),
]


@pytest.mark.parametrize(("argv", "texts"), FLAG_CASES,
                         ids=[" ".join(a[:4]) for a, _ in FLAG_CASES])
def test_flags_are_named_up_front(tmp_path, argv, texts, one_line_error):
    line = one_line_error([*argv, "--out", str(tmp_path)])
    for t in texts:
        assert t in line, line
    assert list(tmp_path.iterdir()) == []  # refused before any work


def test_observer_plan_with_null_values_is_refused(tmp_path):
    # a null in the plan's track (NaN when read) passed every check: NaN compares false
    import numpy as np

    from tmaplan.cli.schedule import read_observer_plan
    from tmaplan.errors import ArgumentError
    from tmaplan.scenario import load_problem

    sc = load_problem("default")
    n = sc.n_steps + 1
    obs = {"times": sc.times.tolist(), "position": np.zeros((n, 2)).tolist(),
           "velocity": np.ones((n, 2)).tolist(), "mean_velocity": np.ones((n, 2)).tolist(),
           "heading": np.zeros(n).tolist(),
           "speed": np.full(n, 6 * 1852 / 3600).tolist()}  # default's 6 kn
    f = tmp_path / "plan.json"
    f.write_text(json.dumps({"problem": "default", "observer": obs}), encoding="utf-8")
    assert read_observer_plan(f, sc).times.shape == (n,)  # the valid file is read
    for key, where in (("position", (3, 0)), ("times", (5,))):
        bad = json.loads(json.dumps(obs))
        if len(where) == 2:
            bad[key][where[0]][where[1]] = None
        else:
            bad[key][where[0]] = None
        f.write_text(json.dumps({"problem": "default", "observer": bad}), encoding="utf-8")
        with pytest.raises(ArgumentError, match=f"--observer-plan.*non-finite values in {key}"):
            read_observer_plan(f, sc)


@pytest.mark.parametrize("interval", ["7 min", "2 h"])
def test_control_interval_must_divide_the_problems_horizon(interval, one_line_error):
    # without --horizon the 45 min horizon was rounded to whole intervals silently: 42 min for
    # 7 min, and 120 min (beyond the problem's horizon) for 2 h
    line = one_line_error(["plan", "default", "--control-interval", interval,
                                    "--no-figure"])
    assert "field '--control-interval'" in line and "planning horizon of 2700 s" in line


def test_control_interval_that_divides_the_horizon_passes_the_checks():
    import argparse

    from tmaplan.cli.preflight import preflight
    from tmaplan.scenario import load_problem

    args = argparse.Namespace(verb="plan", horizon=None, control_interval=180.0, pings=0,
                              objective=None, json=None, problem="default")
    preflight(args, load_problem("default"))  # 45 min = 15 × 3 min


def test_report_command_line_leaves_out_top_level_flags(monkeypatch):
    from tmaplan.cli.args import command_line

    monkeypatch.setattr("sys.argv", ["/x/bin/tmaplan", "--debug", "compare", "default",
                                     "--runs", "3", "--out", "my dir"])
    assert command_line("compare", "fallback") == "tmaplan compare default --runs 3 --out 'my dir'"
    monkeypatch.setattr("sys.argv", ["/x/bin/tmaplan", "rank-costs", "default"])
    assert command_line("rank-costs", "fallback") == "tmaplan rank-costs default"
    monkeypatch.setattr("sys.argv", ["pytest", "compare"])  # not run as tmaplan
    assert command_line("compare", "fallback") == "fallback"


def test_python_dash_m_tmaplan_runs_the_cli():
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "tmaplan", "problems"], capture_output=True,
                         text=True, check=True).stdout
    assert "bow-closing" in out and "default" in out


def test_prior_samples_have_an_upper_limit(tmp_path, one_line_error):
    path = _problem_file(tmp_path, "default", "samples = 100000", "samples = 100000000000000")
    err = one_line_error(["bound", str(path)])
    assert "prior.samples" in err and "between 5 and 10000000" in err
    assert "100000000000000" in err
    path = _problem_file(tmp_path, "default", "samples = 100000", "samples = 1")
    err = one_line_error(["bound", str(path)])  # one sample: a NaN covariance
    assert "prior.samples" in err and "received 1" in err
