"""Prior keys that the chosen kind, distribution or course mode ignores are refused (unless
left at their default), and scenario booleans are strict TOML booleans."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tmaplan.errors import ScenarioError
from tmaplan.estimators.runner import run_prior
from tmaplan.evaluation.plan_general import random_problems
from tmaplan.scenario import dump, from_dict, list_problems, load_problem, loads, to_dict

IGNORED = [  # (problem, key, value, the setting that ignores it)
    ("default", "range_std", "1 km", "range_distribution = 'uniform'"),
    ("default", "range_mean", "10 km", "range_distribution = 'uniform'"),
    ("default", "velocity_mean", [0.0, 0.0], "velocity_distribution = 'speed-course'"),
    ("default", "velocity_std", "2 kn", "velocity_distribution = 'speed-course'"),
    ("default", "speed_mean", "5 kn", "speed_distribution = 'uniform'"),
    ("default", "speed_std", "1 kn", "speed_distribution = 'uniform'"),
    ("default", "course_mean", "10 deg", "course_mode = 'uniform'"),
    ("default", "course_std", "10 deg", "course_mode = 'uniform'"),
    ("default", "mean", [0.0, 0.0, 0.0, 0.0], "kind = 'polar'"),
    ("ristic-bot-moderate", "course_mean", "10 deg", "course_mode = 'reciprocal-bearing'"),
    ("brehard2005-s1", "course_mode", "uniform", "velocity_distribution = 'normal'"),
    ("brehard2005-s1", "speed_distribution", "uniform", "velocity_distribution = 'normal'"),
    ("gordon1993-bot", "bearing_std", "2 deg", "kind = 'gaussian'"),
    ("gordon1993-bot", "range_distribution", "uniform", "kind = 'gaussian'"),
    ("gordon1993-bot", "velocity_std", "1 m/s", "kind = 'gaussian'"),
]


@pytest.mark.parametrize(("problem", "key", "value", "setting"), IGNORED)
def test_an_ignored_prior_key_is_refused(problem, key, value, setting):
    data = to_dict(load_problem(problem))
    data["prior"][key] = value
    with pytest.raises(ScenarioError) as exc:
        from_dict(data, source="case")
    msg = str(exc.value)
    assert msg.startswith(f"case: field 'prior.{key}': expected not set with prior.{setting} "
                          "(it is ignored there), received "), msg


@pytest.mark.parametrize(("problem", "key", "value"), [
    ("gordon1993-bot", "bearing_std", "0 deg"),        # its default: written by dump
    ("brehard2005-s1", "speed_min", 0.0),
    ("ristic-bot-moderate", "range_max", "40 km"),     # a truncation bound of a normal range
    ("ristic-bot-moderate", "speed_max", "30 kn"),     # ... and of a normal speed
    ("contact-astern", "course_std", "5 deg"),         # course_mode "given"
    # the consistency monitor's rejuvenation bounds, read whatever the sampling
    ("brehard2005-s1", "speed_max", "15 kn"),          # a normal velocity prior
    ("gordon1993-bot", "range_min", "1 km"),           # a gaussian prior
    ("gordon1993-bot", "range_max", "40 km"),
])
def test_a_used_or_default_prior_key_is_accepted(problem, key, value):
    data = to_dict(load_problem(problem))
    data["prior"][key] = value
    from_dict(data)


def test_random_problems_still_round_trip():
    for seed in (2027, 2028):
        for s in random_problems(load_problem("default"), 30, seed=seed):
            assert loads(dump(s)) == s


def test_run_prior_keeps_a_uniform_range_prior_valid():
    # Before: run_prior drew a range_mean for every polar prior, also a uniform range one
    # (brehard2004-mp), which ignores it.
    sc = load_problem("brehard2004-mp")
    p = run_prior(sc, np.random.default_rng(3)).prior
    assert p is not None and p.range_mean is None and p.bearing_mean is not None


@pytest.mark.parametrize(("problem", "line", "field"), [
    ("brehard2005-s1", "centred_on_truth = true", "prior.centred_on_truth"),
    ("default", "active = true", "sensors[1].active"),
])
@pytest.mark.parametrize("value", ['"yes"', '"true"', "1", '"on"'])
def test_booleans_are_strict(problem, line, field, value):
    text = dump(load_problem(problem))
    assert text.count(line) == 1
    key = line.split(" = ")[0]
    with pytest.raises(ScenarioError) as exc:
        loads(text.replace(line, f"{key} = {value}"), source="case")
    received = value.replace('"', "'")  # a string is quoted, a number is not
    assert str(exc.value) == (f"case: field '{field}': expected a boolean (true or false), "
                              f"received {received}")


def test_toml_booleans_still_load():
    text = dump(load_problem("default"))
    assert loads(text.replace("active = true", "active = false")).sensors[1].active is False


_OTHER = {"kind": "gaussian", "range_distribution": "log-uniform",
          "velocity_distribution": "speed-course", "speed_distribution": "uniform",
          "course_mode": "uniform"}


def _changed(name, value):
    """A valid value of prior field ``name`` other than ``value``."""
    if name in _OTHER:
        return _OTHER[name] if value != _OTHER[name] else "normal" if name != "kind" else "polar"
    if name in ("mean", "std"):
        return (1234.0, 2345.0, 1.5, 2.5)
    if name == "velocity_mean":
        return (1.5, -2.5)
    return 1.7 * value + 3.0 if value is not None else 3456.0


# every contact's prior of every built-in problem: "problem" or "problem:contact"
WITH_PRIOR = [p["name"] if len(sc.contacts) == 1 else f"{p['name']}:{c.name}"
              for p in list_problems() for sc in [load_problem(p["name"])]
              for c in sc.contacts if c.prior is not None]


def _view(problem):
    name, _, contact = problem.partition(":")
    sc = load_problem(name)
    return sc.contact_view(contact) if contact else sc


@pytest.mark.parametrize("problem", WITH_PRIOR)
def test_a_prior_key_reported_as_ignored_does_not_change_the_draws(problem):
    """Cross-check of the key check's table against the sampler it describes: changing any
    key that ``ignored_prior_keys`` reports as ignored leaves ``sample_prior``'s draws bit for
    bit unchanged (if the sampler starts reading one, the table must change too)."""
    import copy
    import dataclasses

    from tmaplan.models.prior import sample_prior
    from tmaplan.scenario.prior_checks import ignored_prior_keys

    sc = _view(problem)
    ignored = ignored_prior_keys(sc.prior)
    base = sample_prior(sc, 64, np.random.default_rng(5))
    assert ignored, "every built-in prior leaves some key unused"
    for name in ignored:
        p = dataclasses.replace(sc.prior, **{name: _changed(name, getattr(sc.prior, name))})
        changed = copy.copy(sc)  # not validated: the key check would refuse the change
        object.__setattr__(changed, "prior", p)
        draws = sample_prior(changed, 64, np.random.default_rng(5))
        assert np.array_equal(draws, base), (problem, name)


@pytest.mark.parametrize("name", WITH_PRIOR)
def test_run_prior_drops_the_truth_opt_in(name):
    # a prior whose every mean is given refuses centred_on_truth = true (it would do
    # nothing, tests/data/invalid/71_*); run_prior gives every mean from the truth, so its
    # scenario drops the opt-in
    sc = _view(name)
    drawn = run_prior(sc, np.random.default_rng(5)).prior
    assert not drawn.centred_on_truth
    assert drawn.truth_fields in ((), ("course_mode",)) and drawn.truth_means == ()
    with pytest.raises(ScenarioError) as exc:
        sc.replace(prior=dataclasses.replace(drawn, centred_on_truth=True))
    assert exc.value.field == "prior.centred_on_truth"


def test_course_mode_true_alone_does_not_need_the_opt_in():
    # "true" is itself the explicit choice: with every mean given the opt-in is refused
    sc = load_problem("default")
    given = dataclasses.replace(sc.prior, course_mode="true", course_std=0.1)  # std > 0
    assert given.truth_fields == ("course_mode",) and given.truth_means == ()
    assert sc.replace(prior=given).prior == given
    with pytest.raises(ScenarioError) as exc:
        sc.replace(prior=dataclasses.replace(given, centred_on_truth=True))
    assert exc.value.field == "prior.centred_on_truth"
    assert str(exc.value).endswith("received 'true'")


def test_random_problems_keep_the_opt_in_only_for_a_mean_still_omitted():
    # random_problem gives the bearing mean: a base that took only it from the truth gives
    # problems without the opt-in; one whose normal speed mean is the truth keeps it
    base = load_problem("default")
    p = dataclasses.replace(base.prior, bearing_mean=None, centred_on_truth=True)
    for prior, kept in ((p, False), (dataclasses.replace(
            p, speed_distribution="normal", speed_std=1.0), True)):
        for s in random_problems(base.replace(prior=prior), 3, seed=4):
            assert s.prior.centred_on_truth is kept and s.prior.bearing_mean is not None
