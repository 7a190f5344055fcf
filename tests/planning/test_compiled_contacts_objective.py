"""The several-contact objectives by the compiled kernels (tmaplan.planning.compiled_objective,
``HeadingPlanner(compiled=True)`` with a ContactsObjective) against their casadi graphs, finite
differences, and IPOPT on both; the re-planning policy's switch."""

from __future__ import annotations

import gc

import casadi as ca
import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.campaigns import CampaignSpec
from tmaplan.planning.compiled_objective import _ContactsKernel, _Kernel
from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.policies.contacts import ContactsReceding
from tmaplan.scenario import load_problem

KINDS = ("all-contacts-time-to-accuracy", "weighted-time-to-accuracy", "worst-contact")
#: The casadi callbacks each objective's compiled NLP holds (value and reverse derivative).
KERNEL_NAMES = {"all-contacts-time-to-accuracy": {"all_contacts_time",
                                                  "all_contacts_time_reverse"},
                "weighted-time-to-accuracy": {"expected_time", "expected_time_reverse"},
                "worst-contact": {"expected_time", "expected_time_reverse"}}
HORIZON = 1200.0  # 20 min: the tests' NLPs stay small


def _functions(problem, kind):
    """The joint NLP of ``problem`` with ``kind`` built on the graph and on the kernels, each
    as a casadi function of (x, p) giving the objective, its gradient, the constraints and
    their Jacobian; the contacts' prior parameter vector; the planners."""
    cs = ContactSet.from_scenario(load_problem(problem))
    planners = [ContactsPlanner(cs, objective=kind, compiled=c, horizon=HORIZON).joint
                for c in (False, True)]
    gc.collect()  # what the planners do not keep is gone (a callback its NLP calls must stay)
    fns = []
    for pl in planners:
        x, p, f, g = pl.nlp["x"], pl.nlp["p"], pl.nlp["f"], pl.nlp["g"]
        fns.append(ca.Function("f", [x, p], [f, ca.gradient(f, x), g, ca.jacobian(g, x)]))
    h0, s0, _ = planners[0].start_state(None, None, None)
    P = np.concatenate([planners[0].parameter_vector(cs.beliefs(), ()), [h0, s0, 1.0, 1.0]])
    return planners, fns, P, (h0, s0)


def _point(planner, rng, start):
    x = planner.decision_vector(rng.uniform(-1.0, 1.0, planner.n), *start)
    if x.shape[0] < planner.nlp["x"].shape[0]:  # worst-contact's epigraph variable
        x = np.r_[x, 2000.0]
    return x


@pytest.mark.parametrize("problem", ["two-contacts-crossing", "three-contacts-screen"])
@pytest.mark.parametrize("kind", KINDS)
def test_objective_gradient_and_constraints_equal_the_graph(problem, kind):
    """Value, gradient, constraints (worst-contact's epigraph terms E[T_c] among them) and
    their Jacobian equal the graph's to rounding at wandering turn-rate programs; a reverse
    sweep that ignored its seed (∂value/∂σ of the product form) would give another
    gradient."""
    planners, fns, P, start = _functions(problem, kind)
    # the graph's planner has no kernel; the compiled one's NLP calls the kernels it names
    assert planners[0]._callbacks == []
    assert {c.name() for c in planners[1]._callbacks} == KERNEL_NAMES[kind]
    rng = np.random.default_rng(4)
    for _ in range(3):
        x = _point(planners[0], rng, start)
        (f0, g0, c0, J0), (f1, g1, c1, J1) = ([np.asarray(ca.DM(v)) for v in fn(x, P)]
                                              for fn in fns)
        assert f1.item() == pytest.approx(f0.item(), rel=1e-11)
        np.testing.assert_allclose(g1, g0, rtol=1e-7, atol=1e-10 * np.abs(g0).max())
        np.testing.assert_allclose(c1, c0, rtol=1e-11, atol=1e-9)
        np.testing.assert_allclose(J1, J0, rtol=1e-7, atol=1e-10 * np.abs(J0).max())


def _kernel_inputs(n_contacts=3, seed=0):
    """A ContactsKernel over ``n_contacts`` of three-contacts-screen's contexts with a random
    displacement d (K+1, 2) [km] and the contacts' prior parameter vector."""
    cs = ContactSet.from_scenario(load_problem("three-contacts-screen"))
    pl = ContactsPlanner(cs, compiled=True, horizon=HORIZON).joint
    obj = pl.objective
    from tmaplan.planning.objectives import PlanContext

    lay = pl.layout
    ctx = PlanContext(dt=pl.dt, times=pl.times, A=np.eye(4), Q=np.eye(4), v_obs=None,
                      disp=None, turn_rate=None, p=ca.MX.sym("p", lay.size), layout=lay,
                      ping_scale=0.0, turn_rate_max=1.0)
    ctxs = obj.contexts(ctx)[:n_contacts]
    blocks = [lay.block(c) for c in range(n_contacts)]
    kernel = _ContactsKernel(ctxs, blocks, list(obj.accuracies[:n_contacts]), obj.width)
    rng = np.random.default_rng(seed)
    d = np.cumsum(rng.normal(0.0, 0.3, (pl.K + 1, 2)), axis=0)
    P = pl.parameter_vector(cs.beliefs(), ())
    return kernel, ctxs, blocks, obj, d, P


