"""``plan``, ``schedule`` and ``rank-costs`` on a several-contact problem (issue 40).

The joint plan is multi-started from each contact's own plan, so it cannot score worse on
the joint objective than either (up to the solver's tolerance); the shared ping schedule is
certified (its lower bound never above its objective) and its objective is the contacts'
weighted mean; ``rank-costs`` ranks each contact on its own view. A one-contact problem keeps
its JSON shape (no ``contacts`` key). The refusals (a one-contact objective, ``--pings`` with
a time-to-accuracy objective or ``--joint ocp``, ``--workers``, a contact without a prior)
are in ``tests/data/invalid_cli/cases.toml``; ``plan --pings`` in test_cli_contacts_pings.py.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from repo_paths import DATA

from tmaplan.cli import main
from tmaplan.scenario import dump, from_dict, load_problem

PROBLEM = "two-contacts-crossing"


def _run(argv, tmp_path, capsys=None):
    out = tmp_path / f"{argv[0]}.json"
    assert main([*argv, "--json", str(out), "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out if capsys is not None else ""
    return json.loads(out.read_text(encoding="utf-8")), printed


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """The joint plan of the built-in problem, with its console text."""
    tmp = tmp_path_factory.mktemp("plan")
    out = tmp / "plan.json"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["plan", PROBLEM, "--json", str(out), "--out", str(tmp)]) == 0
    return json.loads(out.read_text(encoding="utf-8")), buf.getvalue(), out


def test_joint_plan_is_no_worse_than_each_contacts_own_plan(planned):
    got, _, _ = planned
    sc = load_problem(PROBLEM)
    span = sc.time.horizon + sc.time.dt  # the scale of a time to accuracy [s]
    assert got["objective_name"] == "all-contacts-time-to-accuracy"
    assert got["solver"]["status"] == "Solve_Succeeded"
    assert list(got["contacts"]) == list(sc.contact_names) == list(got["alone_plans"])
    for name, alone in got["alone_plans"].items():
        # the joint NLP started from this plan (or from a start screened better than it)
        assert got["objective"] <= alone["objective"] + 1e-3 * span, name
    for name, c in got["contacts"].items():
        assert 0 < c["expected_time_to_accuracy"] <= span
        assert len(c["range_bound"]) == len(got["observer"]["times"])
        assert c["final_range_bound"] == pytest.approx(c["range_bound"][-1])
        own = got["alone_plans"][name]["contacts"][name]["expected_time_to_accuracy"]
        assert own == pytest.approx(c["alone_expected_time_to_accuracy"], rel=1e-9)
    # the expected time until all are localised is at least each contact's own
    worst = max(c["expected_time_to_accuracy"] for c in got["contacts"].values())
    assert got["objective"] >= worst - 1e-3 * span
    assert {"straight", "single-turn"} <= set(got["baselines"])


def test_joint_plan_console_and_outputs(planned):
    got, printed, _ = planned
    assert "2 contacts, all-contacts-time-to-accuracy" in printed
    assert "joint plan" in printed and "alpha's own plan" in printed
    assert "bravo's own plan" in printed and "start min  course" in printed  # the leg table
    assert Path(got["figure"]).is_file() and got["figure"].endswith(
        f"{PROBLEM}_plan_all-contacts-time-to-accuracy.png")
    assert all(Path(p).is_file() for p in got["exports"].values())
    assert got["legs"] and got["legs"][0]["start"] == 0.0


def test_schedule_along_the_joint_plan_is_certified(planned, tmp_path):
    _, _, plan_json = planned
    got, _ = _run(["schedule", PROBLEM, "--budget", "2", "--observer-plan", str(plan_json),
                   "--no-figure"], tmp_path)
    assert got["observer_plan"] == str(plan_json) and len(got["ping_times"]) <= 2
    plan = json.loads(plan_json.read_text(encoding="utf-8"))
    np.testing.assert_allclose(got["times"], plan["observer"]["times"])
    _check_schedule(got)


def test_shared_schedule_is_certified_and_covers_every_contact(tmp_path, capsys):
    got, printed = _run(["schedule", PROBLEM, "--budget", "2"], tmp_path, capsys)
    _check_schedule(got)
    assert got["max_range"] == pytest.approx(20_000.0)
    assert "2 contacts, weighted mean of their mean-range-bound" in printed
    assert "lower bound" in printed and "gap" in printed
    for name in ("alpha", "bravo"):
        assert f"  {name} " in printed
    assert Path(got["figure"]).is_file()


def _check_schedule(got):
    assert set(got["contacts"]) == {"alpha", "bravo"}
    assert got["solver"]["status"] in ("optimal", "feasible")
    # the certificate: the relaxation's optimum is below every feasible schedule's objective
    assert got["lower_bound"] <= got["objective"] * (1 + 1e-9)
    assert 0 <= got["gap"] <= 1
    assert got["objective"] <= got["no_ping_objective"] * (1 + 1e-9)
    w = {n: c["weight"] for n, c in got["contacts"].items()}
    mean = sum(w[n] * c["objective"] for n, c in got["contacts"].items()) / sum(w.values())
    assert got["objective"] == pytest.approx(mean, rel=1e-9)
    for c in got["contacts"].values():
        assert c["pings_in_reach"] <= len(got["ping_steps"])
        assert c["objective"] <= c["no_ping_objective"] * (1 + 1e-9)
        assert len(c["bound"]) == len(got["times"]) == len(c["reach"])


def test_track_flies_the_joint_plan_for_every_contact(planned, tmp_path):
    # `tmaplan plan P` then `tmaplan track P --observer-plan PLAN.json`: each contact's view
    # refused the plan as one of another problem ('P-alpha'); now every contact flies it, as
    # a one-contact problem of that contact whose own ship flies the plan
    import dataclasses

    from tmaplan.cli.observer_plan import with_observer_plan

    _, _, plan_path = planned
    argv = ["--runs", "1", "--particles", "50", "--no-figure"]
    got, _ = _run(["track", PROBLEM, "--observer-plan", str(plan_path), *argv], tmp_path)
    flown = with_observer_plan(load_problem(PROBLEM), plan_path)
    for name in ("alpha", "bravo"):
        view = dataclasses.replace(flown.contact_view(name), name=f"{PROBLEM}-{name}")
        path = tmp_path / f"{name}.toml"
        path.write_text(dump(view), encoding="utf-8")
        one, _ = _run(["track", str(path), *argv], tmp_path)
        for key in ("bound_range", "rmse_range"):
            np.testing.assert_allclose(got["contacts"][name][key], one[key], rtol=1e-12,
                                       err_msg=f"{name} {key}")


def test_rank_costs_ranks_each_contact_on_its_view(tmp_path):
    got, _ = _run(["rank-costs", PROBLEM, "--candidates", "3", "--runs", "2", "--particles",
                   "50", "--plans", "none", "--cost-samples", "20", "--resamples", "0",
                   "--no-figure"], tmp_path)
    assert set(got) == {"problem", "contacts"} and list(got["contacts"]) == ["alpha", "bravo"]
    for name, c in got["contacts"].items():
        assert c["costs"] and c["candidates"] == 3
        assert Path(c["report"]).name == f"{PROBLEM}-{name}_rank-costs.html"


def test_plan_warns_when_no_plan_can_localise_every_contact(tmp_path, capsys):
    # within 10 min neither contact of two-contacts-crossing is localised on any plan: the
    # all-contacts objective is the horizon on all of them, said in one line
    got, _ = _run(["plan", PROBLEM, "--horizon", "10 min", "--no-figure"], tmp_path)
    err = [x for x in capsys.readouterr().err.splitlines() if "SaturatedObjectiveWarning" in x]
    assert len(err) == 1 and "2 of 2 contacts ('alpha', 'bravo')" in err[0], err
    assert all(c["expected_time_to_accuracy"] >= 600.0 for c in got["contacts"].values())


def test_weighted_means_take_weights_at_any_scale(tmp_path):
    # weights are relative: both 1e308 is both 1 (their sum overflowed to inf: the shared
    # schedule's objective printed 0 m with a NaN gap, compare's weighted mean NaN)
    import tomllib

    from tmaplan.scenario import problems_dir

    d = tomllib.loads((problems_dir() / f"{PROBLEM}.toml").read_text(encoding="utf-8"))
    for c in d["contacts"]:
        c["weight"] = 1e308
    path = tmp_path / "heavy.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    argv = ["--method", "greedy", "--budget", "1", "--no-figure"]
    huge, _ = _run(["schedule", str(path), *argv], tmp_path)
    one, _ = _run(["schedule", PROBLEM, *argv], tmp_path)
    assert huge["ping_steps"] == one["ping_steps"]
    for key in ("objective", "lower_bound", "no_ping_objective"):
        assert np.isfinite(huge[key]) and huge[key] == pytest.approx(one[key], rel=1e-12), key


@pytest.mark.parametrize(("argv", "field"), [
    (["schedule", PROBLEM, "--budget", "500"], "--budget"),
    (["bound", PROBLEM, "--ping-steps", "500", "--no-figure"], "--ping-steps"),
    (["plan", PROBLEM, "--control-interval", "2 min"], "--control-interval")])
def test_a_flag_against_what_the_contacts_share_names_no_contact(argv, field, tmp_path, capsys):
    # the horizon and the planning grid are every contact's: the refusal named the first
    # contact, as if it were about alpha
    assert main([*argv, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"field '{field}'" in err[0] and "(contact '" not in err[0], err


@pytest.mark.parametrize("argv", [
    ["track", PROBLEM, "--estimator", "mle", "--particles", "500"],
    ["rank-costs", PROBLEM, "--plans", "worst-contact"]])
def test_a_bad_flag_is_refused_before_the_first_contacts_block(argv, tmp_path, capsys):
    # the refusal came after "== P: contact alpha (1 of 2) ==" on stdout
    assert main([*argv, "--out", str(tmp_path)]) == 1
    got = capsys.readouterr()
    assert got.out == "" and len(got.err.strip().splitlines()) == 1, got


def test_policies_whose_names_read_alike_in_a_file_name_keep_their_own_files(tmp_path):
    # "planned:a b" and "planned:a_b" were both written to planned_a_b_run0_*: the second
    # policy's flown track overwrote the first's, and the JSON named one file for both
    import tomllib

    from tmaplan.scenario import problems_dir

    d = tomllib.loads((problems_dir() / f"{PROBLEM}.toml").read_text(encoding="utf-8"))
    d["contacts"][0]["name"], d["contacts"][1]["name"] = "a b", "a_b"
    path = tmp_path / "alike.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    got, _ = _run(["compare", str(path), "--policies", "planned:a b,planned:a_b", "--runs",
                   "1", "--particles", "50"], tmp_path)
    files = [got["flown"][p]["exports"]["legs"] for p in ("planned:a b", "planned:a_b")]
    assert files[0] != files[1], files
    texts = [Path(f).read_text(encoding="utf-8") for f in files]
    assert texts[0] != texts[1]  # each contact's own plan, flown


def test_rank_costs_localises_each_contact_at_its_required_accuracy(tmp_path):
    # three-contacts-screen: charlie requires 5 %, the others the default 10 % (or --accuracy,
    # which a contact's own required_accuracy overrides, as in compare); was 10 % for all
    argv = ["rank-costs", "three-contacts-screen", "--candidates", "3", "--runs", "1",
            "--particles", "50", "--plans", "none", "--cost-samples", "20", "--resamples",
            "0", "--no-figure"]
    for extra, want in (([], {"alpha": 0.1, "bravo": 0.1, "charlie": 0.05}),
                        (["--accuracy", "0.2"], {"alpha": 0.2, "bravo": 0.2, "charlie": 0.05})):
        got, _ = _run([*argv, *extra], tmp_path)
        assert {n: c["accuracy"] for n, c in got["contacts"].items()} == want


def test_rank_costs_refuses_a_contact_without_prior_before_ranking_any(tmp_path, capsys):
    # contacts[1] has no prior: refused before contact 0's ranking runs (no header, no runs
    # stored), not after it, in one line naming the contact
    path = DATA / "invalid_cli" / "contacts_one_without_prior.toml"
    assert main(["rank-costs", str(path), "--candidates", "3", "--runs", "2", "--particles",
                 "50", "--plans", "none", "--cost-samples", "20", "--resamples", "0",
                 "--no-figure", "--out", str(tmp_path)]) == 1
    got = capsys.readouterr()
    assert "== " not in got.out and not list(tmp_path.iterdir()), got.out
    err = got.err.strip().splitlines()
    assert len(err) == 1 and "field 'contacts[1].prior'" in err[0] and "'bravo'" in err[0]


def test_one_contact_schedule_keeps_its_shape(tmp_path):
    got, _ = _run(["schedule", "default", "--budget", "2", "--method", "greedy",
                   "--no-figure"], tmp_path)
    assert "contacts" not in got and "max_range" not in got


def test_weighted_objective_is_the_weighted_mean_of_the_contacts_times(tmp_path):
    # three-contacts-screen weighs its fast contact 3: the objective is Σ w E[T] / Σ w plus
    # the turn penalty 0.02·(K+1)·dt·mean (u/u_max)², in [0, 0.02·span], each E[T] scored on
    # the plan's track
    got, _ = _run(["plan", "three-contacts-screen", "--objective", "weighted-time-to-accuracy",
                   "--control-interval", "3 min", "--no-figure"], tmp_path)
    sc = load_problem("three-contacts-screen")
    span = sc.time.horizon + sc.time.dt
    c = got["contacts"]
    assert got["objective_name"] == "weighted-time-to-accuracy"
    assert [c[n]["weight"] for n in sc.contact_names] == [x.weight for x in sc.contacts]
    mean = sum(v["weight"] * v["expected_time_to_accuracy"] for v in c.values()) / sum(
        v["weight"] for v in c.values())
    assert mean - 1e-3 * span <= got["objective"] <= mean + 0.021 * span
    for name, alone in got["alone_plans"].items():
        assert got["objective"] <= alone["objective"] + 1e-3 * span, name


def test_demo_runs_the_three_jobs_for_several_contacts(tmp_path, capsys, monkeypatch):
    """``tmaplan demo P`` on several contacts (issue 40): one joint plan against each
    contact's own plan, one ping schedule for all of them (certified), one campaign of the
    several-contact policies with the key differences on the time until all are localised.
    The baselines on the joint objective are evaluated once (the demo's plan line and the
    campaign's ``single-turn`` evaluated them twice)."""
    import tmaplan.cli.demo_contacts as demo_contacts
    import tmaplan.policies.contacts as contacts_policies
    from tmaplan.caching import LRUCache
    from tmaplan.cli.demo_contacts import CONTACTS_KEY_DIFFERENCES, DEMO_CONTACTS_POLICIES
    from tmaplan.planning.baselines import evaluate_baselines

    joint = []  # the grids evaluated on a given (the joint) evaluator

    def counted(*args, **kw):
        if "evaluator" in kw and len(args) == 1:
            joint.append(args[0].name)
        return evaluate_baselines(*args, **kw)

    for mod in (demo_contacts, contacts_policies):
        monkeypatch.setattr(mod, "evaluate_baselines", counted, raising=False)
    monkeypatch.setattr(contacts_policies, "_BASELINES", LRUCache(8), raising=False)
    js = tmp_path / "demo.json"
    assert main(["demo", "two-contacts-crossing", "--out", str(tmp_path), "--runs", "2",
                 "--particles", "300", "--workers", "1", "--json", str(js)]) == 0
    assert len(joint) == 1, joint
    d = json.loads(js.read_text())
    out = capsys.readouterr().out
    assert d["problem"] == "two-contacts-crossing"
    assert set(d["policies"]) == set(DEMO_CONTACTS_POLICIES)
    assert all("contacts" in d["policies"][p] for p in DEMO_CONTACTS_POLICIES)
    # the joint plan: better than the baselines in its objective; each contact's time on it
    # and on its own plan, said on the console
    assert d["plan"]["objective"] < min(d["plan"]["baselines"].values())
    for c in ("alpha", "bravo"):
        t = d["plan"]["contacts"][c]
        assert 0 < t["expected_time_to_accuracy"] and 0 < t["alone_expected_time_to_accuracy"]
        assert f"{c}  " in out and "on its own plan" in out
    s = d["schedule"]
    assert s["lower_bound"] <= s["objective"] * (1 + 1e-9)
    assert s["objective"] <= min(s["uniform_objective"], s["no_ping_objective"]) + 1e-9
    assert set(s["contacts"]) == {"alpha", "bravo"}
    keys = [(k["a"], k["b"], k["metric"]) for k in d["key_differences"]]
    assert keys == list(CONTACTS_KEY_DIFFERENCES)
    for k in d["key_differences"]:
        assert k["n"] == 2 and (k["decided"] or "not decided at 2 runs" in k["verdict"]
                                or k["verdict"].startswith("undetermined: neither policy"))
    assert "time until every contact is localised, a − b, paired 95 % interval" in out
    assert "planned − nearest-contact" in out and "Stored result" not in out
    assert "the decided campaigns, 200+ paired runs each: docs/results/several-contacts-" in out
    text = Path(d["report"]).read_text()
    assert Path(d["report"]) == tmp_path / "demo" / "report.html"
    assert "Joint plan from the priors" in text and "shared by the contacts" in text


def test_demo_refuses_another_one_contact_problem(tmp_path, capsys):
    assert main(["demo", "bow-closing", "--out", str(tmp_path), "--runs", "2"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "field 'problem': expected 'default'" in err and "tmaplan compare P" in err
    assert "received 'bow-closing'" in err


@pytest.mark.parametrize("active", [True, False])
def test_schedule_warns_that_it_leaves_out_scripted_ranges(tmp_path, capsys, active):
    """Range readings scripted in the file (pings at fixed steps, or passive readings) are not
    in the ping schedule's closed-form bound: its 'no pings' objective was the same with and
    without them, silently (``tmaplan bound`` counts them). One line says so, naming the
    sensor; a file without scripted ranges gets none."""
    import tomllib

    from tmaplan.scenario import problems_dir

    d = tomllib.loads((problems_dir() / "two-contacts-crossing.toml").read_text("utf-8"))
    argv = ["--budget", "1", "--method", "greedy", "--no-figure", "--out", str(tmp_path)]
    assert main(["schedule", "two-contacts-crossing", *argv]) == 0
    assert "warning" not in capsys.readouterr().err
    d["sensors"][1].update(steps=[30, 60], active=active)
    path = tmp_path / "scripted.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")
    assert main(["schedule", str(path), *argv]) == 0
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    what = "pings" if active else "passive range readings (active = false)"
    assert len(err) == 1 and "field 'sensors[1].steps': no scripted range readings" in err[0]
    assert f"leave out these {what}" in err[0] and "received 2 scripted step(s)" in err[0]
