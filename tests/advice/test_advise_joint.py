"""``tmaplan advise`` on a several-contact recording (issue 41 with issue 40's planner): ONE
own-ship manoeuvre planned for all contacts at once, ONE shared ping schedule, and the
navigator's merged leg table (:mod:`tmaplan.models.leg_table`).

The recording is ``simulate two-contacts-crossing --export`` (two contacts on opposite bows,
the own ship straight: both unobservable at its end, so a turn pays). Checked: one joint plan
whose legs are flyable (every rate within the limit, the legs fly the recommended track to a
metre), its objective no worse than holding course, each contact's values on it, the ping
certificate's lower bound below the schedule's objective, the exports read back, the page
and figures; the fallback to holding course when the planner gives no plan; the belief moved
to a later time; the merged table within its stated tolerance and refused beyond it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tmaplan.advice import Platform, contact_problem, contact_rng, solve_contact
from tmaplan.advice.joint import advise_contacts, belief_at
from tmaplan.cli import main
from tmaplan.errors import PlanningError
from tmaplan.io import read_nav, read_recording
from tmaplan.io.plans import Leg, read_legs_csv
from tmaplan.models.leg_table import legs_track, navigator_legs
from tmaplan.models.observer import turn_rate_track
from tmaplan.planning.belief import Belief

NAMES = ["alpha", "bravo"]


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("joint")
    assert main(["simulate", "two-contacts-crossing", "--seed", "0", "--export",
                 str(d / "run"), "--no-figure", "--json", str(d / "s.json")]) == 0
    return d


@pytest.fixture(scope="module")
def advised(recording) -> tuple[dict, str]:
    d = recording
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert main(["advise", str(d / "run" / "bearings.csv"), "--ownship",
                     str(d / "run" / "ownship.csv"), "--budget", "2", "--horizon", "10 min",
                     "--out", str(d / "out"), "--json", str(d / "a.json")]) == 0
    return json.loads((d / "a.json").read_text()), buf.getvalue()


def test_the_export_holds_both_contacts(recording):
    rec = read_recording(recording / "run" / "bearings.csv", recording / "run" / "ownship.csv")
    assert [c.name for c in rec.contacts] == NAMES
    assert all(c.times.size == 180 for c in rec.contacts)


def test_one_joint_plan_for_all_contacts(advised):
    got, text = advised
    adv = got["advice"]
    assert adv["contacts"] == NAMES and adv["objective"] == "all-contacts-time-to-accuracy"
    assert set(got["contacts"]) == set(NAMES)
    # one plan, printed once, for both contacts
    assert text.count("advice for all 2 contacts (alpha, bravo)") == 1
    assert "advice for alpha" not in text and "advice for bravo" not in text
    for n in NAMES:
        c = got["contacts"][n]["advice"]
        for key in ("expected_time_to_accuracy", "hold_course_time_to_accuracy",
                    "alone_expected_time_to_accuracy", "range_bound", "hold_range_bound",
                    "ping_objective", "no_ping_objective", "pings_in_reach"):
            assert key in c, key
        assert len(c["range_bound"]) == len(adv["track"]["times"])
    # no worse than holding course in the objective (every contact localised)
    assert adv["expected_time_to_accuracy"] <= adv["hold_course_time_to_accuracy"]
    assert adv["recommendation"] in ("plan", "hold course")
    if adv["recommendation"] == "plan":
        assert adv["expected_time_to_accuracy"] == adv["plan_time_to_accuracy"]
        assert adv["solver"]["success"]
    # "until every contact is localised" is at least each contact's own time (same draws' max)
    horizon_plus = 600.0 + 15.0
    for n in NAMES:
        t = got["contacts"][n]["advice"]["expected_time_to_accuracy"]
        assert 0 < t <= adv["expected_time_to_accuracy"] + 1e-6 * horizon_plus


def test_the_joint_plan_is_flyable(advised):
    got, _ = advised
    adv = got["advice"]
    limit = Platform().turn_rate_max
    legs = [Leg(**leg) for leg in adv["legs"]]
    assert sum(leg.duration for leg in legs) == pytest.approx(600.0)
    assert all(leg.rate <= limit * (1 + 1e-9) for leg in legs)
    tr = adv["track"]
    P = np.column_stack([tr["east"], tr["north"]])
    dt = float(np.diff(tr["times"])[0])
    speed = float(np.hypot(*(P[1] - P[0]))) / dt  # a straight first step or a turn: <= 1 mm off
    assert speed > 0
    # the exact legs fly the recommended track (to a metre), never past the limit
    flown = legs_track(legs, P[0], speed, dt, P.shape[0] - 1)
    assert np.max(np.hypot(*(flown.position - P).T)) < 1.0
    # the navigator's table: within its stated tolerance, rates within the limit too
    nav = adv["navigator_legs"]
    merged = [Leg(**leg) for leg in nav["legs"]]
    assert len(merged) <= len(legs)
    assert all(leg.rate <= limit * (1 + 1e-9) for leg in merged)
    err = np.max(np.hypot(*(legs_track(merged, P[0], speed, dt, P.shape[0] - 1).position
                            - P).T))
    assert err <= nav["position_tolerance"] + 1.0
    assert nav["max_position_error"] == pytest.approx(err, abs=1.0)


def test_the_shared_pings_and_their_certificate(advised):
    got, text = advised
    adv = got["advice"]
    assert 1 <= len(adv["ping_times"]) <= 2
    assert adv["lower_bound"] <= adv["ping_objective"] * (1 + 1e-9)
    assert 0 <= adv["gap"] < 1 and adv["ping_status"] in ("optimal", "feasible")
    # the shared objective is the contacts' mean (equal weights)
    each = [got["contacts"][n]["advice"]["ping_objective"] for n in NAMES]
    assert adv["ping_objective"] == pytest.approx(np.mean(each), rel=1e-9)
    for n in NAMES:
        c = got["contacts"][n]["advice"]
        assert c["ping_objective"] <= c["no_ping_objective"] * (1 + 1e-9)
    assert "pings in reach of each contact" in text


def test_the_joint_exports_page_and_figures(advised, recording):
    got, _ = advised
    files = got["exports"]
    assert set(files) == {"all-contacts"}
    f = files["all-contacts"]
    nav = read_nav(f["track_gpx"])
    assert nav.times.size == len(got["advice"]["track"]["times"])
    exact, start = read_legs_csv(f["legs"])
    assert len(exact) == len(got["advice"]["legs"]) and start is not None
    merged, _ = read_legs_csv(f["navigator_legs"])
    assert len(merged) == len(got["advice"]["navigator_legs"]["legs"])
    page = Path(got["report"]).read_text()
    assert page.count("data:image/png;base64") == 3
    assert "Advice for all 2 contacts" in page and "Pings:" in page
    assert set(got["figures"]) == {"picture", "residuals", "bound"}


@pytest.fixture(scope="module")
def solutions(recording):
    rec = read_recording(recording / "run" / "bearings.csv", recording / "run" / "ownship.csv")
    pl = Platform(particles=2000)
    n = len(rec.contacts)
    return [solve_contact(contact_problem(rec, c, pl), rng=contact_rng(0, i, n),
                          frame=rec.frame, particles=pl.particles)
            for i, c in enumerate(rec.contacts)], pl


def test_no_plan_means_hold_course_and_says_why(solutions, monkeypatch):
    sols, pl = solutions

    def fail(self, *a, **k):
        raise PlanningError("planted failure")

    monkeypatch.setattr("tmaplan.advice.joint.ContactsPlanner.solve", fail)
    adv = advise_contacts(sols, pl, horizon=300.0)
    assert adv.recommendation == "hold course" and "planted failure" in adv.note
    assert adv.expected_time_to_accuracy == adv.hold_course_time_to_accuracy
    assert math.isnan(adv.plan_time_to_accuracy)
    assert [leg.turn for leg in adv.legs] == ["straight"]
    assert adv.track is adv.hold_track and adv.pings is None


def test_no_own_plan_reads_not_planned_not_nan():
    """A contact's own plan that was never solved (NaN) reads "not planned" on the console and
    in the page, never "nan min"."""
    from tmaplan.cli.advise import _alone

    assert _alone(math.nan) == "not planned" and _alone(math.nan, "") == "not planned"
    assert _alone(90.0) == "1.5 min" and _alone(90.0, "") == "1.5"


def test_a_belief_moved_in_time():
    rng = np.random.default_rng(3)
    X = np.array([3000.0, 4000.0, 2.0, -1.0]) + rng.normal(size=(500, 4)) * [300, 300, 1, 1]
    b = Belief.from_samples(X, t=100.0, assimilated=True)
    own_then = np.array([0.0, 0.0, 0.0, 5.0])
    own_now = np.array([0.0, 500.0, 5.0, 0.0])  # 100 s north at 5 m/s, then turned east
    moved = belief_at(b, 200.0, own_then, own_now)
    # each sample's target: advanced at its velocity; relative to the new own-ship state
    target_now = X[:, :2] + own_then[:2] + 100.0 * (X[:, 2:] + own_then[2:])
    assert moved.samples[:, :2] == pytest.approx(target_now - own_now[:2])
    assert moved.samples[:, 2:] == pytest.approx(X[:, 2:] + own_then[2:] - own_now[2:])
    assert moved.t == 200.0 and moved.assimilated
    # the moment path agrees with the sample path (a linear map)
    m = belief_at(Belief.from_moments(b.mean, b.cov, t=100.0), 200.0, own_then, own_now)
    assert m.mean == pytest.approx(moved.mean) and m.cov == pytest.approx(moved.cov)
    # no time and no own-ship change: the same belief
    same = belief_at(b, 100.0, own_then, own_then)
    assert same.samples == pytest.approx(b.samples)


def _smooth_plan(dt: float = 15.0, minutes: int = 20):
    """A planner-like program: a hard turn, then one-minute legs of small, drifting rates."""
    per_min = np.r_[np.full(4, math.radians(0.5)), math.radians(0.1) *
                    np.exp(-np.arange(minutes - 4) / 3.0) * np.cos(np.arange(minutes - 4))]
    m = int(60 / dt)
    rates = np.repeat(per_min, m)
    tr = turn_rate_track(np.zeros(2), 0.3, 3.0, rates, dt)
    from tmaplan.io.plans import legs_from_track

    legs = legs_from_track(tr.times, tr.heading, turn_rates=rates)
    return legs, tr, rates


def test_the_navigator_table_merges_within_its_tolerance():
    legs, tr, _ = _smooth_plan()
    nav = navigator_legs(legs, tr.position, speed=3.0, dt=15.0)
    assert len(nav.exact) == len(legs) == 17 and len(nav.legs) < len(legs)
    flown = legs_track(nav.legs, tr.position[0], 3.0, 15.0, tr.times.size - 1)
    err = float(np.max(np.hypot(*(flown.position - tr.position).T)))
    assert err <= nav.position_tolerance and err == pytest.approx(nav.max_position_error)
    # a steady turn's rate is its legs' mean: never above the largest
    assert max(leg.rate for leg in nav.legs) <= max(leg.rate for leg in legs) * (1 + 1e-12)
    # the merged legs cover the plan and end on its course
    assert sum(leg.duration for leg in nav.legs) == pytest.approx(tr.times[-1])
    assert "tolerance 50 m" in nav.text() and "exact table is in the CSV/JSON" in nav.text()


def test_no_merge_that_leaves_the_track():
    legs, _, rates = _smooth_plan()
    # at 20 m/s a tenth of a degree per second over minutes is far more than a metre
    fast = turn_rate_track(np.zeros(2), 0.3, 20.0, rates, 15.0)
    nav = navigator_legs(legs, fast.position, speed=20.0, dt=15.0, position_tol=1.0,
                         rate_tol=math.radians(0.2))
    flown = legs_track(nav.legs, fast.position[0], 20.0, 15.0, fast.times.size - 1)
    assert float(np.max(np.hypot(*(flown.position - fast.position).T))) <= 1.0
    loose = navigator_legs(legs, fast.position, speed=20.0, dt=15.0, position_tol=1e4,
                           rate_tol=math.radians(0.2))
    assert len(loose.legs) < len(nav.legs)  # the tolerance, not the rates, stopped the merge


def test_contacts_last_seen_at_different_times(recording, tmp_path):
    """A contact whose bearings end earlier is moved to the latest one's time: one plan from
    the latest own-ship state."""
    lines = (recording / "run" / "bearings.csv").read_text().splitlines()
    bravo = [i for i, x in enumerate(lines) if x.endswith(",bravo")]
    drop = set(bravo[-8:])  # bravo's last 2 minutes
    (tmp_path / "b.csv").write_text("\n".join(x for i, x in enumerate(lines)
                                              if i not in drop) + "\n")
    rec = read_recording(tmp_path / "b.csv", recording / "run" / "ownship.csv")
    pl = Platform(particles=2000)
    sols = [solve_contact(contact_problem(rec, c, pl), rng=contact_rng(0, i, 2),
                          frame=rec.frame, particles=pl.particles)
            for i, c in enumerate(rec.contacts)]
    ends = {s.name: float(s.problem.observer.times[-1]) for s in sols}
    assert ends["bravo"] < ends["alpha"]
    adv = advise_contacts(sols, pl, horizon=300.0)
    assert adv.track.times[0] == pytest.approx(ends["alpha"])
    assert adv.expected_time_to_accuracy <= adv.hold_course_time_to_accuracy
    assert set(adv.contacts) == {"alpha", "bravo"}
