"""The compiled expected time to accuracy (tmaplan.planning.compiled_objective) against the
casadi graph it evaluates, finite differences, and IPOPT on both."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.compiled_objective import expected_time_value_grad
from tmaplan.planning.objectives import PlanContext, expected_time_of, not_localised_graph
from tmaplan.policies import CLOSED_LOOP_OBJECTIVE, Receding
from tmaplan.scenario import load_problem

HORIZON = 900.0


@pytest.fixture(scope="module")
def setup():
    """`bow-closing`, the closed loop's objective over 15 minutes; the graph as a function of
    the displacement beyond constant velocity d (K+1, 2) [km] and the parameters."""
    sc = load_problem("bow-closing")
    planner = HeadingPlanner(sc, objective=CLOSED_LOOP_OBJECTIVE, horizon=HORIZON)
    lay, K1 = planner.layout, planner.K + 1
    disp, vob = ca.MX.sym("disp", K1, 2), ca.MX.sym("v", K1, 2)
    p = ca.MX.sym("p", lay.size)
    ctx = PlanContext(dt=planner.dt, times=planner.times, A=np.eye(4), Q=np.eye(4), v_obs=vob,
                      disp=disp, turn_rate=ca.MX.sym("u", K1 - 1), p=p, layout=lay,
                      ping_scale=0.0, turn_rate_max=1.0)
    f = expected_time_of(ctx, not_localised_graph(ctx, 0.1, 0.25))
    graph = ca.Function("g", [disp, vob, p], [f, ca.gradient(f, disp)])
    return sc, planner, ctx, graph


def _inputs(sc, planner, seed, *, through=False):
    """A belief's parameter vector, a wandering own-ship track (d, disp, v), bearing
    information and step weights drawn from ``seed``; ``through``: the track passes within
    100 m of some draws (the range floor)."""
    rng = np.random.default_rng(seed)
    K1, dt, times = planner.K + 1, planner.dt, planner.times
    prior = Belief.from_prior(sc)
    idx = rng.choice(prior.samples.shape[0], size=600, replace=False)
    b = Belief.from_samples(prior.samples[idx], t=0.0)
    psi = np.cumsum(np.r_[rng.uniform(0, 2 * np.pi), rng.normal(0, 0.08, K1 - 1)])
    v = 5.0 * np.c_[np.sin(psi), np.cos(psi)]
    disp = np.r_[[[0.0, 0.0]], np.cumsum(v[1:] * dt, axis=0)]
    bearing = rng.uniform(0.5, 2.0, K1) / np.radians(1.0) ** 2
    weight = (rng.uniform(size=K1) < 0.8).astype(float)
    P = planner.layout.vector(b, bearing, None, weight)
    if through:  # move two draws onto the own ship's track at steps 3 and 9
        smp = P[planner.layout.slices()["samples"]].reshape(-1, 4)
        for s, k in ((0, 3), (5, 9)):
            smp[s, :2] = disp[k] - times[k] * v[0] - times[k] * smp[s, 2:]
            smp[s, :2] += rng.normal(0.0, 30.0, 2)
        P[planner.layout.slices()["samples"]] = smp.reshape(-1)
    d = (disp - times[:, None] * v[0]) / 1000.0
    return d, disp, v, P


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("through", [False, True])
def test_value_and_gradient_equal_the_graph(setup, seed, through):
    """The kernel's value and its gradient with respect to d equal the casadi graph's to
    rounding (relative 1e-10: the same operations, in another order here and there), also
    where draws fall inside the 100 m range floor."""
    sc, planner, ctx, graph = setup
    d, disp, v, P = _inputs(sc, planner, seed, through=through)
    f, g = (np.asarray(x) for x in graph(disp, v, P))
    value, grad = expected_time_value_grad(ctx, d, P, accuracy=0.1, width=0.25)
    assert value == pytest.approx(float(f.item()), rel=1e-10)
    # the graph's gradient is with respect to disp [m]; the kernel's with respect to d [km]
    np.testing.assert_allclose(grad / 1000.0, g, rtol=1e-8, atol=1e-10 * np.abs(g).max())


def test_callback_value_and_gradient_at_successive_points(setup):
    """Through casadi (the value, then the reverse sweep alone at the same point, from what
    the forward pass stored): a fresh evaluation's value bit for bit and its gradient to the
    rounding of casadi's chain rule, at each of two points in turn and back at the first
    (nothing stale from the other point)."""
    from tmaplan.planning.compiled_objective import compiled_expected_time

    sc, planner, ctx, _ = setup
    K1 = planner.K + 1
    ctx2 = PlanContext(**{**{f: getattr(ctx, f) for f in ("dt", "times", "A", "Q", "v_obs",
                                                           "disp", "turn_rate", "p", "layout",
                                                           "ping_scale", "turn_rate_max")}})
    f = compiled_expected_time(ctx2, 0.1, 0.25)
    fn = ca.Function("c", [ctx.disp, ctx.v_obs, ctx.p], [f, ca.gradient(f, ctx.disp)])
    points = [_inputs(sc, planner, seed) for seed in (5, 6, 5)]
    for d, disp, v, P in points:
        value, g = (np.asarray(x) for x in fn(disp, v, P))
        want, grad = expected_time_value_grad(ctx, d, P, accuracy=0.1, width=0.25)
        assert float(value.item()) == want
        np.testing.assert_allclose(g, grad / 1000.0, rtol=1e-14, atol=0)
        assert g.shape == (K1, 2)
    # the reverse callback asked at another point than the last value's computes it afresh
    reverse, value = ctx2.cache["callbacks"]
    (da, _, _, Pa), (db, _, _, Pb) = points[:2]
    for (d0, P0), (d1, P1) in (((da, Pa), (db, Pa)), ((da, Pa), (da, Pb))):
        value(d0, P0)
        adj_d, adj_p = (np.asarray(x) for x in reverse(d1, P1, 0.0, 1.0))
        np.testing.assert_array_equal(
            adj_d, expected_time_value_grad(ctx, d1, P1, accuracy=0.1, width=0.25)[1])
        assert np.isnan(adj_p).all()  # no derivative with respect to the parameters


def test_gradient_matches_central_differences(setup):
    """The hand-written reverse sweep against central differences of the kernel's own value
    (step 1e-6 km, relative agreement 1e-5 on the largest components)."""
    sc, planner, ctx, _ = setup
    d, _, _, P = _inputs(sc, planner, 3)
    _, grad = expected_time_value_grad(ctx, d, P, accuracy=0.1, width=0.25)
    h = 1e-6
    top = np.argsort(np.abs(grad).ravel())[-12:]
    for flat in top:
        k, j = divmod(int(flat), 2)
        dp, dm = d.copy(), d.copy()
        dp[k, j] += h
        dm[k, j] -= h
        fp = expected_time_value_grad(ctx, dp, P, accuracy=0.1, width=0.25)[0]
        fm = expected_time_value_grad(ctx, dm, P, accuracy=0.1, width=0.25)[0]
        assert (fp - fm) / (2 * h) == pytest.approx(grad[k, j], rel=1e-5)


def test_gradient_changes_with_the_data(setup):
    """A kernel whose gradient ignored the prior information or the step weights would pass
    an equality test on one input only: both move the value and gradient."""
    sc, planner, ctx, _ = setup
    d, _, _, P = _inputs(sc, planner, 4)
    v0, g0 = expected_time_value_grad(ctx, d, P, accuracy=0.1, width=0.25)
    for name in ("icart", "weight"):
        Q = P.copy()
        Q[planner.layout.slices()[name]] *= 0.5
        v1, g1 = expected_time_value_grad(ctx, d, Q, accuracy=0.1, width=0.25)
        assert abs(v1 - v0) > 1e-6 * abs(v0)
        assert np.abs(g1 - g0).max() > 1e-6 * np.abs(g0).max()


def test_ipopt_finds_the_same_plan(setup):
    """IPOPT on the compiled objective takes the graph's path: the same objective (relative
    1e-8) and turn rates (1e-6 rad/s) from the same warm start on a re-plan's belief."""
    sc, planner, _, _ = setup
    compiled = HeadingPlanner(sc, objective=CLOSED_LOOP_OBJECTIVE, horizon=HORIZON,
                              compiled=True)
    prior = Belief.from_prior(sc)
    first = planner.solve(prior, tol=1e-4)
    rng = np.random.default_rng(7)
    idx = rng.choice(prior.samples.shape[0], size=500, replace=False)
    b = Belief.from_samples(prior.samples[idx], t=0.0)
    kw = {"warm_start": first, "tol": 1e-4}
    a, c = planner.solve(b, **kw), compiled.solve(b, **kw)
    assert a.success and c.success
    assert c.objective == pytest.approx(a.objective, rel=1e-8)
    np.testing.assert_allclose(c.turn_rate, a.turn_rate, atol=1e-6)


