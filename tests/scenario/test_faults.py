"""Faults in scenario files: parsing, validation, round trip, and their effect on simulation."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ScenarioError
from tmaplan.geometry import course_speed
from tmaplan.models.faults import apply_manoeuvres, dropped
from tmaplan.scenario import dump, load_problem, loads
from tmaplan.scenario.faults import Faults, TargetManoeuvre
from tmaplan.simulate import draw_common_noise, draw_truth, measure_step, simulate

FAULTS = '''
[faults]
wild_bearing_probability = 0.2
bearing_bias = "0.5 deg"
missed_ping_probability = 0.5
dropouts = [{start = "10 min", end = "15 min", sensors = "bearing"}]
target_manoeuvres = [{time = "22.5 min", course_change = "60 deg"}]
'''


@pytest.fixture(scope="module")
def faulty():
    return loads(dump(load_problem("default")) + FAULTS, source="faulty")


def test_faults_parse_and_round_trip(faulty):
    f = faulty.faults
    assert f.wild_bearing_probability == 0.2
    assert f.bearing_bias == pytest.approx(np.radians(0.5))
    assert f.wild_bearing_spread == pytest.approx(np.pi)
    assert f.dropouts[0].start == 600.0 and f.dropouts[0].end == 900.0
    assert f.target_manoeuvres[0].course_change == pytest.approx(np.radians(60))
    assert loads(dump(faulty)) == faulty
    assert load_problem("default").faults is None


@pytest.mark.parametrize(("line", "field"), [
    ("wild_bearing_probability = -0.5", "faults.wild_bearing_probability"),
    ("bearing_bias = \"100 deg\"", "faults.bearing_bias"),
    ("dropouts = [{start = \"60 min\", end = \"70 min\"}]", "faults.dropouts[0].start"),
    ("target_manoeuvres = [{time = \"20 min\", speed = \"5 kn\"}, "
     "{time = \"10 min\", speed = \"5 kn\"}]", "faults.target_manoeuvres[1].time"),
    ("target_manoeuvres = [{time = \"20 min\", course = \"10 deg\", course_change = "
     "\"10 deg\"}]", "faults.target_manoeuvres[0].course"),
])
def test_invalid_faults_name_the_field(line, field):
    with pytest.raises(ScenarioError) as exc:
        loads(dump(load_problem("default")) + "\n[faults]\n" + line + "\n", source="bad")
    assert exc.value.field == field and "\n" not in str(exc.value)


def test_manoeuvre_changes_the_truth_not_before(faulty):
    base = load_problem("default")
    a = simulate(base, np.random.default_rng(1))
    b = simulate(faulty, np.random.default_rng(1))
    j = 90  # 22.5 min / 15 s
    assert np.array_equal(a.target[:j], b.target[:j])
    ca, _ = course_speed(a.target[j:, 2:])
    cb, _ = course_speed(b.target[j:, 2:])
    turn = np.degrees(np.angle(np.exp(1j * (cb - ca))))
    assert turn[0] == pytest.approx(60.0, abs=1e-6)  # later, the process noise is kept
    assert np.all(np.abs(turn - 60.0) < 10.0)
    x = draw_truth(faulty, np.random.default_rng(2))
    x0 = draw_truth(base, np.random.default_rng(2))
    assert np.array_equal(x[:j], x0[:j]) and not np.allclose(x[j:], x0[j:])


def test_manoeuvre_absolute_course_and_speed():
    times = np.arange(11) * 10.0
    x = np.zeros((11, 4))
    x[:, 3] = 5.0
    x[:, 1] = 5.0 * times
    f = Faults(target_manoeuvres=(TargetManoeuvre(time=45.0, course=np.pi / 2, speed=2.0),))
    y = apply_manoeuvres(f, x, times)
    assert np.allclose(y[5:, 2:], [2.0, 0.0])
    assert np.allclose(y[5:, 0], 2.0 * (times[5:] - 50.0))
    assert np.array_equal(y[:5], x[:5])


def test_sensor_faults_in_open_loop(faulty):
    base = load_problem("default")
    a = simulate(base, np.random.default_rng(1)).measurements[0]
    b = simulate(faulty, np.random.default_rng(1)).measurements[0]
    assert not np.any((b.times >= 600) & (b.times < 900))  # the dropout
    assert b.steps.size == a.steps.size - 20
    err = np.degrees(np.angle(np.exp(1j * (b.values - b.truth))))
    wild = np.abs(err) > 5.0
    assert 0.1 < wild.mean() < 0.3
    assert np.median(err[~wild]) == pytest.approx(0.5, abs=0.3)  # the bias


def test_sensor_faults_in_closed_loop(faulty):
    x = draw_truth(faulty, np.random.default_rng(2))
    noise = draw_common_noise(faulty, np.random.default_rng(3))
    assert noise.fault is not None
    assert draw_common_noise(load_problem("default"), np.random.default_rng(3)).fault is None
    assert measure_step(faulty, 45, x[45], noise) == []  # bearing dropout
    echoes = [any(m.ping for m in measure_step(faulty, k, x[k], noise, ping=True))
              for k in range(100, 181)]
    assert 0.3 < np.mean(echoes) < 0.7  # half the pings missed
    assert dropped(faulty.faults, np.array([599.0, 600.0, 899.0, 900.0]), "bearing").tolist() \
        == [False, True, True, False]
    assert not dropped(faulty.faults, 700.0, "range")


def test_recoveries_in_campaign_records_and_json(faulty, tmp_path):
    import warnings

    from tmaplan.evaluation.campaigns import CampaignSpec, run_campaign
    from tmaplan.evaluation.filter_options import FilterOptions
    from tmaplan.evaluation.records import RunRecord

    spec = CampaignSpec(scenario=faulty, policies=("planned+scheduled",), runs=2,
                        n_particles=500, filter_options=FilterOptions.robust())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = run_campaign(spec, out_dir=tmp_path)
    rec = [RunRecord.load(p, spec.policies) for p in sorted(tmp_path.glob("*/runs/*.npz"))]
    counts = [r.policies["planned+scheduled"].recoveries for r in rec]
    assert len(counts) == 2 and all(isinstance(c, int) for c in counts)
    js = res.to_json()["policies"]["planned+scheduled"]
    assert js["recoveries"] == pytest.approx(np.mean(counts))
    plain = CampaignSpec(scenario=faulty, policies=("planned+scheduled",), runs=2,
                         n_particles=500, filter_options=FilterOptions.plain())
    assert plain.key() != spec.key()
    default = CampaignSpec(scenario=faulty, policies=("planned+scheduled",), runs=2)
    assert "filter" not in default._meta()
