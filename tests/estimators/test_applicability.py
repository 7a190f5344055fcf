"""Estimator applicability (tmaplan.estimators.applicability) through the API, and the output
guard that turns a NaN result into an error (tmaplan.cli.finite)."""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from tmaplan.cli import main
from tmaplan.cli.finite import require_finite
from tmaplan.errors import ArgumentError, EstimationError
from tmaplan.estimators import ESTIMATORS, MLEConfig, estimator_for
from tmaplan.estimators.applicability import (
    APPLICABILITY,
    applicable_estimators,
    check_applicable,
    warn_filter_model,
)
from tmaplan.evaluation.tracking import monte_carlo
from tmaplan.scenario import load_problem


def test_every_estimator_declares_what_it_applies_to():
    assert set(APPLICABILITY) == set(ESTIMATORS)
    sc = load_problem("clavard2013-halfturn-cw")
    for name in ("pf", "pf-bearings", "mle"):
        est = estimator_for(name, sc, n_particles=10)
        assert est.applicability is APPLICABILITY[name]
        # the measurement kinds it needs are among the kinds its estimate uses
        assert APPLICABILITY[name].needs <= est.applies_to
    assert APPLICABILITY["mle"].bounds == {"crlb"} and APPLICABILITY["pf"].bounds == {"truth"}


def test_applicable_estimators_per_problem():
    assert applicable_estimators(load_problem("sharma2024-range-only")) == ("range-only", "pf")
    # clavard2013 has no prior: the filters start from one, the PCRB of pf-bearings too
    assert applicable_estimators(load_problem("clavard2013-halfturn-cw")) == ("mle",)
    assert applicable_estimators(load_problem("ristic-bot-moderate")) == (
        "pf", "pf-bearings", "mle")
    assert "mle" not in applicable_estimators(load_problem("brehard2005-s1"))


def test_monte_carlo_refuses_what_cannot_work():
    sc = load_problem("sharma2024-range-only")
    with pytest.raises(ArgumentError) as exc:
        monte_carlo(sc, "mle", runs=2)
    msg = str(exc.value)
    assert "field 'estimator'" in msg and "needs at least 5 bearing" in msg
    assert "use estimator range-only or pf" in msg and "\n" not in msg
    with pytest.raises(ArgumentError, match=r"field 'bound'.*batch CRLB"):
        monte_carlo(load_problem("clavard2013-halfturn-cw"), MLEConfig(), runs=1,
                    bound="prior")


def test_the_filters_refuse_a_constant_turn_target():
    """The particle filters propagate NCV dynamics, and their PCRB too (`tmaplan bound`
    refuses a constant-turn target for that reason): on a constant-turn target with a prior
    they ran anyway, diverged in every run and printed an NCV bound beside (`track`: final
    RMSE 9.6 km against a "bound" of 0.5 km). Refused, pointing to the MLE."""
    sc = load_problem("default")
    ct = load_problem("clavard2013-halfturn-cw").target
    prior = dataclasses.replace(sc.prior, range_distribution="normal", range_mean=12e3,
                                range_std=3e3)
    circling = sc.replace(target=ct, prior=prior)
    for name in ("pf", "pf-bearings"):
        with pytest.raises(ArgumentError, match=rf"field 'estimator'.*{name} \(.*\) is defined "
                           r"for multi-leg, ncv targets \(its dynamics are nearly constant "
                           r"velocity.*is constant-turn; use estimator mle"):
            monte_carlo(circling, name, runs=1, n_particles=50)
    assert applicable_estimators(circling) == ("mle",)


def test_prior_bound_of_the_filters_stays_available_in_the_api():
    # position-only, documented: refused by the CLI (it would print a NaN range bound), not
    # by the API
    sc = load_problem("default")
    check_applicable("pf", sc, bound="prior")
    with pytest.raises(ArgumentError, match="--bound"):
        check_applicable("pf", sc, bound="prior", cli=True)


def test_require_finite_names_the_quantity():
    payload = {"rmse": [1.0, math.nan], "ok": [1.0, math.inf], "policies": {
        "a": {"x": 1.0}, "b": {"x": float("nan")}}}
    require_finite(payload, ("ok[-1]", "absent", "policies.a.x"))
    with pytest.raises(EstimationError, match=r"p: result 'rmse\[-1\]' is NaN"):
        require_finite(payload, ("rmse[-1]",), source="p")
    with pytest.raises(EstimationError, match=r"result 'policies\.b\.x' is NaN"):
        require_finite(payload, ("policies.*.x",))
    require_finite({"rmse": np.array([1.0, 2.0])}, ("rmse[-1]",))


def test_track_never_exits_0_with_nan(monkeypatch, capsys):
    # an estimator that applies but whose every run is rejected: the command fails naming the
    # quantity instead of printing "RMSE nan m"
    import tmaplan.cli.track as track

    real = track.monte_carlo

    def all_rejected(*a, **k):
        res = real(*a, **k)
        nan = np.full_like(res.rmse_position, np.nan)
        return dataclasses.replace(res, rmse_position=nan, rmse_range=nan,
                                   statuses=("rejected",) * res.runs)

    monkeypatch.setattr(track, "monte_carlo", all_rejected)
    rc = main(["track", "clavard2013-halfturn-cw", "--estimator", "mle", "--runs", "1",
               "--no-figure"])
    out = capsys.readouterr()
    assert rc == 1 and "nan" not in out.out.lower()
    err = out.err.strip().splitlines()
    assert len(err) == 1 and "result 'rmse_position[-1]' is NaN" in err[0]
    assert "run statuses: 1 rejected" in err[0]