@pytest.mark.parametrize("bad", [1, "yes", None])
def test_heading_planner_refuses_a_compiled_that_is_not_a_bool(bad):
    with pytest.raises(ArgumentError, match="compiled"):
        HeadingPlanner(load_problem("bow-closing"), objective=CLOSED_LOOP_OBJECTIVE,
                       horizon=HORIZON, compiled=bad)


def test_receding_compiled_field():
    """`compiled` defaults to the kernel except for the real-time iteration, whose model
    needs second derivatives: True is refused there, as is a non-boolean."""
    sc = load_problem("bow-closing")
    assert Receding().uses_compiled and Receding(solver="sqp").uses_compiled
    assert not Receding(solver="real-time").uses_compiled
    assert not Receding(compiled=False).uses_compiled
    for bad in (Receding(solver="real-time", compiled=True), Receding(compiled=1)):
        with pytest.raises(ArgumentError, match=r"receding\.compiled"):
            bad.resolve(sc)


def test_an_interrupt_in_the_callback_is_raised_once_by_the_evaluation(setup, monkeypatch):
    """A Ctrl-C that lands in the compiled objective (Python called back from casadi's C++)
    does not escape through casadi (which left a Python error set: a ``SystemError`` at the
    next unrelated call); the callback returns NaN and the evaluation raises the interrupt
    once, as a solve does."""
    import signal

    from tmaplan.interrupts import Interrupted, checkpoint
    from tmaplan.planning.compiled_objective import _Kernel

    sc, _, _, _ = setup
    compiled = HeadingPlanner(sc, objective=CLOSED_LOOP_OBJECTIVE, horizon=HORIZON,
                              compiled=True)
    prior = Belief.from_prior(sc)
    plan = compiled.solve(prior, tol=1e-4)
    x, P = np.asarray(plan.warm["x"]), compiled.parameter_vector(prior, ())
    P = np.concatenate([P, [0.0, compiled.speed0, 1.0, 1.0]])
    before = compiled.plan_function(x, P)

    def interrupted(self, *args, **kw):
        raise Interrupted(signal.SIGINT)

    with monkeypatch.context() as m:
        m.setattr(_Kernel, "__call__", interrupted)
        with pytest.raises(Interrupted):
            compiled.plan_function(x, P)
    checkpoint()  # raised once: nothing left over
    after = compiled.plan_function(x, P)  # and the next evaluation is sound
    assert float(after[0].item()) == float(before[0].item())


