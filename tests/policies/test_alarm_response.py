"""Alarm pings: the closed loop's answer to the consistency monitor (tmaplan.policies.alarms)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.campaigns import resolve_policies
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.geometry import wrap_angle
from tmaplan.policies import (
    Action,
    AdaptivePings,
    AlarmResponse,
    BeliefView,
    Combined,
    LeadLag,
    LegTurnLeg,
    NoPing,
    ScheduledPings,
    SingleTurn,
    Straight,
    UniformPings,
    Zigzag,
)
from tmaplan.scenario import dump, load_problem, loads
from tmaplan.simulate import draw_truth


class _Always:
    """A ping policy's controller that asks for a ping at every step."""

    def act(self, belief: BeliefView, t: float) -> Action:
        return Action(turn_rate=0.01, ping=True)


def _belief(step: int, pings: int, alarms: int) -> BeliefView:
    return BeliefView(step=step, t=15.0 * step, heading=0.0, position=np.zeros(2),
                      particles=np.ones((3, 4)), weights=np.full(3, 1 / 3), pings_used=pings,
                      alarms=alarms)


def _drive(ctrl, alarm_steps, n=60):
    """Step a responder for n steps; alarms raised at ``alarm_steps``; returns ping steps."""
    pings: list[int] = []
    for k in range(n):
        alarms = sum(s <= k for s in alarm_steps)
        if ctrl.act(_belief(k, len(pings), alarms), 15.0 * k).ping:
            pings.append(k + 1)
    return pings


def test_an_alarm_pings_at_the_next_step_and_after_the_spacing():
    sc = load_problem("default")  # dt 15 s, ping spacing 120 s, budget 4
    ctrl = AlarmResponse(pings=2, extra_pings=0).wrap(NoPing().controller(sc), sc)
    pings = _drive(ctrl, [10])
    assert pings == [11, 19] and ctrl.alarm_pings == pings
    # no alarm: nothing added
    assert _drive(AlarmResponse().wrap(NoPing().controller(sc), sc), []) == []


def test_the_budget_plus_allowance_is_never_exceeded():
    sc = load_problem("default")
    for extra in (0, 1, 3):
        resp = AlarmResponse(pings=3, extra_pings=extra, spacing=15.0)
        # an alarm at every step and a policy that pings at every step
        ctrl = resp.wrap(NoPing().controller(sc), sc)
        assert len(_drive(ctrl, range(60))) == sc.planning.ping_budget + extra
        ctrl = resp.wrap(_Always(), sc)
        # every step already pings: nothing added, and the policy's own pings pass
        assert _drive(ctrl, range(0, 60, 5)) == list(range(1, 61)) and ctrl.alarm_pings == []
    ctrl = AlarmResponse(pings=1, extra_pings=1).wrap(_Always(), sc)
    ctrl.alarm_pings.append(0)  # once alarm pings were spent, the cap binds the policy too
    assert len(_drive(ctrl, [])) == sc.planning.ping_budget + 1


def test_alarm_pings_respect_spacing_and_forbidden_windows():
    sc = load_problem("default")
    pl = dataclasses.replace(sc.planning, ping_forbidden=((150.0, 300.0),))
    sc = dataclasses.replace(sc, planning=pl)
    ctrl = AlarmResponse(pings=1, extra_pings=2).wrap(NoPing().controller(sc), sc)
    pings = _drive(ctrl, [9])  # wants step 10 (150 s): forbidden until 300 s
    assert pings == [21]


def test_validation():
    for kw in ({"pings": 0}, {"extra_pings": -1}, {"spacing": 0.0}, {"pings": True}):
        with pytest.raises(ArgumentError, match="alarm_response"):
            AlarmResponse(**kw)
    assert FilterOptions.monitored().label() == "monitored"
    assert FilterOptions.responsive().label() == "responsive"
    assert FilterOptions.responsive().alarm_response == AlarmResponse()
    # the defaults never ping beyond the user's budget
    assert FilterOptions.monitored().alarm_response is None
    assert FilterOptions.robust().alarm_response is None


