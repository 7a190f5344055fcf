"""The report is one to hand to a colleague: display units (km, kn, °, min), no raw numpy
reprs, a summary of the key paired differences above the collapsible full table,
small-sample warnings, figures whose lines and legends do not hide one another, short reprs
of results. The same checks run on the HTML text everywhere and on the DOM rendered by
headless Chromium where it is installed."""

from __future__ import annotations

import html
import re
import shutil
import subprocess
from types import SimpleNamespace

import numpy as np
import pytest

from tmaplan.cli.demo import _extra_html
from tmaplan.display import minute_list, scenario_text, short_repr, timespan
from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.ranking_report import candidate_label
from tmaplan.report import comparison_figures, rmse_figure, write_report
from tmaplan.report_tables import baseline_parameters, differences_html, sample_warning
from tmaplan.scenario import list_problems, load_problem, loads, to_dict

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

POLICIES = ("straight", "single-turn", "zigzag+uniform")


@pytest.fixture(scope="module")
def one_run():
    spec = CampaignSpec(scenario=load_problem("default"), policies=POLICIES, runs=1, seed=3,
                        n_particles=200)
    return run_campaign(spec)


@pytest.fixture(scope="module")
def three_runs():
    spec = CampaignSpec(scenario=load_problem("default"), policies=POLICIES, runs=3, seed=3,
                        n_particles=200)
    return run_campaign(spec)


def _demo_extra() -> str:
    # the demo's plan and baselines as the planner returns them: numpy scalars in SI
    plan = SimpleNamespace(objective=np.float64(50.6), status="Solve_Succeeded", seconds=0.7)
    best = {"straight": SimpleNamespace(objective=np.float64(80.1), params={}),
            "single-turn": SimpleNamespace(objective=np.float64(61.0), params={
                "angle": np.float64(2.0943951023931953), "time": np.float64(900.0)}),
            "zigzag": SimpleNamespace(objective=np.float64(66.0), params={
                "leg_duration": np.float64(675.0), "angle": np.float64(-1.0471975511965976)})}
    sched = SimpleNamespace(times=np.array([15.0, 330.0]), method="relaxed",
                            status="feasible", objective=95.1, uniform_objective=123.0,
                            no_ping_objective=149.9)
    return _extra_html(plan, best, sched)


@pytest.fixture(scope="module")
def report(one_run, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    return write_report(one_run, out, command="tmaplan compare default --runs 1",
                        extra_html=_demo_extra())


def _visible_text(html_text: str) -> str:
    """The text without embedded images, entities decoded."""
    return html.unescape(re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "", html_text))


def check_display_units(text: str) -> None:
    """What a reader must not see, and the scenario values they must see in display units."""
    assert "np.float64(" not in text and "array(" not in text and "np.int" not in text
    # no long SI decimals (course 3.4906585 rad, speed 4.1155555 m/s, 0.0087266 rad/s)
    assert not re.search(r"\d\.\d{5,}", text), re.search(r".{40}\d\.\d{5,}.{20}", text)
    for shown in ('course = "200 deg"', 'speed = "8 kn"', 'turn_rate_max = "0.5 deg/s"',
                  'horizon = "45 min"', 'range_max = "25 km"', 'sigma = "1 deg"'):
        assert shown in text, shown
    assert "inf" not in re.sub(r"information|infinite|info", "", text.lower())
    assert not re.search(r"\bnan\b", text.lower())


def test_report_text_is_in_display_units(report):
    text = _visible_text(report.read_text(encoding="utf-8"))
    check_display_units(text)
    assert "turn +120° at 15.0 min" in text and "first turn -60°, legs of 11.2 min" in text
    assert "final range RMSE [km]" in text and "final speed RMSE [kn]" in text


def test_summary_above_the_collapsible_full_table(three_runs):
    text = differences_html(three_runs)
    assert text.index("<h3>Summary</h3>") < text.index("<details>")
    full = text[text.index("<details>"):]
    n_pairs = len(POLICIES) * (len(POLICIES) - 1) // 2
    assert full.count("<tr>") == 1 + 2 * n_pairs and "</details>" in full
    summary = text[:text.index("<details>")]
    assert summary.count("<li>") == 2  # one line per metric
    assert "time to accuracy" in summary and " min" in summary and " km" in summary


