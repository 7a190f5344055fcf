"""The condensed SQP's evaluations (issue 42): the objective's gradient it steps with against
central finite differences, and an accepted full step evaluated once, not twice."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.converged_sqp import ConvergedSQP
from tmaplan.planning.rti import RealTimeIteration, RTIModel
from tmaplan.policies import CLOSED_LOOP_OBJECTIVE
from tmaplan.scenario import load_problem

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


@pytest.fixture(scope="module")
def setup():
    """`bow-closing`, the closed loop's objective over 15 one-minute intervals, a re-plan's
    belief (a subsample of the prior's draws two minutes on) and the NLP's parameters with the
    objective at its scale 1 (the objective in seconds)."""
    sc = load_problem("bow-closing")
    prior = Belief.from_prior(sc)
    planner = HeadingPlanner(sc, objective=CLOSED_LOOP_OBJECTIVE, horizon=900.0)
    idx = np.random.default_rng(3).choice(prior.samples.shape[0], size=500, replace=False)
    belief = Belief.from_samples(prior.samples[idx], t=120.0)
    h0, s0, _ = planner.start_state(None, None, None)
    P = np.concatenate([planner.parameter_vector(belief, ()), [h0, s0, 1.0, 1.0]])
    n_w = planner.nlp["x"].shape[0]
    # a stand-in Hessian model (these tests read the evaluations, not the steps' quality) at
    # a plan from the prior (the solves' warm start)
    plan = planner.solve(prior, tol=1e-3)
    model = RTIModel(hessian=np.eye(n_w), scale=1.0, plan=plan)
    return planner, belief, P, h0, s0, RealTimeIteration(planner, model)


def _controls(planner, h0, s0, seed):
    u = np.random.default_rng(seed).uniform(-0.8, 0.8, planner.n)
    return u, planner.decision_vector(u, h0, s0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gradient_matches_central_differences(setup, seed):
    """∂F/∂u of the re-simulated objective F(u) = f(x(u)) (the condensed SQP's reduced
    gradient, through the states' sensitivities) against central differences in u, at
    random turn-rate programmes. Step h = 1e-5 of the turn-rate range: the truncation error
    (h² · f''') and the round-off (ε·|f|/h) are both below 1e-6 of the gradient's scale."""
    planner, _, P, h0, s0, rti = setup
    u, x = _controls(planner, h0, s0, seed)
    lbw, ubw, lbg, ubg = planner.bounds(h0)
    f0, _, qp = rti.condensed(x, P, lbw, ubw, lbg, ubg)
    # at a simulated x the shooting equalities hold, so z0 = 0 and qp["g"] = Zᵀ∇f, the gradient
    # of F; the QP's "g" adds H z0, with H the (stand-in) model, which z0 = 0 removes
    grad = qp["g"]
    h = 1e-5
    fd = np.empty(u.size)
    for j in range(u.size):
        e = np.zeros(u.size)
        e[j] = h
        fp = rti.evaluate(planner.decision_vector(u + e, h0, s0), P)[0].item()
        fm = rti.evaluate(planner.decision_vector(u - e, h0, s0), P)[0].item()
        fd[j] = (fp - fm) / (2 * h)
    scale = np.max(np.abs(fd))
    assert scale > 0 and np.isfinite(f0)
    np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-5 * scale)


@pytest.mark.parametrize("seed", [0, 1])
def test_one_evaluation_gives_the_merit_function(setup, seed):
    """The objective and the constraints of :meth:`RealTimeIteration.evaluate` are the merit
    function's (objective and constraints alone) up to round-off, and the condensed QP from a
    given evaluation is the one from evaluating again."""
    planner, _, P, h0, s0, rti = setup
    sqp = ConvergedSQP(planner, rti.model, rti=rti)
    _, x = _controls(planner, h0, s0, seed)
    ev = rti.evaluate(x, P)
    f, g = sqp._merit_eval(x, P)
    assert ev[0].item() == pytest.approx(f.item(), rel=1e-13)
    np.testing.assert_allclose(ev[2].reshape(-1), g.reshape(-1), rtol=1e-13, atol=1e-13)
    bounds = planner.bounds(h0)
    a = rti.condensed(x, P, *bounds)
    b = rti.condensed(x, P, *bounds, evaluated=ev)
    assert a[0] == b[0]
    for key in a[2]:
        np.testing.assert_array_equal(a[2][key], b[2][key])


def test_an_accepted_full_step_is_evaluated_once(setup, monkeypatch):
    """A solve never evaluates the same point twice: the full evaluation (objective,
    gradient, constraints, Jacobian) of an accepted full step is the next step's, and the
    merit function alone is called only at shorter steps. The scheme before (the merit
    function at the trial point, then the full evaluation there again) fails this."""
    planner, belief, _, h0, _, rti = setup
    sqp = ConvergedSQP(planner, rti.model, rti=rti, max_iter=8)
    points: dict[str, list[bytes]] = {"evaluate": [], "merit": []}
    evaluate, merit = rti.evaluate, sqp._merit_eval

    def counted_evaluate(x, P):
        points["evaluate"].append(np.asarray(x, float).tobytes())
        return evaluate(x, P)

    def counted_merit(x, P):
        points["merit"].append(np.asarray(x, float).tobytes())
        return merit(x, P)

    monkeypatch.setattr(rti, "evaluate", counted_evaluate)
    monkeypatch.setattr(sqp, "_merit_eval", counted_merit)
    out = sqp.solve(belief, heading0=h0, warm_start=rti.model.plan, tol=1e-4,
                    raise_on_failure=False)
    ev, me = points["evaluate"], points["merit"]
    assert out.iterations >= 2  # at least one line search
    assert len(ev) >= out.iterations  # every step's QP from a full evaluation
    # no point evaluated twice; the start's merit value (the objective's scale) is the one
    # merit call at a point the full evaluation also sees (the first step's)
    assert len(set(ev)) == len(ev)
    assert me and me[0] == ev[0]
    assert not set(ev) & set(me[1:])