def _run(sc, options, i=0, particles=1000, plan_on=None):
    # plan_on: the scenario the policy plans on (faults change the truth, not the plan: the
    # plan of the fault-free problem is the one cached by the other tests)
    pol = resolve_policies(plan_on or sc, ["planned+scheduled"])["planned+scheduled"]
    ss = np.random.SeedSequence(3, spawn_key=(i,)).spawn(3)
    return run_closed_loop(sc, pol, draw_truth(sc, np.random.default_rng(ss[0])),
                           noise_rng=np.random.default_rng(ss[1]),
                           filter_rng=np.random.default_rng(ss[2]), n_particles=particles,
                           options=options)


def test_no_alarm_runs_are_bit_identical_with_and_without_the_response():
    sc = load_problem("default")
    silent = FilterOptions.monitored()
    compared = 0
    for i in range(3):
        a, b = _run(sc, FilterOptions.responsive(), i), _run(sc, silent, i)
        if a.alarms:
            continue
        compared += 1
        assert b.alarms == () and a.alarm_pings.size == 0
        for f in ("estimate", "covariance", "ping_steps", "turn_rate", "truth"):
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
    assert compared >= 2


def test_a_course_change_alarm_brings_a_ping_within_the_budget():
    base = load_problem("default")
    sc = loads(dump(base) + '\n[faults]\ntarget_manoeuvres = [{time = "22.5 min", '
               'course_change = "60 deg"}]\n')
    answered = 0
    for i in range(3):
        r = _run(sc, FilterOptions.responsive(), i, particles=2000, plan_on=base)
        cap = sc.planning.ping_budget + AlarmResponse().extra_pings
        assert r.ping_steps.size <= cap
        assert set(r.alarm_pings) <= set(r.ping_steps)
        late = [a["step"] for a in r.alarms if a["step"] >= 90]
        if late and r.alarm_pings.size:
            answered += int(any(p > late[0] for p in r.alarm_pings))
    assert answered >= 2


def test_receding_replans_at_once_on_an_alarm():
    from tmaplan.estimators.particle_filter import ParticleFilter, PFConfig
    from tmaplan.policies import Receding

    sc = load_problem("default")
    st = ParticleFilter(PFConfig(n_particles=500, dt=15.0, q=1e-6)).init(
        sc, np.random.default_rng(0))

    def belief(k, alarms):
        return BeliefView(step=k, t=15.0 * k, heading=0.0, position=np.zeros(2),
                          particles=st.particles, weights=st.weights, pings_used=0,
                          alarms=alarms)

    for on, expected in ((True, 2), (False, 1)):
        ctrl = Receding(replan_on_alarm=on).controller(sc)
        for k, alarms in ((0, 0), (1, 0), (2, 1), (3, 1)):
            ctrl.act(belief(k, alarms), 15.0 * k)
        assert len(ctrl.log) == expected


def test_an_alarm_turn_turns_away_at_the_maximum_rate_then_hands_back():
    sc = load_problem("default")  # turn rate ≤ 0.5 °/s, dt 15 s: 7.5° per step
    ctrl = AlarmResponse(pings=0, turn=np.radians(60.0)).wrap(_Always(), sc)
    rates = [ctrl.act(_belief(k, 0, int(k >= 10)), 15.0 * k).turn_rate for k in range(30)]
    u_max = sc.observer.turn_rate_max
    # contact believed at 045°, heading 000°: starboard changes the cross-LOS speed most
    assert rates[:10] == [0.01] * 10 and rates[18:] == [0.01] * 12
    assert rates[10:18] == pytest.approx([u_max] * 8)
    assert sum(rates[10:18]) * 15.0 == pytest.approx(np.radians(60.0))
    assert ctrl.alarm_pings == []
    with pytest.raises(ArgumentError, match=r"alarm_response\.turn"):
        AlarmResponse(turn=4.0)


