"""Joint heading + ping OCP (issue 14, items 4-5): relaxed/bonmin, certificate, comparison."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import PlanningError
from tmaplan.planning import PingEvaluator, plan_joint, plan_joint_ocp

# small case: 15 min horizon, 5 control intervals of 3 min, candidates every 12th step (3 min)
SMALL = {"horizon": 900.0, "control_interval": 180.0, "n_starts": 1}
STRIDE = 12


@pytest.fixture(scope="module")
def relaxed(default, prior):
    return plan_joint_ocp(default, budget=2, belief=prior, ping_stride=STRIDE, **SMALL)


@pytest.fixture(scope="module")
def alternating(default, prior):
    return plan_joint(default, budget=2, belief=prior, **SMALL)


@pytest.mark.solver_sensitive
def test_relaxed_joint_bounds_its_rounded_and_polished_pair(relaxed):
    assert relaxed.success and relaxed.mode == "relaxed" and relaxed.nlp_solver == "ipopt"
    # the relaxation's optimum (fractional weights) below the NLP headings with the rounded
    # pings, and polishing never ends above where it starts
    assert relaxed.relaxed_objective <= relaxed.rounded_objective
    assert relaxed.objective <= relaxed.rounded_objective * (1 + 1e-9)
    assert relaxed.relaxed_objective <= relaxed.objective
    w = relaxed.weights
    assert w.shape == relaxed.candidate_steps.shape
    assert np.all(relaxed.candidate_steps % STRIDE == 1)  # stride from the first step (1)
    assert w.sum() == pytest.approx(2.0, abs=1e-6)
    assert relaxed.rounded_steps.size == 2


def test_joint_certificate_on_its_pings(default, prior, relaxed):
    r = relaxed
    assert r.pings.steps.size == 2 and np.all(np.diff(r.pings.steps) >= 8)  # 120 s spacing
    assert np.isfinite(r.lower_bound) and r.lower_bound <= r.objective
    assert r.gap == pytest.approx((r.objective - r.lower_bound) / r.objective)
    assert r.pings.gap_reference.startswith("relaxation")
    # independent evaluation of the returned pair
    ev = PingEvaluator(default, r.heading.observer, prior, "mean-range-bound")
    assert ev.value(r.pings.steps.tolist()) == pytest.approx(r.objective, rel=1e-9)
    js = r.payload()
    assert {"objective", "lower_bound", "gap", "solver"} <= set(js)
    assert {"status", "seconds"} <= set(js["solver"])


@pytest.mark.solver_sensitive
def test_joint_no_worse_than_alternating_on_small_case(relaxed, alternating):
    # measured (default, 15 min, K = 2, one machine): joint 182.245 m, alternating 182.300 m.
    # Both are local methods on a non-convex problem, so which is ahead by 0.03 % depends on
    # the solvers' paths (another machine's round-off may land either a hair lower); on
    # `default` over 45 min the joint OCP is better at K = 1 and 3 (-1.1 %, -0.8 %) and equal
    # at K = 2, at 10-20 x the time (benchmarks/planning.py --joint). With a single start
    # ("even") it was 5 % worse at K = 3: a joint OCP worse by more than 0.5 % is a defect.
    assert relaxed.objective <= alternating.objective * (1 + 5e-3)


@pytest.mark.solver_sensitive
def test_bonmin_is_in_casadi_and_runs_on_a_tiny_case(default, prior):
    import casadi as ca

    assert ca.has_nlpsol("bonmin")  # casadi's wheels ship it; the mode depends on it
    r = plan_joint_ocp(default, budget=1, belief=prior, ping_stride=STRIDE, mode="bonmin",
                       **SMALL)
    assert r.mode == "bonmin" and r.nlp_solver == "bonmin" and r.success
    assert np.all(np.minimum(r.weights, 1 - r.weights) < 1e-6)  # binary
    assert r.weights.sum() == pytest.approx(1.0)
    assert r.rounded_steps.tolist() == r.candidate_steps[r.weights > 0.5].tolist()
    assert r.lower_bound <= r.objective <= r.rounded_objective * (1 + 1e-9)


@pytest.mark.solver_sensitive
def test_sqp_osqp_solves_the_relaxation(default, prior, relaxed):
    r = plan_joint_ocp(default, budget=2, belief=prior, ping_stride=STRIDE,
                       nlp_solver="sqp-osqp", **SMALL)
    assert r.nlp_solver == "sqp-osqp" and r.iterations > 0
    # same relaxation as IPOPT's, to the SQP's tolerance
    assert r.relaxed_objective == pytest.approx(relaxed.relaxed_objective, rel=2e-3)
    assert r.lower_bound <= r.objective


@pytest.mark.parametrize(("kw", "field"), [
    ({"budget": 0}, "budget"), ({"budget": -1}, "budget"), ({"budget": 1.5}, "budget"),
    ({"budget": 9}, "budget"), ({"budget": 1, "ping_stride": 0}, "ping_stride"),
    ({"budget": 1, "ping_stride": 2.0}, "ping_stride"), ({"budget": 1, "mode": "exact"}, "mode"),
    ({"budget": 1, "nlp_solver": "cplex"}, "nlp_solver"),
    ({"budget": 1, "polish_rounds": 0}, "polish_rounds"), ({"budget": 1, "init": "x"}, "init"),
])
def test_invalid_arguments_name_the_field(default, prior, kw, field):
    with pytest.raises(PlanningError, match=field):
        plan_joint_ocp(default, belief=prior, **({"ping_stride": STRIDE} | SMALL | kw))


@pytest.mark.parametrize("method", ["ocp", "alternating"])
def test_cli_plan_with_joint_pings(capsys, method):
    import json

    from tmaplan.cli import main

    stride = ["--ping-stride", "12"] if method == "ocp" else []  # alternating: every step
    rc = main(["plan", "default", "--horizon", "900", "--control-interval", "180", "--starts",
               "1", "--objective", "mean-range-bound", "--pings", "2", *stride,
               "--joint", method, "--no-figure", "--json", "-"])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)["pings"]
    assert d["method"] == method and len(d["ping_steps"]) == 2
    assert {"status", "seconds"} <= set(d["solver"])
    assert d["lower_bound"] <= d["objective"]
    assert d["gap"] == pytest.approx((d["objective"] - d["lower_bound"]) / d["objective"])


def test_cli_joint_pings_need_a_closed_form_objective(capsys):
    from tmaplan.cli import main

    rc = main(["plan", "default", "--horizon", "900", "--control-interval", "180", "--starts",
               "1", "--objective", "logdet", "--pings", "1", "--no-figure", "--json", "-"])
    assert rc == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "objective" in err[0]


def test_forbidden_window_and_spacing_hold(default, prior):
    # no ping in the first 5 min (where the unconstrained plan pings, at step 1), 4 min apart
    r = plan_joint_ocp(default, budget=2, belief=prior, ping_stride=STRIDE,
                       forbidden=[(0.0, 300.0)], min_spacing=240.0, **SMALL)
    assert np.all(r.candidate_steps * 15.0 > 300.0)
    assert np.all(r.pings.times > 300.0) and np.all(np.diff(r.pings.times) >= 240.0)
    assert r.lower_bound <= r.objective


def test_alternating_returns_a_consistent_pair_at_the_round_limit(default, prior):
    # one round: pings scheduled, headings re-solved with them; the pings returned must be
    # scheduled on the headings returned (they were those of the previous track)
    r = plan_joint(default, budget=2, belief=prior, max_rounds=1, **SMALL)
    ev = PingEvaluator(default, r.heading.observer, prior, "mean-range-bound")
    assert ev.value(r.pings.steps.tolist()) == pytest.approx(r.objective, rel=1e-12)
    assert r.history[-1] == r.objective and r.iterations == 1
