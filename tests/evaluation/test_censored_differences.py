"""A paired difference of times to accuracy over runs that neither policy localised is not a
tie (issue 40's acceptance sweep): each such run is censored at the horizon + dt on both
sides, so its difference is zero by construction and decides nothing. The difference counts
those runs (``both_censored``, in ``compare``'s JSON), the report and the demo's console say
how many, and a difference censored on both sides in every run is "undetermined", never
``0 [0, 0] min``."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from tmaplan.evaluation.metrics import PairedDifference, censored_note, paired_difference
from tmaplan.headline import Comparison, key_json, key_lines, verdict
from tmaplan.report_tables import censored_lines, differences_html

INF = np.inf
CENSOR = 301.0  # the horizon + dt [s]


def test_runs_censored_on_both_sides_are_counted():
    vals = {"a": np.array([INF, INF, 100.0, INF, 50.0]),
            "b": np.array([INF, 200.0, INF, INF, 60.0])}
    d = paired_difference(vals, "a", "b", "time_to_accuracy", censor=CENSOR)
    assert d.both_censored == 2 and not d.undetermined
    assert censored_note(d) == ("2 of 5 paired runs censored on both sides (neither policy "
                                "localised)")
    never = {"a": np.full(4, INF), "b": np.full(4, INF)}
    d = paired_difference(never, "a", "b", "time_to_accuracy", censor=CENSOR)
    assert (d.mean, d.ci_low, d.ci_high) == (0.0, 0.0, 0.0)  # the numbers a tie would have
    assert d.both_censored == 4 and d.undetermined
    assert censored_note(d) == "undetermined: neither policy localised in any of the 4 paired runs"
    # a metric without censoring counts none; a stored difference without the count says nothing
    d = paired_difference({"a": np.ones(3), "b": np.ones(3)}, "a", "b", "final_range_error")
    assert d.both_censored == 0 and not d.undetermined and censored_note(d) == ""
    old = PairedDifference(a="a", b="b", metric="time_to_accuracy", mean=0.0, ci_low=0.0,
                           ci_high=0.0, level=0.95, n=4)
    assert old.both_censored is None and not old.undetermined and censored_note(old) == ""


def _fake(tta_a, tta_b):
    """A campaign's differences (time to accuracy censored, final range error) of a and b."""
    tta = {"a": np.asarray(tta_a, float), "b": np.asarray(tta_b, float)}
    fre = {"a": np.array([900.0, 1100.0, 1000.0, 1300.0]),
           "b": np.array([1000.0, 1150.0, 1200.0, 1250.0])}
    return SimpleNamespace(policies=("a", "b"), differences=(
        paired_difference(tta, "a", "b", "time_to_accuracy", censor=CENSOR),
        paired_difference(fre, "a", "b", "final_range_error")))


def test_the_report_says_undetermined_not_a_zero_interval():
    text = differences_html(_fake([INF] * 4, [INF] * 4))
    summary = text.split("<details>")[0]
    assert ("<strong>time to accuracy</strong>: undetermined: no policy localised in any of "
            "the 4 paired runs.") in summary
    assert "[+0, +0]" not in text and "+0 min" not in text
    assert ("<td>undetermined</td><td>undetermined</td><td>undetermined: neither policy "
            "localised in any of the 4 paired runs</td>") in text
    # the final range error is unaffected
    assert "final range error</strong>: lowest mean" in summary
    assert censored_lines(_fake([INF] * 4, [INF] * 4)) == [
        "a − b, time to accuracy: undetermined: neither policy localised in any of the 4 "
        "paired runs"]


def test_the_report_counts_runs_censored_on_both_sides():
    fake = _fake([INF, INF, 100.0, 120.0], [INF, 250.0, 200.0, 260.0])
    text = differences_html(fake)
    assert "1 of 4 paired runs censored on both sides (neither policy localised)" in text
    assert "undetermined" not in text.replace("is undetermined)", "")
    assert censored_lines(fake) == ["a − b, time to accuracy: 1 of 4 paired runs censored on "
                                    "both sides (neither policy localised)"]
    # no run censored on both sides: no line, the report as before
    assert censored_lines(_fake([50.0, INF, 100.0, 120.0], [INF, 250.0, 200.0, 260.0])) == []


def test_the_demo_lines_say_undetermined():
    never = {"planned": np.full(5, INF), "straight": np.full(5, INF)}
    fre = {"planned": np.full(5, 1e3) + np.arange(5.0), "straight": np.full(5, 2e3)}
    live = Comparison.from_values(command="c", seed=0, times_to_accuracy=never,
                                  final_range_errors=fre, censor=CENSOR)
    keys = (("planned", "straight", "time_to_accuracy"),)
    lines = key_lines(live, keys=keys)
    assert "undetermined" in lines[1] and "[+0.00, +0.00]" not in lines[1], lines
    assert lines[1].endswith("undetermined: neither policy localised in any of the 5 paired "
                             "runs"), lines
    (row,) = key_json(live, keys=keys)
    assert row["both_censored"] == 5 and not row["decided"]
    # a stored decided difference does not make it decided either
    stored = PairedDifference(a="planned", b="straight", metric="time_to_accuracy",
                              mean=-60.0, ci_low=-90.0, ci_high=-30.0, level=0.95, n=2000)
    d = next(x for x in live.differences if x.metric == "time_to_accuracy")
    assert verdict(d, stored).startswith("undetermined")


def test_the_several_contact_metrics_read_in_display_units():
    """The report printed the aggregate metrics of several contacts in SI without a unit
    (``+0  ([+0, +0] ,``; a final error of ``-607  ([-3.13e+03, +1.92e+03] ,``)."""
    tta = {"a": np.array([100.0, 200.0, INF]), "b": np.array([160.0, 230.0, 250.0])}
    fre = {"a": np.array([900.0, 1100.0, 1000.0]), "b": np.array([1500.0, 1150.0, 1700.0])}
    fake = SimpleNamespace(policies=("a", "b"), differences=(
        paired_difference(tta, "a", "b", "time_to_accuracy_all", censor=CENSOR),
        paired_difference(fre, "a", "b", "worst_final_range_error")))
    text = differences_html(fake)
    assert "<strong>time until every contact is localised</strong>" in text
    assert "<strong>worst contact's final range error</strong>" in text
    assert "<td>-0.217 min</td>" in text and "<td>-0.45 km</td>" in text, text
