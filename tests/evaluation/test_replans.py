"""Re-plans that converge or say so (issue 38): the receding controller's log, its fallback
starts, the campaign's counts (``replans`` of ``tmaplan compare``) and the warning above 1 %."""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest
from repo_paths import DATA

from tmaplan.errors import SolverError
from tmaplan.evaluation.replans import (
    NOT_CONVERGED_WARNING,
    ReplanCounts,
    ReplanWarning,
    replan_flags,
    warn_not_converged,
)
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.policies import Receding, Straight
from tmaplan.policies.base import BeliefView

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

_KW = {"objective": "mean-range-bound", "horizon": 900.0, "replan_interval": 300.0,
       "solver": "ipopt"}


@pytest.fixture(scope="module")
def small(default):
    """`default` flown for 15 minutes (three re-plans), a 15-interval range-bound plan."""
    sc = default.replace(time=dataclasses.replace(default.time, horizon=900.0))
    prior = Belief.from_prior(sc)
    planner = HeadingPlanner(sc, objective="mean-range-bound", horizon=900.0)
    return sc, prior, planner, planner.solve(prior)


class _WarmFails:
    """A planner whose warm-started solves stop at the iteration limit (``always``: every
    solve), the others solved by the real planner."""

    def __init__(self, planner: HeadingPlanner, always: bool = False) -> None:
        self.planner, self.always, self.calls = planner, always, []

    def __getattr__(self, name):
        return getattr(self.planner, name)

    def solve(self, b, **kw):
        self.calls.append("warm" if kw.get("warm_start") is not None else "start")
        if self.always or kw.get("warm_start") is not None:
            raise SolverError("ipopt", "Maximum_Iterations_Exceeded", "injected")
        return self.planner.solve(b, **kw)


