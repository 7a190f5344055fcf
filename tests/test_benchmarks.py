"""The benchmark scripts whose output docs/results/ records: their statistics and options.

The paired difference's censoring, the separation of tuning and evaluation seeds, and the
options the scripts' docstrings document (they exist, the bracketed ones are optional, and a
documented number is the default).
"""

from __future__ import annotations

import argparse
import re
import sys

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.metrics import paired_difference

SCRIPTS = ("planning_pays", "planning_general", "value_of_information", "closed_loop",
           "particle_filter", "interrupts", "contacts_general", "multi_contact_plan",
           "contacts_replans", "contacts_open_loop")


class _Parsed(Exception):
    pass


def _parser(bench, monkeypatch) -> argparse.ArgumentParser:
    """The parser a script's ``main`` builds (stopped at ``parse_args``)."""
    seen = {}

    def capture(self, *args, **kw):
        seen["parser"] = self
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_args", capture)
    with pytest.raises(_Parsed):
        bench.main()
    return seen["parser"]


@pytest.mark.parametrize("name", SCRIPTS)
def test_documented_options_exist_are_optional_and_default_as_shown(name, benchmark_script,
                                                                    monkeypatch):
    bench = benchmark_script(name)
    parser = _parser(bench, monkeypatch)
    actions = {o: act for act in parser._actions for o in act.option_strings}
    doc = bench.__doc__
    for opt in re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", doc):
        assert opt in actions, f"{name}: {opt} documented, not an option"
    for opt, value in re.findall(r"\[(--[a-z][a-z-]*)(?: ([^\]\s]+))?\]", doc):
        act = actions[opt]
        assert not act.required, f"{name}: {opt} shown optional, is required"
        if re.fullmatch(r"\d+", value or ""):
            assert act.default == int(value), f"{name}: {opt} shown {value}, default " \
                                              f"{act.default}"


def test_planning_pays_refuses_the_tuning_seed_for_the_evaluation(benchmark_script,
                                                                  monkeypatch):
    bench = benchmark_script("planning_pays")

    def no_work(*args, **kw):
        raise AssertionError("work started before the seeds were checked")

    monkeypatch.setattr(bench, "load_problem", no_work)
    for argv in (["--seed", "1000"], ["--seed", "2000", "--no-tune", "--select-runs", "4"]):
        monkeypatch.setattr(sys, "argv", ["planning_pays.py", *argv])
        with pytest.raises(SystemExit):
            bench.main()


@pytest.fixture(autouse=True)
def _restore_particle_filter():
    """``closed_loop.py`` wraps the filter's methods with timers when it is loaded."""
    from tmaplan.estimators.particle_filter import ParticleFilter

    saved = {k: ParticleFilter.__dict__[k] for k in ("init", "predict", "update")}
    yield
    for k, v in saved.items():
        setattr(ParticleFilter, k, v)


def test_closed_loop_gaps_take_an_explicit_seed_zero(benchmark_script, monkeypatch):
    bench = benchmark_script("closed_loop")
    seeds = []
    monkeypatch.setattr(bench, "gaps", lambda runs, particles, seed: seeds.append(seed))
    for argv, want in ((["--gaps"], 1000), (["--gaps", "--seed", "0"], 0),
                       (["--gaps", "--seed", "7"], 7)):
        monkeypatch.setattr(sys, "argv", ["closed_loop.py", *argv])
        bench.main()
        assert seeds[-1] == want


@pytest.mark.parametrize("censor", [float("nan"), float("inf"), True, "600", 5.0])
def test_paired_difference_refuses_a_censor_that_is_not_conservative(censor):
    vals = {"a": np.array([10.0, np.inf, 30.0]), "b": np.array([20.0, 25.0, np.inf])}
    with pytest.raises(ArgumentError, match="censor"):
        paired_difference(vals, "a", "b", "t", censor=censor)


def test_paired_difference_censors_both_arms_alike():
    vals = {"a": np.array([10.0, np.inf, 30.0]), "b": np.array([20.0, 25.0, np.inf])}
    d = paired_difference(vals, "a", "b", "t", censor=40.0)
    assert d.mean == pytest.approx(((10 - 20) + (40 - 25) + (30 - 40)) / 3)
    # a censor equal to the largest finite value is allowed (the horizon itself)
    assert paired_difference(vals, "a", "b", "t", censor=30).n == 3