def test_gradient_matches_central_differences():
    kernel, _, _, _, d, P = _kernel_inputs()
    kernel(d, P, True)
    grad = kernel.grad.T.copy()
    rng = np.random.default_rng(1)
    for _ in range(6):
        k, j = int(rng.integers(1, d.shape[0])), int(rng.integers(0, 2))
        h = 1e-6
        dp, dm = d.copy(), d.copy()
        dp[k, j] += h
        dm[k, j] -= h
        fd = (kernel(dp, P, False) - kernel(dm, P, False)) / (2 * h)
        assert grad[k, j] == pytest.approx(fd, rel=1e-5, abs=1e-6 * np.abs(grad).max())


def test_a_second_gradient_at_the_same_point_is_the_first_and_values_do_not_depend_on_order():
    """casadi asks for the value, then the gradient at the same point (the reverse sweeps
    alone, from the stored forward passes): the same gradient as a fresh evaluation, and again
    the same after another point; the value does not depend on the contacts' order."""
    kernel, ctxs, blocks, obj, d, P = _kernel_inputs()
    kernel(d, P, False)
    kernel(d, P, True)
    first = kernel.grad.copy()
    kernel(d, P, True)
    np.testing.assert_array_equal(kernel.grad, first)
    kernel(d, P, False)  # a value here, then the gradient elsewhere: that point's
    kernel(d + 0.1, P, True)
    fresh = _ContactsKernel(ctxs, blocks, list(obj.accuracies), obj.width)
    fresh(d + 0.1, P, True)
    np.testing.assert_array_equal(kernel.grad, fresh.grad)
    assert not np.array_equal(fresh.grad, first)
    kernel(d, P, True)
    np.testing.assert_array_equal(kernel.grad, first)
    rev = _ContactsKernel(ctxs[::-1], blocks[::-1], list(obj.accuracies[::-1]), obj.width)
    assert rev(d, P, True) == pytest.approx(kernel(d, P, False), rel=1e-13)
    np.testing.assert_allclose(rev.grad, first, rtol=1e-10, atol=1e-13 * np.abs(first).max())


def test_one_contact_in_the_product_form_is_the_one_contact_kernel():
    kernel, ctxs, blocks, obj, d, P = _kernel_inputs(n_contacts=1)
    one = _Kernel(ctxs[0], obj.accuracies[0], obj.width)
    assert kernel(d, P, True) == pytest.approx(one(d, P[blocks[0]], True), rel=1e-13)
    np.testing.assert_allclose(kernel.grad, one.grad, rtol=1e-9,
                               atol=1e-12 * np.abs(one.grad).max())


def test_ipopt_finds_the_same_joint_plan_on_the_kernels():
    """The joint NLP from the priors solved from the same start on the graph and on the
    kernels: the same objective to 1e-6 and the same turn rates to 1e-3 of the largest."""
    cs = ContactSet.from_scenario(load_problem("two-contacts-crossing"))
    joints = [ContactsPlanner(cs, compiled=c, horizon=HORIZON).joint for c in (False, True)]
    start = joints[0].start_programs()[1]
    plans = [j.solve(cs.beliefs(), starts=[start]) for j in joints]
    assert all(p.success for p in plans)
    assert plans[1].objective == pytest.approx(plans[0].objective, rel=1e-6)
    umax = max(abs(plans[0].turn_rate).max(), 1e-12)
    np.testing.assert_allclose(plans[1].turn_rate, plans[0].turn_rate, atol=1e-3 * umax)


@pytest.mark.parametrize("compiled", [True, False])
def test_receding_re_plans_on_the_planner_its_field_names(compiled):
    sc = load_problem("two-contacts-crossing")
    joint = ContactsReceding(compiled=compiled).controller(sc).planner.joint
    names = {c.name() for c in joint._callbacks}
    assert names == (KERNEL_NAMES["all-contacts-time-to-accuracy"] if compiled else set())


def test_receding_runs_re_planned_on_the_graph_are_not_reused_for_the_kernels():
    """A campaign stored by name keys several contacts' `receding` apart from the runs stored
    while its re-plans ran on the graph (their key said "sqp", as one contact's does)."""
    one, two = load_problem("default"), load_problem("two-contacts-crossing")
    meta = {sc.name: CampaignSpec(scenario=sc, policies=("straight", "receding"), runs=2)._meta()
            for sc in (one, two)}
    assert meta["default"]["replan"] == "sqp"
    assert meta["two-contacts-crossing"]["replan"] == "compiled-joint"
    assert "replan" not in CampaignSpec(scenario=two, policies=("planned",), runs=2)._meta()


@pytest.mark.parametrize("bad", [None, 1, "yes"])
def test_receding_refuses_a_compiled_that_is_not_a_bool(bad):
    sc = load_problem("two-contacts-crossing")
    with pytest.raises(ArgumentError, match=r"receding\.compiled"):
        ContactsReceding(compiled=bad).controller(sc)
