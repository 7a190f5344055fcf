"""Command line: every number checked up front with one line, unit-aware time flags, one
vocabulary across verbs (--out, --no-figure, --version, --observer-plan, ``problem`` in JSON),
and estimator/bound combinations that cannot give a number refused with a reason."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from repo_paths import DATA, ROOT

from tmaplan.cli import main
from tmaplan.cli.args import MAX_PLAN_STEPS
from tmaplan.scenario import load_problem

# (argv, text the one-line error must contain). Values that need no scenario are refused by
# the argument types before anything is loaded; the others by the up-front checks.
RANGE_CASES = [
    (["plan", "default", "--horizon", "0"], "--horizon must be a duration > 0 s"),
    (["plan", "default", "--horizon", "-5 min"], "--horizon must be a duration > 0 s"),
    (["plan", "default", "--horizon", "30 parsecs"], "with a unit like '30 min'"),
    (["plan", "default", "--horizon", "3 km"], "--horizon must be a duration"),
    (["plan", "default", "--horizon", "8 days"], "at most 604800 s"),
    (["plan", "default", "--horizon", "100000"], f"at most {MAX_PLAN_STEPS} steps"),
    (["plan", "default", "--horizon", "50 s"], "whole number (>= 1) of control intervals"),
    # past the problem's 45 min: a track off its grid (refused by schedule --observer-plan)
    (["plan", "default", "--horizon", "60 min"],
     "--horizon': expected at most the problem's horizon of 2700 s (45 min), received "
     "'3600 s (60 min)'"),
    (["plan", "default", "--control-interval", "20 s"], "(>= 1) of steps of dt = 15 s"),
    # options of the joint plan without --pings were ignored
    (["plan", "default", "--joint", "alternating"], "'--joint': expected only with --pings K"),
    (["plan", "default", "--ping-stride", "3"], "'--ping-stride': expected only with --pings"),
    (["plan", "default", "--pings", "2", "--joint", "alternating", "--ping-stride", "3"],
     "'--ping-stride': expected only with --joint ocp"),
    (["plan", "default", "--starts", "0"], "--starts must be >= 1, received 0"),
    (["plan", "default", "--starts", "100"], "--starts must be <= 7"),
    (["plan", "default", "--starts", "2.5"], "--starts must be an integer >= 1"),
    (["schedule", "default", "--min-spacing", "-5"], "--min-spacing must be a duration >= 0"),
    (["schedule", "default", "--budget", "-1"], "--budget must be >= 0, received -1"),
    (["schedule", "default", "--time-limit", "0"], "--time-limit must be a duration > 0"),
    (["bound", "default", "--samples", "1"], "--samples must be >= 2, received 1"),
    (["bound", "default", "--ping-every", "0 s"], "--ping-every must be a duration > 0"),
    (["bound", "brehard2005-s1", "--ping-every", "3 s"], ">= dt = 6 s"),
    (["bound", "default", "--ping-steps", "5,x"], "comma-separated integers"),
    (["bound", "default", "--ping-steps", "5,99999"], "steps within 0..180"),
    (["track", "default", "--runs", "0"], "--runs must be >= 1, received 0"),
    (["track", "default", "--particles", "1"], "--particles must be >= 2, received 1"),
    (["track", "default", "--particles", "10000000"], "--particles must be <= 1000000"),
    (["track", "default", "--seed", "-1"], "--seed must be >= 0, received -1"),
    (["track", "default", "--particles", "1e4", "--runs", "1.5"],  # 1e4 is an integer
     "--runs must be an integer >= 1, received '1.5'"),
    (["compare", "default", "--accuracy", "0"], "--accuracy must be in (0, 1), received 0.0"),
    (["compare", "default", "--accuracy", "10 %", "--workers", "1000"],
     "--workers must be <= 256"),
    (["compare", "default", "--runs", "1000001"], "--runs must be <= 100000"),
    (["demo", "--runs", "0"], "--runs must be >= 1, received 0"),
    (["demo", "--particles", "1"], "--particles must be >= 2, received 1"),
    (["simulate", "default", "--seed", "abc"], "--seed must be an integer >= 0"),
    (["crlb", "clavard2013-halfturn-cw", "--frequencies", "-1"], "--frequencies must be >= 0"),
    (["plan", "default", "--objective", "nope"], "invalid choice: 'nope'"),
    (["plan"], "the following arguments are required: problem"),
    (["plan", "default", "--frob", "2"], "unrecognized arguments: --frob 2 (see 'tmaplan plan"),
]


@pytest.mark.parametrize(("argv", "text"), RANGE_CASES,
                         ids=[" ".join(a) for a, _ in RANGE_CASES])
def test_cli_numbers_are_checked_up_front(argv, text, one_line_error):
    line = one_line_error(argv)
    assert line.startswith(f"tmaplan {argv[0]}: error:"), line
    assert text in line, line


def test_out_must_be_a_directory(tmp_path, one_line_error):
    f = tmp_path / "afile"
    f.write_text("x")
    line = one_line_error(["simulate", "default", "--out", str(f)])
    assert "--out must be a directory" in line and "afile" in line


# ------------------------------------------------------------------ estimator applicability
APPLICABILITY = [
    # sharma2024 has one bearing (at t = 0): the MLE is built on bearings
    (["track", "sharma2024-range-only", "--estimator", "mle", "--runs", "2"],
     ["mle (the batch MLE of clavard2013) needs at least 5 bearing measurements",
      "sharma2024-range-only has 1", "use --estimator range-only or pf"]),
    (["track", "gordon1993-bot", "--estimator", "mle"], ["use --estimator pf"]),
    (["track", "default", "--bound", "prior"], ["field '--bound'", "use --bound truth"]),
    (["track", "clavard2013-halfturn-cw", "--estimator", "mle", "--bound", "prior"],
     ["with --estimator mle"]),
    (["track", "default", "--estimator", "range-only"],
     ["range-only (range-only tracking of sharma2024) needs at least 3 range",
      "default has 0"]),
    # an option of another estimator was silently ignored
    (["track", "clavard2013-halfturn-cw", "--estimator", "mle", "--pf-variant", "bootstrap"],
     ["field '--pf-variant': expected only with --estimator pf", "received 'bootstrap'"]),
    (["track", "default", "--estimator", "pf-bearings", "--pf-variant", "regularised"],
     ["field '--pf-variant'", "ignored by pf-bearings"]),
    (["track", "default", "--range-only-mode", "dirac"],
     ["field '--range-only-mode': expected only with --estimator range-only"]),
    (["track", "clavard2013-halfturn-cw", "--estimator", "mle", "--particles", "500"],
     ["field '--particles': expected only with --estimator pf or pf-bearings",
      "received 500"]),
]


@pytest.mark.parametrize(("argv", "texts"), APPLICABILITY,
                         ids=[" ".join(a[1:4]) for a, _ in APPLICABILITY])
def test_track_refuses_combinations_that_cannot_work(argv, texts, one_line_error):
    line = one_line_error([*argv, "--no-figure"])
    for t in texts:
        assert t in line, line


def test_mle_still_runs_where_it_applies(capsys):
    # ristic-bot-moderate: the process-noise drift (146 m) is 4× the finest bearing resolution,
    # under the documented 10× limit: the MLE runs and gives finite numbers.
    assert main(["track", "ristic-bot-moderate", "--estimator", "mle", "--runs", "1",
                 "--no-figure", "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert np.isfinite(d["rmse_position"][-1]) and d["problem"] == "ristic-bot-moderate"


# ------------------------------------------------------------------ one vocabulary
def test_version(capsys):
    import tmaplan

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"tmaplan {tmaplan.__version__}"


def test_no_plot_is_a_deprecated_alias_of_no_figure(tmp_path, capsys):
    assert main(["simulate", "default", "--no-plot", "--out", str(tmp_path), "--json",
                 str(tmp_path / "s.json")]) == 0
    err = capsys.readouterr().err
    assert "--no-plot is deprecated, use --no-figure" in err
    assert not list(tmp_path.glob("*.png"))


def test_crlb_writes_its_figure_to_out(tmp_path, capsys):
    js = tmp_path / "c.json"
    assert main(["crlb", "clavard2013-halfturn-cw", "--out", str(tmp_path), "--json",
                 str(js)]) == 0
    out = capsys.readouterr().out
    assert "t_N = 10.45 min" in out  # 627 s, in minutes like every console line
    fig = tmp_path / "crlb_clavard2013-halfturn-cw.png"
    assert fig.stat().st_size > 10_000
    assert json.loads(js.read_text())["figure"] == str(fig)
    assert main(["crlb", "clavard2013-halfturn-cw", "--no-figure", "--out",
                 str(tmp_path / "none"), "--json", "-"]) == 0
    assert not (tmp_path / "none").exists()


def test_problem_key_in_every_json(tmp_path, capsys):
    runs = {
        "simulate": ["simulate", "brehard2005-s1", "--no-figure"],
        "crlb": ["crlb", "clavard2013-halfturn-cw", "--no-figure"],
        "bound": ["bound", "brehard2005-s1", "--no-figure"],
        "schedule": ["schedule", "default", "--budget", "1", "--method", "greedy",
                     "--no-figure"],
    }
    for verb, argv in runs.items():
        assert main([*argv, "--json", "-"]) == 0, verb
        d = json.loads(capsys.readouterr().out)
        assert d["problem"] == argv[1], verb


def test_bound_console_names_and_units(capsys):
    assert main(["bound", "brehard2005-s1", "--method", "closed-form", "--no-figure"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if "final std" in x)
    for name in ("β ", "ln r ", "β̇ ", "ṙ/r "):
        assert name in line, line
    assert "°/s" in line and "1/s" in line and "[" not in line  # no bare numpy array
    assert "over 100 min" in out


def test_truth_centred_prior_is_noted_on_every_run(capsys):
    assert main(["bound", "brehard2005-s1", "--no-figure", "--json", "-"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "warning: brehard2005-s1: the prior is centred on the target's true initial state" \
        in err[0]
    assert "prior.bearing_mean, prior.range_mean, prior.velocity_mean" in err[0]
    assert main(["schedule", "default", "--budget", "1", "--method", "greedy", "--no-figure",
                 "--json", "-"]) == 0
    assert capsys.readouterr().err == ""  # default's prior does not use the truth


def test_time_flags_take_units(capsys):
    outs = []
    for spacing in ("2 min", "120"):
        assert main(["schedule", "default", "--budget", "3", "--method", "greedy",
                     "--min-spacing", spacing, "--no-figure", "--json", "-"]) == 0
        outs.append(json.loads(capsys.readouterr().out))
    assert outs[0]["ping_times"] == outs[1]["ping_times"]
    assert np.min(np.diff(outs[0]["ping_times"])) >= 120.0
    assert main(["schedule", "default", "--budget", "3", "--method", "greedy", "--no-figure"]
                ) == 0
    line = capsys.readouterr().out.splitlines()[0]
    assert "with pings at" in line and " min along the scripted track" in line


def test_schedule_along_a_saved_plan(tmp_path, capsys, one_line_error):
    # `plan --json PLAN.json` then `schedule --observer-plan PLAN.json`: the pings and the
    # bound are those of the API's schedule_pings along the same plan's track.
    from tmaplan.planning import Belief, HeadingPlanner, schedule_pings
    from tmaplan.policies.plan_starts import plan_from_prior

    plan_js, sched_js = tmp_path / "plan.json", tmp_path / "sched.json"
    assert main(["plan", "default", "--horizon", "15 min", "--no-figure",
                 "--json", str(plan_js)]) == 0
    assert main(["schedule", "default", "--budget", "2", "--method", "greedy",
                 "--observer-plan", str(plan_js), "--no-figure", "--json", str(sched_js)]) == 0
    capsys.readouterr()
    p, d = json.loads(plan_js.read_text()), json.loads(sched_js.read_text())
    assert d["times"][-1] == pytest.approx(900.0) and d["observer_plan"] == str(plan_js)
    sc = load_problem("default")
    belief = Belief.from_prior(sc)
    plan = plan_from_prior(sc, planner=HeadingPlanner(sc, horizon=900.0))  # as `plan` does
    np.testing.assert_allclose(p["observer"]["position"], plan.observer.position, atol=1e-6)
    ref = schedule_pings(sc, budget=2, method="greedy", observer=plan.observer, belief=belief)
    assert d["ping_times"] == pytest.approx(ref.times.tolist(), abs=1e-9)
    assert d["objective"] == pytest.approx(ref.objective, rel=1e-9)
    # the plan's track differs from the scripted one, and so does the schedule
    assert main(["schedule", "default", "--budget", "2", "--method", "greedy", "--no-figure",
                 "--json", "-"]) == 0
    assert json.loads(capsys.readouterr().out)["objective"] != pytest.approx(d["objective"])

    line = one_line_error(["schedule", "ristic-bot-moderate", "--observer-plan",
                                    str(plan_js), "--no-figure"])
    assert "--observer-plan" in line and "a plan of problem 'ristic-bot-moderate'" in line
    line = one_line_error(["schedule", "default", "--observer-plan", str(sched_js),
                                    "--no-figure"])
    assert "with an 'observer' track" in line and str(sched_js) in line
    line = one_line_error(["schedule", "default", "--observer-plan",
                                    str(tmp_path / "missing.json"), "--no-figure"])
    assert "no such file" in line


def test_binary_scenario_file_names_the_file(tmp_path, one_line_error):
    f = tmp_path / "scenario.toml"
    f.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    line = one_line_error(["simulate", str(f)])
    assert str(f) in line and "UTF-8 text file" in line


def test_a_scenario_written_from_the_docs_plans_and_compares(tmp_path, capsys):
    # the example of docs/scenario-files.md, to which the README points
    docs = (ROOT / "docs" / "scenario-files.md").read_text(
        encoding="utf-8")
    f = tmp_path / "my.toml"
    f.write_text(docs.split("```toml\n", 1)[1].split("```", 1)[0], encoding="utf-8")
    assert main(["plan", str(f), "--horizon", "20 min", "--no-figure",
                 "--json", "-"]) == 0
    out = capsys.readouterr()
    d = json.loads(out.out)
    assert d["problem"] == "my-case" and d["objective"] < d["baselines"]["straight"]
    assert "warning" not in out.err  # the example's prior does not use the truth
    # (the offline plan was just exercised by `plan`; a tactic keeps the compare cheap)
    assert main(["compare", str(f), "--policies", "straight,leg-turn-leg+scheduled", "--runs",
                 "2", "--particles", "300", "--out", str(tmp_path / "cmp"), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["problem"] == "my-case"
    assert set(d["policies"]) == {"straight", "leg-turn-leg+scheduled"}
    assert all(np.isfinite(p["final_range_rmse"]) for p in d["policies"].values())


def test_simulate_summary_is_named_in_minutes_and_has_no_prior_warning(capsys):
    # simulate does not read the prior, so the truth-centred prior of brehard2005-s2 is not
    # flagged there; its console line names what it counts, times in minutes
    assert main(["simulate", "brehard2005-s2", "--no-figure"]) == 0
    out = capsys.readouterr()
    assert out.err == ""
    assert "1000 steps of 6 s over 100 min" in out.out
    assert "1000 bearing (sensors[0])" in out.out


def test_crlb_frequencies_all_is_the_library_default(tmp_path):
    """`tmaplan crlb` counts no frequency line by default (as `track`, whose MLE bound is this
    one), the library's crlb() every line: `--frequencies all` gives the library's default,
    and the default's difference is visible in the JSON."""
    from tmaplan.bounds.crlb import crlb

    sc = load_problem("clavard2013-halfturn-cw")
    lib = crlb(sc)  # library default: every line
    default, every = tmp_path / "d.json", tmp_path / "a.json"
    assert main(["crlb", sc.name, "--no-figure", "--json", str(default)]) == 0
    assert main(["crlb", sc.name, "--frequencies", "all", "--no-figure", "--json",
                 str(every)]) == 0
    d, a = json.loads(default.read_text()), json.loads(every.read_text())
    assert a["frequencies"] == len(sc.sensors_of("frequency")[0].f0) > 0 == d["frequencies"]
    assert a["final_range_std"] == pytest.approx(lib.final_range_std, rel=1e-12)
    assert d["final_range_std"] == pytest.approx(crlb(sc, frequencies=0).final_range_std,
                                                 rel=1e-12)
    # track takes the same value; its MLE bound is the CRLB of the same lines
    tj = tmp_path / "t.json"
    assert main(["track", sc.name, "--estimator", "mle", "--runs", "1", "--frequencies", "all",
                 "--no-figure", "--json", str(tj)]) == 0
    assert json.loads(tj.read_text())["bound_range"][-1] == pytest.approx(
        lib.final_range_std, rel=1e-6)


