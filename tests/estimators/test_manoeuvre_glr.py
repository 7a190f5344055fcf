"""Velocity-jump GLR (tmaplan.estimators.manoeuvre_glr) and its place in the monitor."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.estimators.consistency import MonitorConfig, MonitoredFilter
from tmaplan.estimators.manoeuvre_glr import glr_threshold, velocity_jump_glr
from tmaplan.estimators.particle_filter import ParticleFilter, PFConfig
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.simulate import Measurement

SIG, DT = math.radians(1.0), 15.0
OWN_V = np.array([0.0, 3.0])


@dataclasses.dataclass(frozen=True)
class _Post:
    mean: np.ndarray
    cov: np.ndarray


def _velocities(speed, turn_deg):
    c0 = math.radians(200.0)
    c1 = c0 + math.radians(turn_deg)
    return (speed * np.array([math.sin(c0), math.cos(c0)]),
            speed * np.array([math.sin(c1), math.cos(c1)]))


def _truth(turn_deg, onset, n, speed=5.0):
    """Relative states at steps 0..n of a target 12 km NE that turns at ``onset``."""
    v0, v1 = _velocities(speed, turn_deg)
    x = np.array([8485.0, 8485.0, *(v0 - OWN_V)])
    out = [x.copy()]
    for k in range(1, n + 1):
        if k == onset + 1:
            x[2:] = v1 - OWN_V
        x[:2] += DT * x[2:]
        out.append(x.copy())
    return np.array(out)


def _history(turn_deg, seed, n=40, onset=25):
    X = _truth(turn_deg, onset, n)
    rng = np.random.default_rng(seed)
    post = _Post(X[0] + np.array([200.0, -200.0, 0.1, 0.0]), np.diag([1e3**2] * 2 + [1.0] * 2))
    meas = [(Measurement(kind="bearing", sigma=SIG,
                         value=math.atan2(X[k, 0], X[k, 1]) + SIG * rng.standard_normal()),)
            for k in range(1, n + 1)]
    return [(post, np.zeros(2), OWN_V, m) for m in meas]


def test_glr_sees_a_clear_turn_and_not_a_straight_track():
    for seed in range(3):
        quiet = velocity_jump_glr(_history(0.0, seed), DT, max_back=16)
        turn = velocity_jump_glr(_history(90.0, seed), DT, max_back=16)
        assert quiet is not None and turn is not None
        h = glr_threshold(1e-3, turn.candidates)
        assert quiet.statistic < h < turn.statistic
        assert turn.candidates == 15 and 12 <= turn.back <= 18  # onset 15 steps back


def _monitored_run(turn_deg, cfg, seed=0, n=150, onset=90):
    pf = ParticleFilter(PFConfig(n_particles=1000, dt=DT, q=1e-5))
    X = _truth(turn_deg, onset, n, speed=6.0)
    rng, frng = np.random.default_rng(seed), np.random.default_rng(seed + 100)
    mf = MonitoredFilter(pf, cfg)
    st = mf.wrap(pf.from_gaussian(X[0] + np.array([300.0, -300.0, 0.3, -0.2]),
                                  np.diag([1e3**2] * 2 + [1.0, 1.0]), frng), OWN_V)
    for k in range(1, n + 1):
        st = mf.predict(st, None, frng)
        z = math.atan2(X[k, 0], X[k, 1]) + SIG * rng.standard_normal()
        st = mf.update(st, [Measurement(kind="bearing", value=z, sigma=SIG)], frng)
    return st


def test_monitor_glr_alarms_after_a_turn_only():
    cfg = dataclasses.replace(FilterOptions.glr().monitor, cusum=False, recover=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = _monitored_run(0.0, cfg)
        turned = _monitored_run(90.0, cfg, seed=1)
    assert clean.log == ()
    glr = [a["step"] for a in turned.log if a["test"] == "glr"]
    assert glr and 90 < glr[0] <= 110
    assert FilterOptions.glr().label() == "glr"


def test_glr_bad_arguments():
    with pytest.raises(ArgumentError, match="glr_window"):
        MonitorConfig(glr_window=8)  # shorter than lookback
    with pytest.raises(ArgumentError, match="glr_alpha"):
        MonitorConfig(glr_window=40, glr_alpha=0.7)
    with pytest.raises(ArgumentError, match="max_back"):
        velocity_jump_glr(_history(0.0, 0), DT, max_back=2)
    with pytest.raises(ArgumentError, match="min_after"):
        velocity_jump_glr(_history(0.0, 0), DT, min_after=0)
    with pytest.raises(ArgumentError, match="candidates"):
        glr_threshold(1e-3, 0)


@pytest.mark.parametrize(("field", "kw"), [
    ("iterations", {"iterations": -1}),  # was an UnboundLocalError
    ("iterations", {"iterations": 1.5}),
    ("dt", {"dt": 0.0}),  # every lag 0: a silent statistic of 0
    ("dt", {"dt": float("nan")}),
    ("min_after", {"min_after": 2.5}),
    ("max_back", {"max_back": 10.5}),
])
def test_glr_refuses_invalid_settings(field, kw):
    args = {"dt": DT, **kw}
    with pytest.raises(ArgumentError, match=f"field '{field}'"):
        velocity_jump_glr(_history(0.0, 0), **args)
