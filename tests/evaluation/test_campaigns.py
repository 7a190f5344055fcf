"""Review of the campaign bookkeeping: stored run files, the spec's checks, the policies
passed in, and the report's command line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.metrics import RunMetrics
from tmaplan.evaluation.records import PolicyRun, RunRecord
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.policies import Combined, Straight
from tmaplan.scenario import load_problem

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _record() -> RunRecord:
    k = 5
    m = RunMetrics(position_error=np.ones(k), range_error=np.ones(k),
                   rel_range_error=np.ones(k), course_error=np.ones(k), speed_error=np.ones(k),
                   time_to_accuracy=float("inf"), diverged=False, pings_used=0,
                   final_position_error=1.0, final_range_error=1.0, final_rel_range_error=1.0)
    pr = PolicyRun(metrics=m, observer=np.zeros((k, 2)), target=np.ones((k, 2)),
                   estimate=np.ones((k, 2)), ping_steps=np.zeros(0, int),
                   replan_seconds=np.zeros(0), replan_converged=np.zeros(0, bool),
                   replan_fell_back=np.zeros(0, bool), replan_infeasible=np.zeros(0, bool))
    return RunRecord(run=0, policies={"straight": pr})


def test_a_truncated_run_file_is_recomputed_not_a_crash(tmp_path):
    """A run file cut short (a full disk, a copy interrupted) is a torn zip archive: loading
    it gives None (the run is recomputed), not a zipfile.BadZipFile out of the resume."""
    path = tmp_path / "run_00000.npz"
    _record().save(path)
    assert RunRecord.load(path, ("straight",)) is not None
    data = path.read_bytes()
    for cut in (len(data) // 2, len(data) - 10):
        path.write_bytes(data[:cut])
        assert RunRecord.load(path, ("straight",)) is None


def test_a_failed_save_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A write that fails (a full disk) raises and leaves neither a run file nor a stray
    ``.tmp`` file in the campaign directory."""
    import tmaplan.evaluation.records as records

    def full_disk(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(records.np, "savez", full_disk)
    with pytest.raises(OSError, match="No space"):
        _record().save(tmp_path / "runs" / "run_00000.npz")
    assert list((tmp_path / "runs").iterdir()) == []


@pytest.mark.parametrize(("change", "field"), [
    ({"truth": "Prior"}, "truth"),          # was flown as truth = "scenario"
    ({"runs": True}, "runs"),
    ({"n_particles": 300.0}, "n_particles"),
    ({"seed": -1}, "seed"),
    ({"seed": 1.5}, "seed"),
    ({"policies": "straight"}, "policies"),  # was read as the policies 's', 't', ...
    ({"policies": ()}, "policies"),
    # these ended in a bare TypeError ('<' between str and int) before the checks ran
    ({"runs": "3"}, "runs"),
    ({"n_particles": "300"}, "n_particles"),
    ({"accuracy": "0.1"}, "accuracy"),
    ({"accuracy": float("nan")}, "accuracy"),
])
def test_campaign_spec_misreadings_are_refused_naming_the_field(scenario, change, field):
    spec = CampaignSpec(scenario=scenario, policies=("straight",), runs=1, n_particles=50)
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        run_campaign(dataclasses.replace(spec, **change))


@pytest.mark.parametrize(("kw", "field"), [
    ({"backend": "process"}, "backend"),    # was found only after resolving the policies
    ({"max_new_runs": -1}, "max_new_runs"),  # was todo[:-1]: all runs but the last
    ({"max_new_runs": True}, "max_new_runs"),
    ({"workers": "2"}, "workers"),           # a bare TypeError
    ({"workers": 0}, "workers"),
])
def test_run_campaign_misreadings_are_refused_naming_the_field(scenario, kw, field):
    spec = CampaignSpec(scenario=scenario, policies=("straight",), runs=2, n_particles=50)
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        run_campaign(spec, **kw)


def test_policy_objects_must_match_the_spec_names(scenario):
    """Policies passed in with a name the spec does not list were flown in every run and
    left out of the results and the report without a word; one missing ended in a bare
    KeyError after every run was computed."""
    spec = CampaignSpec(scenario=scenario, policies=("straight",), runs=1, n_particles=50)
    pol = Combined(manoeuvre=Straight())
    for bad in ({"straight": pol, "extra": pol}, {"other": pol}):
        with pytest.raises(ArgumentError, match="field 'policies'"):
            run_campaign(spec, policies=bad)
    dup = dataclasses.replace(spec, policies=("straight", "straight"))
    with pytest.raises(ArgumentError, match="field 'policies'"):
        run_campaign(dup, policies={"straight": pol})
    res = run_campaign(spec, policies={"straight": pol})
    assert res.policies == ("straight",)


class _Stop(Exception):
    pass


def _reproduce_command(monkeypatch, verb: str, argv: list[str], patches: dict) -> str:
    """The command line the report of ``tmaplan VERB argv`` says reproduces it, when run as
    ``python -m tmaplan`` (argv[0] is the package's __main__.py: the fallback is used)."""
    import importlib
    import sys

    from tmaplan.cli import main

    seen: dict[str, str] = {}

    def report(*a, command, **k):
        seen["command"] = command
        raise _Stop

    mod = importlib.import_module(f"tmaplan.cli.{verb.replace('-', '_')}")
    for target, value in patches.items():
        monkeypatch.setattr(target, value if value is not None else report)
    monkeypatch.setattr(sys, "argv", ["/x/tmaplan/__main__.py", verb, *argv])
    with pytest.raises(_Stop):
        main(["--debug", verb, *argv])
    assert mod is not None
    return seen["command"]


def test_compare_report_command_keeps_accuracy_and_truth(monkeypatch, tmp_path):
    """``python -m tmaplan compare … --accuracy 0.2 --truth scenario``: the report's
    "Reproduce" line left both out, so it reproduced another campaign."""
    import tmaplan.cli.compare as compare

    argv = ["default", "--runs", "2", "--accuracy", "0.2", "--truth", "scenario", "--out",
            str(tmp_path)]
    cmd = _reproduce_command(monkeypatch, "compare", argv, {
        f"{compare.__name__}.run_campaign": lambda spec, **k: spec,
        "tmaplan.report.write_report": None})  # imported by compare when it writes
    assert "--accuracy 0.2" in cmd and "--truth scenario" in cmd, cmd


def test_rank_costs_report_command_keeps_every_setting(monkeypatch, tmp_path):
    """Likewise ``rank-costs``: --accuracy, --plans, --cost-samples and --resamples change
    the result and were left out."""
    from types import SimpleNamespace

    import tmaplan.cli.rank_costs as rank

    fake = SimpleNamespace(to_json=dict)
    argv = ["default", "--candidates", "3", "--accuracy", "0.2", "--plans", "none",
            "--cost-samples", "50", "--resamples", "10", "--no-figure", "--out",
            str(tmp_path)]
    cmd = _reproduce_command(monkeypatch, "rank-costs", argv, {
        f"{rank.__name__}.rank_costs": lambda *a, **k: fake,
        "tmaplan.ranking_report.write_ranking_report": None})  # imported when it writes
    for part in ("--accuracy 0.2", "--plans none", "--cost-samples 50", "--resamples 10"):
        assert part in cmd, cmd


def test_equal_policies_fingerprint_equally_with_numpy_scalars():
    """``UniformPings(budget=np.int64(3)) == UniformPings(budget=3)``, but the fingerprint
    hashed the repr (``np.int64(3)`` vs ``3``): the same campaign was keyed twice and a resume
    recomputed every run. Numpy scalars now hash as the Python value they equal; the
    fingerprints of policies with plain Python values are unchanged (pinned)."""
    from tmaplan.evaluation.records import policy_fingerprint as fp
    from tmaplan.policies import ScheduledPings, SingleTurn, UniformPings, Zigzag

    turn = Combined(manoeuvre=SingleTurn(angle=1.0, time=600.0), ping=UniformPings(budget=3))
    zig = Combined(manoeuvre=Zigzag(leg_duration=300.0, angle=0.5, start=0.0),
                   ping=ScheduledPings(steps=(3, 9)))
    assert (fp(turn), fp(zig)) == ("2e5e615a6212ee4d", "3c56d468aa44a60d")  # stored keys
    turn_np = Combined(manoeuvre=SingleTurn(angle=np.float64(1.0), time=np.float32(600.0)),
                       ping=UniformPings(budget=np.int64(3)))
    zig_np = Combined(manoeuvre=Zigzag(leg_duration=300.0, angle=0.5, start=0.0),
                      ping=ScheduledPings(steps=(np.int64(3), np.int32(9))))
    assert turn_np == turn and zig_np == zig
    assert fp(turn_np) == fp(turn) and fp(zig_np) == fp(zig)
    assert fp(UniformPings(budget=4)) != fp(UniformPings(budget=np.int64(3)))
    # booleans and mapping keys alike
    assert fp({np.int64(2): np.True_, 10: "a"}) == fp({2: True, 10: "a"})
