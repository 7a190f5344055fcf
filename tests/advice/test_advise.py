"""``tmaplan advise`` (issue 41): recorded bearings and navigation in, solutions and advice out.

* the round trip ``simulate --export`` → ``advise`` reproduces the estimators on the same
  measurements: the ML solution is ``track``'s (:func:`tmaplan.estimators.run` on the
  simulated run), the particle filter's posterior the same function's on the simulation's
  arrays with the same seed rule;
* on exported runs with an own-ship turn, each solution's range, course and speed lie within
  its own stated 95 % interval of the truth (a binomial test over seeds, false-alarm rate
  stated), and the verdict before the turn is "unobservable";
* the verb's outputs: JSON keys (docs/cli.md), leg table, GPX/CSV track, figures and page.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from repo_paths import DATA
from scipy import stats

from tmaplan.advice.problem import Platform, bearings_problem, contact_problem, read_platform
from tmaplan.advice.solution import Z_95, contact_rng, solve_contact
from tmaplan.cli import main
from tmaplan.cli.simulate import DEFAULT_ORIGIN, export, parse_start
from tmaplan.errors import DataError
from tmaplan.estimators.runner import run
from tmaplan.io import read_nav, read_recording, read_truth
from tmaplan.scenario import load
from tmaplan.simulate import simulate

PROBLEM = DATA / "advise" / "manoeuvre.toml"
#: The own ship's turn starts at 20 min (manoeuvre.toml).
TURN = 1200.0


def _export(tmp: Path, seed: int) -> tuple[Path, object]:
    sim = simulate(load(PROBLEM), np.random.default_rng(seed))  # as `simulate --seed`
    d = tmp / f"run{seed}"
    export(sim, d, origin=DEFAULT_ORIGIN, start=parse_start("2024-06-01T12:00:00Z"), seed=seed)
    return d, sim


def test_round_trip_reproduces_the_estimators(tmp_path, capsys):
    seed = 4
    assert main(["simulate", str(PROBLEM), "--seed", str(seed), "--export",
                 str(tmp_path / "run"), "--no-figure", "--json", str(tmp_path / "s.json")]) == 0
    assert main(["advise", str(tmp_path / "run" / "bearings.csv"), "--ownship",
                 str(tmp_path / "run" / "ownship.csv"), "--no-advice", "--no-figure",
                 "--seed", "7", "--json", str(tmp_path / "a.json")]) == 0
    got = json.loads((tmp_path / "a.json").read_text())["contacts"]["contact"]
    sc = load(PROBLEM)
    sim = simulate(sc, np.random.default_rng(seed))
    # the MLE: `track --estimator mle`'s function on the simulated run
    tr = run("mle", sc, sim)
    state = tr.estimates[-1] + sim.observer.state[-1]
    mle = got["mle"]
    # the CSV carries every digit: the same optimum to a millimetre
    assert mle["position"]["east"] == pytest.approx(state[0], abs=1e-3)
    assert mle["position"]["north"] == pytest.approx(state[1], abs=1e-3)
    assert mle["speed"] == pytest.approx(math.hypot(*state[2:]), abs=1e-6)
    crlb = np.sqrt(np.diag(tr.covariances[-1]))
    assert mle["std"]["east"] == pytest.approx(crlb[0], rel=1e-5)
    # from NMEA (1e-7 minute of arc, 0.2 mm; ms times) the same optimum to a centimetre
    rec = read_recording(tmp_path / "run" / "bearings.csv", tmp_path / "run" / "ownship.nmea")
    nm = solve_contact(contact_problem(rec, rec.contacts[0], Platform()),
                       rng=contact_rng(7, 0, 1))
    assert nm.mle.state[:2] == pytest.approx(state[:2], abs=1e-2)
    # the particle filter: the same function on the simulation's own arrays, same seed rule
    # (a resampling step amplifies any difference: the files' micrometres give centimetres)
    bm = next(m for m in sim.measurements if m.kind == "bearing")
    t0 = sim.times[0]
    p0 = sim.observer.position[0]
    cp = bearings_problem("contact", bm.times - t0, bm.values, np.full(bm.times.size, bm.sigma),
                          sim.times - t0, sim.observer.position[:, 0] - p0[0],
                          sim.observer.position[:, 1] - p0[1], Platform(), source="sim")
    sol = solve_contact(cp, rng=contact_rng(7, 0, 1))
    pf = got["pf"]
    assert pf["position"]["east"] == pytest.approx(sol.pf.state[0], abs=1e-2)
    assert pf["position"]["north"] == pytest.approx(sol.pf.state[1], abs=1e-2)
    assert pf["std"]["range"] == pytest.approx(sol.pf.std["range"], rel=1e-5)
    assert got["observable"] and got["verdict"].startswith("observable")


def test_solutions_cover_the_truth(tmp_path):
    """Each seed's solution holds range, course and speed within its 95 % intervals.

    The reported solution is the particle filter's posterior: the batch CRLB assumes a
    constant-velocity contact, and the contact's process noise puts its current course
    outside the CRLB's interval in 6 of these 10 runs (7 miss one of the three; issue 41's
    finding).

    A run misses when any of the three is outside: under nominal coverage a miss has
    probability at most 0.15 (union bound), so more than ``limit`` misses in ``n`` runs has
    probability below 1 % (the test's false-alarm rate, computed below)."""
    n = 10
    limit = int(stats.binom.ppf(0.99, n, 0.15))
    assert stats.binom.sf(limit, n, 0.15) < 0.01
    misses = []
    for seed in range(n):
        d, _ = _export(tmp_path, seed)
        rec = read_recording(d / "bearings.csv", d / "ownship.csv")
        truth = read_truth(d / "truth.json")
        c = rec.contacts[0]
        sol = solve_contact(contact_problem(rec, c, Platform()), rng=contact_rng(seed, 0, 1),
                            frame=rec.frame)
        assert sol.observable and sol.mle.status == "ok" and sol.pf.status == "ok"
        x = truth.contacts["contact"][-1]
        own = rec.nav.east[-1], rec.nav.north[-1]
        r_true = math.hypot(x[0] - own[0], x[1] - own[1])
        # the reported course is true (from true north at the contact), as truth.json's
        c_true = float(rec.frame.true_azimuth(x[0], x[1], math.atan2(x[2], x[3]))[0])
        s_true = math.hypot(x[2], x[3])
        e = sol.pf  # the reported solution (advise's `solution`)
        dc = (c_true - e.course + math.pi) % (2 * math.pi) - math.pi
        miss = (abs(r_true - e.range) > Z_95 * e.std["range"]
                or abs(dc) > Z_95 * e.std["course"]
                or abs(s_true - e.speed) > Z_95 * e.std["speed"])
        misses.append(miss)
    assert sum(misses) <= limit, misses


def test_unobservable_before_the_manoeuvre(tmp_path, capsys):
    d, _ = _export(tmp_path, 1)
    lines = (d / "bearings.csv").read_text().splitlines()
    keep = [lines[0]] + [x for x in lines[1:] if x.startswith("2024-06-01T12:1")]  # < 12:20
    (d / "early.csv").write_text("\n".join(keep) + "\n")
    assert main(["advise", str(d / "early.csv"), "--ownship", str(d / "ownship.gpx"),
                 "--no-advice", "--no-figure", "--json", str(tmp_path / "a.json")]) == 0
    got = json.loads((tmp_path / "a.json").read_text())["contacts"]["contact"]
    assert not got["observable"] and not got["manoeuvred"]
    assert got["verdict"].startswith("unobservable: no own-ship manoeuvre yet")
    assert got["ekelund_range"] is None and got["solution"] == "pf"
    assert got["std"]["range"] > 0.2 * got["range"]  # the range is not known
    assert "unobservable: no own-ship manoeuvre yet" in capsys.readouterr().out


def test_ekelund_range_is_a_cross_check(tmp_path):
    d, sim = _export(tmp_path, 2)
    rec = read_recording(d / "bearings.csv", d / "ownship.csv")
    c = rec.contacts[0]
    sol = solve_contact(contact_problem(rec, c, Platform()), rng=contact_rng(0, 0, 1))
    ek = sol.ekelund
    assert ek is not None and TURN < ek.time < TURN + 200
    k = int(np.argmin(np.abs(sim.times - ek.time)))
    r_true = float(np.hypot(*sim.relative[k, :2]))
    # a classical approximation with its own spread: within 3 of its standard deviations
    assert abs(ek.range - r_true) < 3 * ek.std, (ek, r_true)
    assert ek.std < 0.6 * r_true


def test_advise_outputs(tmp_path, capsys):
    d, _ = _export(tmp_path, 3)
    out = tmp_path / "out"
    assert main(["advise", str(d / "bearings.csv"), "--ownship", str(d / "ownship.csv"),
                 "--budget", "2", "--horizon", "10 min", "--out", str(out),
                 "--json", str(tmp_path / "a.json")]) == 0
    text = capsys.readouterr().out
    assert "start min  course °  turn" in text and "pings:" in text
    got = json.loads((tmp_path / "a.json").read_text())
    adv = got["advice"]
    assert adv["expected_time_to_accuracy"] <= adv["hold_course_time_to_accuracy"]
    assert sum(leg["duration"] for leg in adv["legs"]) == pytest.approx(600.0)
    assert all(leg["rate"] <= Platform().turn_rate_max for leg in adv["legs"])
    assert len(adv["ping_times"]) <= 2 and adv["lower_bound"] <= adv["ping_objective"]
    assert 0 <= adv["gap"] < 1
    assert set(got["reference"]) == {"time", "lat", "lon", "projection"}
    for key in ("time", "range", "bearing", "course", "speed", "position", "std",
                "observable", "ekelund_range"):
        assert key in got["contacts"]["contact"]
    files = got["exports"]["contact"]
    nav = read_nav(files["track_gpx"])  # the navigation readers read it back
    assert nav.times.size == len(adv["track"]["times"])
    assert Path(files["legs"]).read_text().startswith("start_min,course_deg,turn")
    page = Path(got["report"]).read_text()
    assert page.count("data:image/png;base64") == 3 and "Advice for contact" in page


def test_several_contacts(tmp_path):
    d, _ = _export(tmp_path, 5)
    lines = (d / "bearings.csv").read_text().splitlines()
    rows = lines[1:]
    second = [x.rsplit(",", 1)[0] + ",B" for x in rows]
    (d / "two.csv").write_text("\n".join([lines[0], *rows, *second]) + "\n")
    assert main(["advise", str(d / "two.csv"), "--ownship", str(d / "ownship.csv"),
                 "--no-advice", "--no-figure", "--json", str(tmp_path / "a.json")]) == 0
    got = json.loads((tmp_path / "a.json").read_text())["contacts"]
    assert set(got) == {"contact", "B"}
    # the same bearings: the same ML solution; the filters draw from their own seeds
    assert got["B"]["mle"]["range"] == pytest.approx(got["contact"]["mle"]["range"], rel=1e-9)
    assert got["B"]["pf"]["range"] != got["contact"]["pf"]["range"]


def test_platform_file(tmp_path):
    p = tmp_path / "p.toml"
    p.write_text('range_max = "30 km"\nspeed_max = "20 kn"\nturn_rate_max = "1 deg/s"\n')
    pl = read_platform(p)
    assert pl.range_max == 30000.0 and pl.speed_max == pytest.approx(20 * 1852 / 3600)
    assert pl.turn_rate_max == pytest.approx(math.radians(1.0)) and pl.range_min == 1000.0
    p.write_text("depth = 3\n")
    with pytest.raises(DataError, match=r"p.toml: unknown key 'depth'"):
        read_platform(p)
    p.write_text('range_min = "50 km"\n')
    with pytest.raises(DataError, match=r"key 'range_max': expected > range_min"):
        read_platform(p)


def test_combined_bearings_keep_the_likelihood():
    from tmaplan.advice.problem import combine_bearings

    rng = np.random.default_rng(0)
    steps = np.repeat(np.arange(5), 4)
    z = 3.1 + 0.02 * rng.standard_normal(steps.size)  # across ±π
    z = (z + np.pi) % (2 * np.pi) - np.pi
    sig = np.full(steps.size, 0.02)
    k, zb, sb = combine_bearings(steps, z, sig)
    assert k.tolist() == list(range(5)) and sb == pytest.approx(0.01)

    def cost(h, zz, ss, kk):
        r = (zz - h[kk] + np.pi) % (2 * np.pi) - np.pi
        return float(np.sum((r / ss) ** 2))

    h1, h2 = np.full(5, 3.1), np.full(5, -3.12)
    # the same likelihood up to a constant: equal differences between two hypotheses
    assert cost(h1, z, sig, steps) - cost(h2, z, sig, steps) == pytest.approx(
        cost(h1, zb, sb, k) - cost(h2, zb, sb, k), rel=1e-9)


def test_a_contact_with_too_few_bearings_is_left_out(tmp_path, capsys):
    data = DATA / "invalid_cli"
    lines = (data / "advise_bearings.csv").read_text().splitlines()
    extra = [x.rsplit(",", 1)[0] + ",B" for x in lines[1:4]]
    (tmp_path / "b.csv").write_text("\n".join([*lines, *extra]) + "\n")
    assert main(["advise", str(tmp_path / "b.csv"), "--ownship",
                 str(data / "advise_ownship.csv"), "--no-advice", "--no-figure",
                 "--json", str(tmp_path / "a.json")]) == 0
    got = json.loads((tmp_path / "a.json").read_text())
    assert set(got["contacts"]) == {"A"}
    err = capsys.readouterr().err
    assert "fewer than 5 bearings at different times left out: 'B' (3)" in err
    assert any("'B' (3)" in w for w in got["warnings"])


def test_a_prior_that_excludes_the_solution_is_told(tmp_path, capsys):
    d, _ = _export(tmp_path, 3)
    assert main(["advise", str(d / "bearings.csv"), "--ownship", str(d / "ownship.csv"),
                 "--range-min", "30 km", "--no-advice", "--no-figure",
                 "--json", str(tmp_path / "a.json")]) == 0
    got = json.loads((tmp_path / "a.json").read_text())["contacts"]["contact"]
    assert "outside the prior's 30-40 km" in got["cross_check"]
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "warning: SolutionWarning" in err[0]
