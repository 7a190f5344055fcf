"""The command line prints a warning as one line, as it prints errors."""

from __future__ import annotations

import warnings

import tmaplan.cli.simulate as simulate_verb
from tmaplan.cli import main
from tmaplan.estimators.particle_filter import DegeneracyWarning
from tmaplan.scenario import problems_dir


def test_a_warning_is_one_line_naming_the_verb_and_its_category(monkeypatch, capsys):
    def run(args):
        warnings.warn("particle filter degenerate\nat step 3", DegeneracyWarning, stacklevel=1)

    monkeypatch.setattr(simulate_verb, "run", run)
    assert main(["simulate", "default"]) == 0
    err = capsys.readouterr().err
    # not Python's two lines (file:line: Category: text, then the source line)
    assert err == ("tmaplan simulate: warning: DegeneracyWarning: particle filter degenerate "
                   "at step 3\n"), err
    # the replacement is undone when main returns
    assert warnings.showwarning.__module__ == "warnings"


def test_compare_warns_of_a_planning_horizon_past_the_problems_end(tmp_path, capsys):
    """``planning.horizon`` 15 min on a 10 min problem: ``compare``'s ``planned`` planned 15 min
    and flew 10, silently."""
    text = (problems_dir() / "default.toml").read_text(encoding="utf-8")
    head, planning = text.replace('name = "default"', 'name = "long"').split("[planning]")
    f = tmp_path / "long.toml"
    f.write_text(head.replace('horizon = "45 min"', 'horizon = "10 min"') + "[planning]"
                 + planning.replace('horizon = "45 min"', 'horizon = "15 min"'), encoding="utf-8")
    assert main(["compare", str(f), "--policies", "planned,straight", "--runs", "1",
                 "--particles", "100", "--out", str(tmp_path / "o"), "--json",
                 str(tmp_path / "c.json")]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if "warning" in ln]
    assert err == ["tmaplan compare: warning: ScenarioWarning: long: field 'planning.horizon': "
                   "900 s (15 min) is longer than time.horizon; 600 s (10 min) used: a plan is "
                   "made over 900 s (15 min), but a run ends at time.horizon and flies and "
                   "scores only its first 600 s (10 min) (give planning.horizon <= "
                   "time.horizon)"], err


def test_compare_warns_of_a_truth_the_particle_filter_does_not_model(tmp_path, capsys):
    """``compare --truth scenario`` on a constant-turn contact: the filter's NCV dynamics do
    not model its truth (``track`` refuses it); a robustness study, warned, not refused."""
    import dataclasses

    from tmaplan.scenario import dump, load_problem

    sc = load_problem("two-contacts-crossing")
    ct = load_problem("clavard2013-halfturn-cw").target
    alpha, bravo = sc.contacts
    prior = dataclasses.replace(alpha.prior, range_distribution="normal", range_mean=12e3,
                                range_std=3e3)
    f = tmp_path / "circling.toml"
    f.write_text(dump(sc.replace(
        name="circling", time=dataclasses.replace(sc.time, horizon=600.0),
        planning=dataclasses.replace(sc.planning, horizon=600.0),
        contacts=(dataclasses.replace(alpha, target=ct, prior=prior), bravo))))
    assert main(["compare", str(f), "--policies", "straight", "--runs", "1", "--particles",
                 "100", "--truth", "scenario", "--out", str(tmp_path / "o"), "--json",
                 str(tmp_path / "c.json")]) == 0
    err = [ln for ln in capsys.readouterr().err.splitlines() if "target.model" in ln]
    assert err == ["tmaplan compare: warning: ScenarioWarning: circling: field "
                   "'contacts[0].target.model': the particle filter assumes a "
                   "nearly-constant-velocity target, this contact's truth turns: the runs "
                   "measure the filter's robustness to the model mismatch (contact 'alpha'), "
                   "received 'constant-turn'"], err
