"""Impossible plans refused at load or before solving, suspicious input warned (issue 38).

The refusals are in the invalid-input corpus (tests/data/invalid, tests/data/invalid_cli);
here: the rules' boundaries, every warning, the cross-checks of the keep-out share and of the
memory model, and that the three inputs that reached the solver (a keep-out of 20 km with
the contact at 12 km, a turn-rate limit of 90 °/s, a 30-day horizon) are refused before any
solver is built.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
import tomllib
import warnings

import pytest

from tmaplan.errors import ArgumentError, ScenarioError, ScenarioWarning
from tmaplan.scenario import from_dict, list_problems, load_problem, problems_dir, save

GIB = 2.0**30


def _base() -> dict:
    return tomllib.loads((problems_dir() / "default.toml").read_text(encoding="utf-8"))


def _with(changes: dict, base: dict | None = None) -> dict:
    d = copy.deepcopy(base if base is not None else _base())
    for path, value in changes.items():
        *head, last = path.split(".")
        cur = d
        for k in head:
            cur = cur[int(k)] if k.isdigit() else cur[k]
        if value is None:
            del cur[last]
        else:
            cur[last] = value
    return d


def _warned(fn, *args, **kw) -> list[str]:
    """The ScenarioWarning messages ``fn(*args, **kw)`` issues."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fn(*args, **kw)
    return [str(w.message) for w in caught if issubclass(w.category, ScenarioWarning)]


@pytest.fixture
def no_solver(monkeypatch):
    """casadi's NLP solvers and symbols raise: a test passes only if nothing was built."""
    import casadi

    def built(*a, **k):
        raise AssertionError("a casadi solver or graph was built")

    monkeypatch.setattr(casadi, "nlpsol", built)
    monkeypatch.setattr(casadi.MX, "sym", built)


# ------------------------------------------------------------------ turn rates (at load)
@pytest.mark.parametrize(("changes", "field"), [
    ({"observer.turn_rate_max": "90 deg/s"}, "observer.turn_rate_max"),
    ({"observer.turn_rate_max": "10.01 deg/s"}, "observer.turn_rate_max"),
    ({"observer.turn_rate_max": None,
      "observer.legs": [{"start": "10 min", "course": "90 deg", "turn_rate": "20 deg/s"}]},
     "observer.legs[0].turn_rate"),
])
def test_a_turn_rate_no_ship_flies_is_refused_at_load(changes, field):
    with pytest.raises(ScenarioError) as exc:
        from_dict(_with(changes), source="f.toml")
    assert exc.value.field == field and "at most 10 °/s" in str(exc.value)
    assert "\n" not in str(exc.value)


def test_the_turn_rate_refusal_reads_the_value_per_minute():
    with pytest.raises(ScenarioError) as exc:
        from_dict(_with({"observer.turn_rate_max": "90 deg/s"}))
    msg = str(exc.value)
    # 90 °/s at 6 kn (3.09 m/s) is a circle of radius 3.09 / (π/2) = 2 m
    assert '"90 deg/min" is 1.5 °/s' in msg and "5400 °/min" in msg and "radius 2 m" in msg


def test_per_step_turn_rates_and_a_circling_target_are_limited_too():
    sc = load_problem("default")
    rates = (0.0,) * (sc.n_steps - 1) + (math.radians(12),)
    with pytest.raises(ScenarioError, match=r"observer\.turn_rates\[179\]"):
        sc.replace(observer=dataclasses.replace(sc.observer, turn_rates=rates,
                                                turn_rate_max=None))
    cw = load_problem("clavard2013-halfturn-cw")
    with pytest.raises(ScenarioError, match=r"target\.omega"):
        cw.replace(target=dataclasses.replace(cw.target, omega=math.radians(11), radius=10.0))


@pytest.mark.parametrize(("rate", "warned"), [("0.5 deg/s", False), ("5.7 deg/s", False),
                                              ("6 deg/s", True), ("10 deg/s", True)])
def test_a_fast_turn_rate_is_warned_below_the_refusal(rate, warned):
    msgs = _warned(from_dict, _with({"observer.turn_rate_max": rate}), source="f.toml")
    hits = [m for m in msgs if "observer.turn_rate_max" in m]
    assert bool(hits) == warned, msgs
    if warned:
        assert hits[0].startswith("f.toml: field 'observer.turn_rate_max': ") and "°/min" in hits[0]


