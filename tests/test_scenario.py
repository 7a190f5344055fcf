"""Scenario files: every built-in problem loads and round-trips; invalid input is rejected
with a message naming the field, the expected and the received value."""

from __future__ import annotations

import copy
import re
import tomllib

import numpy as np
import pytest

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


def test_every_design_problem_is_built_in():
    names = {p["name"] for p in list_problems()}
    assert DESIGN_PROBLEMS <= names
    for p in list_problems():
        assert p["description"], p["name"]


@pytest.mark.parametrize("name", sorted(DESIGN_PROBLEMS))
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
        if path.stem != "default":
            key = "ristic2004" if path.stem.startswith("ristic") else path.stem.split("-")[0]
            assert text.lstrip().startswith(f"# {key}:"), path.name
            assert not re.search(r"\bL\d{2,4}\b", text), path.name


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
    # File 000 §6 "every 80 s" with δ = 6 s: first grid step at or after each multiple of 80 s
    # (NOTES_000 §5.3: k = 14, 27, 40, 54, ...; 75 pings over 6000 s).
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