def test_a_problem_planning_horizon_past_its_end_is_refused_by_plan(tmp_path, one_line_error):
    # `--horizon 60 min` was refused, the same horizon from the problem's [planning] table
    # planned 15 minutes past the problem's end (bearings that are never measured)
    from tmaplan.scenario import dump

    sc = load_problem("default")
    f = tmp_path / "long.toml"
    f.write_text(dump(sc.replace(planning=dataclasses.replace(sc.planning, horizon=3600.0))))
    line = one_line_error(["plan", str(f), "--no-figure"])
    assert "planning.horizon" in line and "2700 s (45 min)" in line and "3600 s" in line


@pytest.mark.parametrize("verb", [["compare", "--policies", "straight"], ["rank-costs"]])
def test_truths_from_the_prior_of_a_circling_target_are_refused_up_front(tmp_path, verb,
                                                                           one_line_error,
                                                                           monkeypatch):
    # draw_truth refuses a constant-turn target with --truth prior, but only in the first run,
    # after the offline plans (minutes); the verbs now check it before anything is planned
    from tmaplan.scenario import Prior, dump

    circle = load_problem("clavard2013-halfturn-cw")
    prior = Prior(kind="gaussian", mean=(7530.0, 11000.0, 5.0, 0.0), std=(100.0, 100.0, 1.0, 1.0))
    f = tmp_path / "circle.toml"
    f.write_text(dump(circle.replace(prior=prior)))

    def flown(*a, **k):
        raise AssertionError("a run was flown before the check")

    monkeypatch.setattr("tmaplan.evaluation.closed_loop.draw_truth", flown)
    monkeypatch.setattr("tmaplan.simulate.draw_truth", flown)  # rank-costs imports it late
    line = one_line_error([verb[0], str(f), *verb[1:], "--out", str(tmp_path)])
    assert "target.model" in line and "constant-turn" in line and "--truth scenario" in line


