"""The report's RMSE figure overlays the truth-conditioned PCRB over the campaign's own runs
(ristic2004, ch. 6), names it, and states the filter's efficiency RMSE/PCRB."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.bounds.truth_bound import truth_bounds
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.report import BOUND_NAME, efficiency, rmse_figure, write_report
from tmaplan.scenario import load_problem

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")


@pytest.fixture(scope="module")
def result():
    spec = CampaignSpec(scenario=load_problem("default"),
                        policies=("straight", "zigzag+uniform"), runs=2, seed=5,
                        n_particles=300)
    return run_campaign(spec)


def test_campaign_bound_is_the_truth_bound_along_each_run(result):
    sc = result.spec.scenario
    s = result.summary["straight"]
    assert s["bound_position"].shape == (sc.n_steps + 1,)
    # run 0 alone, without pings, through truth_bounds (positions only: the information
    # depends on the relative position); the campaign averages covariances over 2 runs, so
    # its squared bound is at least half of run 0's.
    ex = result.examples["straight"]
    pos0, rng0 = truth_bounds(sc, (ex.target - ex.observer)[None])
    assert np.all(s["bound_position"] ** 2 >= 0.5 * pos0**2 * (1 - 1e-9))
    assert np.all(s["bound_range"] ** 2 >= 0.5 * rng0**2 * (1 - 1e-9))
    assert np.all(s["bound_range"] <= s["bound_position"] * (1 + 1e-9))
    # the pings of zigzag+uniform make its range bound drop at the first ping of run 0
    z = result.summary["zigzag+uniform"]
    k = int(result.examples["zigzag+uniform"].ping_steps[0])
    assert z["bound_range"][k] < 0.8 * z["bound_range"][k - 1]


def test_rmse_figure_overlays_the_named_bound_and_states_efficiency(result, tmp_path):
    fig = rmse_figure(result)
    eff = efficiency(result)
    ax_pos, ax_rng = fig.axes[:2]
    assert "truth-conditioned PCRB" in fig.get_suptitle()
    assert BOUND_NAME in fig.get_suptitle()
    for ax, key in ((ax_pos, "bound_position"), (ax_rng, "bound_range")):
        dotted = [ln for ln in ax.get_lines() if ln.get_linestyle() == ":"]
        assert len(dotted) == len(result.policies)
        for ln, name in zip(dotted, result.policies):
            np.testing.assert_allclose(ln.get_ydata(), result.summary[name][key])
    labels = [t.get_text() for t in ax_pos.get_legend().get_texts()]
    for name in result.policies:
        e = eff[name]
        s = result.summary[name]
        assert e["final_position"] == pytest.approx(
            s["rmse_position"][-1] / s["bound_position"][-1])
        assert e["final_range"] == pytest.approx(s["rmse_range"][-1] / s["bound_range"][-1])
        assert any(name in lab and f"{e['final_position']:.2g}" in lab for lab in labels)
    text = write_report(result, tmp_path, command="x").read_text()
    assert "truth-conditioned PCRB" in text and "RMSE / PCRB final" in text
