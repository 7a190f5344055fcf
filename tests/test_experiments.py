"""Monte Carlo comparison: common random numbers, backend independence, resume, metrics."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess

import numpy as np
import pytest

from tmaplan.errors import PlanningError
from tmaplan.evaluation.metrics import censor_time, paired_difference, settling_time
from tmaplan.evaluation.records import RunRecord, scenario_hash
from tmaplan.experiments import CampaignSpec, resolve_policies, run_campaign, run_one
from tmaplan.policies import Combined, SingleTurn, Straight, UniformPings, Zigzag
from tmaplan.report import write_report
from tmaplan.scenario import dump, load_problem, loads

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _spec(scenario, runs=3, policies=("straight", "zigzag+uniform")):
    return CampaignSpec(scenario=scenario, policies=policies, runs=runs, seed=11,
                        n_particles=300)


def test_settling_time():
    t = np.arange(6) * 10.0
    assert settling_time(t, np.array([0.5, 0.05, 0.2, 0.05, 0.04, 0.01]), 0.1) == 30.0
    assert settling_time(t, np.array([0.05] * 6), 0.1) == 0.0
    assert settling_time(t, np.array([0.05] * 5 + [0.2]), 0.1) == float("inf")
    # docs/findings.md's "first time after which the error *stays* below": a dip is not enough
    assert settling_time(t, np.array([0.5, 0.05, 0.05, 0.2, 0.5, 0.05]), 0.1) == 50.0
    assert settling_time(t, np.array([0.05, np.nan, 0.05, 0.05, 0.05, 0.05]), 0.1) == 20.0


def test_censor_time_is_the_horizon_plus_one_step(scenario):
    """"Never" counts as the horizon + dt: 45.25 min on default (docs/findings.md), 30.25
    min on bow-closing."""
    assert censor_time(scenario.times) == 45.25 * 60.0
    assert censor_time(load_problem("bow-closing").times) == 30.25 * 60.0
    assert censor_time(np.array([100.0, 110.0, 120.0])) == 30.0


def test_paired_difference_interval():
    rng = np.random.default_rng(0)
    base = rng.normal(100, 30, 400)
    vals = {"a": base - 5 + rng.normal(0, 1, 400), "b": base}
    d = paired_difference(vals, "a", "b", "m")
    # pairing removes the ±30 spread: the interval is about ±0.1 around −5
    assert d.ci_low < -5 < d.ci_high and d.ci_high - d.ci_low < 0.3 and d.excludes_zero
    d2 = paired_difference({"a": np.array([1.0, np.inf]), "b": np.array([2.0, 3.0])}, "a", "b",
                           "t", censor=10.0)
    assert d2.mean == pytest.approx(3.0)
    # a level given in percent, or unpaired runs, are refused (not NaN bounds)
    from tmaplan.errors import ArgumentError

    for bad in (95, 0.0, 1.0, True, float("nan")):
        with pytest.raises(ArgumentError, match="level"):
            paired_difference(vals, "a", "b", "m", level=bad)
    with pytest.raises(ArgumentError, match="one value per run"):
        paired_difference({"a": np.zeros(3), "b": np.zeros(4)}, "a", "b", "m")
    # a NaN (e.g. the final range error of a non-finite estimate), or an infinite time
    # without censor, is refused with the runs named (it made the mean and interval NaN)
    with pytest.raises(ArgumentError, match=r"values\['b'\].*nan at run\(s\) \[1\]"):
        paired_difference({"a": np.zeros(3), "b": np.array([0.0, np.nan, 1.0])}, "a", "b", "m")
    with pytest.raises(ArgumentError, match=r"values\['a'\].*censor"):
        paired_difference({"a": np.array([1.0, np.inf]), "b": np.zeros(2)}, "a", "b", "t")
    with pytest.raises(ArgumentError, match=r"values\['a'\]"):  # NaN is not censored
        paired_difference({"a": np.array([1.0, np.nan]), "b": np.zeros(2)}, "a", "b", "t",
                          censor=10.0)



def test_paired_difference_is_scipys_paired_t_interval_at_any_real_level():
    """The interval is the paired t interval (n − 1 degrees of freedom) of scipy; a level
    given as a numpy scalar (np.float32) was refused as not a confidence level."""
    from scipy import stats

    rng = np.random.default_rng(3)
    a, b = rng.normal(10.0, 3.0, 25), rng.normal(10.5, 3.0, 25)
    for level in (0.95, np.float32(0.9), np.float64(0.8)):
        d = paired_difference({"a": a, "b": b}, "a", "b", "m", level=level)
        ci = stats.ttest_rel(a, b).confidence_interval(float(level))
        assert (d.ci_low, d.ci_high) == pytest.approx((ci.low, ci.high), rel=1e-12)
        assert d.level == float(level) and d.n == 25
    from tmaplan.errors import ArgumentError

    with pytest.raises(ArgumentError, match="level"):
        paired_difference({"a": a, "b": b}, "a", "b", "m", level="0.95")

def test_common_random_numbers(scenario):
    spec = _spec(scenario, policies=("straight", "zigzag"))
    pols = {"straight": Combined(manoeuvre=Straight()),
            "zigzag": Combined(manoeuvre=Zigzag(leg_duration=300.0, angle=0.7))}
    a = run_one(spec, pols, 0).to_arrays()
    b = run_one(spec, pols, 0).to_arrays()
    for k in a:
        assert np.array_equal(a[k], b[k]), k
    # same truth for every policy in a run, a different truth in another run
    assert np.array_equal(a["straight/target"], a["zigzag/target"])
    c = run_one(spec, pols, 1)
    assert not np.array_equal(a["straight/target"], c.policies["straight"].target)
    # the manoeuvre changes the track (so the comparison is not vacuous)
    assert not np.array_equal(a["straight/observer"], a["zigzag/observer"])


def test_run_record_round_trips_and_scenario_hash_is_content(scenario, tmp_path):
    spec = _spec(scenario, policies=("x",))
    rec = run_one(spec, {"x": Combined(manoeuvre=Straight(), ping=UniformPings(budget=2))}, 0)
    rec.save(tmp_path / "r.npz")
    back = RunRecord.load(tmp_path / "r.npz", ("x",))
    assert back is not None and back.run == 0
    a, b = rec.to_arrays(), back.to_arrays()
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    assert back.policies["x"].metrics.pings_used == 2
    assert RunRecord.load(tmp_path / "r.npz", ("y",)) is None  # another campaign's file
    # the hash is the content: equal after a TOML round trip, different after any change
    assert scenario_hash(loads(dump(scenario))) == scenario_hash(scenario)
    moved = scenario.replace(observer=dataclasses.replace(scenario.observer,
                                                          position=(1.0, 0.0)))
    assert scenario_hash(moved) != scenario_hash(scenario)
    assert _spec(moved).key() != _spec(scenario).key()


def test_policies_respect_limits_and_budget(scenario):
    spec = _spec(scenario, policies=("x",))
    pol = Combined(manoeuvre=SingleTurn(angle=np.radians(120), time=600.0),
                   ping=UniformPings(budget=3))
    out = run_one(spec, {"x": pol}, 0).policies["x"]
    assert out.metrics.pings_used == 3 and len(out.ping_steps) == 3
    obs = out.observer
    v = np.diff(obs, axis=0) / scenario.time.dt
    speed = np.hypot(*v.T)
    assert np.allclose(speed, scenario.observer.speed, rtol=1e-3)  # chord ≈ arc at 0.5°/s
    course = np.unwrap(np.arctan2(v[:, 0], v[:, 1]))
    assert np.max(np.abs(np.diff(course))) <= scenario.observer.turn_rate_max * 15.0 + 1e-9


@pytest.mark.timeout(300)
def test_backends_bit_identical(scenario):
    """Serial, 2 processes and Dask give the same results, the real-time-iteration receding
    policy included (its model is computed once in the parent and shipped to the workers;
    the IPOPT re-plans' shipped first plan: test_multi_start_receding_is_bit_identical_...)."""
    spec = _spec(scenario, runs=2, policies=("straight", "zigzag+uniform", "receding-realtime"))
    pols = resolve_policies(scenario, spec.policies)
    serial = run_campaign(spec, policies=pols)
    procs = run_campaign(spec, workers=2, backend="processes", policies=pols)
    dask = run_campaign(spec, workers=2, backend="dask", policies=pols)
    for other in (procs, dask):
        assert other.policies == serial.policies
        for name in serial.policies:
            for key in ("rmse_position", "rmse_range", "time_to_accuracy_runs"):
                assert np.array_equal(serial.summary[name][key], other.summary[name][key])
        assert _untimed(other) == _untimed(serial)


@pytest.mark.timeout(300)
def test_multi_start_receding_is_bit_identical_on_workers(scenario):
    """The five-start receding policy (its first plan computed once in the parent and shipped)
    flies the same on 2 processes as serially (10 minutes, 2 re-plans, a 10-minute
    look-ahead)."""
    from tmaplan.policies import Combined, Receding

    sc = scenario.replace(time=dataclasses.replace(scenario.time, horizon=600.0))
    spec = _spec(sc, runs=2, policies=("receding",))
    pols = {"receding": Combined(manoeuvre=Receding(objective="mean-range-bound",
                                                    horizon=600.0, solver="multi-start")
                                 ).resolve(sc)}
    assert pols["receding"].manoeuvre.first_plan is not None
    serial = run_campaign(spec, policies=pols)
    procs = run_campaign(spec, workers=2, backend="processes", policies=pols)
    assert _untimed(procs) == _untimed(serial)
    assert np.array_equal(serial.summary["receding"]["rmse_range"],
                          procs.summary["receding"]["rmse_range"])


def _untimed(result):
    """The campaign's policies JSON without wall-clock timings (planning seconds)."""
    return json.dumps({name: {k: v for k, v in d.items() if "seconds" not in k}
                       for name, d in result.to_json()["policies"].items()})


def test_interrupted_campaign_resumes(scenario, tmp_path, monkeypatch):
    spec = _spec(scenario, runs=4)
    with pytest.raises(PlanningError, match="incomplete"):
        run_campaign(spec, out_dir=tmp_path, max_new_runs=2)  # "killed" after two runs
    files = sorted((tmp_path / f"campaign-{spec.key()}" / "runs").glob("*.npz"))
    assert [f.name for f in files] == ["run_00000.npz", "run_00001.npz"]
    # a torn file left by a kill is recomputed, not trusted
    (files[1].parent / "run_00002.npz").write_bytes(b"partial")
    res = run_campaign(spec, out_dir=tmp_path)
    assert res.loaded_runs == (0, 1) and res.computed_runs == (2, 3)
    fresh = run_campaign(spec)
    for name in spec.policies:
        assert np.array_equal(res.summary[name]["rmse_position"],
                              fresh.summary[name]["rmse_position"])
    # every run stored: the policies are not resolved again (no offline plan, no schedule)
    import tmaplan.evaluation.campaigns as campaigns

    def _no_resolve(*a, **k):
        raise AssertionError("policies resolved for a campaign with every run stored")

    monkeypatch.setattr(campaigns, "_resolve", _no_resolve)
    again = run_campaign(spec, out_dir=tmp_path)
    assert again.computed_runs == () and again.loaded_runs == (0, 1, 2, 3)
    for name in spec.policies:
        assert np.array_equal(again.summary[name]["rmse_position"],
                              res.summary[name]["rmse_position"])
    with pytest.raises(AssertionError, match="resolved"):  # the patch is in force
        run_campaign(_spec(scenario, runs=1))


def test_report_has_every_figure(scenario, tmp_path):
    res = run_campaign(_spec(scenario, runs=2))
    path = write_report(res, tmp_path, command="tmaplan compare default --runs 2")
    text = path.read_text()
    assert text.count("data:image/png;base64,") == 3
    assert "tmaplan compare default --runs 2" in text and "[time]" in text
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        pytest.skip("no headless chromium on this machine: figures checked as embedded PNGs")
    proc = subprocess.run(
        [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={tmp_path / 'chrome'}",
         "--virtual-time-budget=5000", "--dump-dom", path.as_uri()],
        capture_output=True, text=True, timeout=120)
    assert 'data-images-loaded="3"' in proc.stdout, proc.stderr[-2000:]
    assert 'data-images-total="3"' in proc.stdout


@pytest.mark.timeout(300)
def test_compare_cli_json_identical_for_any_worker_count(tmp_path):
    from tmaplan.cli import main

    outs = []
    for workers in ("1", "2"):
        js = tmp_path / f"w{workers}.json"
        assert main(["compare", "default", "--policies", "straight,zigzag+uniform", "--runs",
                     "3", "--particles", "300", "--seed", "5", "--workers", workers,
                     "--out", str(tmp_path / f"out{workers}"), "--json", str(js)]) == 0
        d = json.loads(js.read_text())
        outs.append({k: d[k] for k in ("policies", "differences", "runs", "seed", "times")})
    assert json.dumps(outs[0], sort_keys=True) == json.dumps(outs[1], sort_keys=True)


@pytest.mark.parametrize(("args", "message"), [
    (["--runs", "0"], "runs must be >= 1, received 0"),
    (["--particles", "1"], "particles must be >= 2, received 1"),
    (["--workers", "0"], "workers must be >= 1, received 0"),
    (["--accuracy", "2"], "accuracy must be in (0, 1), received 2.0"),
    (["--policies", "straight,loop"],
     "field '--policies': expected names MANOEUVRE[+PING] with MANOEUVRE in"),
])
def test_compare_rejects_bad_input_with_one_line(args, message, tmp_path, capsys):
    from tmaplan.cli import main

    base = ["compare", "default", "--runs", "2", "--out", str(tmp_path)]
    assert main(base + args) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


def test_every_policy_satisfies_the_policy_protocol(scenario):
    from tmaplan.policies import (
        AdaptivePings,
        Controller,
        ManoeuvrePolicy,
        NoPing,
        Planned,
        Policy,
        Receding,
        ScheduledPings,
    )

    manoeuvres = [Straight(), SingleTurn(angle=1.0, time=600.0),
                  Zigzag(leg_duration=300.0, angle=0.5), Planned(), Receding()]
    pings = [NoPing(), UniformPings(budget=2), ScheduledPings(steps=(3, 9)), AdaptivePings()]
    for m in manoeuvres:
        assert isinstance(m, ManoeuvrePolicy), m
    for p in [*pings, Combined(manoeuvre=Straight(), ping=UniformPings(budget=2))]:
        assert isinstance(p, Policy) and not isinstance(p, ManoeuvrePolicy), p
        assert isinstance(p.controller(scenario), Controller)
    assert Combined(manoeuvre=Straight(), ping=UniformPings()).name == "straight+uniform"


@pytest.mark.timeout(400)
def test_resolve_policies_solves_the_offline_plans_on_the_workers(monkeypatch):
    """With ``workers > 1`` the offline plan of ``planned`` (and ``receding``) is computed
    first, its multi-start on the worker processes; not for manoeuvres without one."""
    from tmaplan.policies import CLOSED_LOOP_OBJECTIVE

    calls = []

    class Stop(Exception):
        pass

    def fake(scenario, objective, *, workers=1, pool=None):
        calls.append((scenario.name, objective, workers))
        raise Stop

    monkeypatch.setattr("tmaplan.evaluation.campaigns.offline_plan", fake)
    sc = load_problem("default")
    assert set(resolve_policies(sc, ["straight", "zigzag"], workers=2)) == {"straight",
                                                                             "zigzag"}
    assert calls == []
    with pytest.raises(Stop):
        resolve_policies(sc, ["straight", "planned"], workers=2)
    assert calls == [("default", CLOSED_LOOP_OBJECTIVE, 2)]


def test_stored_runs_of_another_policy_under_the_same_name_are_not_reused(scenario,
                                                                          tmp_path):
    """Policy objects passed in enter the key by what they fly: a second tuned turn stored
    under the same name gets its own runs (the first one's are not loaded), and the same
    policy again, or a plan differing only in its solve time, reuses them."""
    from tmaplan.evaluation.records import policy_fingerprint
    from tmaplan.policies import Planned

    spec = _spec(scenario, runs=1)

    def pols(angle):
        turn = SingleTurn(angle=np.radians(angle), time=scenario.time.t0 + 300.0,
                          name="tuned-turn")
        return {"straight": Combined(manoeuvre=Straight()),
                "tuned-turn": Combined(manoeuvre=turn)}

    spec = dataclasses.replace(spec, policies=("straight", "tuned-turn"))
    first = run_campaign(spec, out_dir=tmp_path, policies=pols(60.0))
    assert first.computed_runs == (0,)
    other = run_campaign(spec, out_dir=tmp_path, policies=pols(-120.0))
    assert other.computed_runs == (0,) and other.loaded_runs == ()
    fresh = run_campaign(spec, policies=pols(-120.0))
    assert np.array_equal(other.examples["tuned-turn"].observer,
                          fresh.examples["tuned-turn"].observer)
    assert not np.array_equal(first.examples["tuned-turn"].observer,
                              other.examples["tuned-turn"].observer)
    again = run_campaign(spec, out_dir=tmp_path, policies=pols(60.0))
    assert again.loaded_runs == (0,) and again.computed_runs == ()
    assert spec.key(pols(60.0)) != spec.key() != spec.key(pols(-120.0))
    # timings are not what a plan flies; its turn rates are (a stand-in for a HeadingPlan)
    @dataclasses.dataclass(frozen=True)
    class Plan:
        turn_rate: np.ndarray
        seconds: float

    plan = Plan(turn_rate=np.linspace(-0.01, 0.01, 31), seconds=1.5)
    p = Planned(objective="mean-range-bound", plan=plan)
    slower = dataclasses.replace(plan, seconds=11.5)
    assert policy_fingerprint(p) == policy_fingerprint(dataclasses.replace(p, plan=slower))
    moved = dataclasses.replace(plan, turn_rate=plan.turn_rate + 1e-12)
    assert policy_fingerprint(p) != policy_fingerprint(dataclasses.replace(p, plan=moved))


def test_campaign_json_says_where_the_truths_came_from(scenario):
    for truth in ("prior", "scenario"):
        spec = CampaignSpec(scenario=scenario, policies=("straight",), runs=1, seed=11,
                            n_particles=100, truth=truth)
        assert run_campaign(spec).to_json()["truth"] == truth
