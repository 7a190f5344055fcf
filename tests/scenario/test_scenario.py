"""Scenario files: every built-in problem loads and round-trips; invalid input is rejected
with a message naming the field, the expected and the received value."""

from __future__ import annotations

import copy
import re
import tomllib

import numpy as np
import pytest
from repo_paths import ROOT

from tmaplan.errors import ScenarioError
from tmaplan.scenario import (
    dump,
    from_dict,
    list_problems,
    load,
    load_problem,
    loads,
    measurement_steps,
    problems_dir,
    save,
)

DESIGN_PROBLEMS = {
    "brehard2005-s1", "brehard2005-s2", "brehard2004-mp", "clavard2013-halfturn-cw",
    "clavard2013-halfturn-acw", "sharma2024-range-only", "ristic-bot-moderate",
    "ristic-bot-high", "gordon1993-bot", "default",
}
#: Our own planning problems (not from a paper): each says what it exercises.
OUR_PROBLEMS = {"default", "bow-closing", "contact-astern", "two-contacts-crossing",
                "three-contacts-screen"}


def test_every_design_problem_is_built_in():
    names = {p["name"] for p in list_problems()}
    assert DESIGN_PROBLEMS <= names
    for p in list_problems():
        assert p["description"], p["name"]


@pytest.mark.parametrize("name", sorted(DESIGN_PROBLEMS | OUR_PROBLEMS))
def test_load_dump_load_is_identity(name):
    s = load_problem(name)
    text = dump(s)
    s2 = loads(text)
    assert s2 == s
    assert dump(s2) == text  # and the dump is a fixed point


def test_every_file_parameter_is_commented():
    # Every built-in file cites its source in comments: the citation key of docs/references.md
    # (the problem's name prefix; the ristic-bot-* files cite ristic2004), never a line number.
    for path in problems_dir().glob("*.toml"):
        text = path.read_text(encoding="utf-8")
        assert text.lstrip().startswith("#"), path.name
        if path.stem not in OUR_PROBLEMS:
            key = "ristic2004" if path.stem.startswith("ristic") else path.stem.split("-")[0]
            assert text.lstrip().startswith(f"# {key}:"), path.name
            assert not re.search(r"\bL\d{2,4}\b", text), path.name


@pytest.mark.parametrize(("name", "rel_bearing", "closing"), [
    ("bow-closing", 10.0, True), ("contact-astern", 185.0, None)])
def test_our_planning_problems_have_their_geometry(name, rel_bearing, closing):
    """The extra planning problems say what they exercise, and their prior (never the truth)
    puts the contact where the comment says; the single-run truth is inside the prior."""
    from tmaplan.geometry import wrap_angle
    from tmaplan.planning.belief import Belief

    s = load_problem(name)
    text = (problems_dir() / f"{name}.toml").read_text(encoding="utf-8")
    assert text.startswith("# tmaplan's planning case") and "What it exercises:" in text
    assert not s.prior.centred_on_truth and s.planning is not None
    m = Belief.from_prior(s).mean
    course = float(s.observer.course)
    rel = np.degrees(float(wrap_angle(np.arctan2(m[0], m[1]) - course)))
    assert abs(float(wrap_angle(np.radians(rel - rel_bearing)))) < np.radians(1.0)
    if closing:
        assert m[:2] @ m[2:] < 0          # mean range rate < 0
    r0 = np.hypot(*s.target.position)
    assert s.prior.range_min <= r0 <= s.prior.range_max


def test_units_are_converted_at_load():
    s = load_problem("ristic-bot-moderate")
    assert s.time.horizon == 32 * 60.0
    assert s.observer.speed == pytest.approx(5 * 1852 / 3600, rel=1e-15)
    assert s.sensors[0].sigma == pytest.approx(np.radians(1.5), rel=1e-15)
    assert s.target.q == pytest.approx(9e-6, rel=1e-12)  # 9e-12 km²/s³