@pytest.mark.parametrize("reported", [False, True])
def test_an_interrupt_in_the_callback_is_raised_by_the_solver_call(setup, monkeypatch,
                                                                   reported):
    """An interrupt inside the callback (raised there, or reported by C code as a
    SystemError: numpy reading a casadi matrix while the handler ran) gives NaN to casadi and
    is raised as an interrupt when the solver call ends; before, the SystemError became
    casadi's RuntimeError (and its dump on stderr). Another SystemError stays an error."""
    import tmaplan.planning.compiled_objective as co
    from tmaplan.interrupts import Interrupted, solver_call

    sc, planner, ctx, _ = setup
    ctx2 = PlanContext(**{**{f: getattr(ctx, f) for f in ("dt", "times", "A", "Q", "v_obs",
                                                           "disp", "turn_rate", "p", "layout",
                                                           "ping_scale", "turn_rate_max")}})
    f = co.compiled_expected_time(ctx2, 0.1, 0.25)
    fn = ca.Function("c", [ctx.disp, ctx.v_obs, ctx.p], [f])
    _, disp, v, P = _inputs(sc, planner, 7)
    error: list[BaseException] = []

    def interrupted(*args):
        try:
            raise error[0]
        except BaseException as exc:
            if not reported:
                raise
            raise SystemError("<function DM.__array__> returned a result with an exception "
                              "set") from exc

    monkeypatch.setattr(co, "_value_grad", interrupted)
    error.append(Interrupted())
    with pytest.raises(Interrupted), solver_call():
        assert np.isnan(float(fn(disp, v, P)))
    error[0] = ValueError("not an interrupt")
    with pytest.raises(RuntimeError, match="Error in Function"), solver_call():
        fn(disp, v, P)


def test_the_callback_reads_and_writes_casadi_buffers_in_column_major_order():
    """A dense callback on casadi's buffers (``eval_buffer``): inputs of shapes (3, 2) and
    (1, 1) arrive as those matrices, outputs (2, 3) and (1, 1) leave as given, and an output
    the caller does not need (casadi passes no buffer for it) is skipped."""
    from tmaplan.planning.compiled_objective import _callback_class

    seen = []

    def fn(arg):
        seen.append([a.copy() for a in arg])
        return [arg[0].T * arg[1][0, 0], float(arg[0].sum())]

    cb = _callback_class()("probe", ((3, 2), (1, 1)), ((2, 3), (1, 1)), fn)
    x = np.arange(6.0).reshape(3, 2)
    both = cb(ca.DM(x), ca.DM(2.0))
    assert np.array_equal(seen[-1][0], x) and seen[-1][1].shape == (1, 1)
    assert np.array_equal(np.asarray(both[0]), 2.0 * x.T) and float(both[1]) == 15.0
    X, s = ca.MX.sym("X", 3, 2), ca.MX.sym("s")
    first = ca.Function("first", [X, s], [cb(X, s)[0]])  # the second output unused
    assert np.array_equal(np.asarray(first(x, 3.0)), 3.0 * x.T)
    cb_alive = cb  # casadi does not keep the callback alive
    assert cb_alive is cb