def test_closed_loop_times_each_path_setup_from_an_empty_plan_cache(benchmark_script):
    from tmaplan.policies import manoeuvres
    from tmaplan.scenario import load_problem

    bench = benchmark_script("closed_loop")
    sc = load_problem("default")
    manoeuvres._PLAN_CACHE[(sc, "stale")] = object()
    try:
        pols, _ = bench._policies(sc, ["straight"], "new")
        assert set(pols) == {"straight"}
        assert (sc, "stale") not in manoeuvres._PLAN_CACHE
    finally:
        manoeuvres._PLAN_CACHE.pop((sc, "stale"), None)


def test_closed_loop_old_path_is_the_graph_before_issue_42(benchmark_script):
    """The ``old`` path's ``receding`` re-plans on the objective's casadi graph (the path
    issue 42's ratios are taken against); ``--new-solver ipopt`` on the compiled kernel."""
    from tmaplan.scenario import load_problem

    bench = benchmark_script("closed_loop")
    sc = load_problem("bow-closing")
    old, _ = bench._policies(sc, ["receding"], "old")
    new, _ = bench._policies(sc, ["receding"], "new", "ipopt")
    assert not old["receding"].manoeuvre.uses_compiled
    assert new["receding"].manoeuvre.uses_compiled
    assert new["receding"].manoeuvre.solver == "ipopt"


@pytest.mark.parametrize("runs", [2.5, True, 0, "4"])
def test_plan_check_refuses_runs_that_are_not_whole(runs):
    from tmaplan.experiments import plan_campaign, select_plan, tune_single_turn
    from tmaplan.scenario import load_problem

    sc = load_problem("default")
    with pytest.raises(ArgumentError, match="runs"):
        tune_single_turn(sc, runs=runs)
    with pytest.raises(ArgumentError, match="runs"):
        select_plan(sc, {"a": None, "b": None}, runs=runs)
    with pytest.raises(ArgumentError, match="runs"):
        plan_campaign(sc, runs=runs)


def test_planning_pays_refuses_an_unknown_baseline_before_the_tuning(benchmark_script,
                                                                     monkeypatch):
    from tmaplan.evaluation.plan_check import PLAN_BASELINES
    from tmaplan.experiments import plan_campaign
    from tmaplan.scenario import load_problem

    with pytest.raises(ArgumentError, match="baselines") as err:
        plan_campaign(load_problem("default"), runs=2, baselines=["straigth"])
    assert str(PLAN_BASELINES) in str(err.value)  # the script's list is plan_campaign's
    bench = benchmark_script("planning_pays")
    monkeypatch.setattr(bench, "load_problem", lambda *a, **k: pytest.fail("work started"))
    monkeypatch.setattr(sys, "argv", ["planning_pays.py", "--baselines", "straight,lead-lagg"])
    with pytest.raises(SystemExit):
        bench.main()


@pytest.mark.parametrize("script, argv", [
    ("planning_pays", ["--runs", "1"]), ("planning_general", ["--seed", "9", "--runs", "1"]),
    ("planning_general", ["--seed", "9", "--problems", "1"]),
    ("contacts_general", ["--seed", "9", "--runs", "1"]),
    ("contacts_general", ["--seed", "9", "--problems", "1"]),
    ("contacts_open_loop", ["two-contacts-crossing", "--runs", "1"]),
    ("value_of_information", ["--runs", "1"]), ("particle_filter", ["--runs", "1"])])
def test_benchmarks_refuse_too_few_runs_before_work(benchmark_script, monkeypatch, capsys,
                                                    script, argv):
    # one run (or one problem) gave NaN standard deviations and intervals after the work
    bench = benchmark_script(script)
    for name in ("load_problem", "load", "random_problems", "random_contacts_problems",
                 "ProcessPoolExecutor"):
        if hasattr(bench, name):
            monkeypatch.setattr(bench, name, lambda *a, **k: pytest.fail("work started"))
    monkeypatch.setattr(sys, "argv", [f"{script}.py", *argv])
    with pytest.raises(SystemExit):
        bench.main()
    assert "at least 2" in capsys.readouterr().err