def test_unit_variants_give_identical_scenarios():
    base = tomllib.loads((problems_dir() / "brehard2005-s1.toml").read_text())
    alt = copy.deepcopy(base)
    alt["time"]["dt"] = "0.1 min"
    alt["time"]["horizon"] = "100 min"
    alt["target"]["position"] = [0.0, 3500.0]
    alt["observer"]["position"] = ["3500 m", 0]
    alt["sensors"][0]["sigma"] = 0.05
    alt["prior"]["range_std"] = 2000
    assert from_dict(alt) == from_dict(base)


def test_load_by_path_and_save_refuses_overwrite(tmp_path):
    s = load_problem("default")
    p = save(s, tmp_path / "x.toml")
    assert load(p) == s
    with pytest.raises(FileExistsError):
        save(s, p)
    save(s, p, overwrite=True)


def test_unknown_problem_lists_choices():
    with pytest.raises(ScenarioError) as exc:
        load("no-such-problem")
    msg = str(exc.value)
    assert "no-such-problem" in msg and "brehard2005-s1" in msg and "default" in msg


def test_ping_period_rule():
    # brehard2005 §6 "every 80 s" with δ = 6 s: first grid step at or after each multiple of 80 s
    # (docs/errata.md: k = 14, 27, 40, 54, ...; 75 pings over 6000 s).
    s = load_problem("brehard2005-s1")
    from tmaplan.scenario import RangeSensor

    steps = measurement_steps(RangeSensor(sigma=100.0, period=80.0), s.time)
    assert list(steps[:4]) == [14, 27, 40, 54]
    assert len(steps) == 75
    assert np.all(steps * 6.0 >= 80.0 * np.arange(1, 76))


def _base() -> dict:
    return tomllib.loads((problems_dir() / "default.toml").read_text())


def _set(d: dict, path: str, value) -> dict:
    d = copy.deepcopy(d)
    keys = path.split(".")
    cur = d
    for k in keys[:-1]:
        cur = cur[int(k)] if k.isdigit() else cur[k]
    last = keys[-1]
    if value is _DELETE:
        del cur[last]
    else:
        cur[last] = value
    return d


_DELETE = object()

INVALID = [
    # (path, value, field named in the message, fragment of the expected text)
    ("bogus", 1, "bogus", "no such key"),
    ("target.speeed", "3 kn", "target.speeed", "no such key"),
    ("time.dt", 0, "time.dt", "greater than 0"),
    ("time.dt", "-5 s", "time.dt", "greater than 0"),
    ("time.dt", "5 km", "dt", "time"),
    ("time.horizon", "44.9 min", "time.horizon", "whole number"),
    ("time.horizon", "45 blips", "horizon", "unknown unit"),
    ("sensors.0.sigma", 0, "sensors[0].sigma", "greater than 0"),
    ("sensors.0.sigma", "-1 deg", "sensors[0].sigma", "greater than 0"),
    ("sensors.0.kind", "sonar", "sensors[0].kind", "'bearing', 'range' or 'frequency'"),
    ("sensors.0.ambiguity", "2pi", "sensors[0].ambiguity", "'none' or 'pi'"),
    ("sensors.1.steps", [3, 181], "sensors[1].steps[1]", "within the horizon"),
    ("sensors.1.sigma", "nan m", "sigma", ""),
    ("observer.speed", "12 kn", "observer.speed", "within"),
    ("observer.turn_rate_max", 0, "observer.turn_rate_max", "greater than 0"),
    ("observer.velocity", [1.0, 2.0], "observer.velocity", "not both"),
    ("target.model", "spiral", "target.model", "'ncv', 'multi-leg' or 'constant-turn'"),
    ("target.q", -1.0, "target.q", "greater than or equal to 0"),
    ("target.position", _DELETE, "target.position", "[x, y]"),
    ("prior.range_max", "1 km", "prior.range_max", "> range_min"),
    ("prior.range_distribution", "gamma", "prior.range_distribution", "'normal'"),
    ("planning.ping_budget", 1000, "planning.ping_budget", "<= the number of steps"),
    ("planning.ping_budget", -1, "planning.ping_budget", "greater than or equal to 0"),
    ("planning.control_interval", "25 s", "planning.control_interval", "whole number"),
    ("planning.replan_interval", "100 s", "planning.replan_interval", "whole number"),
    ("name", _DELETE, "name", "required"),
    ("sensors", [], "sensors", "at least one sensor"),
]


