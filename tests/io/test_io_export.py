"""``tmaplan simulate P --export DIR``: the simulated run as recorded data, read back to the
simulation's own numbers (bearings to round-off, own-ship positions to a millimetre)."""

from __future__ import annotations

import datetime as dt
import json

import numpy as np
import pytest
from test_io_bearings import quiet

from tmaplan.cli import main
from tmaplan.geometry import angle_diff
from tmaplan.io import read_nav, read_recording, read_truth
from tmaplan.scenario import dump, load_problem
from tmaplan.simulate import simulate


@pytest.mark.parametrize("problem", ["default", "brehard2004-mp"])
def test_export_reads_back_the_simulation(tmp_path, capsys, problem):
    out = tmp_path / "exp"
    assert main(["simulate", problem, "--seed", "3", "--no-figure", "--export", str(out),
                 "--json", str(tmp_path / "sim.json")]) == 0
    payload = json.loads((tmp_path / "sim.json").read_text())
    assert sorted(payload["export"]) == ["bearings", "ownship_csv", "ownship_gpx",
                                         "ownship_nmea", "truth"]
    scenario = load_problem(problem)
    sim = simulate(scenario, np.random.default_rng(3))
    (m,) = [m for m in sim.measurements if m.kind == "bearing"]
    t0, p0 = sim.times[0], sim.observer.position[0]
    for nav, tol in (("ownship.csv", 1e-6), ("ownship.gpx", 1e-6), ("ownship.nmea", 1e-3)):
        rec = quiet(read_recording, out / "bearings.csv", out / nav)
        assert rec.start == dt.datetime(2024, 6, 1, 12, tzinfo=dt.UTC)
        assert rec.frame is not None and (rec.frame.lat0, rec.frame.lon0) == (45.0, -5.0)
        (c,) = rec.contacts
        assert c.name == "contact"
        np.testing.assert_array_equal(c.times, m.times - t0)
        # the file's bearings are true; turned to the plane at the own ship they are the
        # simulation's (the plane's azimuths) to round-off (NMEA: its millimetres move the
        # convergence by tan(lat)/R = 1.6e-10 rad per mm)
        grid = rec.frame.grid_azimuth(c.ownship.position[:, 0], c.ownship.position[:, 1],
                                      c.bearing)
        assert np.max(np.abs(angle_diff(grid, m.values))) < (1e-9 if tol > 1e-5 else 1e-10)
        np.testing.assert_allclose(c.sigma, float(m.sigma), rtol=1e-15)
        np.testing.assert_allclose(c.ownship.position, sim.observer.position[m.steps] - p0,
                                   rtol=0, atol=tol)
        # the velocity between fixes is the simulation's mean velocity over the step
        later = m.steps >= 1
        np.testing.assert_allclose(c.ownship.velocity[later],
                                   sim.observer.mean_velocity[m.steps[later]], rtol=0,
                                   atol=tol / scenario.time.dt)
    nmea = quiet(read_nav, out / "ownship.nmea")
    np.testing.assert_allclose(nmea.speed, sim.observer.speed, atol=1e-3)
    truth = read_truth(out / "truth.json")
    np.testing.assert_allclose(truth.contacts["contact"],
                               sim.target - np.r_[p0, 0.0, 0.0], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(truth.times, sim.times - t0)
    assert truth.extra["problem"] == problem and truth.extra["seed"] == 3
    assert truth.extra["scenario_offset"] == [float(p0[0]), float(p0[1])]
    assert "wrote" in capsys.readouterr().out


def test_origin_and_start_flags(tmp_path):
    out = tmp_path / "exp"
    assert main(["simulate", "default", "--no-figure", "--export", str(out), "--origin=-33.5,151.5",
                 "--start", "2025-12-31T23:55:00-03:00"]) == 0
    rec = quiet(read_recording, out / "bearings.csv", out / "ownship.nmea")
    assert rec.start == dt.datetime(2026, 1, 1, 2, 55, tzinfo=dt.UTC)
    assert rec.frame is not None and (rec.frame.lat0, rec.frame.lon0) == (-33.5, 151.5)


@pytest.mark.parametrize(("argv", "expect"), [
    (["--origin", "45,-5"], "--origin: expected given only with --export"),
    (["--start", "2024-01-01T00:00:00Z"], "--start: expected given only with --export"),
    (["--export", "E", "--origin", "95,0"], "--origin must be a latitude in [-90, 90]"),
    (["--export", "E", "--origin", "north"], "--origin must be LAT,LON in degrees"),
    (["--export", "E", "--start", "2024-01-01T00:00:00"], "--start must be an ISO 8601 time "
                                                          "with a zone"),
    (["--export", "/proc/tmaplan-export"], "--export: expected a directory where files can be "
                                           "written"),
])
def test_bad_export_flags_are_one_line(tmp_path, one_line_error, argv, expect):
    argv = [a.replace("E", str(tmp_path / "e")) if a == "E" else a for a in argv]
    line = one_line_error(["simulate", "default", "--no-figure", *argv])
    assert expect in line.replace("field '--", "--").replace("': expected", ": expected"), line


def test_a_run_without_bearings_is_not_exported(tmp_path, one_line_error):
    text = dump(load_problem("default"))
    start = text.index("[[sensors]]")
    p = tmp_path / "nobearing.toml"
    p.write_text(text[:start] + '[[sensors]]\nkind = "range"\nsigma = 100.0\nperiod = 60.0\n')
    line = one_line_error(["simulate", str(p), "--no-figure", "--export", str(tmp_path / "e")])
    assert "--export" in line and "a problem whose run has bearings" in line, line