def _view(prior, t=0.0):
    n = 500
    return BeliefView(step=int(t // 15), t=t, heading=0.0, position=np.zeros(2),
                      particles=prior.samples[:n], weights=np.full(n, 1 / n), pings_used=0,
                      alarms=0)


def test_counts_add_up_and_old_logs_read_a_failure_as_a_fallback():
    log = [{"success": True, "fell_back": False}, {"success": True, "fell_back": True},
           {"success": False, "fell_back": True, "infeasible": False},
           {"success": False, "fell_back": True, "infeasible": True},
           {"success": False}]  # the last: no keys (not converged, fell back)
    ok, back, bad = replan_flags(log)
    assert ok.tolist() == [True, True, False, False, False]
    assert back.tolist() == [False, True, True, True, True]
    assert bad.tolist() == [False, False, False, True, False]
    c = ReplanCounts.count([(ok, back, bad), replan_flags([])])
    assert c == ReplanCounts(total=5, converged=2, not_converged=2, fell_back=4)
    assert c.infeasible == 1 and c.converged + c.not_converged + c.infeasible == c.total
    assert c.to_json() == {"total": 5, "converged": 2, "not_converged": 2, "fell_back": 4}
    assert c.not_converged_share == 0.4
    assert c.text() == "5 re-plans, 2 not converged (40.0 %), 1 infeasible, 4 fell back"
    none = ReplanCounts.count([])
    assert none == ReplanCounts() and none.not_converged_share == 0.0
    assert none.text() == "no re-plans"
    # a re-plan without a plan always fell back, and a converged one is never infeasible,
    # whatever a log says
    flags = (np.array([False, True]), np.array([False, False]), np.array([False, True]))
    assert ReplanCounts.count([flags]) == ReplanCounts(total=2, converged=1,
                                                       not_converged=1, fell_back=1)


def test_warning_only_above_one_percent():
    at = ReplanCounts(total=100, converged=99, not_converged=1, fell_back=1)
    over = ReplanCounts(total=99, converged=97, not_converged=2, fell_back=2)
    assert at.not_converged_share == NOT_CONVERGED_WARNING
    with warnings.catch_warnings():
        warnings.simplefilter("error", ReplanWarning)
        warn_not_converged({"a": at, "b": ReplanCounts()})
    with pytest.warns(ReplanWarning, match=r"b 2 of 99 \(2\.0 %\)") as rec:
        warn_not_converged({"a": at, "b": over})
    assert len(rec) == 1 and "\n" not in str(rec[0].message) and "a 1" not in str(
        rec[0].message)


def test_a_re_plan_at_the_iteration_limit_is_reported_not_converged_and_fell_back(small):
    """A real IPOPT failure (``max_iter`` 1) at every start: the re-plan is logged not
    converged and fallen back, naming the status, and the own ship flies on (straight: no
    plan before)."""
    sc, prior, _, plan = small
    ctrl = Receding(**_KW, first_plan=plan).controller(sc)
    ctrl.planner = HeadingPlanner(sc, objective="mean-range-bound", horizon=900.0,
                                  solver_options={"max_iter": 1})
    act = ctrl.act(_view(prior), 0.0)
    (entry,) = ctrl.log
    assert not entry["success"] and entry["fell_back"] and not entry["infeasible"]
    assert "Maximum_Iterations_Exceeded" in entry["status"]
    assert "fallback starts" in entry["status"]  # the fallback was tried, and said so
    assert ctrl.plan is None and act.turn_rate == 0.0


def test_a_re_plan_rescued_by_the_fallback_starts_converges_and_says_it_fell_back(small):
    sc, prior, planner, plan = small
    ctrl = Receding(**_KW, first_plan=plan).controller(sc)
    ctrl.planner = flaky = _WarmFails(planner)
    ctrl.act(_view(prior), 0.0)
    (entry,) = ctrl.log
    assert entry["success"] and entry["fell_back"] and entry["solver"] == "ipopt"
    assert entry["start"].startswith("multi-start: ")
    assert flaky.calls[0] == "warm" and set(flaky.calls[1:]) == {"start"}
    # the plan flown is a converged solve, the best of the fallback starts
    assert ctrl.plan.success and ctrl.plan.status in ("Solve_Succeeded",
                                                      "Solved_To_Acceptable_Level")
    # ... no worse than the straight start, one of them, solved on its own
    b = Belief.from_particles(prior.samples[:500], np.full(500, 1 / 500), t=0.0,
                              assimilated=True)
    straight = planner.solve(b, starts=[np.zeros(planner.n)], tol=1e-4,
                             raise_on_failure=False)
    if straight.success:
        assert ctrl.plan.objective <= straight.objective + 1e-9 * abs(straight.objective)
    # without the fallback the same failure keeps the previous plan at once
    ctrl = Receding(**_KW, first_plan=plan, fallback_starts=False).controller(sc)
    ctrl.planner = flaky = _WarmFails(planner)
    ctrl.act(_view(prior), 0.0)
    assert not ctrl.log[0]["success"] and ctrl.log[0]["fell_back"] and flaky.calls == ["warm"]


def test_a_re_plan_inside_the_keep_out_range_is_infeasible_not_unconverged(small):
    """The target estimate already inside the keep-out range: no plan can keep out; the
    re-plan is logged infeasible (the planner declined), not as a solver failure."""
    sc, prior, planner, plan = small
    ctrl = Receding(**_KW, first_plan=plan).controller(sc)
    ctrl.planner = planner
    near = prior.samples[:500].copy()
    near[:, :2] *= 0.5 * planner.keep_out / np.hypot(*prior.mean[:2])  # inside it
    view = dataclasses.replace(_view(prior), particles=near)
    ctrl.act(view, 0.0)
    (entry,) = ctrl.log
    assert not entry["success"] and entry["fell_back"] and entry["infeasible"]
    assert "keep_out_range" in entry["status"]
    counts = ReplanCounts.count([replan_flags(ctrl.log)])
    assert (counts.not_converged, counts.infeasible) == (0, 1)


def test_a_converged_re_plan_did_not_fall_back(small):
    sc, prior, planner, plan = small
    ctrl = Receding(**_KW, first_plan=plan).controller(sc)
    ctrl.planner = planner
    ctrl.act(_view(prior), 0.0)
    (entry,) = ctrl.log
    assert entry["success"] and not entry["fell_back"] and "start" not in entry


def _campaign(sc, plan, tmp_path, monkeypatch, always):
    from tmaplan.evaluation.campaigns import CampaignSpec, run_campaign

    real = HeadingPlanner.solve

    def solve(self, b, **kw):
        if always or kw.get("warm_start") is not None:
            raise SolverError("ipopt", "Maximum_Iterations_Exceeded", "injected")
        return real(self, b, **kw)

    monkeypatch.setattr(HeadingPlanner, "solve", solve)
    spec = CampaignSpec(scenario=sc, policies=("straight", "receding"), runs=1,
                        n_particles=200)
    pols = {"straight": Straight(), "receding": Receding(**_KW, first_plan=plan)}
    return run_campaign(spec, policies=pols, out_dir=tmp_path)


def test_campaign_counts_re_plans_not_converged_and_warns(small, tmp_path, monkeypatch):
    sc, _, _, plan = small
    with pytest.warns(ReplanWarning, match=r"receding 3 of 3 \(100\.0 %\)"):
        res = _campaign(sc, plan, tmp_path, monkeypatch, always=True)
    assert res.summary["receding"]["replans"] == ReplanCounts(
        total=3, converged=0, not_converged=3, fell_back=3)
    payload = res.to_json()["policies"]
    assert payload["receding"]["replans"] == {"total": 3, "converged": 0,
                                              "not_converged": 3, "fell_back": 3}
    # a policy that never re-plans counts zeros, with the same keys
    assert payload["straight"]["replans"] == {"total": 0, "converged": 0,
                                              "not_converged": 0, "fell_back": 0}
    # the run file keeps them: the stored run, reloaded, counts the same
    with pytest.warns(ReplanWarning):
        again = _campaign(sc, plan, tmp_path, monkeypatch, always=True)
    assert again.loaded_runs == (0,) and again.computed_runs == ()
    assert again.summary["receding"]["replans"] == res.summary["receding"]["replans"]


def test_campaign_counts_re_plans_rescued_by_the_fallback(small, tmp_path, monkeypatch):
    sc, _, _, plan = small
    with warnings.catch_warnings():
        warnings.simplefilter("error", ReplanWarning)  # all converged: no warning
        res = _campaign(sc, plan, tmp_path, monkeypatch, always=False)
    assert res.summary["receding"]["replans"] == ReplanCounts(
        total=3, converged=3, not_converged=0, fell_back=3)


def test_compare_prints_the_counts_and_the_warning(tmp_path, monkeypatch, capsys):
    """``tmaplan compare``: the counts in the console table, the JSON and the report, and the
    warning as one line on stderr (the campaign's records stand in for re-plans here; the
    real ones are counted above)."""
    import tmaplan.evaluation.campaigns as campaigns
    from tmaplan.cli import main

    real = campaigns.run_one

    def run_one(spec, policies, run):
        rec = real(spec, policies, run)
        pr = dataclasses.replace(rec.policies["straight"], replan_seconds=np.ones(2),
                                 replan_converged=np.array([True, False]),
                                 replan_fell_back=np.array([False, True]),
                                 replan_infeasible=np.array([False, False]))
        return dataclasses.replace(rec, policies={"straight": pr})

    monkeypatch.setattr(campaigns, "run_one", run_one)
    js = tmp_path / "out.json"
    with warnings.catch_warnings():
        warnings.simplefilter("always", ReplanWarning)  # (this module ignores RuntimeWarning)
        assert main(["compare", "default", "--policies", "straight", "--runs", "1",
                     "--particles", "100", "--out", str(tmp_path), "--json", str(js)]) == 0
    out, err = capsys.readouterr()
    assert err == ("tmaplan compare: warning: ReplanWarning: re-plans not converged above "
                   "1 %: straight 1 of 2 (50.0 %); the own ship kept its previous plan there "
                   "(docs/cli.md, 'Re-plans')\n"), err
    assert "2 re-plans, 1 not converged (50.0 %), 1 fell back" in out
    d = json.loads(js.read_text())
    assert d["policies"]["straight"]["replans"] == {"total": 2, "converged": 1,
                                                    "not_converged": 1, "fell_back": 1}
    report = (tmp_path / "default_compare" / "report.html").read_text()
    assert "Warning: re-plans not converged." in report and "2 / 1 (50.0 %) / 1" in report


def test_a_re_plan_that_stalled_converges_or_says_so():
    """A recorded hard re-plan: ``bow-closing``, run 50 of seed 0, the alarm re-plan at
    t = 1485 s, where the warm-started IPOPT solve crept along a plateau of the objective
    (every belief draw far from localised along the previous, almost straight plan) to its
    iteration limit on the machine it was recorded on, and the turn-early starts converged
    in 15-17 iterations. Whatever IPOPT does here on this machine, the re-plan ends with a
    converged plan or is logged as not; it falls back exactly when the warm-started solve
    did not converge; and a rescued plan is a converged solve from a fallback start."""

    from tmaplan.planning.heading_plan import HeadingPlan
    from tmaplan.scenario import load_problem

    d = np.load(DATA / "planning" / "bow_closing_stalled_replan.npz")
    sc = load_problem("bow-closing")
    t = float(d["t"])
    n = d["previous_turn_rate"].size
    # the previous plan (from t = 1200 s): the controller reads its turn rates and times
    prev = HeadingPlan(times=d["previous_times"], heading=d["previous_heading"],
                       turn_rate=d["previous_turn_rate"], speed=np.zeros(n),
                       switch_times=np.zeros(0), observer=None, objective=float("nan"),
                       range_bound=np.zeros(0), transcription="direct", status="recorded",
                       success=True, iterations=0, seconds=0.0)
    ctrl = Receding(solver="ipopt", first_plan=prev).controller(sc)
    ctrl.plan, ctrl.next_replan = prev, t
    samples = d["samples"]
    view = BeliefView(step=int(t // sc.time.dt), t=t, heading=float(d["heading0"]),
                      position=d["position0"], particles=samples,
                      weights=np.full(len(samples), 1 / len(samples)), pings_used=0, alarms=0)
    ctrl.act(view, t)
    (entry,) = ctrl.log
    # the same solve as the controller's first, on its own
    b = Belief.from_particles(samples, view.weights, t=t, assimilated=True)
    warm = ctrl.planner.solve(b, heading0=view.heading, position0=view.position,
                              warm_start=prev, tol=1e-4, raise_on_failure=False)
    assert entry["fell_back"] == (not warm.success)
    if warm.success:
        assert entry["success"] and "start" not in entry
        np.testing.assert_allclose(ctrl.plan.turn_rate, warm.turn_rate, rtol=0, atol=1e-12)
    elif entry["success"]:  # rescued: a converged solve from a fallback start
        assert ctrl.plan is not prev and ctrl.plan.success
        assert ctrl.plan.status in ("Solve_Succeeded", "Solved_To_Acceptable_Level")
        assert entry["start"].split(": ")[1] in ("mirrored", "straight", "early-port",
                                                 "early-starboard")
        assert np.isfinite(ctrl.plan.objective)
    else:  # reported: the previous plan kept, both failures named
        assert ctrl.plan is prev and not entry["infeasible"]
        assert "fallback starts" in entry["status"]


def test_demo_says_the_re_plans_of_the_policies_that_re_plan(capsys):
    """``tmaplan demo``'s console: one line per re-planning policy, none for the others,
    nothing with ``--json -``."""
    import argparse
    import types

    from tmaplan.cli.demo import _say_replans

    counts = {"planned": ReplanCounts(),
              "receding-realtime": ReplanCounts(total=360, converged=359, not_converged=1,
                                                fell_back=3)}
    result = types.SimpleNamespace(policies=tuple(counts),
                                   summary={k: {"replans": c} for k, c in counts.items()})
    _say_replans(argparse.Namespace(json=None), result)
    out = capsys.readouterr().out.splitlines()
    assert out == [f"    {'receding-realtime':<28} 360 re-plans, 1 not converged (0.3 %), "
                   "3 fell back"], out
    _say_replans(argparse.Namespace(json="-"), result)
    assert capsys.readouterr().out == ""
