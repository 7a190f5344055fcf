"""Review tests of the closed-form LPC PCRB and its inputs (brehard2005 §4–5)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from tmaplan.bounds.closed_form import (
    closed_form_model,
    closed_form_pcrb,
    side_assumption_density,
    side_density_gaussian,
)
from tmaplan.bounds.closed_form_engine import ClosedFormEngine
from tmaplan.bounds.inputs import (
    check_ping_steps,
    information_rates,
    lpc_prior_information,
    prepare,
    resolve_ping_steps,
)
from tmaplan.bounds.lpc_terms import SYM_INDEX
from tmaplan.bounds.pcrb import SideAssumptionWarning
from tmaplan.errors import ArgumentError
from tmaplan.scenario import RangeSensor, load_problem


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SideAssumptionWarning)
        return fn(*args, **kw)


@pytest.fixture(scope="module")
def passive_range():
    """sharma2024-range-only (a passive range sensor every step), 20 steps."""
    sc = load_problem("sharma2024-range-only")
    return sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))


def test_explicit_pings_keep_the_passive_range_sensor(passive_range):
    sc = passive_range
    sig = next(s.sigma for s in sc.sensors if isinstance(s, RangeSensor))
    steps, w, _ = resolve_ping_steps(sc, None)
    assert steps.size == 0  # continuous range measurements are not pings
    assert np.allclose(w[1:], 1.0 / sig**2)
    steps, w2, _ = resolve_ping_steps(sc, [])
    assert steps.size == 0 and np.array_equal(w2, w)
    steps, w3, _ = resolve_ping_steps(sc, [3])
    assert steps.tolist() == [3] and w3[3] == pytest.approx(2.0 / sig**2)
    a = _quiet(closed_form_pcrb, sc, prior_samples=2000)
    b = _quiet(closed_form_pcrb, sc, ping_steps=[], prior_samples=2000)
    np.testing.assert_allclose(b.range_bound, a.range_bound, rtol=1e-12)
    assert a.ping_steps.size == 0


def test_explicit_pings_use_the_active_sensor_sigma(passive_range):
    sc = passive_range
    active = RangeSensor(kind="range", sigma=200.0, steps=(5,))
    sc = sc.replace(sensors=(*sc.sensors, active))
    steps, _, sig = resolve_ping_steps(sc, None)
    assert steps.tolist() == [5] and sig == 200.0
    steps, w2, sig = resolve_ping_steps(sc, [7])
    assert sig == 200.0
    assert w2[7] - w2[6] == pytest.approx(1.0 / 200.0**2)
    assert w2[5] == pytest.approx(w2[6])


@pytest.mark.parametrize("steps", [[2.7], [True], ["3"], "12", [np.nan], [3.0], 5, [[1, 2], [3]]])
def test_ping_steps_must_be_integers(steps):
    with pytest.raises(ArgumentError, match="ping_steps"):
        check_ping_steps(steps, 10)


def test_ping_steps_accept_integer_sequences():
    assert check_ping_steps(np.array([0, 10]), 10).tolist() == [0, 10]
    assert check_ping_steps((np.int64(3), 4), 10).tolist() == [3, 4]
    assert check_ping_steps([], 10).size == 0
    with pytest.raises(ArgumentError, match=r"steps in \[0, 10\]"):
        check_ping_steps([11], 10)


@pytest.fixture(scope="module")
def engine():
    sc = load_problem("brehard2005-s1")
    sc = sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))
    return closed_form_model(sc, prior_samples=2000)


@pytest.mark.parametrize("u", [np.ones(15), np.ones(30), np.full(21, np.nan),
                               -np.ones(21), np.full(21, np.inf), np.ones((1, 21)), "x"])
def test_evaluate_refuses_bad_ping_weights(engine, u):
    with pytest.raises(ArgumentError, match="'u'"):
        engine.evaluate(u)


@pytest.mark.parametrize("u", [np.full((2, 21), np.nan), -np.ones((2, 21)),
                               np.ones((2, 3, 21))])
def test_evaluate_schedules_refuses_bad_ping_weights(engine, u):
    with pytest.raises(ArgumentError, match="'u'"):
        engine.evaluate_schedules(u)


def test_evaluate_accepts_valid_ping_weights(engine):
    u = np.zeros(21)
    u[[0, 7]] = 1.0
    var = engine.evaluate(u)[0]
    rb = engine.evaluate_schedules(u[None, :], backend="numpy")[0]
    np.testing.assert_allclose(rb, np.sqrt(engine.er2 * var[:, 1]), rtol=1e-9)


def _build_kw(engine):
    return dict(mean=engine.moments[:4, 0], second_moment=engine.moments[4:, 0],
                prior_information=engine.prior_information, observer=engine.observer,
                dt=engine.dt, q=0.0025, bearing_info=engine.bearing_info, ping_sigma=100.0)


@pytest.mark.parametrize(("field", "value"), [
    ("dt", -6.0), ("dt", np.nan), ("q", 0.0), ("q", -1.0), ("q", True), ("q", "0.1"),
    ("ping_sigma", 0.0), ("ping_sigma", -100.0), ("ping_sigma", np.inf),
    ("mean", np.zeros(3)), ("mean", np.full(4, np.nan)), ("prior_information", np.eye(3)),
    ("second_moment", np.full((4, 4), np.inf)), ("bearing_info", np.full(21, np.nan)),
    ("bearing_info", -np.ones(21)), ("bearing_info", np.ones(20))])
def test_engine_build_refuses_bad_arguments(engine, field, value):
    kw = _build_kw(engine)
    kw["second_moment"] = _unpack(kw["second_moment"])
    kw[field] = value
    with pytest.raises(ArgumentError, match=f"'{field}'"):
        ClosedFormEngine.build(**kw)


def test_engine_build_reproduces_the_engine(engine):
    kw = _build_kw(engine)
    kw["second_moment"] = _unpack(kw["second_moment"])
    kw["q"] = float(load_problem("brehard2005-s1").target.q)
    again = ClosedFormEngine.build(**kw)
    np.testing.assert_allclose(again.evaluate()[0], engine.evaluate()[0], rtol=1e-12)


def _unpack(v):
    M = np.empty((4, 4))
    for n, (i, j) in enumerate(SYM_INDEX):
        M[i, j] = M[j, i] = v[n]
    return M


@pytest.fixture(scope="module")
def short_s1():
    sc = load_problem("brehard2005-s1")
    return sc.replace(time=dataclasses.replace(sc.time, horizon=20 * sc.time.dt))


@pytest.mark.parametrize("tol", [np.nan, -1.0, "0.1", None])
def test_side_tol_is_checked(short_s1, tol):
    with pytest.raises(ArgumentError, match="'side_tol'"):
        closed_form_pcrb(short_s1, prior_samples=2000, side_tol=tol)


@pytest.mark.parametrize("n", [2000.7, "2000", True, 5, np.float64(2000.0)])
def test_prior_samples_must_be_an_integer(short_s1, n):
    with pytest.raises(ArgumentError, match="'prior_samples'"):
        prepare(short_s1, prior_samples=n)


def test_rng_must_be_a_generator(short_s1):
    with pytest.raises(ArgumentError, match="'rng'"):
        prepare(short_s1, prior_samples=2000, rng=3)
    inp = prepare(short_s1, prior_samples=np.int64(2000), rng=np.random.default_rng(1))
    assert inp.prior_samples == 2000


@pytest.mark.parametrize("floor", [0.0, -1.0, np.nan])
def test_side_density_floor_is_checked(short_s1, floor):
    inp = prepare(short_s1, prior_samples=2000)
    with pytest.raises(ArgumentError, match="'floor'"):
        side_assumption_density(inp, floor=floor)


def test_side_density_gaussian_theta_is_checked():
    with pytest.raises(ArgumentError, match="'theta'"):
        side_density_gaussian(np.nan, np.zeros(2), np.eye(2))


@pytest.mark.parametrize(("kw", "field"), [
    ({"t_start": np.nan}, "t_start"), ({"t_start": "0"}, "t_start"),
    ({"n_steps": -5}, "n_steps"), ({"n_steps": True}, "n_steps"), ({"n_steps": 2.5}, "n_steps")])
def test_information_rates_arguments_are_checked(short_s1, kw, field):
    with pytest.raises(ArgumentError, match=f"'{field}'"):
        information_rates(short_s1, **kw)


def test_information_rates_plan_window(short_s1):
    b, r = information_rates(short_s1, t_start=short_s1.time.t0 + 12.0, n_steps=np.int64(4),
                             include_start=False)
    assert b.tolist() == [0.0] + [1 / 0.05**2] * 4 and not r.any()


@pytest.mark.parametrize("w", [-np.ones(200), np.full(200, np.nan), np.ones(3), np.zeros(200)])
def test_lpc_prior_information_weights_are_checked(short_s1, w):
    X = prepare(short_s1, prior_samples=2000).prior_subsample[:200]
    with pytest.raises(ArgumentError, match="'weights'"):
        lpc_prior_information(X, w)


def test_information_rates_of_a_subset_of_the_sensors():
    # the one per-step information function also serves the passive/active range split
    sc = load_problem("sharma2024-range-only")
    b_all, r_all = information_rates(sc)
    rng_sensors = [s for s in sc.sensors if s.kind == "range"]
    b_r, r_r = information_rates(sc, sensors=rng_sensors)
    assert not b_r.any() and np.array_equal(r_r, r_all) and r_all.any()
    b_b, r_b = information_rates(sc, sensors=[s for s in sc.sensors if s.kind == "bearing"])
    assert np.array_equal(b_b, b_all) and b_all.any() and not r_b.any()
    assert not any(x.any() for x in information_rates(sc, sensors=[]))
