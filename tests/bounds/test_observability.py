"""Tests of tmaplan.bounds.observability: lecadre1997 Props 1–4, clavard2013 Results 1, 3, 5."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.bounds.observability import (
    ct_observability,
    ct_vs_cv_test,
    observability,
    rank_test,
    switch_time_scan,
)
from tmaplan.errors import ArgumentError
from tmaplan.models.target import constant_turn_state
from tmaplan.scenario import load_problem

T = np.arange(40.0)


def _observer(man=None, v1=(5.0, 0.0), v2=(0.0, 5.0)):
    v1, v2 = np.asarray(v1), np.asarray(v2)
    if man is None:
        return T[:, None] * v1
    return np.where(T[:, None] <= man, T[:, None] * v1, man * v1 + (T[:, None] - man) * v2)


def _source(change=None, v1=(-3.0, -1.0), v2=(2.0, -3.0), p0=(5000.0, 20000.0)):
    p0, v1, v2 = np.asarray(p0), np.asarray(v1), np.asarray(v2)
    if change is None:
        return p0 + T[:, None] * v1
    return np.where(T[:, None] <= change, p0 + T[:, None] * v1,
                    p0 + change * v1 + (T[:, None] - change) * v2)


def _brg(src, obs):
    d = src - obs
    return np.arctan2(d[:, 0], d[:, 1])


# docs/errata.md§2.4 geometry: source (5, 20) km, (−3, −1) m/s; observer 5 m/s east.
CASES = [
    # (label, source change, observer manoeuvre, expected rank, state dim, test name)
    ("RUN/RUN", None, None, 3, 4, "§III"),
    ("Prop 1", None, 20.0, 4, 4, "Property 1"),
    ("Prop 2", 15.0, None, 5, 6, "Property 2"),
    ("Prop 3", 15.0, 28.0, 6, 6, "Property 3"),
    ("Prop 3, observer first", 25.0, 5.0, 6, 6, "Property 3"),
    ("same instant", 15.0, 15.0, 5, 6, "Property 3"),
]


@pytest.mark.parametrize(("label", "change", "man", "rank", "dim", "name"), CASES)
def test_file003_rank_tests(label, change, man, rank, dim, name):
    b = _brg(_source(change), _observer(man))
    res = rank_test(b, T, change_times=[] if change is None else [change],
                    observer_manoeuvre_times=[] if man is None else [man])
    assert (res.rank, res.expected_rank) == (rank, dim), res.verdict
    assert res.predicted_rank == rank
    assert res.observable == (rank == dim)
    assert name in res.test and ("NOT observable" in res.verdict) == (rank < dim)
    # clear gap between kept and dropped singular values (tolerance is not borderline)
    sv = res.singular_values
    assert sv[rank - 1] > 1e-7
    if rank < dim:
        assert sv[rank] < 1e-12


def test_three_leg_source_property2():
    ch = [10.0, 25.0]
    p = np.array([5000.0, 20000.0])
    vs = [np.array(v) for v in ([-3.0, -1.0], [2.0, -3.0], [1.0, 2.0])]
    tau = np.clip(T[:, None], [0.0, 10.0, 25.0], [10.0, 25.0, np.inf]) - [0.0, 10.0, 25.0]
    src = p + tau @ np.stack(vs)
    res = rank_test(_brg(src, _observer()), T, change_times=ch)
    assert (res.rank, res.expected_rank) == (7, 8)
    res = rank_test(_brg(src, _observer(28.0)), T, change_times=ch,
                    observer_manoeuvre_times=[28.0])
    assert (res.rank, res.expected_rank) == (8, 8)


def test_collision_legs_property1_exception():
    """Stationary source due north: two collision legs give rank 2; one collision leg then a
    non-collision leg gives rank 4 (docs/errata.md)."""
    src = np.array([0.0, 20000.0]) + 0 * T[:, None]
    r = rank_test(_brg(src, _observer(20.0, (0.0, 5.0), (0.0, 3.0))), T,
                  observer_manoeuvre_times=[20.0])
    assert r.rank == 2 and r.predicted_rank == 2 and not r.observable
    r = rank_test(_brg(src, _observer(20.0, (0.0, 5.0), (4.0, 3.0))), T,
                  observer_manoeuvre_times=[20.0])
    assert r.rank == 4 and r.observable


def test_rank_is_rotation_invariant():
    a = 1.1
    R = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    for change, man, rank in [(None, None, 3), (15.0, 28.0, 6)]:
        src, obs = _source(change), _observer(man)
        res = rank_test(_brg(src @ R.T, obs @ R.T), T,
                        change_times=[] if change is None else [change])
        assert res.rank == rank


def test_property4_switch_time_identification():
    """Unknown source instant: only the true instant (15) leaves a zero residual; the
    observer's manoeuvre instant (28) is the degenerate r ≡ 0 solution and is rejected."""
    obs = _observer(28.0)
    b = _brg(_source(15.0), obs)
    scan = switch_time_scan(b, T, obs, candidates=np.arange(5.0, 36.0))
    assert scan.best == 15.0
    res = np.sort(scan.residuals)
    assert res[0] < 1e-9 and res[1] > 1e-4
    assert scan.degenerate[list(scan.candidates).index(28.0)]


