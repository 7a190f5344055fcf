"""Simulation: reproducibility, geometry of the published scenarios, measurement noise."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.scenario import list_problems, load_problem
from tmaplan.simulate import simulate, simulate_contacts


@pytest.mark.parametrize("name", [p["name"] for p in list_problems()])
def test_simulate_every_problem(name):
    s = load_problem(name)
    if len(s.contacts) > 1:  # several contacts (issue 40): each contact's run
        runs = simulate_contacts(s, np.random.default_rng(7)).runs
        again = simulate_contacts(s, np.random.default_rng(7)).runs
        for c in s.contact_names:
            _same_runs(runs[c], again[c], runs[c].scenario)
        return
    _same_runs(simulate(s, np.random.default_rng(7)), simulate(s, np.random.default_rng(7)), s)


def _same_runs(a, b, s):
    assert np.array_equal(a.target, b.target)
    for ma, mb in zip(a.measurements, b.measurements, strict=True):
        assert np.array_equal(ma.values, mb.values)
        assert np.all(np.isfinite(ma.values))
    assert a.times.shape == (s.n_steps + 1,)
    assert np.array_equal(a.relative, a.target - a.observer.state)


def test_brehard2005_s2_bearing_passes_abeam():
    # docs/errata.md: relative velocity (2, −9) m/s between 1500 and 4500 s, so r_y crosses 0
    # near t ≈ 2722 s and the bearing passes ±90°; with the π ambiguity of eq. 4 the measured
    # bearing jumps from ≈ −90° to ≈ +90° there.
    s = load_problem("brehard2005-s2")
    sim = simulate(s, None)
    ry = sim.relative[:, 1]
    k = np.nonzero(np.diff(np.sign(ry)) != 0)[0]
    assert len(k) == 1
    assert 2700 <= sim.times[k[0]] <= 2740
    m = sim.measurements[0]
    j = np.searchsorted(m.steps, k[0])
    assert np.degrees(m.truth[j - 1]) < -85 and np.degrees(m.truth[j + 1]) > 85
    # before the manoeuvre the relative velocity is (6 − 10, 3 + 2) = (−4, 5) m/s; noise-free
    assert sim.relative[0] == pytest.approx([-3500.0, 3500.0, -4.0, 5.0])
    assert sim.relative[300, 2:] == pytest.approx([2.0, -9.0])


def test_bearing_noise_statistics():
    s = load_problem("ristic-bot-moderate")
    res = []
    for seed in range(200):
        sim = simulate(s, np.random.default_rng(seed))
        m = sim.measurements[0]
        res.append(np.angle(np.exp(1j * (m.values - m.truth))))
    r = np.concatenate(res)
    sigma = s.sensors[0].sigma
    # 6400 samples: the sample std is within 4 % of σ with overwhelming probability (its
    # relative standard error is 1/sqrt(2·6400) = 0.9 %).
    assert r.std() == pytest.approx(sigma, rel=0.04)
    assert abs(r.mean()) < 4 * sigma / np.sqrt(r.size)


def test_relative_bearings_are_relative_to_heading():
    s = load_problem("ristic-bot-moderate")
    sim = simulate(s, np.random.default_rng(0))
    m = sim.measurements[0]
    back = np.angle(np.exp(1j * (m.relative + sim.observer.heading[m.steps])))
    assert back == pytest.approx(np.angle(np.exp(1j * m.values)), abs=1e-12)


def test_json_payload_has_design_keys():
    sim = simulate(load_problem("gordon1993-bot"), np.random.default_rng(0))
    d = sim.to_json()
    for key in ("times", "target", "observer", "measurements"):
        assert key in d
    assert len(d["times"]) == 25