@pytest.mark.parametrize(("path", "value", "field", "expected"), INVALID)
def test_invalid_scenarios_name_the_field(path, value, field, expected):
    with pytest.raises(ScenarioError) as exc:
        from_dict(_set(_base(), path, value), source="case")
    msg = str(exc.value)
    assert msg.startswith("case: field '"), msg
    assert field in msg, msg
    assert expected in msg, msg
    assert "\n" not in msg
    assert isinstance(exc.value, ValueError)


def test_leg_turn_rate_over_limit():
    d = _base()
    d["observer"]["legs"] = [{"start": "5 min", "course": "90 deg", "turn_rate": "1 deg/s"}]
    with pytest.raises(ScenarioError, match=r"observer.legs\[0\].turn_rate.*turn_rate_max"):
        from_dict(d)


def test_turn_rate_sequence_length_and_limit():
    d = _base()
    d["observer"]["turn_rates"] = [0.0] * 10
    with pytest.raises(ScenarioError, match="one turn rate per step"):
        from_dict(d)
    d["observer"]["turn_rates"] = [0.0] * 179 + ["1 deg/s"]
    with pytest.raises(ScenarioError, match=r"turn_rates\[179\]"):
        from_dict(d)


def test_bad_toml_is_a_scenario_error():
    with pytest.raises(ScenarioError, match="valid TOML"):
        loads("name = ")


# ------------------------------------------------------------------ priors and the truth
TRUTH_FIELDS = {
    "brehard2004-mp": ("bearing_mean",),
    "brehard2005-s1": ("bearing_mean", "range_mean", "velocity_mean"),
    "brehard2005-s2": ("bearing_mean", "range_mean", "velocity_mean"),
    "ristic-bot-moderate": ("bearing_mean", "range_mean", "speed_mean"),
    "ristic-bot-high": ("bearing_mean", "range_mean", "speed_mean"),
    "sharma2024-range-only": ("bearing_mean", "range_mean"),
    "default": (),
    "gordon1993-bot": (),
    "bow-closing": (),
    "contact-astern": (),
}


@pytest.mark.parametrize("name", sorted(TRUTH_FIELDS))
def test_builtin_priors_say_what_they_take_from_the_truth(name):
    p = load_problem(name).prior
    assert p.truth_fields == TRUTH_FIELDS[name]
    assert p.centred_on_truth == bool(TRUTH_FIELDS[name])
    if p.centred_on_truth:  # without the opt-in the same file is refused, naming the key
        d = tomllib.loads((problems_dir() / f"{name}.toml").read_text())
        del d["prior"]["centred_on_truth"]
        with pytest.raises(ScenarioError, match=rf"prior\.{TRUTH_FIELDS[name][0]}.*"
                                                 "centred_on_truth = true"):
            from_dict(d)


def _docs_scenario_text() -> str:
    """The example of docs/scenario-files.md (the README points there)."""
    path = ROOT / "docs" / "scenario-files.md"
    block = path.read_text(encoding="utf-8").split("```toml\n", 1)[1].split("```", 1)[0]
    assert "[prior]" in block and 'name = "my-case"' in block
    return block


def test_docs_prior_is_complete_and_does_not_use_the_truth():
    from tmaplan.models.prior import prior_relative_moments

    s = loads(_docs_scenario_text(), source="docs/scenario-files.md")
    assert s.prior is not None and s.prior.truth_fields == () and not s.prior.centred_on_truth
    _, cov = prior_relative_moments(s, n=20_000)
    vel_std = np.sqrt(np.diag(cov)[2:])
    # speed uniform on [0, 15 kn] with a uniform course: per-axis std sqrt(E s²/2) = 15 kn/√6
    assert vel_std == pytest.approx(15 * 1852 / 3600 / np.sqrt(6), rel=0.03)
    assert np.all(np.linalg.eigvalsh(cov) > 0)


