"""NumpyFunction: casadi evaluated into numpy buffers, bit for bit the DM call."""

import pickle

import casadi as ca
import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.casadi_eval import NumpyFunction
from tmaplan.scenario import load_problem


def _toy():
    x = ca.MX.sym("x", 3)
    p = ca.MX.sym("p", 2, 2)
    y = ca.vertcat(ca.sin(x[0]) * p[0, 1], x[1] * x[2] + p[1, 0])
    return ca.Function("toy", [x, p], [ca.dot(x, x), y, ca.jacobian(y, x), ca.mtimes(p, p.T)])


def test_matches_dm_call_bitwise_dense_and_sparse_outputs():
    fn = _toy()
    x = np.array([0.3, -1.2, 2.5])
    p = np.array([[1.0, 2.0], [3.0, -4.0]])  # a matrix input: column-major in casadi
    ref = [np.asarray(o.full()) for o in fn(x, p)]
    got = NumpyFunction(fn)(x, p)
    assert fn.sparsity_out(2).nnz() < 6  # the Jacobian is structurally sparse
    assert [g.shape for g in got] == [r.shape for r in ref]
    for g, r in zip(got, ref):
        np.testing.assert_array_equal(g, r)


def test_outputs_are_fresh_arrays_and_object_pickles():
    f = NumpyFunction(_toy())
    a = f(np.ones(3), np.eye(2))
    b = f(np.zeros(3), np.zeros((2, 2)))
    assert a[0].item() == 3.0 and b[0].item() == 0.0  # a is not overwritten by the next call
    g = pickle.loads(pickle.dumps(f))
    np.testing.assert_array_equal(g(np.ones(3), np.eye(2))[2], a[2])


def test_bad_input_is_named():
    f = NumpyFunction(_toy())
    with pytest.raises(ArgumentError, match="toy input i0"):
        f(np.ones(4), np.eye(2))
    with pytest.raises(ArgumentError, match="toy arguments"):
        f(np.ones(3))
    x = ca.MX.sym("x", ca.Sparsity.diag(2))
    with pytest.raises(ArgumentError, match="dense"):
        NumpyFunction(ca.Function("sparse_in", [x], [ca.sum1(ca.sum2(x))]))


def test_planner_plan_function_matches_dm_call():
    """The planner's plan outputs (objective, bound, track, constraints) by both routes."""
    sc = load_problem("default")
    pl = HeadingPlanner(sc)
    b = Belief.from_prior(sc)
    P = np.concatenate([pl.parameter_vector(b, ()), [0.0, pl.speed0, 1.0, 1.0]])
    x = pl._guesses(0.0, pl.speed0)[1][0]
    ref = [np.asarray(o.full()) for o in pl.plan_function.fn(x, P)]
    got = pl.plan_function(x, P)
    assert len(ref) == pl.plan_function.fn.n_out() >= 4  # objective, bound, track, constraints
    for g, r in zip(got, ref, strict=True):
        assert g.shape == r.shape
        np.testing.assert_array_equal(g, r)
