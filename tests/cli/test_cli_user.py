"""Command line as a new user meets it: a scenario whose clock starts at t0 = 1 h, in nmi, kn
and minutes, with two sensors (bearings every second step, pings left to the scheduler)."""

from __future__ import annotations

import json

from tmaplan.cli import main

T0 = 3600.0
SCENARIO = """
name = "late-start"
[time]
t0 = "1 h"
dt = "20 s"
horizon = "10 min"
[target]
model = "ncv"
position = ["3 nmi", "4 nmi"]
speed = "12 kn"
course = "180 deg"
q = "1e-6 m^2/s^3"
[observer]
speed = "6 kn"
course = "90 deg"
turn_rate_max = "1 deg/s"
[[sensors]]
kind = "bearing"
sigma = "1 deg"
every = 2
[[sensors]]
kind = "range"
sigma = "30 m"
steps = []
[prior]
kind = "polar"
bearing_mean = "37 deg"
bearing_std = "2 deg"
range_distribution = "uniform"
range_min = "2 nmi"
range_max = "8 nmi"
velocity_distribution = "speed-course"
speed_distribution = "uniform"
speed_max = "15 kn"
course_mode = "uniform"
samples = 500
[planning]
ping_budget = 2
ping_min_spacing = "1 min"
control_interval = "1 min"
replan_interval = "2 min"
"""


def _scenario(tmp_path):
    f = tmp_path / "late.toml"
    f.write_text(SCENARIO, encoding="utf-8")
    return str(f)


def test_plan_json_times_are_all_on_the_scenario_clock(tmp_path, capsys):
    # baseline_params.time was counted from t0 (120 s) beside switch_times on the scenario
    # clock (3660 s): one JSON document, two clocks
    assert main(["plan", _scenario(tmp_path), "--objective", "position-bound", "--horizon",
                 "4 min", "--no-figure", "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    end = T0 + 240.0
    assert all(T0 <= t <= end for t in d["switch_times"]), d["switch_times"]
    turn = d["baseline_params"]["single-turn"]["time"]
    assert T0 < turn < end, turn


def test_schedule_figure_is_on_the_clock_of_its_ping_times(tmp_path, monkeypatch, capsys):
    # the console and the JSON give the ping times on the scenario clock ("60.3, 61.3 min");
    # the figure drew them (and its axis) from t0, at 0.3 and 1.3 min
    figs = []

    def keep(*a, **k):
        figs.append(real(*a, **k))
        return figs[-1]

    import tmaplan.plotting as plotting

    real = plotting.plot_schedule  # the verb imports it when it draws
    monkeypatch.setattr(plotting, "plot_schedule", keep)
    assert main(["schedule", _scenario(tmp_path), "--method", "greedy", "--budget", "2",
                 "--out", str(tmp_path), "--json", "-"]) == 0
    d = json.loads(capsys.readouterr().out)
    ax = figs[0].axes[0]
    lines = sorted(ln.get_xdata()[0] for ln in ax.lines if ln.get_color() == "C3")
    assert lines == [t / 60.0 for t in d["ping_times"]] and min(lines) > T0 / 60.0
    lo, hi = ax.get_xlim()
    assert lo < T0 / 60.0 + 1 and hi > T0 / 60.0 + 9


def test_compare_time_to_accuracy_axis_says_it_counts_from_t0(tmp_path, monkeypatch, capsys):
    # time to accuracy is a duration since t0 (JSON, console); the figure said "time [min]"
    # beside the RMSE figure whose "time [min]" is the scenario clock (60..70 min here)
    import tmaplan.report as report

    labels = {}
    real = report.save_figure

    def keep(fig, path, *a, **k):
        labels[str(path).rsplit("/", 1)[-1]] = fig.axes[0].get_xlabel()
        return real(fig, path, *a, **k)

    monkeypatch.setattr(report, "save_figure", keep)
    assert main(["compare", _scenario(tmp_path), "--policies", "straight+no-ping", "--runs",
                 "1", "--particles", "200", "--out", str(tmp_path), "--json", "-"]) == 0
    capsys.readouterr()
    assert labels["time_to_accuracy.png"] == "time since t0 [min]"
    assert labels["rmse.png"] == "time [min]"
