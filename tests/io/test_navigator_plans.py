"""Plans a navigator can use (issue 41, item 3): every plan prints and writes its leg table
and its GPX/CSV track; its turn rates never exceed the limit (so they paste into
``observer.turn_rates``); ``track`` and ``simulate`` fly a plan (``--observer-plan``), and
``simulate`` draws bearing and bearing rate against time."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.io import read_legs_csv, read_nav
from tmaplan.io.plans import Leg, step_turn_rates
from tmaplan.scenario import load


@pytest.fixture(scope="module")
def plan_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("plan")
    assert main(["plan", "default", "--horizon", "10 min", "--no-figure", "--out", str(out),
                 "--json", str(out / "plan.json")]) == 0
    return out, json.loads((out / "plan.json").read_text())


def test_plan_rates_within_the_limit_paste_into_turn_rates(plan_run):
    _, got = plan_run
    sc = load("default")
    limit = sc.observer.turn_rate_max
    rates = np.asarray(got["turn_rate"])
    assert np.max(np.abs(rates)) <= limit  # exactly: clipped at the source
    assert all(leg["rate"] <= limit for leg in got["legs"])
    # the plan's per-step rates are a valid observer.turn_rates (they were refused at +1e-8)
    per_step = np.repeat(rates, round(60.0 / sc.time.dt))
    K = sc.time.n_steps
    u = np.zeros(K)
    u[:per_step.size] = per_step
    sc.replace(observer=dataclasses.replace(sc.observer, turn_rates=tuple(u)))


def test_plan_writes_its_leg_table_and_track(plan_run, capsys):
    _, got = plan_run
    files = got["exports"]
    legs, start = read_legs_csv(files["legs"])
    assert start is not None and sum(leg.duration for leg in legs) == pytest.approx(600.0)
    assert [leg.turn for leg in legs] == [leg["turn"] for leg in got["legs"]]
    for key in ("track_gpx", "track_csv"):
        nav = read_nav(files[key])
        assert nav.times.size == len(got["observer"]["times"])


def test_step_turn_rates_integrate_the_legs():
    legs = (Leg(start=0.0, course=0.0, turn="straight", rate=0.0, duration=100.0),
            Leg(start=100.0, course=0.0, turn="starboard", rate=0.01, duration=50.0),
            Leg(start=150.0, course=0.5, turn="port", rate=0.005, duration=40.0))
    u = step_turn_rates(legs, 15.0, 20)
    assert u.shape == (20,) and np.max(np.abs(u)) <= 0.01
    # the course at every grid time is the legs' (piecewise linear) course
    psi = np.concatenate([[0.0], np.cumsum(u * 15.0)])
    t = 15.0 * np.arange(21)
    expect = np.interp(t, [0, 100, 150, 190], [0.0, 0.0, 0.5, 0.3])
    assert psi == pytest.approx(expect, abs=1e-12)


def test_simulate_and_track_fly_a_plan(plan_run, tmp_path, capsys):
    out, got = plan_run
    for plan in (out / "plan.json", Path(got["exports"]["legs"])):
        assert main(["simulate", "default", "--observer-plan", str(plan), "--out",
                     str(tmp_path), "--json", str(tmp_path / "s.json")]) == 0
        sim = json.loads((tmp_path / "s.json").read_text())
        pos = np.asarray(sim["observer"])[:, :2]
        planned = np.asarray(got["observer"]["position"])
        n = planned.shape[0]
        # to a millimetre: the rates clipped to the limit (by ~1e-8 rad/s) and a leg's rate
        # its steps' median move the track by micrometres
        assert pos[:n] == pytest.approx(planned, abs=1e-3), plan
        assert Path(sim["bearings_figure"]).exists()
    assert main(["track", "default", "--estimator", "pf", "--particles", "500", "--runs", "1",
                 "--observer-plan", str(out / "plan.json"), "--no-figure", "--out",
                 str(tmp_path), "--json", str(tmp_path / "t.json")]) == 0


def test_observer_plan_refusals(plan_run, tmp_path, capsys):
    out, _ = plan_run
    bad = tmp_path / "legs.csv"
    bad.write_text("start_min,course_deg,turn,rate_deg_s,duration_min\n"
                   "0.0,90.0,straight,0.0,10.0\n")
    assert main(["simulate", "default", "--observer-plan", str(bad), "--out",
                 str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "field '--observer-plan'" in err[0] and "initial course" in err[0]
    fast = tmp_path / "fast.csv"
    fast.write_text("start_min,course_deg,turn,rate_deg_s,duration_min\n"
                    "0.0,0.0,starboard,2.0,1.0\n")
    assert main(["simulate", "default", "--observer-plan", str(fast), "--out",
                 str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "turn_rate_max" in err[0]
    assert main(["simulate", "brehard2004-mp", "--observer-plan", str(out / "plan.json"),
                 "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a plan of problem 'brehard2004-mp'" in err[0]
