"""Degenerate priors and ignored sensor keys are refused at load, naming the field: a zero
prior std that leaves the prior without a density (the bounds' NaN or "singular matrix" at
step 0), a truncated normal range or speed that keeps a negligible mass in its support (every
draw at a bound), and a sensor key that the sensor's other keys make unused."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest
from scipy import stats

from tmaplan.errors import ScenarioError
from tmaplan.models.prior import sample_prior
from tmaplan.scenario import dump, from_dict, load_problem, loads, measurement_steps, problems_dir
from tmaplan.scenario.prior_checks import MIN_TRUNCATED_MASS, truncated_normal_log_mass


def _data(problem: str) -> dict:
    return tomllib.loads((problems_dir() / f"{problem}.toml").read_text(encoding="utf-8"))


def _refused(data: dict) -> ScenarioError:
    with pytest.raises(ScenarioError) as exc:
        from_dict(data, source="case")
    msg = str(exc.value)
    assert msg.startswith(f"case: field '{exc.value.field}': expected ") and "\n" not in msg
    return exc.value


# ------------------------------------------------------------------------ zero prior stds
@pytest.mark.parametrize("value", ["0 deg", 0, 0.0])
def test_zero_bearing_std_is_refused(value):
    d = _data("default")
    d["prior"]["bearing_std"] = value
    err = _refused(d)
    assert err.field == "prior.bearing_std" and err.received == 0.0
    assert str(err).startswith("case: field 'prior.bearing_std': expected > 0 for a polar prior")


def test_an_omitted_bearing_std_is_refused():
    # its default is 0: a polar prior must give its bearing spread
    d = _data("default")
    del d["prior"]["bearing_std"]
    err = _refused(d)
    assert err.field == "prior.bearing_std" and "default when the key is left out" in str(err)


@pytest.mark.parametrize("i", range(4))
def test_a_zero_gaussian_std_entry_is_refused(i):
    d = _data("gordon1993-bot")
    std = list(d["prior"]["std"])
    std[i] = 0.0
    d["prior"]["std"] = std
    err = _refused(d)
    assert err.field == f"prior.std[{i}]" and err.received == 0.0


def test_a_gaussian_prior_keeps_its_unread_bearing_std_default():
    s = load_problem("gordon1993-bot")
    assert s.prior.kind == "gaussian" and s.prior.bearing_std == 0.0
    assert loads(dump(s)) == s  # dump writes bearing_std = 0.0: still accepted


@pytest.mark.parametrize(("problem", "mode"), [("contact-astern", "given"),
                                               ("default", "true")])
def test_zero_course_std_is_refused_where_it_fixes_the_course(problem, mode):
    d = _data(problem)
    d["prior"]["course_mode"] = mode
    d["prior"]["course_std"] = "0 deg"
    err = _refused(d)
    assert err.field == "prior.course_std" and f"course_mode = '{mode}'" in str(err)
    d["prior"]["course_std"] = "5 deg"
    assert from_dict(d).prior.course_std == pytest.approx(math.radians(5.0))


@pytest.mark.parametrize(("key", "field"), [
    ("range_std", "range_std"), ("speed_std", "speed_std"), ("course_std", "course_std")])
def test_point_masses_that_keep_a_density_are_accepted(key, field):
    """A zero range or speed std is a point mass at its mean (documented, refused outside
    [min, max]); a zero course std about the reciprocal bearing follows the bearing's spread.
    The Monte Carlo bound's step 0 stays finite for each."""
    from tmaplan.bounds.pcrb import monte_carlo_pcrb

    d = _data("ristic-bot-moderate")
    d["prior"][key] = 0.0
    s = from_dict(d)
    assert getattr(s.prior, field) == 0.0
    res = monte_carlo_pcrb(s, samples=100, rng=np.random.default_rng(0), prior_samples=2000)
    assert np.all(np.isfinite(res.std[0])) and np.all(res.std[0] > 0)


# -------------------------------------------------------------------- ignored sensor keys
@pytest.mark.parametrize(("key", "value"), [("first_step", 5), ("every", 3)])
def test_bearing_sensor_with_steps_refuses_first_step_and_every(key, value):
    d = _data("default")
    d["sensors"][0].update({"steps": [1, 2], key: value})
    err = _refused(d)
    assert err.field == f"sensors[0].{key}" and err.received == value
    assert "expected not set with sensors[0].steps = [1, 2] (it is ignored there" in str(err)


def test_the_users_bearing_sensor_is_refused_at_first_step():
    d = _data("default")
    d["sensors"][0].update({"steps": [1, 2], "first_step": 5, "every": 3})
    assert _refused(d).field == "sensors[0].first_step"