def _headings_with_alarm(pol, sc, alarm_step, combined=False):
    """Heading history [rad] of ``pol`` (alone, or in a :class:`Combined` with pings) wrapped
    by a 90° alarm turn (no alarm pings), with one alarm raised at ``alarm_step`` (None:
    never)."""
    from tmaplan.policies.base import initial_course

    inner = (Combined(manoeuvre=pol, ping=UniformPings()) if combined else pol).controller(sc)
    ctrl = AlarmResponse(pings=0, turn=np.pi / 2).wrap(inner, sc)
    p = np.array([[5000.0, 8000.0, 0.0, -3.0], [5200.0, 8100.0, 0.5, -3.0]])
    h = initial_course(sc)
    out = [h]
    for k in range(sc.n_steps):
        alarms = int(alarm_step is not None and k >= alarm_step)
        b = BeliefView(step=k, t=float(sc.times[k]), heading=h, position=np.zeros(2),
                       particles=p, weights=np.array([0.5, 0.5]), pings_used=0, alarms=alarms)
        h += ctrl.act(b, float(sc.times[k])).turn_rate * sc.time.dt
        out.append(h)
    return np.array(out)


@pytest.mark.parametrize("make", [
    lambda sc: SingleTurn(angle=np.radians(60.0), time=sc.time.t0 + 0.75 * sc.time.horizon),
    lambda sc: SingleTurn(angle=np.radians(-180.0), time=sc.time.t0 + 0.1 * sc.time.horizon),
    lambda sc: Zigzag(leg_duration=1200.0, angle=np.radians(40.0), start=sc.time.t0),
    lambda sc: LegTurnLeg(first_leg=300.0),
    lambda sc: LeadLag(lead_time=0.0, lag_time=300.0),
    lambda sc: Straight(),
], ids=["single-turn-late", "single-turn-early", "zigzag", "leg-turn-leg", "lead-lag",
        "straight"])
def test_an_alarm_turn_offsets_the_courses_of_every_manoeuvre_policy(make):
    """An alarm at step 50, while the policy holds a course (its turns, if any, are over by
    then or start later): a 90° turn over steps 50–61 (7.5° per step), then the policy flies
    on 90° off its un-alarmed headings to the end, never turning back."""
    sc = load_problem("default")
    pol = make(sc)
    for combined in (False, True):
        plain = _headings_with_alarm(pol, sc, None, combined)
        alarmed = _headings_with_alarm(pol, sc, 50, combined)
        np.testing.assert_array_equal(alarmed[:51], plain[:51])
        offset = alarmed[62:] - plain[62:]
        assert abs(offset[0]) == pytest.approx(np.pi / 2, abs=1e-9)
        np.testing.assert_allclose(offset, offset[0], atol=1e-9)


def test_an_alarm_turn_during_a_turn_keeps_the_rest_of_the_turn():
    """A single turn of −180° interrupted by the alarm's 90° turn finishes its own turn
    afterwards: it ends 90° off its un-alarmed course."""
    sc = load_problem("default")
    pol = SingleTurn(angle=np.radians(-180.0), time=sc.time.t0 + 0.1 * sc.time.horizon)
    plain, alarmed = _headings_with_alarm(pol, sc, None), _headings_with_alarm(pol, sc, 40)
    assert abs(alarmed[-1] - plain[-1]) == pytest.approx(np.pi / 2, abs=1e-9)
    assert plain[-1] - plain[0] == pytest.approx(-np.pi, abs=1e-9)


def test_a_tactic_decides_its_turn_after_an_alarm_turn_from_the_line_of_sight():
    """An alarm turn during the first leg offsets it; the doctrine's turn is then decided from
    the belief's line of sight, as ever (the contact abeam on the other side)."""
    from tmaplan.policies.tactics import belief_line_of_sight, doctrine_course

    sc = load_problem("default")
    pol = LegTurnLeg()                        # turn at a third of the horizon (step 60)
    plain, alarmed = _headings_with_alarm(pol, sc, None), _headings_with_alarm(pol, sc, 10)
    assert abs(alarmed[25] - plain[25]) == pytest.approx(np.pi / 2, abs=1e-9)
    np.testing.assert_allclose(alarmed[22:61] - plain[22:61], alarmed[22] - plain[22],
                               atol=1e-9)
    p = np.array([[5000.0, 8000.0, 0.0, -3.0], [5200.0, 8100.0, 0.5, -3.0]])
    beta, _ = belief_line_of_sight(BeliefView(step=0, t=0.0, heading=0.0, position=np.zeros(2),
                                              particles=p, weights=np.array([0.5, 0.5]),
                                              pings_used=0))
    for h in (plain, alarmed):
        assert float(wrap_angle(h[-1] - doctrine_course(beta, h[60]))) == pytest.approx(
            0.0, abs=1e-9)


