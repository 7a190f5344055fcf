"""The demo's headline (issue 38): every difference shown has its paired 95 % interval, an
undecided one is labelled "not decided at N runs" and never ranked, the stored result is
labelled with its commands, and a live run is set against it. Synthetic campaign results:
paired values drawn with known means, so which differences are decided is known."""

from __future__ import annotations

import dataclasses
import json
import re

import numpy as np
import pytest

from tmaplan.cli.demo import DEMO_POLICIES
from tmaplan.evaluation.metrics import PairedDifference, paired_difference
from tmaplan.headline import (
    KEY_DIFFERENCES,
    Comparison,
    StoredResult,
    difference_of,
    key_json,
    key_lines,
    key_table_html,
    live_html,
    live_lines,
    load_stored,
    stored_html,
    stored_lines,
    stored_payload,
    verdict,
)

POLICIES = DEMO_POLICIES
#: mean time to accuracy [min] per policy; per-run spread 13 min, shared by every policy in a
#: run (paired) plus 4 min of its own; runs never localised: beyond 45 min (inf)
MEANS = {"straight": 43.0, "single-turn": 29.3, "zigzag": 30.0, "planned": 27.9,
         "receding": 23.0, "planned+uniform": 9.0, "planned+scheduled": 3.0,
         "planned+scheduled-terminal": 26.0, "receding+scheduled": 3.0}
CENSOR = 45.25 * 60.0


def _campaign(runs, seed, policies=POLICIES, command=None):
    rng = np.random.default_rng(seed)
    common = rng.normal(0.0, 13.0, runs)
    err_common = rng.normal(0.0, 30.0, runs)
    tta, fre = {}, {}
    for i, p in enumerate(policies):
        t = 60.0 * np.clip(MEANS[p] + common + rng.normal(0.0, 4.0, runs), 0.0, None)
        tta[p] = np.where(t > 45 * 60.0, np.inf, t)
        fre[p] = np.abs(100.0 + 10.0 * i + err_common + rng.normal(0.0, 5.0, runs))
    cmd = command or (f"tmaplan compare default --policies {','.join(policies)} --runs {runs} "
                      f"--seed {seed} --workers 2")
    return Comparison.from_values(command=cmd, seed=seed, times_to_accuracy=tta,
                                  final_range_errors=fre, censor=CENSOR, commit="abc1234",
                                  first_runs=3)


def _pd(a="planned", b="single-turn", mean=-60.0, lo=-90.0, hi=-30.0, n=2000,
        metric="time_to_accuracy"):
    return PairedDifference(a=a, b=b, metric=metric, mean=mean, ci_low=lo, ci_high=hi,
                            level=0.95, n=n)


def test_verdicts_name_the_winner_only_when_the_interval_excludes_zero():
    assert verdict(_pd()) == "planned sooner"
    assert verdict(_pd(mean=60.0, lo=30.0, hi=90.0)) == "single-turn sooner"
    assert verdict(_pd(mean=-10.0, lo=-40.0, hi=20.0, n=40)) == "not decided at 40 runs"
    assert verdict(_pd(metric="final_range_error")) == "planned smaller"
    assert verdict(_pd(n=1, lo=-np.inf, hi=np.inf)) == "no interval with 1 run"


def test_a_live_verdict_is_set_against_the_stored_one():
    stored = _pd()
    # undecided live: says so, and what the stored runs decide
    v = verdict(_pd(mean=250.0, lo=-80.0, hi=580.0, n=40), stored)
    assert v == "not decided at 40 runs (stored 2000 runs: planned sooner)"
    # decided the same way
    assert verdict(_pd(n=40, lo=-200.0, hi=-5.0), stored) == ("planned sooner, as the stored "
                                                             "2000 runs")
    # decided the other way: chance, not a ranking; the live winner is not named as such
    v = verdict(_pd(mean=300.0, lo=10.0, hi=590.0, n=40), stored)
    assert "opposite to the stored 2000 runs" in v and "not a ranking" in v
    assert "sooner" not in v
    # decided live where the stored runs do not decide
    v = verdict(_pd(n=40), _pd(mean=-5.0, lo=-20.0, hi=10.0))
    assert v == "planned sooner; the stored 2000 runs do not decide it"