# -- clavard2013 ----------------------------------------------------------------------------------

Z = np.array([7530.0, 10000.0, 1000.0, 0.0, 0.005])
TT = np.arange(0.0, 628.0, 3.0)


def test_result1_moving_vs_motionless_observer():
    obs = np.stack([6.0 * TT, 0 * TT], axis=-1)
    vel = np.tile([6.0, 0.0], (TT.size, 1))
    r = ct_observability(TT, obs, vel, Z)
    assert (r.rank, r.expected_rank, r.observable) == (5, 5, True)
    still = np.tile([2000.0, -500.0], (TT.size, 1))
    r = ct_observability(TT, still, 0 * vel, Z)
    assert (r.rank, r.predicted_rank, r.observable) == (4, 4, False)
    assert "homothety" in r.verdict
    # the homothety of Result 2 (μ = 3) gives identical bearings (docs/errata.md checklist 10)
    mu = 3.0
    Z2 = np.r_[mu * (Z[:2] - still[0]) + still[0], mu * Z[2], Z[3:]]
    b1 = constant_turn_state(Z[:2], Z[2], Z[3], Z[4], TT)[:, :2] - still
    b2 = constant_turn_state(Z2[:2], Z2[2], Z2[3], Z2[4], TT)[:, :2] - still
    np.testing.assert_allclose(np.arctan2(*b1.T), np.arctan2(*b2.T), atol=1e-12)


def test_result5_frequency_and_circle_centre():
    vel = np.zeros((TT.size, 2))
    off = np.tile([2000.0, -500.0], (TT.size, 1))
    r = ct_observability(TT, off, vel, Z, f0=[3000.0], sigma_f=[3.0])
    assert (r.rank, r.expected_rank, r.observable) == (6, 6, True)
    centre = np.tile(Z[:2], (TT.size, 1))
    r = ct_observability(TT, centre, vel, Z, f0=[3000.0], sigma_f=[3.0])
    assert r.rank < 6 and not r.observable and "centre" in r.verdict


def test_result3_ct_never_mistaken_for_cv():
    obs = np.stack([6.0 * TT, 0 * TT], axis=-1)
    ct = constant_turn_state(Z[:2], Z[2], Z[3], Z[4], TT)[:, :2]
    r = ct_vs_cv_test(np.arctan2(*(ct - obs).T), TT, obs)
    assert r.rank == 4 and r.observable
    # also from a motionless observer
    still = np.tile([2000.0, -500.0], (TT.size, 1))
    r = ct_vs_cv_test(np.arctan2(*(ct - still).T), TT, still)
    assert r.observable
    # control: bearings of a CV source are reproduced by a CV source (rank stays 3, file
    # 003 §III), so the test can fail
    cv = np.array([5000.0, 15000.0]) + TT[:, None] * [-2.0, 1.0]
    r = ct_vs_cv_test(np.arctan2(*(cv - obs).T), TT, obs)
    assert r.rank == 3 and not r.observable


