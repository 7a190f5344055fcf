"""The closed loop, the policies and the campaign for several contacts (issue 40)."""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pytest

from tmaplan.errors import ArgumentError, PlanningError, ScenarioWarning
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.evaluation.contacts_campaign import aggregate_metrics
from tmaplan.evaluation.contacts_loop import run_contacts_loop
from tmaplan.evaluation.metrics import censor_time
from tmaplan.evaluation.records import without_timings
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.planning.contacts import ContactSet
from tmaplan.planning.ping_contacts import schedule_contact_pings
from tmaplan.policies import SingleTurn, Straight
from tmaplan.policies.contacts import (
    Alternate,
    check_contacts_policy,
    heaviest_contact,
    nearest_contact,
    parse_contacts_policy,
)
from tmaplan.scenario import load
from tmaplan.simulate import draw_truth


@pytest.mark.parametrize("policy", [Straight(), SingleTurn(angle=1.2, time=600.0)],
                         ids=["straight", "single-turn"])
def test_one_contact_loop_is_the_closed_loop_bit_for_bit(policy):
    # an independent implementation of the per-run loop: with one contact it must draw and
    # filter exactly as run_closed_loop does
    sc = load("default")
    target = draw_truth(sc, np.random.default_rng(1))
    a = run_closed_loop(sc, policy, target, noise_rng=np.random.default_rng(2),
                        filter_rng=np.random.default_rng(3), n_particles=300)
    b = run_contacts_loop(sc, policy, {"contact": target},
                          noise_rng=np.random.default_rng(2),
                          filter_rng=np.random.default_rng(3), n_particles=300)["contact"]
    for field in ("estimate", "covariance", "turn_rate", "ping_steps", "truth"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    np.testing.assert_array_equal(a.observer.position, b.observer.position)
    assert a.recoveries == b.recoveries


def test_several_contacts_loop_shares_the_own_ship_and_filters_each_contact():
    sc = load("two-contacts-crossing")
    rng = np.random.default_rng(5)
    targets = {n: draw_truth(v, rng) for n, v in sc.contact_views().items()}
    runs = run_contacts_loop(sc, SingleTurn(angle=1.5, time=900.0), targets,
                             noise_rng=np.random.default_rng(6),
                             filter_rng=np.random.default_rng(7), n_particles=400)
    assert list(runs) == ["alpha", "bravo"]
    np.testing.assert_array_equal(runs["alpha"].observer.position,
                                  runs["bravo"].observer.position)
    for n, r in runs.items():
        np.testing.assert_array_equal(r.target, targets[n])
        assert np.isfinite(r.estimate).all()
        # each filter tracks its own contact: its estimate is nearer its own truth than the
        # other contact's (the contacts are on opposite bows, 15-20 km apart)
        other = targets["bravo" if n == "alpha" else "alpha"]
        own_pos = r.observer.position
        err_own = np.linalg.norm(r.estimate[-1, :2] + own_pos[-1] - targets[n][-1, :2])
        err_other = np.linalg.norm(r.estimate[-1, :2] + own_pos[-1] - other[-1, :2])
        assert err_own < err_other


def test_several_contacts_loop_refuses_a_track_per_wrong_contact():
    sc = load("two-contacts-crossing")
    with pytest.raises(ArgumentError, match="targets"):
        run_contacts_loop(sc, Straight(), {"alpha": np.zeros((sc.n_steps + 1, 4))},
                          noise_rng=np.random.default_rng(0),
                          filter_rng=np.random.default_rng(0))


def test_aggregate_metrics_take_the_latest_time_and_the_worst_errors():
    from tmaplan.evaluation.metrics import run_metrics

    times = np.arange(5.0) * 10
    truth = np.tile([1000.0, 0, 0, 0], (5, 1))
    est_a = truth * np.array([[1.3], [1.2], [1.05], [1.0], [1.0]])
    est_b = truth * np.array([[1.3], [1.3], [1.3], [1.08], [1.02]])
    v = np.zeros((5, 2))
    a, b = (run_metrics(times, truth, e, v, accuracy=0.1) for e in (est_a, est_b))
    agg = aggregate_metrics({"a": a, "b": b})
    assert (a.time_to_accuracy, b.time_to_accuracy) == (20.0, 30.0)
    assert agg.time_to_accuracy == 30.0
    np.testing.assert_array_equal(agg.range_error, np.maximum(a.range_error, b.range_error))
    assert agg.final_range_error == b.final_range_error


def _prior_range(sc, name, lo, hi):
    cs = tuple(dataclasses.replace(c, prior=dataclasses.replace(c.prior, range_min=lo,
                                                                 range_max=hi))
               if c.name == name else c for c in sc.contacts)
    return dataclasses.replace(sc, contacts=cs)


@pytest.mark.parametrize("near", ["alpha", "bravo"])
def test_nearest_contact_is_the_one_of_least_prior_mean_range(near):
    sc = _prior_range(load("two-contacts-crossing"), near, 3000.0, 8000.0)
    assert nearest_contact(sc) == near


def test_heaviest_contact_is_the_one_of_largest_weight():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert heaviest_contact(load("three-contacts-screen")) == "charlie"
    # equal weights: the first, said
    with pytest.warns(ScenarioWarning, match="heaviest-contact: contacts 'alpha', 'bravo' are "
                      "equally heavy.*flying the plan for 'alpha'"):
        assert heaviest_contact(load("two-contacts-crossing")) == "alpha"


def test_nearest_contact_says_when_contacts_are_equally_near():
    # the built-in's two priors are the same uniform 5-25 km ranges: their sampled means
    # differ by 0.2 %, no tactical choice
    with pytest.warns(ScenarioWarning, match="nearest-contact: contacts 'alpha', 'bravo' are "
                      r"equally near .*within 1 %.*flying the plan for 'alpha'"):
        assert nearest_contact(load("two-contacts-crossing")) == "alpha"
    sc = _prior_range(load("two-contacts-crossing"), "bravo", 3000.0, 8000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert nearest_contact(sc) == "bravo"


def test_policy_names_for_several_contacts():
    sc = load("two-contacts-crossing")
    assert check_contacts_policy("planned:bravo", sc) == ("planned", None, "bravo")
    assert check_contacts_policy("nearest-contact+uniform", sc) == (
        "nearest-contact", "uniform", None)
    with pytest.raises(ArgumentError, match=r"alpha, bravo.*planned:zulu"):
        check_contacts_policy("planned:zulu", sc)
    with pytest.raises(ArgumentError, match="receding-realtime flies for one contact"):
        check_contacts_policy("receding-realtime", sc)
    assert check_contacts_policy("receding", sc) == ("receding", None, None)
    assert check_contacts_policy("straight+scheduled", sc) == ("straight", "scheduled", None)
    with pytest.raises(PlanningError, match="unknown policy"):
        check_contacts_policy("straight+adaptive", sc)


@pytest.mark.parametrize("ping", ["scheduled", "scheduled-terminal"])
def test_scheduled_pings_are_one_schedule_for_every_contact(ping):
    sc = load("two-contacts-crossing")
    pol = parse_contacts_policy(f"straight+{ping}", sc)
    objective = "terminal-range-bound" if ping == "scheduled-terminal" else "mean-range-bound"
    ref = schedule_contact_pings(ContactSet.from_scenario(sc), budget=sc.planning.ping_budget,
                                 method="relaxed", objective=objective, gap_reference="none",
                                 observer=Straight().nominal_track(sc))
    steps = tuple(int(k) for k in ref.schedule.steps)
    assert pol.name == f"straight+{ping}" and pol.ping.steps == steps
    assert len(steps) == sc.planning.ping_budget
    rng = np.random.default_rng(5)
    targets = {n: draw_truth(v, rng) for n, v in sc.contact_views().items()}
    runs = run_contacts_loop(sc, pol, targets, noise_rng=np.random.default_rng(6),
                             filter_rng=np.random.default_rng(7), n_particles=300)
    for r in runs.values():  # one ping, every contact
        np.testing.assert_array_equal(r.ping_steps, steps)
    silent = dataclasses.replace(sc, sensors=tuple(s for s in sc.sensors if s.kind != "range"))
    with pytest.raises(ArgumentError, match="no active range sensor"):
        check_contacts_policy(f"planned+{ping}", silent)


def test_alternate_alternates_the_contacts_courses():
    sc = load("two-contacts-crossing")
    pol = Alternate(angles=(1.0, -1.0), start=600.0)
    sched = pol._schedule(sc)
    leg = (sc.time.t0 + sc.time.horizon - 600.0) / 4
    assert [round(t - 600.0, 6) for t, _ in sched[1:]] == [round(i * leg, 6) for i in range(4)]
    c0 = sched[0][1]
    assert [c - c0 for _, c in sched[1:]] == pytest.approx([1.0, -1.0, 1.0, -1.0])
    track = pol.nominal_track(sc)
    assert track.heading.shape == (sc.n_steps + 1,)


def test_campaign_on_several_contacts(tmp_path):
    sc = load("two-contacts-crossing")
    spec = CampaignSpec(scenario=sc, policies=("straight", "alternate"), runs=3, seed=11,
                        n_particles=300)
    res = run_campaign(spec, out_dir=tmp_path)
    censor = censor_time(sc.times)
    for name in spec.policies:
        s = res.summary[name]
        t_all = s["time_to_accuracy_all_runs"]
        per = {c: v["time_to_accuracy_runs"] for c, v in s["contacts"].items()}
        assert set(per) == {"alpha", "bravo"}
        np.testing.assert_array_equal(t_all, np.maximum(per["alpha"], per["bravo"]))
        cens = {c: np.minimum(t, censor) for c, t in per.items()}
        w = s["weighted_time_to_accuracy_runs"]  # equal weights: the mean
        np.testing.assert_allclose(w, 0.5 * (cens["alpha"] + cens["bravo"]))
        worst = s["worst_final_range_error"]
        assert worst >= max(np.mean(v["final_range_error_runs"])
                            for v in s["contacts"].values()) - 1e-9
    metrics = {d.metric for d in res.differences}
    assert {"time_to_accuracy_all", "worst_final_range_error",
            "weighted_time_to_accuracy"} <= metrics
    payload = res.to_json()
    pj = payload["policies"]["alternate"]
    assert set(pj["contacts"]) == {"alpha", "bravo"}
    assert {"time_to_accuracy_all", "weighted_time_to_accuracy",
            "worst_final_range_error"} <= set(pj)
    json.dumps(payload)
    # the stored runs (every contact's) are reloaded: the same results
    again = run_campaign(spec, out_dir=tmp_path)
    assert len(again.loaded_runs) == 3
    assert without_timings(again.to_json()) == without_timings(payload)


def test_contacts_with_their_own_required_accuracy_share_one_own_ship():
    # a contact's required accuracy lives in its view's planning table: not a second own ship
    from tmaplan.planning.contacts import ContactSet

    cs = ContactSet.from_scenario(load("three-contacts-screen"))
    assert cs.names == ("alpha", "bravo", "charlie")
    assert cs.required_accuracies == (0.1, 0.1, 0.05)
    sc = load("two-contacts-crossing")
    views = list(sc.contact_views().values())
    other = dataclasses.replace(views[1], planning=dataclasses.replace(
        views[1].planning, ping_budget=7))
    with pytest.raises(ArgumentError, match=r"contacts\[bravo\]\.planning"):
        ContactSet(views=(views[0], other), names=("alpha", "bravo"))


def test_compare_default_policies_for_several_contacts():
    import argparse

    from tmaplan.cli import compare

    seen = []
    args = argparse.Namespace(policies=compare.POLICIES, truth="prior")
    compare.preflight_several(args, load("two-contacts-crossing"),
                              lambda a, view: seen.append(a.policies))
    assert args.policies == compare.CONTACTS_POLICIES
    assert seen == ["single-turn", "single-turn"]  # each contact's view, a turning stand-in
    with pytest.raises(ArgumentError, match="--policies"):
        compare.preflight_several(argparse.Namespace(policies="zigzag", truth="prior"),
                                  load("two-contacts-crossing"), lambda a, v: None)


def test_receding_replans_on_every_contacts_posterior():
    from tmaplan.policies.contacts import ContactsReceding

    sc = load("two-contacts-crossing")
    first = ContactsReceding(first_plan=None, replan_interval=900.0)
    pol = dataclasses.replace(first, first_plan=first.controller(sc).planner.solve())
    rng = np.random.default_rng(5)
    targets = {n: draw_truth(v, rng) for n, v in sc.contact_views().items()}
    runs = run_contacts_loop(sc, pol, targets, noise_rng=np.random.default_rng(6),
                             filter_rng=np.random.default_rng(7), n_particles=200)
    log = runs["alpha"].replans
    assert [e["t"] for e in log] == [900.0, 1800.0]
    for e in log:  # converged, or reported as not converged
        assert isinstance(e["success"], bool) and e["seconds"] > 0
    u_max = sc.observer.turn_rate_max
    assert np.all(np.abs(runs["alpha"].turn_rate) <= u_max + 1e-12)
    # the first leg flies the plan from the priors
    np.testing.assert_allclose(runs["alpha"].turn_rate[0],
                               np.clip(pol.first_plan.plan.turn_rate[0], -u_max, u_max))


@pytest.mark.parametrize("fallback", [True, False])
def test_receding_falls_back_to_other_starts_when_the_warm_start_fails(monkeypatch, fallback):
    """A re-plan whose warm-started joint solve fails is solved again from the other starts
    (``multi-start: …``, logged ``fell_back``); without fallbacks the previous plan is kept
    and the re-plan reported as not converged."""
    from tmaplan.errors import SolverError
    from tmaplan.planning.contacts import ContactsPlanner
    from tmaplan.policies.contacts import ContactsReceding

    sc = load("two-contacts-crossing")
    first = ContactsReceding(first_plan=None, replan_interval=1800.0, fallback_starts=fallback)
    pol = dataclasses.replace(first, first_plan=first.controller(sc).planner.solve())
    solve = ContactsPlanner.solve

    def failing(self, *a, **kw):
        if kw.get("warm_start") is not None:
            raise SolverError("ipopt", "Maximum_Iterations_Exceeded", "a stalled warm start")
        return solve(self, *a, **kw)

    monkeypatch.setattr(ContactsPlanner, "solve", failing)
    rng = np.random.default_rng(5)
    targets = {n: draw_truth(v, rng) for n, v in sc.contact_views().items()}
    runs = run_contacts_loop(sc, pol, targets, noise_rng=np.random.default_rng(6),
                             filter_rng=np.random.default_rng(7), n_particles=200)
    (e,) = runs["alpha"].replans
    assert e["t"] == 1800.0 and e["fell_back"]
    if fallback:
        assert e["success"] and e["start"].startswith("multi-start: ")
    else:
        assert not e["success"] and "stalled warm start" in e["status"]


@pytest.mark.parametrize("tol", [0.0, 1.5, "1e-4", True])
def test_receding_refuses_a_bad_fallback_tolerance(tol):
    from tmaplan.policies.contacts import ContactsReceding

    with pytest.raises(ArgumentError, match=r"receding\.fallback_tol"):
        ContactsReceding(fallback_tol=tol).controller(load("two-contacts-crossing"))


def test_a_degenerate_filter_says_whose_it_is():
    # with one filter per contact, "particle filter degenerate at step 24" alone did not say
    # which contact's filter; 5 particles on 1° bearings degenerate (20 did, by chance, with
    # the numpy kernel's random numbers, not with the compiled kernel's)
    import warnings

    from tmaplan.estimators import DegeneracyWarning

    sc = load("two-contacts-crossing")
    rng = np.random.default_rng(5)
    targets = {n: draw_truth(v, rng) for n, v in sc.contact_views().items()}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_contacts_loop(sc, Straight(), targets, noise_rng=np.random.default_rng(6),
                          filter_rng=np.random.default_rng(7), n_particles=5)
    msgs = [str(w.message) for w in caught if issubclass(w.category, DegeneracyWarning)]
    assert msgs
    assert all(m.startswith(("contact 'alpha': particle filter degenerate at step",
                             "contact 'bravo': particle filter degenerate at step"))
               for m in msgs), msgs


def test_planned_says_when_no_plan_can_localise_every_contact():
    # within 10 min neither contact of two-contacts-crossing is localised on any plan: the
    # all-contacts objective is about the horizon on all of them, and `planned` flies the
    # least turning plan; said once where the plan is made, as `tmaplan plan` says it
    from tmaplan.planning.contacts import SaturatedObjectiveWarning

    sc = load("two-contacts-crossing")
    short = dataclasses.replace(sc, time=dataclasses.replace(sc.time, horizon=600.0),
                                planning=dataclasses.replace(sc.planning, horizon=600.0))
    with pytest.warns(SaturatedObjectiveWarning, match="2 of 2 contacts"):
        parse_contacts_policy("planned", short)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        parse_contacts_policy("receding", short)  # the same plan, solved once
        assert parse_contacts_policy("planned", sc).name == "planned"  # 45 min: no warning
