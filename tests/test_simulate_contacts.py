"""Simulation of several contacts (issue 40): one truth per contact, bearings tagged by
contact, a ping ranging every contact within the sensor's ``max_range``; one contact draws
exactly what :func:`tmaplan.simulate.simulate` draws."""

from __future__ import annotations

import dataclasses
import json
import tomllib

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.geometry import range_of
from tmaplan.scenario import dump, from_dict, load_problem, problems_dir
from tmaplan.simulate import (
    draw_common_noise,
    measure_step,
    simulate,
    simulate_contacts,
)


def _two(max_range=None, ping_every=None):
    """``default`` with a second contact "bravo" (14 km at 315°) and, if asked, a range
    sensor reaching ``max_range`` that pings every ``ping_every`` steps."""
    d = tomllib.loads((problems_dir() / "default.toml").read_text(encoding="utf-8"))
    target, prior = d.pop("target"), d.pop("prior")
    d["contacts"] = [{"name": "alpha", "target": target, "prior": prior},
                     {"name": "bravo", "target": {**target, "position": ["-9.9 km", "9.9 km"],
                                                  "course": "110 deg"},
                      "prior": {**prior, "bearing_mean": "315 deg"}}]
    if ping_every is not None:
        d["sensors"][1] = {"kind": "range", "sigma": "50 m", "every": ping_every,
                           **({"max_range": max_range} if max_range else {})}
    return from_dict(d)


@pytest.mark.parametrize("name", ["default", "brehard2005-s1", "clavard2013-halfturn-cw",
                                  "sharma2024-range-only"])
def test_one_contact_draws_exactly_what_simulate_draws(name):
    s = load_problem(name)
    r1, r2 = np.random.default_rng(11), np.random.default_rng(11)
    a = simulate(s, r1)
    b = simulate_contacts(s, r2)
    assert list(b.runs) == ["contact"]
    run = b.runs["contact"]
    assert np.array_equal(a.target, run.target) and np.array_equal(a.relative, run.relative)
    for ma, mb in zip(a.measurements, run.measurements, strict=True):
        assert np.array_equal(ma.values, mb.values) and np.array_equal(ma.steps, mb.steps)
        assert mb.contact == "contact"
    assert r1.random() == r2.random()  # the same number of draws
    assert b.to_json() == a.to_json()  # and the one-contact JSON shape


def test_several_contacts_one_own_ship_one_truth_each():
    s = _two()
    sim = simulate_contacts(s, np.random.default_rng(3))
    assert list(sim.runs) == ["alpha", "bravo"]
    a, b = sim.runs["alpha"], sim.runs["bravo"]
    assert a.observer is b.observer is sim.observer
    assert not np.allclose(a.target[0], b.target[0])
    for name, run in sim.runs.items():
        assert all(m.contact == name for m in run.measurements)
        # the noise-free bearings are each contact's own
        bearing = run.measurements[0]
        rel = run.target - np.hstack([sim.observer.position, sim.observer.velocity])
        expected = np.arctan2(rel[bearing.steps, 0], rel[bearing.steps, 1])
        np.testing.assert_allclose(bearing.truth, expected, atol=1e-12)
    # the contacts' noises are different draws
    assert not np.allclose(a.measurements[0].values - a.measurements[0].truth,
                           b.measurements[0].values - b.measurements[0].truth)
    # reproducible
    again = simulate_contacts(s, np.random.default_rng(3))
    assert np.array_equal(again.runs["bravo"].measurements[0].values,
                          b.measurements[0].values)


def test_a_ping_ranges_only_the_contacts_within_max_range():
    unlimited = simulate_contacts(_two(ping_every=10), np.random.default_rng(5))
    ranges = {n: range_of(r.relative) for n, r in unlimited.runs.items()}
    reach = 11e3  # between the two contacts' ranges over part of the run
    s = _two(max_range=reach, ping_every=10)
    sim = simulate_contacts(s, np.random.default_rng(5))
    kept_any = 0
    for name, run in sim.runs.items():
        full, cut = unlimited.runs[name].measurements[1], run.measurements[1]
        assert cut.kind == "range" and np.all(cut.truth <= reach)
        # exactly the steps whose true range is within reach, with the same values
        inside = full.truth <= reach
        assert np.array_equal(cut.steps, full.steps[inside])
        assert np.array_equal(cut.values, full.values[inside])
        assert np.all(ranges[name][full.steps[~inside]] > reach)
        kept_any += cut.steps.size
        # the bearings do not depend on the reach
        assert np.array_equal(run.measurements[0].values,
                              unlimited.runs[name].measurements[0].values)
    assert 0 < kept_any < sum(r.measurements[1].steps.size for r in unlimited.runs.values())


def test_max_range_with_one_contact():
    s = load_problem("default")
    ping = dataclasses.replace(s.sensors[1], steps=tuple(range(1, s.n_steps + 1)))
    near = s.replace(sensors=(s.sensors[0], dataclasses.replace(ping, max_range=10e3)))
    far = s.replace(sensors=(s.sensors[0], ping))
    a = simulate(near, np.random.default_rng(2)).measurements[1]
    b = simulate(far, np.random.default_rng(2)).measurements[1]
    assert 0 < a.steps.size < b.steps.size and np.all(a.truth <= 10e3)
    assert np.array_equal(a.values, b.values[b.truth <= 10e3])