def _pings_after_alarm(inner, sc, alarm_step, n=None, tight_until=None):
    """Ping steps of ``inner`` wrapped by ``AlarmResponse(pings=1)`` with one alarm at
    ``alarm_step``; the belief's range is uncertain (a wide two-particle cloud), or certain
    before step ``tight_until``."""
    wide = np.array([[5000.0, 8000.0, 0.0, -3.0], [9000.0, 12000.0, 0.5, -3.0]])
    tight = np.array([[5000.0, 8000.0, 0.0, -3.0], [5001.0, 8001.0, 0.0, -3.0]])
    ctrl = AlarmResponse(pings=1).wrap(inner.controller(sc), sc)
    pings: list[int] = []
    for k in range(sc.n_steps if n is None else n):
        p = tight if tight_until is not None and k < tight_until else wide
        b = BeliefView(step=k, t=float(sc.times[k]), heading=0.0, position=np.zeros(2),
                       particles=p, weights=np.array([0.5, 0.5]), pings_used=len(pings),
                       alarms=int(k >= alarm_step))
        if ctrl.act(b, float(sc.times[k])).ping:
            pings.append(k + 1)
    return pings, ctrl


def test_the_policys_ping_waits_for_the_minimum_spacing_after_an_alarm_ping():
    sc = load_problem("default")            # dt 15 s, ping spacing 120 s (8 steps), budget 4
    gap = round(sc.planning.ping_min_spacing / sc.time.dt)
    # the alarm pings at 59; the schedule's 60 is deferred to 67, the earliest the spacing
    # allows, not dropped: the budget's ping is still flown
    pings, ctrl = _pings_after_alarm(ScheduledPings(steps=(60, 120)), sc, 58)
    assert pings == [59, 67, 120] and ctrl.alarm_pings == [59]
    assert ctrl.deferred_pings == [60]
    # deferred pings queue: each keeps the spacing after the previous one
    pings, _ = _pings_after_alarm(ScheduledPings(steps=(60, 68, 150)), sc, 58)
    assert pings == [59, 67, 75, 150]
    # adaptive pings (the reviewer's cases): the range is uncertain throughout, or only from
    # the alarm on
    for tight in (None, 59):
        pings, ctrl = _pings_after_alarm(AdaptivePings(threshold=0.1), sc, 58, tight_until=tight)
        assert np.all(np.diff(pings) >= gap), pings
    assert 59 in ctrl.alarm_pings
    # no alarm: the policy's pings pass unchanged
    pings, ctrl = _pings_after_alarm(ScheduledPings(steps=(60, 61)), sc, 10**6)
    assert pings == [60, 61] and ctrl.deferred_pings == []


def test_a_deferred_ping_honours_forbidden_windows_and_the_cap():
    sc = load_problem("default")
    pl = dataclasses.replace(sc.planning, ping_forbidden=((1000.0, 1100.0),))
    forbidden = dataclasses.replace(sc, planning=pl)
    pings, _ = _pings_after_alarm(ScheduledPings(steps=(60, 120)), forbidden, 58)
    assert pings == [59, 74, 120]           # 67 (1005 s) is forbidden until 1100 s
    # budget 4 + 2 extra = 6: the queue never takes the total past the cap
    pings, _ = _pings_after_alarm(ScheduledPings(steps=(60, 68, 76, 84, 92, 100)), sc, 58)
    assert pings == [59, 67, 75, 83, 91, 99]