# ------------------------------------------------------------------ other load warnings
@pytest.mark.parametrize(("path", "value", "flies"), [
    ("observer.course", "400 deg", "flies 40°"), ("target.course", "-400 deg", "flies 320°"),
    ("prior.bearing_mean", "405 deg", "flies 45°")])
def test_a_direction_beyond_360_warns_with_what_it_wraps_to(path, value, flies):
    msgs = _warned(from_dict, _with({path: value}))
    assert len(msgs) == 1 and f"field '{path}'" in msgs[0] and flies in msgs[0], msgs


@pytest.mark.parametrize("value", ["-30 deg", "360 deg", "359.9 deg", "-360 deg"])
def test_a_direction_within_a_turn_is_not_warned(value):
    assert _warned(from_dict, _with({"observer.course": value})) == []


@pytest.mark.parametrize(("path", "value", "warned"), [
    ("sensors.0.sigma", "90 deg", True), ("sensors.0.sigma", "11 deg", False),
    ("prior.bearing_std", "90 deg", True), ("prior.bearing_std", "50 deg", False)])
def test_a_very_wide_angular_sigma_is_warned(path, value, warned):
    msgs = _warned(from_dict, _with({path: value}))
    field = path.replace(".0.", "[0].")
    assert bool([m for m in msgs if f"field '{field}'" in m]) == warned, msgs


def test_a_wide_course_std_is_warned_only_where_the_course_reads_it():
    given = {"prior.course_mode": "given", "prior.course_mean": "200 deg",
             "prior.course_std": "80 deg"}
    msgs = _warned(from_dict, _with(given))
    assert any("prior.course_std" in m and "uniform" in m for m in msgs), msgs


@pytest.mark.parametrize("name", [p["name"] for p in list_problems()])
def test_the_built_in_problems_raise_no_warning(name):
    from tmaplan.models.plausibility import suspicious
    from tmaplan.planning.feasibility import check_keep_out

    assert _warned(load_problem, name) == []
    for sc in load_problem(name).contact_views().values():  # each contact's (issue 40)
        assert suspicious(sc) == []
        assert _warned(check_keep_out, sc) == []


# ------------------------------------------------------------------ the truth and the prior
def _default(**prior) -> object:
    sc = load_problem("default")
    return sc.replace(prior=dataclasses.replace(sc.prior, **prior)) if prior else sc


@pytest.mark.parametrize(("prior", "field", "text"), [
    ({"bearing_mean": math.radians(225)}, "prior.bearing_mean", "looks the other way"),
    ({"bearing_mean": math.radians(60)}, "prior.bearing_mean", "7.5 σ"),
    ({"range_min": 15000.0}, "prior.range_min", "outside the prior's range interval"),
    ({"range_max": 10000.0}, "prior.range_max", "[5 km, 10 km]"),
    ({"speed_max": 2.0}, "prior.speed_max", "true speed, 8.0 kn"),
])
def test_a_truth_outside_its_own_prior_is_warned(prior, field, text):
    from tmaplan.models.plausibility import suspicious

    found = suspicious(_default(**prior))
    assert [f for f, _ in found] == [field] and text in found[0][1], found


def test_a_gaussian_prior_far_from_the_truth_is_warned():
    from tmaplan.models.plausibility import suspicious

    g = load_problem("gordon1993-bot")  # truth at x = 700 m, prior 400 ± 300 m: 1 σ
    assert suspicious(g) == []
    far = g.replace(prior=dataclasses.replace(g.prior, mean=(4000.0, 0.0, -50.0, 0.0)))
    assert [f for f, _ in suspicious(far)] == ["prior.mean[0]"]