def test_closed_loop_ping_beyond_reach_returns_no_range():
    s = load_problem("default")
    ping = dataclasses.replace(s.sensors[1], max_range=10e3)
    s = s.replace(sensors=(s.sensors[0], ping))
    noise = draw_common_noise(s, np.random.default_rng(0))
    k = 5
    for r, n_ranges in ((12e3, 0), (8e3, 1)):
        got = measure_step(s, k, np.array([r, 0.0, 0.0, 0.0]), noise, ping=True)
        assert sum(m.kind == "range" for m in got) == n_ranges


def test_simulate_verb_writes_every_contact(tmp_path, capsys):
    path = tmp_path / "two.toml"
    path.write_text(dump(_two(max_range="11 km", ping_every=10)), encoding="utf-8")
    out = tmp_path / "sim.json"
    assert main(["simulate", str(path), "--json", str(out), "--out", str(tmp_path)]) == 0
    got = json.loads(out.read_text(encoding="utf-8"))
    assert list(got["contacts"]) == ["alpha", "bravo"]
    assert {"times", "observer", "observer_heading", "seed"} <= set(got)
    for name, one in got["contacts"].items():
        assert {"target", "relative", "measurements", "figure"} <= set(one)
        assert all(m["contact"] == name for m in one["measurements"])
        assert (tmp_path / f"default-{name}_geometry.png").is_file()
    printed = capsys.readouterr().out
    assert "default contact alpha:" in printed and "default contact bravo:" in printed


def test_simulate_exports_every_contact_tagged(tmp_path):
    from tmaplan.io import read_bearings
    from tmaplan.io.truth import read_truth

    s = _two()
    path = tmp_path / "two.toml"
    path.write_text(dump(s), encoding="utf-8")
    out = tmp_path / "sim.json"
    assert main(["simulate", str(path), "--seed", "4", "--export", str(tmp_path / "x"),
                 "--no-figure", "--json", str(out), "--out", str(tmp_path)]) == 0
    log = read_bearings(tmp_path / "x" / "bearings.csv")
    assert log.names == ("alpha", "bravo")
    sim = simulate_contacts(s, np.random.default_rng(4))
    for c in log.contacts:
        m = sim.runs[c.name].measurements[0]
        diff = np.angle(np.exp(1j * (np.asarray(c.bearing) - m.values)))  # wrapped
        assert c.bearing.shape == m.values.shape and np.abs(diff).max() < 1e-6
    truth = read_truth(tmp_path / "x" / "truth.json")
    assert list(truth.contacts) == ["alpha", "bravo"]
    p0 = sim.observer.position[0]
    for name, run in sim.runs.items():
        np.testing.assert_allclose(truth.contacts[name][:, :2], run.target[:, :2] - p0,
                                   atol=1e-6)


def test_the_batch_crlb_leaves_out_the_ranges_beyond_reach():
    """Cross-check: a reach equals listing only the steps whose true range is within it."""
    from tmaplan.bounds.crlb import crlb
    from tmaplan.scenario import ObserverLeg

    s = load_problem("default")
    leg = ObserverLeg(start=900.0, course=float(np.radians(90.0)),
                      turn_rate=s.observer.turn_rate_max)
    s = s.replace(observer=dataclasses.replace(s.observer, legs=(leg,)))
    every = dataclasses.replace(s.sensors[1], steps=tuple(range(1, s.n_steps + 1, 5)))
    reach = 9e3
    limited = s.replace(sensors=(s.sensors[0], dataclasses.replace(every, max_range=reach)))
    truth = simulate(s, None)
    inside = tuple(int(k) for k in every.steps if range_of(truth.relative)[k] <= reach)
    assert 0 < len(inside) < len(every.steps)
    listed = s.replace(sensors=(s.sensors[0], dataclasses.replace(every, steps=inside)))
    a, b = crlb(limited, frequencies=0), crlb(listed, frequencies=0)
    assert a.n_measurements == b.n_measurements
    np.testing.assert_allclose(a.final_std, b.final_std, rtol=1e-9)
    assert any("max_range" in n for n in a.notes)
    full = crlb(s.replace(sensors=(s.sensors[0], every)), frequencies=0)
    assert full.n_measurements["range"] > a.n_measurements["range"] > 0


def test_the_bound_applies_the_reach_without_a_warning(tmp_path, capsys):
    """`tmaplan bound` (the PCRB conditioned on the true track) counts only the pings whose
    true range is within the reach: with every ping out of reach it is the bound without a
    ping (tests/bounds/test_pcrb_reach.py for the PCRBs themselves)."""
    d = tomllib.loads((problems_dir() / "default.toml").read_text(encoding="utf-8"))
    d["sensors"][1]["max_range"] = "5 km"  # the truth stays beyond 6.6 km
    path = tmp_path / "reach.toml"
    path.write_text(dump(from_dict(d)), encoding="utf-8")

    def bound(problem, *flags):
        out = tmp_path / "b.json"
        assert main(["bound", str(problem), "--no-figure", "--samples", "20", "--json",
                     str(out), "--out", str(tmp_path), *flags]) == 0
        return json.loads(out.read_text(encoding="utf-8"))

    got = bound(path, "--ping-every", "10 min")
    assert "max_range" not in capsys.readouterr().err
    assert got["std"] == bound("default")["std"]
    assert got["std"] != bound("default", "--ping-every", "10 min")["std"]