def test_small_sample_warnings(one_run, three_runs):
    assert "undefined (no spread" in sample_warning(1)
    assert "2 degree(s) of freedom" in sample_warning(3)
    assert sample_warning(10) == ""
    ranking = sample_warning(3, ranking=True)
    assert "3 Monte Carlo runs per candidate" in ranking and "bootstrap" in ranking
    assert "degree(s) of freedom" not in ranking and sample_warning(10, ranking=True) == ""
    text = differences_html(one_run)
    assert "undefined (1 run)" in text and "interval undefined" in text
    assert "no confidence interval with a single run" in text and "better than" not in text
    assert "inf" not in text
    assert "[" in differences_html(three_runs)


def test_scenario_text_round_trips_for_every_problem():
    for p in list_problems():
        sc = load_problem(p["name"])
        text = scenario_text(to_dict(sc))
        back = loads(text, source="display")
        assert back.name == sc.name
        a, b = np.asarray(sc.times), np.asarray(back.times)
        np.testing.assert_allclose(a, b, rtol=1e-5)
        for c0, c1 in zip(sc.contacts, back.contacts, strict=True):  # each contact's target
            t0, t1 = c0.target, c1.target
            for f in ("speed", "course", "omega", "radius", "q"):
                x, y = getattr(t0, f, None), getattr(t1, f, None)
                assert (x is None) == (y is None), f
                if x is not None:
                    assert y == pytest.approx(x, rel=1e-5, abs=1e-12), (p["name"], f)
        assert not re.search(r"\d\.\d{7,}", text), p["name"]


def test_baseline_parameters_and_candidate_labels_in_words():
    assert baseline_parameters({}) == "no turn"
    assert baseline_parameters({"angle": np.float64(-np.pi / 2), "time": 600.0}) == \
        "turn -90° at 10.0 min"
    assert candidate_label("single-turn:+60deg@900s") == "single-turn +60° at 15 min"
    assert candidate_label("zigzag:-30deg,leg600s") == "zigzag -30°, legs of 10 min"


def test_short_reprs(one_run):
    from tmaplan.simulate import simulate

    r = repr(one_run)
    assert len(r) < 800 and r.startswith("CampaignResult(") and "array(" not in r
    sim = simulate(load_problem("default"), np.random.default_rng(0))
    for obj in (sim, sim.observer):
        r = repr(obj)
        assert len(r) < 600 and "<float64 array (181" in r, r
    assert short_repr(3) == object.__repr__(3)


def test_heading_plan_and_belief_reprs_are_short():
    # repr(plan) was 35 000 characters (every array printed)
    from tmaplan.planning import Belief, HeadingPlanner

    sc = load_problem("default")
    belief = Belief.from_prior(sc)
    plan = HeadingPlanner(sc, horizon=600.0, n_starts=1).solve(belief)
    for obj in (plan, belief, plan.observer):
        r = repr(obj)
        assert len(r) < 600 and "array(" not in r and "\n" not in r, r
    assert f"objective={plan.objective:.4g}" in repr(plan)
    assert "samples=<float64 array (" in repr(belief)


def test_tracks_lines_all_visible_and_legends_outside(three_runs, tmp_path):
    from matplotlib.image import imread

    paths = comparison_figures(three_runs, tmp_path)
    assert imread(paths["tracks"]).shape[1] > 900
    fig = rmse_figure(three_runs)
    fig.canvas.draw()
    for ax in fig.axes[:2]:
        lines = [ln for ln in ax.get_lines() if ln.get_linestyle() != ":"]
        styles = {(ln.get_linestyle(), ln.get_linewidth()) for ln in lines}
        assert len(styles) == len(lines) == len(POLICIES)
        z = [ln.get_zorder() for ln in lines]
        assert z == sorted(z) and len(set(z)) == len(z)  # later policies on top, thinner
        widths = [ln.get_linewidth() for ln in lines]
        assert widths == sorted(widths, reverse=True)
        leg = ax.get_legend().get_window_extent()
        assert leg.y1 <= ax.get_window_extent().y0 + 1.0  # below the axes, over no data


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(_chromium() is None, reason="no headless chromium on this machine")
def test_report_rendered_in_headless_chromium(report, tmp_path):
    proc = subprocess.run(
        [str(_chromium()), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", f"--user-data-dir={tmp_path / 'chrome'}",
         "--virtual-time-budget=5000", "--dump-dom", report.as_uri()],
        capture_output=True, text=True, timeout=120)
    dom = proc.stdout
    assert "<h1>" in dom, proc.stderr[-2000:]
    assert 'data-images-loaded="3"' in dom
    check_display_units(_visible_text(dom))
    assert "Warning: small sample" in dom and "<details>" in dom