def test_planning_general_eval_seeds(benchmark_script, monkeypatch, capsys):
    # --eval-seed R: a seed of its own per problem (never the tuning seed); a negative root
    # is refused before any work (SeedSequence raised a bare ValueError)
    bench = benchmark_script("planning_general")
    assert [bench.evaluation_seed(None, i) for i in range(3)] == [0, 0, 0]
    seeds = [bench.evaluation_seed(2030, i) for i in range(30)]
    assert len(set(seeds)) == 30 and 1000 not in seeds and min(seeds) >= 0
    assert seeds == [bench.evaluation_seed(2030, i) for i in range(30)]  # reproducible
    monkeypatch.setattr(bench, "random_problems", lambda *a, **k: pytest.fail("work started"))
    monkeypatch.setattr(sys, "argv", ["planning_general.py", "--seed", "9", "--eval-seed", "-1"])
    with pytest.raises(SystemExit):
        bench.main()
    assert "--eval-seed" in capsys.readouterr().err


def test_multi_contact_benchmarks_build_their_contacts(benchmark_script):
    """The several-contact benchmarks' contacts share one own ship (a ContactSet builds)."""
    plan = benchmark_script("multi_contact_plan").contacts()
    assert plan.names == ("north-east", "astern", "west")
    pings = benchmark_script("multi_contact_pings").contacts(20)
    assert len(pings) == 2 and pings.views[0].time.n_steps == 20


@pytest.mark.slow  # two joint plans, each contact's own plan and the grid: ~35 s
@pytest.mark.solver_sensitive
def test_contacts_open_loop_flies_the_families_it_names(benchmark_script):
    # the campaign's plans are the ones the script's table names: the policies `compare`
    # flies under those names, the grid's best zig-zag as `compare` flies it (the grid's
    # angle is the whole swing), the next turns of the joint objective's ranking, a joint
    # plan of a stricter threshold that differs from the joint plan; the predicted
    # objectives are the joint planner's and the grid's, and the shapes are described
    from tmaplan.planning.baselines import evaluate_baselines
    from tmaplan.policies import contacts as pc
    from tmaplan.scenario import load_problem

    bench = benchmark_script("contacts_open_loop")
    sc = load_problem("two-contacts-crossing")
    pols, pred = bench.candidates(sc, 2)
    assert list(pols) == ["planned", "planned-half-accuracy", "single-turn", "turn2", "turn3",
                          "zigzag", "planned:alpha", "planned:bravo", "alternate"]
    for name in ("planned", "single-turn", "planned:alpha", "planned:bravo", "alternate"):
        assert pols[name] == pc.parse_contacts_policy(name, sc)
    pl = pc.contacts_planner(sc)
    grid = evaluate_baselines(pl.contacts.views[0],
                              evaluator=pl.joint.evaluator(pl.contacts.beliefs()))
    assert pred["planned"] == pytest.approx(pc.joint_contacts_plan(sc).objective, rel=1e-9)
    z = grid["zigzag"][0]
    assert pred["zigzag"] == pytest.approx(z.objective, rel=1e-9)
    assert pols["zigzag"].manoeuvre.angle == pytest.approx(0.5 * z.params["angle"])
    np.testing.assert_allclose(pols["zigzag"].manoeuvre.nominal_track(sc).position,
                               z.track.position, atol=1e-6)
    for name, b in zip(("single-turn", "turn2", "turn3"), grid["single-turn"][:3], strict=True):
        m = pols[name].manoeuvre
        assert (m.angle, m.time - sc.time.t0) == pytest.approx((b.params["angle"],
                                                                 b.params["time"]))
        assert pred[name] == pytest.approx(b.objective, rel=1e-9)
    assert pred["planned"] < min(pred[k] for k in ("single-turn", "turn2", "turn3", "zigzag"))
    half = pols["planned-half-accuracy"].manoeuvre.plan.heading
    assert not np.allclose(half, pols["planned"].manoeuvre.plan.heading, atol=1e-3)
    shape = bench.describe(sc, pols)
    b = grid["single-turn"][0].params
    assert shape["single-turn"] == (f"{round(np.degrees(b['angle'])):+d}° at "
                                    f"{b['time'] / 60:.1f} min")
    assert "-0°" not in " ".join(shape.values())
    assert shape["zigzag"].startswith("first leg ") and shape["alternate"].startswith("legs ")