def test_difference_of_flips_a_stored_b_minus_a():
    d = _pd(a="single-turn", b="planned", mean=60.0, lo=30.0, hi=90.0)
    f = difference_of([d], "planned", "single-turn", "time_to_accuracy")
    assert (f.a, f.b, f.mean, f.ci_low, f.ci_high, f.n) == ("planned", "single-turn", -60.0,
                                                           -90.0, -30.0, 2000)
    assert difference_of([d], "planned", "single-turn", "final_range_error") is None
    assert difference_of([d], "planned", "zigzag", "time_to_accuracy") is None


def test_from_values_matches_the_project_s_paired_difference():
    c = _campaign(50, 1)
    d = difference_of(c.differences, "planned", "single-turn", "time_to_accuracy")
    # independent: the same draws, censored by hand
    rng = np.random.default_rng(1)
    common = rng.normal(0.0, 13.0, 50)
    rng.normal(0.0, 30.0, 50)
    vals = {}
    for p in POLICIES:
        t = 60.0 * np.clip(MEANS[p] + common + rng.normal(0.0, 4.0, 50), 0.0, None)
        vals[p] = np.where(t > 45 * 60.0, CENSOR, t)
        rng.normal(0.0, 5.0, 50)
    ref = paired_difference(vals, "planned", "single-turn", "time_to_accuracy")
    assert d.mean == pytest.approx(ref.mean, rel=1e-12)
    assert (d.ci_low, d.ci_high) == pytest.approx((ref.ci_low, ref.ci_high), rel=1e-12)
    assert c.stats["planned"]["mean_time_to_accuracy"] == pytest.approx(vals["planned"].mean())
    assert c.stats["planned"]["runs"] == 50
    assert len(c.first_runs["planned"]["time_to_accuracy"]) == 3


def _numbers(line):
    return [float(x) for x in re.findall(r"[+-]\d+(?:\.\d+)?", line)]


def test_every_key_line_has_an_interval_and_no_undecided_ranking():
    live = _campaign(40, 7)
    lines = key_lines(live)
    pairs = [x for x in lines if x.startswith("    ")]
    assert len(pairs) == len(KEY_DIFFERENCES)
    seen = set()
    for line in pairs:
        mean, lo, hi = _numbers(line.split("  ", 2)[-1])[:3]
        assert lo <= mean <= hi, line
        decided = lo > 0 or hi < 0
        seen.add(decided)
        assert ("not decided at 40 runs" in line) == (not decided), line
        if not decided:
            assert "sooner" not in line and "smaller" not in line, line
    assert seen == {True, False}  # both kinds are exercised
    # at 40 runs the 1.4-min difference of planned and the single turn is not decided
    d = difference_of(live.differences, "planned", "single-turn", "time_to_accuracy")
    assert d.ci_low < 0 < d.ci_high


def test_stored_result_round_trips_and_decides_with_more_runs(tmp_path):
    big = _campaign(2000, 38, POLICIES[:4])
    small = _campaign(300, 38)
    stored = StoredResult(problem="default", campaigns=(small, big), date="2026-11-28")
    path = tmp_path / "stored.json"
    path.write_text(json.dumps(stored_payload(stored)))
    back = load_stored(path)
    assert back == stored
    merged = back.merged()
    assert merged.policies[:4] == POLICIES[:4] and set(merged.policies) == set(POLICIES)
    # each pair from the largest campaign that flew both
    assert difference_of(merged.differences, "planned", "single-turn",
                         "time_to_accuracy").n == 2000
    assert difference_of(merged.differences, "receding", "planned",
                         "time_to_accuracy").n == 300
    assert merged.stats["planned"]["runs"] == 2000 and merged.stats["planned+uniform"][
        "runs"] == 300
    lines = stored_lines(back)
    assert lines[0].startswith("Stored result of 2000 and 300 paired runs on 'default'")
    assert any(big.command in x and "2000 runs, seed 38, commit abc1234" in x for x in lines)
    assert any(small.command in x for x in lines)
    text = "\n".join(lines)
    assert "planned − single-turn" in text
    assert re.search(r"planned − single-turn .*\[.*\] +planned sooner", text), text