def test_scenario_level_verdicts():
    r = observability(load_problem("clavard2013-halfturn-acw"), frequencies=0)
    assert r.observable and r.test == "clavard2013 Result 1"
    r = observability(load_problem("clavard2013-halfturn-cw"))
    assert r.observable and r.expected_rank == 9
    r = observability(load_problem("default"))  # straight observer, CV target
    assert not r.observable and r.rank == 3
    r = observability(load_problem("brehard2005-s2"))  # manoeuvring observer
    assert r.observable and "Property 1" in r.test


def test_bad_inputs():
    b = _brg(_source(), _observer(20.0))
    b[3] = np.nan
    with pytest.raises(ArgumentError, match="bearings"):
        rank_test(b, T)
    with pytest.raises(ArgumentError, match="at least"):
        rank_test(np.zeros(3), np.arange(3.0))
    with pytest.raises(ArgumentError, match="frequencies"):
        observability(load_problem("clavard2013-halfturn-cw"), frequencies=6)


def test_pseudo_measurement_identity_with_a_change_before_the_first_bearing():
    """O p = z for the true parameters (positions at times[0]). A change time before
    times[0] gave a negative time on leg 1 and a wrong matrix."""
    from tmaplan.bounds.observability import observability_matrix

    t = T[10:]
    obs = _observer(20.0)[10:]
    src = _source(5.0)[10:]  # source changed at t = 5, before the first bearing at t = 10
    b = _brg(src, obs)
    O = observability_matrix(b, t, change_times=[5.0])
    z = np.sum(np.stack([np.cos(b), -np.sin(b)], axis=-1) * obs, axis=-1)
    p = np.r_[src[0], -3.0, -1.0, 2.0, -3.0]  # position at t[0], leg-1 and leg-2 velocities
    np.testing.assert_allclose(O @ p, z, atol=1e-8 * np.max(np.abs(z)))


@pytest.mark.parametrize("call, field", [
    (lambda b: rank_test(b, T, change_times=[np.nan]), "change_times"),
    (lambda b: rank_test(b[::-1], T[::-1], change_times=[15.0]), "times"),
    (lambda b: rank_test(b, T, rtol=np.nan), "rtol"),
    (lambda b: rank_test(b, T, rtol=-1.0), "rtol"),
    (lambda b: ct_vs_cv_test(b, T, _observer(20.0), rtol=2.0), "rtol"),
    (lambda b: switch_time_scan(b, T, _observer(20.0), [np.nan, 15.0]), "candidates"),
    (lambda b: ct_observability(T, _observer(20.0), np.tile([5.0, 0.0], (T.size, 1)),
                                [7530.0, 10000.0, 1000.0, 0.0]), "theta"),
    (lambda b: ct_observability(T, _observer(20.0), np.tile([5.0, 0.0], (T.size, 1)),
                                [7530.0, 10000.0, 1000.0, 0.0, 0.005], rtol=np.nan), "rtol"),
    (lambda b: observability(load_problem("clavard2013-halfturn-cw"), frequencies=True),
     "frequencies"),
    (lambda b: observability(load_problem("clavard2013-halfturn-cw"), frequencies=1.5),
     "frequencies"),
])
def test_bad_arguments_name_their_field(call, field):
    """Decreasing times gave a wrong matrix (no time on any leg: rank 2 for Property 2);
    NaN change times or candidates were a LinAlgError from the SVD, a NaN or negative rtol
    silently gave rank 0 or full rank, a short theta a tuple-unpacking ValueError, and
    frequencies=True/1.5 used one line."""
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        call(_brg(_source(15.0), _observer(20.0)))