def _undefined_differences():
    """Three policies whose a-b and b-c mean differences are undefined (NaN)."""
    from tmaplan.evaluation.metrics import PairedDifference

    nan = float("nan")

    def pd(a, b, mean, lo, hi):
        return PairedDifference(a=a, b=b, metric="final_range_error", mean=mean, ci_low=lo,
                                ci_high=hi, level=0.95, n=3)

    return SimpleNamespace(policies=("a", "b", "c"), differences=(
        pd("a", "b", nan, nan, nan), pd("a", "c", -500.0, -900.0, -100.0),
        pd("b", "c", nan, nan, nan)))


def test_undefined_differences_are_said_not_printed_as_nan():
    fake = _undefined_differences()
    text = differences_html(fake)
    assert "nan" not in text.lower() and "undefined" in text
    assert "lowest mean with <strong>a</strong>" in text and "-0.5 km" in text


def test_policy_styles_are_never_dotted_like_the_bounds():
    from tmaplan.report import line_style

    for i in range(12):
        ls = line_style(i)["ls"]
        assert ls not in (":", "dotted")
        if isinstance(ls, tuple):
            assert max(ls[1][::2]) >= 5  # a dash, not dots


def test_summary_names_the_policies_whose_mean_is_undefined():
    """A policy whose mean difference is undefined (a non-finite final error in one run) was
    left out of the summary line without a word: "better than 1 of the 1 other policies"
    with three policies compared."""
    fake = _undefined_differences()
    summary = differences_html(fake).split("<details>")[0]
    assert "better than 1 of the 1 other policies" in summary
    assert "Mean undefined for b." in summary


def test_an_accuracy_below_one_percent_is_not_printed_as_zero(one_run, tmp_path):
    """The report and the time-to-accuracy figure printed the accuracy with ``:.0%``: 0.005
    was "below 0%", 0.025 "below 2%"."""
    import dataclasses

    res = dataclasses.replace(one_run, spec=dataclasses.replace(one_run.spec, accuracy=0.005))
    text = write_report(res, tmp_path, command="tmaplan compare default").read_text()
    flat = " ".join(text.split())
    assert "below 0.5% and staying there" in flat and "below 0% " not in flat


@pytest.mark.parametrize("seconds, text", [(40.0, "40 s"), (2700.0, "45 min"),
                                           (750.0, "12.5 min"), (700.0, "11.67 min"),
                                           (60.0, "1 min"), (float("nan"), "undefined")])
def test_timespan_reads_as_a_person_writes_it(seconds, text):
    """No ``0.666667 min`` in a console line: seconds below a minute, else at most two
    decimals of a minute."""
    assert timespan(seconds) == text


def test_minute_list_formats_scenario_times():
    assert minute_list([840.0, 1620.0]) == "14.0, 27.0 min"
    assert minute_list(np.array([600.0]), 0) == "10 min" == minute_list(600.0, 0)
    assert minute_list([]) == "none"


def test_a_short_scenario_prints_its_horizon_in_seconds(capsys, tmp_path):
    from tmaplan.cli import main

    f = tmp_path / "short.toml"
    from tmaplan.scenario import load_problem, save

    sc = load_problem("default")
    save(sc.replace(time=sc.time.__class__(dt=10.0, horizon=40.0, t0=sc.time.t0)), f)
    assert main(["simulate", str(f), "--no-figure"]) == 0
    assert "over 40 s;" in capsys.readouterr().out
