"""The demo's stored result (package data, :mod:`tmaplan.headline`) is labelled with the
commands that reproduce it and is what the code computes now: the first runs of each stored
campaign, recomputed with the same command's seeds, give the stored per-run values. A change to
the closed loop that moves the results makes this test fail, and ``benchmarks/demo_stored.py``
must be re-run (the stored result cannot silently go stale).

Tolerances: a run's result depends only on the campaign's seed and the run index
(:mod:`tmaplan.evaluation.campaigns`), bit for bit on one machine; on another, floating-point
differences may move a time to accuracy by a step or a final range error slightly, so a time
must agree within one time step and a final range error within 1 % (or 1 m).
"""

from __future__ import annotations

import math

import pytest

from tmaplan.evaluation.campaigns import run_one
from tmaplan.experiments import CampaignSpec, resolve_policies
from tmaplan.headline import KEY_DIFFERENCES, difference_of, load_stored, stored_lines
from tmaplan.scenario import load_problem

STORED = load_stored()

#: The policies recomputed: the headline's plan and the baselines it is set against.
RECOMPUTED = ("straight", "single-turn", "planned")


def _policies_of(command: str) -> list[str]:
    words = command.split()
    return words[words.index("--policies") + 1].split(",")


def test_the_label_names_each_command_with_its_provenance():
    text = "\n".join(stored_lines(STORED))
    assert text.startswith("Stored result of ")
    for c in STORED.campaigns:
        assert c.command.startswith(f"tmaplan compare {STORED.problem} --policies ")
        assert f" --runs {c.runs} " in c.command and f" --seed {c.seed} " in c.command
        assert _policies_of(c.command) == list(c.policies)
        assert c.commit and c.particles == 3000 and c.truth == "prior" and c.accuracy == 0.1
        assert c.command in text and f"{c.runs} runs, seed {c.seed}, commit {c.commit}" in text


def test_every_key_difference_is_stored_with_its_interval():
    merged = STORED.merged()
    for a, b, metric in KEY_DIFFERENCES:
        d = difference_of(merged.differences, a, b, metric)
        assert d is not None, (a, b, metric)
        assert d.ci_low <= d.mean <= d.ci_high and d.n >= 300


def _close_time(stored, live, dt):
    if stored is None or live is None:
        return stored is None and live is None
    return abs(stored - live) <= dt


@pytest.fixture(scope="module")
def recomputed():
    """Runs 0 and 1 of :data:`RECOMPUTED` with the stored campaigns' settings (every stored
    campaign flies them with the same seed: a run's values do not depend on the other
    policies of its campaign, nor on its number of runs), and the time step."""
    c = STORED.campaigns[0]
    assert all((x.seed, x.particles, x.truth, x.accuracy) == (c.seed, c.particles, c.truth,
                                                               c.accuracy)
               for x in STORED.campaigns)
    scenario = load_problem(STORED.problem)
    spec = CampaignSpec(scenario=scenario, policies=RECOMPUTED, runs=2, seed=c.seed,
                        n_particles=c.particles, truth=c.truth,
                        accuracy=c.accuracy)
    policies = resolve_policies(scenario, RECOMPUTED)
    return [run_one(spec, policies, i) for i in range(2)], scenario.time.dt


@pytest.mark.parametrize("campaign", range(len(STORED.campaigns)))
def test_the_first_stored_runs_match_a_live_recomputation(campaign, recomputed):
    records, dt = recomputed
    c = STORED.campaigns[campaign]
    names = [p for p in RECOMPUTED if p in c.policies]
    assert names and all(len(c.first_runs[p]["time_to_accuracy"]) >= 2 for p in names)
    for i, record in enumerate(records):
        for p in names:
            m = record.policies[p].metrics
            live_t = None if math.isinf(m.time_to_accuracy) else m.time_to_accuracy
            t = c.first_runs[p]["time_to_accuracy"][i]
            e = c.first_runs[p]["final_range_error"][i]
            assert _close_time(t, live_t, dt), (p, i, t, live_t)
            assert abs(m.final_range_error - e) <= max(1.0, 0.01 * abs(e)), (
                p, i, e, m.final_range_error)