def test_every_verb_with_numeric_results_declares_them():
    import importlib

    for verb in ("track", "bound", "crlb", "plan", "schedule", "compare", "demo"):
        mod = importlib.import_module(f"tmaplan.cli.{verb}")
        assert mod.FINITE and all(isinstance(p, str) for p in mod.FINITE), verb


def test_compare_never_exits_0_with_nan(monkeypatch, capsys, tmp_path):
    import tmaplan.cli.compare as compare

    real = compare.run_campaign

    def diverged(*a, **k):
        res = real(*a, **k)
        res.summary["straight"]["final_range_rmse"] = float("nan")
        return res

    monkeypatch.setattr(compare, "run_campaign", diverged)
    rc = main(["compare", "default", "--policies", "straight", "--runs", "1", "--particles",
               "100", "--out", str(tmp_path)])
    out = capsys.readouterr()
    assert rc == 1 and "nan" not in out.out.lower()
    err = out.err.strip().splitlines()
    assert len(err) == 1 and "result 'policies.straight.final_range_rmse' is NaN" in err[0]
    assert "report written to" in err[0]


@pytest.mark.parametrize(("name", "fewest"), [("pf-bearings", 7), ("mle", 5)])
def test_declared_minimum_is_what_the_estimator_needs(name, fewest):
    # pf-bearings fits 2k + 1 >= 7 bearings (k >= 3, brehard2004); the MLE needs more
    # measurements than the 4 parameters of a constant-velocity track. With one bearing fewer
    # every run raised inside monte_carlo although check_applicable had let it through.
    sc = load_problem("ristic-bot-moderate")  # one bearing per step from step 1

    def short(n):
        return dataclasses.replace(sc, time=dataclasses.replace(sc.time,
                                                                horizon=n * sc.time.dt))

    assert name in applicable_estimators(short(fewest))
    assert name not in applicable_estimators(short(fewest - 1))
    with pytest.raises(ArgumentError, match=f"needs at least {fewest} bearing"):
        check_applicable(name, short(fewest - 1))


def test_range_only_counts_the_ranges_within_the_sensors_reach():
    """A range sensor's ``max_range`` returns no reading beyond it: range-only tracking of a
    contact out of reach has no measurement and is refused (it ran on the prior alone, with a
    bound, before); a reach beyond every range changes nothing."""
    sc = load_problem("sharma2024-range-only")
    rng_sensor = sc.sensors[0]
    assert rng_sensor.kind == "range"

    def reach(m):
        return dataclasses.replace(sc, sensors=(dataclasses.replace(rng_sensor, max_range=m),
                                                *sc.sensors[1:]))

    check_applicable("range-only", reach(50e3))  # every range within 50 km
    assert applicable_estimators(reach(50e3)) == applicable_estimators(sc)
    with pytest.raises(ArgumentError) as exc:
        check_applicable("range-only", reach(100.0), cli=True)  # the contact stays beyond 384 m
    msg = str(exc.value)
    assert "needs at least 3 range measurements" in msg and "\n" not in msg
    assert "has 0 within max_range on the true track" in msg
    assert "range-only" not in applicable_estimators(reach(100.0))


def _circling(name: str = "default"):
    """``name`` (10 min) with its first contact on clavard2013's constant-turn track, a prior
    with explicit means (a constant-turn target needs them)."""
    sc = load_problem(name)
    sc = sc.replace(time=dataclasses.replace(sc.time, horizon=600.0),
                    planning=dataclasses.replace(sc.planning, horizon=600.0))
    ct = load_problem("clavard2013-halfturn-cw").target
    first = sc.contacts[0]
    prior = dataclasses.replace(first.prior, range_distribution="normal", range_mean=12e3,
                                range_std=3e3)
    return sc.replace(contacts=(dataclasses.replace(first, target=ct, prior=prior),
                                *sc.contacts[1:]))


@pytest.mark.parametrize(("name", "field"), [
    ("default", "field 'target.model'"),
    ("two-contacts-crossing", "field 'contacts[0].target.model'")])
def test_a_campaign_against_a_truth_the_filter_does_not_model_is_warned(name, field):
    """``compare --truth scenario`` on a constant-turn contact flew the particle filter (NCV
    dynamics) silently, where ``track`` refuses it: a robustness study, so warned, not
    refused."""
    from tmaplan.errors import ScenarioWarning
    from tmaplan.experiments import CampaignSpec, run_campaign

    sc = _circling(name)
    spec = CampaignSpec(scenario=sc, policies=("straight",), runs=1, seed=0, n_particles=50,
                        truth="scenario")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run_campaign(spec)
    msgs = [str(w.message) for w in caught if issubclass(w.category, ScenarioWarning)
            and "target.model" in str(w.message)]
    who = " (contact 'alpha')" if name != "default" else ""
    assert msgs == [f"{sc.name}: {field}: the particle filter assumes a nearly-constant-velocity "
                    "target, this contact's truth turns: the runs measure the filter's "
                    f"robustness to the model mismatch{who}, received 'constant-turn'"], msgs
    # the contacts the filter models: nothing to say
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warn_filter_model(load_problem(name))
    assert not caught
