"""Review of the rank-costs report: the figure's axes carry the costs' units, the page's
title is escaped like its heading."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from tmaplan.ranking_report import plot_cost_ranking, write_ranking_report


def _result(problem: str = "default") -> SimpleNamespace:
    names = ("mean-range-bound", "expected-time-to-accuracy", "mean-expected-crlb-range",
             "pcrb-cartesian-range")
    costs = tuple(SimpleNamespace(name=n, values=np.arange(3.0) + i, spearman=0.5,
                                  spearman_ci=(0.1, 0.9), kendall=0.3, spearman_rmse=0.4,
                                  spearman_rmse_ci=(0.0, 0.8)) for i, n in enumerate(names))
    spec = SimpleNamespace(runs=3, n_particles=100, seed=0, accuracy=0.1)
    return SimpleNamespace(problem=problem, candidates=("straight", "zigzag", "planned"),
                           families=("straight", "zigzag", "planned"), costs=costs,
                           time_to_accuracy=np.array([900.0, 600.0, 300.0]),
                           final_range_rmse=np.array([3e3, 2e3, 1e3]), censor=2760.0,
                           default_objective="mean-range-bound",
                           closed_loop_objective="expected-time-to-accuracy", skipped={},
                           campaign=SimpleNamespace(spec=spec))


def test_cost_axes_carry_the_costs_units(tmp_path):
    """The x axes said "cost (minimised)" for costs in m, s and fractions of the horizon."""
    fig = plot_cost_ranking(_result(), tmp_path / "r.png")
    labels = [ax.get_xlabel() for ax in fig.axes if ax.get_visible()]
    assert labels[0].startswith("mean-range-bound [m]")
    assert labels[1].startswith("expected-time-to-accuracy [s]")
    assert labels[2].startswith("mean-expected-crlb-range [m]")
    assert labels[3].startswith("pcrb-cartesian-range [m]")
    from tmaplan.ranking_report import cost_label

    assert cost_label("my-cost") == "my-cost"


def test_problem_name_is_escaped_in_the_page_title(tmp_path):
    """A scenario name may hold '<' and '&' (only '/', '\\' and control characters are
    refused); the <title> wrote it raw. The report is named after the problem."""
    path = write_ranking_report(_result("a<b>&<script>"), tmp_path, command="tmaplan x")
    assert path.name == "a<b>&<script>_rank-costs.html"
    text = path.read_text()
    assert "<title>tmaplan rank-costs: a&lt;b&gt;&amp;&lt;script&gt;</title>" in text
    assert "<b>" not in text and "<script>" not in text


def test_an_accuracy_below_one_percent_is_not_printed_as_zero(tmp_path):
    res = _result()
    res.campaign.spec.accuracy = 0.025
    flat = " ".join(write_ranking_report(res, tmp_path, command="x").read_text().split())
    assert "below 2.5% and staying" in flat
