"""Command line: problems, simulate, errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tmaplan.cli import main


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
        assert k["decided"] or "not decided at 2 runs" in k["verdict"]


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