def test_docs_prior_without_velocity_names_the_keys_to_add():
    text = _docs_scenario_text()
    for key in ("velocity_distribution", "speed_distribution", "speed_max", "course_mode"):
        text = "\n".join(x for x in text.splitlines() if not x.startswith(key))
    with pytest.raises(ScenarioError) as exc:
        loads(text, source="docs/scenario-files.md")
    msg = str(exc.value)
    assert "prior.velocity_std" in msg
    for key in ("velocity_mean", "velocity_std", "speed-course", "speed_max", "course_mode"):
        assert key in msg, msg


def test_course_mode_true_is_an_explicit_choice():
    # (with a spread: a zero course_std is refused, tests/scenario/test_scenario_spreads.py)
    d = _set(_set(_base(), "prior.course_mode", "true"), "prior.course_std", "10 deg")
    s = from_dict(d)
    assert s.prior.truth_fields == ("course_mode",) and not s.prior.centred_on_truth


# ------------------------------------------------------------------ plausibility
@pytest.mark.parametrize(("path", "ok", "refused", "unit"), [
    ("sensors.0.sigma", 0.2, 0.21, "rad"),
    ("target.course", -6.28, 6.3, "rad"),
    ("prior.bearing_std", 1.0, 1.01, "rad"),
    ("observer.turn_rate_max", 0.1, 0.11, "rad/s"),
])
def test_bare_number_limits(path, ok, refused, unit):
    d = _base()
    if path == "observer.turn_rate_max":
        d = _set(d, "observer.speed_max", "6 kn")
    from_dict(_set(d, path, ok))
    from_dict(_set(d, path, str(ok)))
    with pytest.raises(ScenarioError, match=rf"write \"{refused:g} deg"):
        from_dict(_set(d, path, refused))
    with pytest.raises(ScenarioError, match="implausible"):
        from_dict(_set(d, path, str(refused)))  # a unit-less string is a bare number too
    s = from_dict(_set(d, path, f"{refused} {unit}"))  # an explicit unit is accepted
    assert loads(dump(s)) == s and f'"{refused!r} {unit}"' in dump(s)


def test_dump_writes_units_where_a_bare_number_would_be_refused():
    d = _base()
    d["sensors"][0]["sigma"] = "15 deg"
    d["observer"]["turn_rate_max"] = "10 deg/s"
    d["observer"]["speed_max"] = "6 kn"
    d["prior"]["bearing_std"] = "70 deg"
    s = from_dict(d)
    text = dump(s)
    assert loads(text) == s and dump(loads(text)) == text
    assert f'sigma = "{float(np.radians(15.0))!r} rad"' in text
    assert 'course_mode = "uniform"' in text  # ordinary values stay bare SI numbers


def test_python_values_are_si_and_not_second_guessed():
    from tmaplan.scenario import BearingSensor

    # the bare-number rule protects files; the Python API is SI by contract
    assert BearingSensor(sigma=0.5).sigma == 0.5
    s = load_problem("default")
    s2 = s.replace(sensors=(BearingSensor(sigma=0.5), s.sensors[1]))
    assert s2.sensors[0].sigma == 0.5


def test_speed_limit_holds_for_every_construction_path():
    import dataclasses

    s = load_problem("default")
    with pytest.raises(ScenarioError, match=r"target\.speed.*at most 150 m/s"):
        s.replace(target=dataclasses.replace(s.target, speed=151.0))
    with pytest.raises(ScenarioError, match=r"prior\.speed_max.*at most 150 m/s"):
        from_dict(_set(_base(), "prior.speed_max", "300 kn"))
    from_dict(_set(_base(), "prior.speed_max", "150 m/s"))  # the limit itself is accepted


def test_binary_file_names_the_file(tmp_path):
    f = tmp_path / "x.toml"
    f.write_bytes(b"name = \"a\"\n\xff\xfe\x00")
    with pytest.raises(ScenarioError) as exc:
        load(f)
    assert str(f) in str(exc.value) and "0xff at offset 11" in str(exc.value)
