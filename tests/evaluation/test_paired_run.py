"""The one per-run loop of the closed-loop Monte Carlo (tmaplan.evaluation.closed_loop.
paired_run): run i's truth and streams, every policy on the same truth and noise, the same
record the campaigns store."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tmaplan.evaluation.campaigns import CampaignSpec, run_one
from tmaplan.evaluation.closed_loop import fly, paired_run, run_closed_loop
from tmaplan.evaluation.seeding import run_streams
from tmaplan.policies import Straight, parse_policy
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth


@pytest.fixture(scope="module")
def default():
    return load_problem("default")


def test_a_paired_run_is_the_run_flown_by_hand_on_its_streams(default):
    pols = {"straight": parse_policy("straight", default).resolve(default),
            "zigzag": parse_policy("zigzag", default).resolve(default)}
    got = dict(paired_run(default, pols, seed=3, run=2, n_particles=60))
    assert list(got) == ["straight", "zigzag"]
    st = run_streams(3, 2)
    target = draw_truth(default, np.random.default_rng(st.truth), from_prior=True)
    for name, pol in pols.items():
        ref = run_closed_loop(default, pol, target, noise_rng=np.random.default_rng(st.noise),
                              filter_rng=np.random.default_rng(st.filter), n_particles=60)
        np.testing.assert_array_equal(got[name].estimate, ref.estimate)
        np.testing.assert_array_equal(got[name].target, target)
        np.testing.assert_array_equal(fly(default, pol, target, st, n_particles=60).estimate,
                                      ref.estimate)
    # paired: the same truth for both policies, different own-ship tracks
    assert not np.array_equal(got["straight"].observer.position,
                              got["zigzag"].observer.position)


def test_the_campaign_run_is_the_paired_run(default):
    spec = CampaignSpec(scenario=default, policies=("straight",), runs=1, seed=4,
                        n_particles=60)
    pol = {"straight": parse_policy("straight", default).resolve(default)}
    rec = run_one(spec, pol, 0)
    [(_, res)] = paired_run(default, pol, seed=4, run=0, n_particles=60)
    m = res.metrics(spec.accuracy)
    assert rec.policies["straight"].metrics.to_json() == m.to_json()
    np.testing.assert_array_equal(rec.policies["straight"].metrics.position_error,
                                  m.position_error)


def test_run_metrics_json_says_never_with_null(default):
    [(_, res)] = paired_run(default, {"s": Straight()}, seed=0, run=0, n_particles=60)
    js = res.metrics(1e-9).to_json()  # an accuracy no run reaches
    assert js["time_to_accuracy"] is None
    assert math.isfinite(js["final_range_error"]) and js["pings_used"] == 0
    assert isinstance(js["diverged"], bool)