def test_a_contact_on_the_own_ship_is_warned_for_every_verb(tmp_path, capsys):
    from tmaplan.cli import main

    sc = load_problem("default")
    on = sc.replace(target=dataclasses.replace(sc.target, position=(30.0, 40.0)))
    f = save(on, tmp_path / "on.toml")
    assert main(["simulate", str(f), "--no-figure", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "warning: ScenarioWarning: " in err[0], err
    assert "field 'target.position'" in err[0] and "50 m from the own ship" in err[0]


# ------------------------------------------------------------------ keep-out range
@pytest.mark.parametrize("keep_out_km", [6.0, 10.0, 20.0])
def test_the_keep_out_share_is_the_uniform_range_cdf(keep_out_km):
    # default's prior: range uniform on [5, 25] km, independent of the bearing, so the share
    # within R of the own ship is (R − 5)/20 (an independent computation of the samples')
    from tmaplan.planning import Belief
    from tmaplan.planning.feasibility import keep_out_share

    b = Belief.from_prior(load_problem("default"))
    p = (keep_out_km - 5.0) / 20.0
    n = b.samples.shape[0]
    assert keep_out_share(b, keep_out_km * 1000.0) == pytest.approx(
        p, abs=5 * math.sqrt(p * (1 - p) / n))


def _keep_out(km: float, sc=None):
    sc = sc or load_problem("default")
    return sc.replace(planning=dataclasses.replace(sc.planning, keep_out_range=km * 1000.0))


def test_a_keep_out_range_the_contact_starts_inside_is_refused():
    from tmaplan.planning.feasibility import check_keep_out

    with pytest.raises(ScenarioError) as exc:
        check_keep_out(_keep_out(20.0))
    e = exc.value
    assert e.field == "planning.keep_out_range" and e.source == "default"
    assert "less than 12 km, the contact's true initial range" in e.expected
    assert "75% of the prior's mass lies inside" in e.received


def test_a_keep_out_range_over_the_prior_median_is_refused_and_a_share_warned():
    from tmaplan.planning.feasibility import check_keep_out

    # a log-uniform range on [5, 25] km: median √125 = 11.2 km, mean range about 12 km; the
    # contact moved out to 20 km, so the prior's median bounds the keep-out range
    sc = load_problem("default")
    sc = sc.replace(prior=dataclasses.replace(sc.prior, range_distribution="log-uniform"),
                    target=dataclasses.replace(sc.target, position=(14142.0, 14142.0)))
    with pytest.raises(ScenarioError, match="median range"):
        check_keep_out(_keep_out(11.5, sc))
    # ln(10/5)/ln 5 = 43 % inside: planned, with a warning
    msgs = _warned(check_keep_out, _keep_out(10.0, sc))
    assert len(msgs) == 1 and "43% of the prior's mass" in msgs[0], msgs
    assert _warned(check_keep_out, _keep_out(5.0, sc)) == []


def test_the_offline_plan_refuses_the_keep_out_range_before_any_solver(no_solver):
    from tmaplan.policies.plan_starts import plan_from_prior

    with pytest.raises(ScenarioError, match=r"planning\.keep_out_range"):
        plan_from_prior(_keep_out(20.0))
    with pytest.raises(ScenarioError, match="field 'keep_out_range'"):  # an argument's
        plan_from_prior(load_problem("default"), keep_out_range=20000.0)


# ------------------------------------------------------------------ horizon vs interval
def test_a_planning_horizon_shorter_than_one_control_interval_is_refused(no_solver):
    from tmaplan.planning import HeadingPlanner

    sc = load_problem("default")
    short = sc.replace(planning=dataclasses.replace(sc.planning, horizon=30.0))
    with pytest.raises(ScenarioError) as exc:
        HeadingPlanner(short)
    assert exc.value.field == "planning.horizon" and "shorter than one interval" in str(exc.value)
    with pytest.raises(ArgumentError) as exc:
        HeadingPlanner(sc, horizon=30.0, control_interval=60.0)  # rounded up to 60 s before
    assert exc.value.field == "horizon"


def _long_planning_horizon(name: str, planning: float = 900.0):
    sc = load_problem(name)
    return sc.replace(time=dataclasses.replace(sc.time, horizon=600.0),
                      planning=dataclasses.replace(sc.planning, horizon=planning))


def test_a_planning_horizon_past_the_problems_end_is_warned():
    """A 15 min planning.horizon on a 10 min problem: the planners planned 15 min and the runs
    flew the first 10 silently (issue 40's acceptance sweep)."""
    from tmaplan.planning import HeadingPlanner
    from tmaplan.planning.contacts import ContactSet, ContactsPlanner

    for name, build in (("default", HeadingPlanner),
                        ("two-contacts-crossing",
                         lambda sc: ContactsPlanner(ContactSet.from_scenario(sc)))):
        msgs = _warned(build, _long_planning_horizon(name))
        assert msgs, name
        assert all(m == (f"{name}: field 'planning.horizon': 900 s (15 min) is longer than "
                         "time.horizon; 600 s (10 min) used: a plan is made over 900 s (15 "
                         "min), but a run ends at time.horizon and flies and scores only its "
                         "first 600 s (10 min) (give planning.horizon <= time.horizon)")
                   for m in msgs), msgs
    # within the problem's horizon, or a horizon given to the planner: nothing to say
    assert _warned(HeadingPlanner, _long_planning_horizon("default", 600.0)) == []
    assert _warned(HeadingPlanner, _long_planning_horizon("default"), horizon=600.0) == []


# ------------------------------------------------------------------ memory
def test_max_steps_is_the_largest_count_that_fits():
    from tmaplan.memory import MODELS, estimate, max_steps

    for parts in ([("heading", 1)], [("heading", 3), ("baselines", 1)], [("schedule", 1)],
                  [("arrays", 1), ("bound", 1)]):
        for avail in (0.05 * GIB, 2 * GIB, 64 * GIB):
            m = max_steps(parts, avail)
            assert (m == 0 or estimate(m, parts) <= avail) and avail < estimate(m + 1, parts)
    # linear models: twice the steps, twice the per-step memory
    h = MODELS["heading"]
    assert h.bytes(2000) - h.bytes(1000) == pytest.approx(h.bytes(1000) - h.bytes(0))


def test_check_steps_names_the_field_and_the_steps_that_fit():
    from tmaplan.memory import HEADROOM, check_steps, max_steps

    parts = [("heading", 1)]
    check_steps(180, parts, field="time.horizon", dt=15.0, received="45 min",
                available=1 * GIB)  # fits
    with pytest.raises(ScenarioError) as exc:
        check_steps(129_600, parts, field="time.horizon", dt=20.0, received="30 d",
                    available=8 * GIB, source="long")
    m = max_steps(parts, HEADROOM * 8 * GIB)
    msg = str(exc.value)
    assert exc.value.field == "time.horizon" and f"at most {m} steps of dt = 20 s" in msg
    assert "129600 steps need about 17" in msg and "8 GiB of memory available" in msg
    with pytest.raises(ArgumentError) as exc:
        check_steps(129_600, parts, field="--horizon", dt=20.0, received="30 d",
                    available=8 * GIB)
    assert not isinstance(exc.value, ScenarioError)


def test_the_available_memory_is_known_here():
    from tmaplan.memory import available_bytes

    assert 0 < available_bytes()


def test_a_30_day_horizon_is_refused_before_any_graph(no_solver, monkeypatch):
    from tmaplan.planning import HeadingPlanner

    monkeypatch.setattr("tmaplan.memory.available_bytes", lambda: 16 * GIB)  # a workstation
    sc = load_problem("default")
    long = sc.replace(time=dataclasses.replace(sc.time, dt=20.0, horizon=30 * 86400.0),
                      planning=dataclasses.replace(sc.planning, horizon=None,
                                                   control_interval=60.0))
    assert long.n_steps == 129_600
    with pytest.raises(ScenarioError) as exc:
        HeadingPlanner(long)
    assert exc.value.field == "time.horizon" and "129600 steps need about" in str(exc.value)


# ------------------------------------------------------------------ the three inputs, CLI
def _scenario_file(tmp_path, case: str):
    d = _base()
    if case == "keep-out":
        d = _with({"planning.keep_out_range": "20 km"}, d)
    elif case == "turn-rate":
        d = _with({"observer.turn_rate_max": "90 deg/s"}, d)
    else:  # 30 days at 20 s: 129 600 steps
        d = _with({"time.dt": "20 s", "time.horizon": "30 d", "planning.horizon": "30 d",
                   "planning.control_interval": "1 min"}, d)
    import tomli_w

    f = tmp_path / f"{case}.toml"
    f.write_text(tomli_w.dumps(d), encoding="utf-8")
    return f


@pytest.mark.parametrize(("case", "field"), [("keep-out", "planning.keep_out_range"),
                                             ("turn-rate", "observer.turn_rate_max"),
                                             ("horizon", "planning.horizon")])
def test_the_three_impossible_inputs_are_refused_before_any_solver(
        case, field, tmp_path, one_line_error, no_solver, monkeypatch):
    monkeypatch.setattr("tmaplan.memory.available_bytes", lambda: 16 * GIB)
    f = _scenario_file(tmp_path, case)
    cpu = time.process_time()
    line = one_line_error(["plan", str(f), "--no-figure", "--out", str(tmp_path)])
    cpu = time.process_time() - cpu
    assert f"field '{field}'" in line, line
    # refused in well under a second of CPU time here; the bound only guards against a
    # return of the solver's minutes (no solver can have run: no_solver)
    assert cpu < 30.0, cpu


def test_a_load_warning_is_one_line_once(tmp_path, capsys):
    from tmaplan.cli import main

    f = tmp_path / "c.toml"
    import tomli_w

    f.write_text(tomli_w.dumps(_with({"observer.course": "400 deg"})), encoding="utf-8")
    # the file is loaded twice (the preflight, the verb): its warning is printed once
    assert main(["simulate", str(f), "--no-figure", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [f"tmaplan simulate: warning: ScenarioWarning: {f}: field 'observer.course': "
                   "a direction beyond ±360° is taken modulo 360°: 400° flies 40° (write "
                   "\"40 deg\" if that is meant), received 400°"], err


def test_a_prior_warning_reaches_the_verbs_that_read_the_prior(tmp_path, capsys):
    from tmaplan.cli import main

    sc = _default(bearing_mean=math.radians(225))
    f = save(sc, tmp_path / "back.toml")
    assert main(["simulate", str(f), "--no-figure", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().err == ""  # simulate does not read the prior
    assert main(["bound", str(f), "--no-figure", "--out", str(tmp_path)]) == 0
    err = [x for x in capsys.readouterr().err.splitlines() if "ScenarioWarning" in x]
    assert len(err) == 1 and "prior.bearing_mean" in err[0] and "other way" in err[0], err


@pytest.mark.parametrize("verb", ["plan", "schedule", "bound", "compare", "rank-costs",
                                  "demo", "simulate", "crlb", "track"])
def test_every_verb_checks_its_memory_first(verb, tmp_path, one_line_error, monkeypatch,
                                            no_solver):
    monkeypatch.setattr("tmaplan.memory.available_bytes", lambda: 1e5)  # 100 kB
    argv = [verb] + ([] if verb == "demo" else ["default"]) + {
        "compare": ["--policies", "planned", "--runs", "1"], "track": ["--runs", "1"],
        "rank-costs": ["--runs", "1"], "demo": ["--runs", "1"]}.get(verb, [])
    line = one_line_error([*argv, "--out", str(tmp_path)])
    assert "steps need about" in line and "the per-step arrays" in line, line


def test_default_fits_in_the_memory_of_a_small_machine():
    # every verb's estimate on the built-in problems stays under 2 GiB
    import argparse

    from tmaplan.cli.feasible import check_memory

    for p in list_problems():
        sc = load_problem(p["name"])
        sc = sc.contact_view(sc.contacts[0].name)  # one contact (issue 40)
        for verb in ("plan", "schedule", "bound", "rank-costs", "simulate"):
            args = argparse.Namespace(verb=verb, horizon=None, control_interval=None,
                                      pings=0, plans="all", workers=1)
            check_memory(args, sc, available=2 * GIB)


def test_the_bound_and_the_scheduler_check_their_memory_first(monkeypatch, no_solver):
    from tmaplan.bounds.closed_form import closed_form_pcrb
    from tmaplan.planning import schedule_pings

    monkeypatch.setattr("tmaplan.memory.available_bytes", lambda: 1e6)  # 1 MB
    sc = load_problem("default")
    with pytest.raises(ScenarioError, match="the closed-form bound"):
        closed_form_pcrb(sc)
    with pytest.raises(ScenarioError, match="the ping scheduler"):
        schedule_pings(sc, budget=2)


@pytest.mark.parametrize("verb", [["plan"], ["compare", "--policies", "straight,planned"]])
@pytest.mark.parametrize("case", ["keep-out", "turn-rate", "horizon"])
def test_an_impossible_input_is_refused_before_the_heavy_imports(case, verb, tmp_path):
    """The refusal comes before matplotlib, scipy.stats and pint's registry are imported (a
    second of start-up between them: ``python benchmarks/refusals.py`` times the refusals):
    only the verb named is imported, figures and reports import matplotlib when they draw,
    and a scenario in common units is read without pint (:data:`tmaplan.units.COMMON_UNITS`)."""
    import subprocess
    import sys

    f = _scenario_file(tmp_path, case)
    code = ("import sys; import tmaplan.memory as m; m.available_bytes = lambda: 16 * 2**30; "
            "from tmaplan.cli import main; "
            f"status = main({[*verb[:1], str(f), *verb[1:], '--out', str(tmp_path)]!r}); "
            "print(status, sorted(m for m in ('matplotlib', 'scipy.stats', 'pint') "
            "if m in sys.modules))")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert run.stdout.split(maxsplit=1) == ["1", "[]\n"], (run.stdout, run.stderr)
    assert "error: " in run.stderr and run.stderr.count("\n") == 1, run.stderr