def test_live_lines_are_labelled_illustrative_and_set_against_the_stored_result():
    stored = StoredResult(problem="default", campaigns=(_campaign(2000, 38),))
    live = _campaign(40, 7)
    lines = live_lines(live, stored)
    assert lines[0].startswith("This run (illustrative: 40 paired runs, seed 7")
    undecided = [x for x in lines if "not decided at 40 runs" in x]
    assert undecided and all("(stored 2000 runs: " in x for x in undecided)
    # the per-policy lines keep the campaign's order: no ranking by the live means
    names = [x.split()[0] for x in lines[1:1 + len(POLICIES)]]
    assert names == list(POLICIES)
    js = key_json(live, stored=stored)
    assert [(d["a"], d["b"], d["metric"]) for d in js] == list(KEY_DIFFERENCES)
    for d in js:
        assert d["ci_low"] <= d["mean"] <= d["ci_high"] and d["n"] == 40
        assert d["decided"] == (d["ci_low"] > 0 or d["ci_high"] < 0)
        assert d["decided"] or "not decided at 40 runs" in d["verdict"]


def test_html_sections_say_the_same():
    stored = StoredResult(problem="default", campaigns=(_campaign(2000, 38),))
    live = _campaign(40, 7)
    page = stored_html(stored) + live_html(live, stored)
    assert "Stored result of 2000 paired runs" in page
    assert stored.campaigns[0].command in page
    assert "illustrative (40 paired runs, seed 7)" in page
    table = key_table_html(live, stored=stored)
    for row in re.findall(r"<tr><td>.*?</tr>", table):
        cells = re.findall(r"<td>(.*?)</td>", row)
        assert cells[3].startswith("[") and cells[3].endswith("]"), cells
        lo, hi = (float(x) for x in cells[3][1:-1].split(","))
        assert ("not decided at 40 runs" in cells[4]) == (not (lo > 0 or hi < 0)), cells


def test_a_pair_the_stored_result_lacks_is_shown_on_its_own():
    live = _campaign(40, 7)
    only = StoredResult(problem="default",
                        campaigns=(_campaign(2000, 38, ("straight", "planned")),))
    js = {(d["a"], d["b"], d["metric"]): d for d in key_json(live, stored=only)}
    alone = js["planned", "zigzag", "time_to_accuracy"]
    assert "stored" not in alone["verdict"]
    assert "stored 2000 runs" in js["planned", "straight", "time_to_accuracy"]["verdict"]
    assert key_lines(dataclasses.replace(live, differences=())) == []


@pytest.mark.parametrize(("lo", "hi", "decided"), [(-90.0, -30.0, True), (-90.0, 30.0, False)])
def test_the_report_summary_ranks_the_lowest_mean_only_when_decided(lo, hi, decided):
    from types import SimpleNamespace

    from tmaplan.report_tables import differences_html

    d = _pd(a="planned", b="single-turn", mean=-30.0, lo=lo, hi=hi, n=40)
    text = differences_html(SimpleNamespace(policies=("planned", "single-turn"),
                                            differences=(d,)))
    assert ("lowest mean with <strong>planned</strong>" in text) == decided
    assert ("lowest mean not decided at 40 runs" in text) == (not decided)
    assert ("no: not decided at 40 runs" in text) == (not decided)