def test_keys_at_their_default_are_accepted_and_files_round_trip():
    d = _data("default")
    d["sensors"][0].update({"steps": [1, 2], "first_step": 1, "every": 1})
    s = from_dict(d)
    assert list(measurement_steps(s.sensors[0], s.time)) == [1, 2]
    assert loads(dump(s)) == s  # dump writes first_step = 1, every = 1 with the steps
    sharma = load_problem("sharma2024-range-only")  # a bearing at steps = [0]
    assert loads(dump(sharma)) == sharma


def test_frequency_sensor_with_steps_refuses_first_step():
    d = _data("clavard2013-halfturn-cw")
    (i,) = [j for j, x in enumerate(d["sensors"]) if x["kind"] == "frequency"]
    d["sensors"][i].update({"steps": [3, 4], "first_step": 2})
    assert _refused(d).field == f"sensors[{i}].first_step"


def test_range_sensor_first_step_goes_with_every():
    d = _data("default")
    d["sensors"][1]["first_step"] = 3  # pings at steps = [] only: first_step unused
    err = _refused(d)
    assert err.field == "sensors[1].first_step" and "without sensors[1].every" in str(err)
    d["sensors"][1]["every"] = 4
    s = from_dict(d)
    assert list(measurement_steps(s.sensors[1], s.time))[:3] == [3, 7, 11]


# ------------------------------------------------------------ degenerate truncated normals
def _normal_range(mean: str, std: str) -> dict:
    d = _data("default")
    d["prior"].update({"range_distribution": "normal", "range_mean": mean, "range_std": std})
    return d


def test_a_normal_range_far_outside_its_truncation_is_refused():
    err = _refused(_normal_range("400 km", "1 m"))
    msg = str(err)
    assert err.field == "prior.range_mean" and err.received == 400e3
    assert "[range_min, range_max] = [5000, 25000] m" in msg
    assert "it keeps 10^-3.05" in msg and "of its mass" in msg


@pytest.mark.parametrize(("mean", "std", "ok"), [
    ("400 km", "100 km", True),     # mass ≈ 4.9e-5: a skewed but real prior
    ("30 km", "1 km", False),       # 5σ above range_max: ≈ 2.9e-7
    ("29 km", "1 km", True),        # 4σ above: ≈ 3.2e-5
    ("0.2 km", "1 km", False),      # 4.8σ below range_min: ≈ 7.9e-7
    ("0.5 km", "1 km", True),       # 4.5σ below: ≈ 3.4e-6
])
def test_the_mass_threshold(mean, std, ok):
    m, s = (float(x.split()[0]) * 1e3 for x in (mean, std))
    mass = stats.norm.cdf(25e3, m, s) - stats.norm.cdf(5e3, m, s)
    assert bool(mass >= MIN_TRUNCATED_MASS) == ok
    d = _normal_range(mean, std)
    if ok:
        assert from_dict(d).prior.range_mean == m
    else:
        assert _refused(d).field == "prior.range_mean"


def test_a_normal_speed_far_outside_its_truncation_is_refused():
    d = _data("default")
    d["prior"].update({"speed_distribution": "normal", "speed_mean": "40 kn",
                       "speed_std": "0.5 kn"})
    err = _refused(d)
    assert err.field == "prior.speed_mean" and "[speed_min, speed_max] = [0, " in str(err)


def test_log_mass_is_accurate_in_the_tails():
    # agrees with scipy where the plain difference of cdfs is accurate ...
    for mean, std, lo, hi in [(0.0, 1.0, -1.0, 1.0), (12e3, 4e3, 5e3, 25e3),
                              (10.0, 2.0, 0.0, math.inf), (0.0, 1.0, 3.0, 4.0)]:
        ref = stats.norm.cdf(hi, mean, std) - stats.norm.cdf(lo, mean, std)
        assert math.exp(truncated_normal_log_mass(mean, std, lo, hi)) == pytest.approx(ref)
    # ... and stays finite, symmetric and ordered where the cdfs round to 0 or 1
    up = truncated_normal_log_mass(0.0, 1.0, 40.0, 41.0)
    down = truncated_normal_log_mass(0.0, 1.0, -41.0, -40.0)
    assert math.isfinite(up) and up == pytest.approx(down, rel=1e-12)
    assert up == pytest.approx(stats.norm.logsf(40.0), rel=1e-3)
    far = truncated_normal_log_mass(400e3, 1.0, 5e3, 25e3)
    assert far == pytest.approx(-(375e3 ** 2) / 2, rel=1e-3)


def test_a_truth_centred_range_far_outside_is_refused_when_sampled():
    # the mean is the true range (12 km), known only when the prior is sampled
    s = load_problem("default")
    sc = s.replace(prior=dataclasses.replace(
        s.prior, range_distribution="normal", range_max=None, range_std=1.0, range_min=15e3,
        bearing_mean=None, centred_on_truth=True))  # loads: the truth is not the prior's
    with pytest.raises(ScenarioError) as exc:
        sample_prior(sc, 4, np.random.default_rng(0))
    assert exc.value.field == "prior.range_mean" and str(exc.value).startswith("default: ")
    assert "true initial range" in str(exc.value)