@pytest.mark.parametrize("path", sorted((DATA / "planning").glob(
    "*.toml")), ids=lambda p: p.stem)
def test_a_planning_horizon_of_no_whole_control_intervals_is_refused_by_the_planner(
        path, one_line_error):
    # the planner rounded it silently (a 60 min control interval in a 45 min problem planned
    # 60 min); only planning reads these fields, so the file still loads for the other verbs
    from tmaplan.errors import ScenarioError
    from tmaplan.planning import HeadingPlanner
    from tmaplan.scenario import load

    head = dict(line[2:].split(": ", 1) for line in path.read_text().splitlines()[:2])
    sc = load(path)  # loads: `track`, `crlb`, `schedule`, a straight `compare` do not plan
    with pytest.raises(ScenarioError) as exc:
        HeadingPlanner(sc)
    assert exc.value.field == head["expect-field"] and head["expect"] in str(exc.value)
    line = one_line_error(["plan", str(path), "--no-figure"])
    assert head["expect-field"] in line


@pytest.mark.parametrize("name", ["few-bearings", "x"])
def test_a_failed_computation_names_its_problem(tmp_path, one_line_error, name):
    """An error of the computation itself (not of a flag or a field) says which problem it
    is about: a script running many problems can tell which one failed. A name that is
    merely a word of the message ("x" in "(x, y, vx, vy)") still goes in front."""
    from tmaplan.scenario import load_problem, save

    sc = load_problem("default")
    f = tmp_path / "few.toml"
    save(dataclasses.replace(sc, name=name, planning=None,
                             time=dataclasses.replace(sc.time, horizon=30.0)), f)
    line = one_line_error(["crlb", str(f), "--no-figure"])
    assert line.startswith(f"tmaplan crlb: error: {name}: too few measurements"), line
    # flags name themselves, without the problem in front
    line = one_line_error(["bound", "default", "--method", "closed-form", "--samples", "50",
                           "--no-figure"])
    assert line.startswith("tmaplan bound: error: field '--samples'"), line


def test_a_field_error_without_a_source_names_its_problem(monkeypatch, one_line_error):
    """A field error raised without its source (e.g. a scenario field checked deep in a
    computation) gets the problem's name in front; one with a source keeps its own."""
    import tmaplan.cli.crlb as verb
    from tmaplan.errors import ScenarioError

    def failing(args, source=None):
        raise ScenarioError("prior.range_std", "> 0 m", 0.0, source=source)

    monkeypatch.setattr(verb, "run", failing)
    line = one_line_error(["crlb", "default", "--no-figure"])
    assert line == ("tmaplan crlb: error: default: field 'prior.range_std': expected > 0 m, "
                    "received 0.0"), line
    monkeypatch.setattr(verb, "run", lambda args: failing(args, source="other.toml"))
    line = one_line_error(["crlb", "default", "--no-figure"])
    assert line.startswith("tmaplan crlb: error: other.toml: field 'prior.range_std'"), line
