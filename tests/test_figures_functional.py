"""Plan and schedule figures plot the functional that was optimised, named with its units,
with the baselines evaluated on the same functional (issue 13, item 5)."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.display import objective_label
from tmaplan.models.observer import observer_track
from tmaplan.planning import Belief, HeadingPlanner, evaluate_baselines, schedule_pings
from tmaplan.planning.objectives import ObjectiveEvaluator
from tmaplan.plotting import plot_plan, plot_schedule
from tmaplan.scenario import load_problem


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


@pytest.mark.parametrize(("objective", "unit"), [("mean-relative-range-crlb", "[σ_r/r, –]"),
                                                 ("range-bound", "[m]"),
                                                 ("logdet", "[−ln det FIM, SI units]")])
def test_plan_figure_plots_the_optimised_functional(scenario, tmp_path, objective, unit):
    planner = HeadingPlanner(scenario, objective=objective, n_starts=1)
    belief = Belief.from_prior(scenario)
    plan = planner.solve(belief)
    base = evaluate_baselines(scenario, planner.objective, belief=belief, n_steps=planner.K)
    fig = plot_plan(plan, base, belief, tmp_path / "plan.png", objective=planner.objective.name)
    assert (tmp_path / "plan.png").stat().st_size > 0
    bx = fig.axes[1]
    assert objective in bx.get_title() and unit in bx.get_title()
    assert objective_label(objective) in bx.get_xlabel()
    widths = [p.get_width() for p in bx.patches]
    # the plotted bars are the functional the planner minimised, re-evaluated here on the
    # plan's track by an independent evaluator, and the baselines' best on the same one
    ev = ObjectiveEvaluator(scenario, objective, n_steps=planner.K, belief=belief)
    assert widths[0] == pytest.approx(ev(plan.observer)[0], rel=1e-6, abs=1e-9)
    for w, (name, lst) in zip(widths[1:], base.items(), strict=True):
        assert w == pytest.approx(ev(lst[0].track)[0], rel=1e-9, abs=1e-12), name
    # every candidate of each baseline grid appears as a dot on its family's row
    dots = {round(ln.get_ydata()[0]): ln.get_xdata() for ln in bx.get_lines()}
    for i, lst in enumerate(base.values(), start=1):
        np.testing.assert_allclose(dots[i], [b.objective for b in lst])
    if objective != "range-bound":  # not the closed-form range bound in disguise
        assert not np.isclose(widths[0], plan.range_bound[-1], rtol=1e-3)


@pytest.mark.parametrize("objective", ["mean-range-bound", "terminal-range-bound",
                                       "mean-position-bound"])
def test_schedule_figure_plots_the_optimised_functional(scenario, tmp_path, objective):
    belief = Belief.from_prior(scenario)
    res = schedule_pings(scenario, budget=2, method="greedy", objective=objective,
                         belief=belief)
    fig = plot_schedule(scenario, observer_track(scenario.observer, scenario.time), belief,
                        res, tmp_path / "s.png")
    ax = fig.axes[0]
    assert objective_label(objective) in ax.get_title() and "[m]" in ax.get_title()
    values = [res.no_ping_objective, res.uniform_objective, res.objective]
    lines = ax.get_lines()
    curves = [ln for ln in lines if len(ln.get_xdata()) == scenario.n_steps + 1]
    assert len(curves) == 3
    if objective.startswith("mean-"):
        # each curve's mean over the horizon is the plotted horizontal line, is the value
        flat = [ln for ln in lines if len(ln.get_ydata()) == 2
                and ln.get_ydata()[0] == ln.get_ydata()[1] and ln.get_xdata()[0] == 0]
        ys = sorted(float(ln.get_ydata()[0]) for ln in flat)
        np.testing.assert_allclose(ys, sorted(values), rtol=1e-9)
        for c, v in zip(curves, values, strict=True):
            assert np.mean(c.get_ydata()) == pytest.approx(v, rel=1e-6)
    else:
        for c, v in zip(curves, values, strict=True):
            assert c.get_ydata()[-1] == pytest.approx(v, rel=1e-6)
    assert res.objective <= res.uniform_objective * (1 + 1e-9)


def test_objective_label_units():
    assert objective_label("range-bound") == "range-bound [m]"
    assert objective_label("expected-time-to-accuracy") == "expected-time-to-accuracy [s]"
    assert objective_label("mean-position-bound+0.5*turn-penalty") == (
        "mean-position-bound [m] + 0.5*turn-penalty [–]")
    assert objective_label("something-new") == "something-new"
