"""Batch MLE whose range the data do not determine: status "unobservable", left out of the RMSE.

The far contact is ristic-bot-moderate (own ship turning 140° -> 20°, 32 scans of 60 s) with the
target moved to 60 km and a 1° bearing noise: nominally observable (the batch CRLB at the truth
gives a final range std of ≈ 18 km, 0.3 of the range), but a few runs in a hundred walk off to
ranges of 1e20 m with an accepted cost, which made the Monte Carlo range RMSE ~1e20 m.
"""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.bounds.batch_fim import true_parameters
from tmaplan.cli import main
from tmaplan.errors import ArgumentError
from tmaplan.estimators import MLEConfig, fisher_information, mle, state_track, tma_data
from tmaplan.estimators.runner import MLEEstimator, run
from tmaplan.evaluation.tracking import NOT_USED, monte_carlo
from tmaplan.scenario import load_problem, loads
from tmaplan.scenario.io import problems_dir
from tmaplan.simulate import simulate

RANGE = 60e3  # [m]


def _far_text() -> str:
    text = (problems_dir() / "ristic-bot-moderate.toml").read_text(encoding="utf-8")
    east, north = RANGE * np.sin(np.radians(80.0)), RANGE * np.cos(np.radians(80.0))
    text = text.replace('position = ["4.92 km", "0.85 km"]', f'position = ["{east:.1f} m", '
                        f'"{north:.1f} m"]').replace('sigma = "1.5 deg"    #', 'sigma = "1 deg"  #')
    text = text.replace('name = "ristic-bot-moderate"', 'name = "far-contact"')
    assert 'sigma = "1 deg"' in text and f"{east:.1f} m" in text
    return text


def _relative_range_std_at_truth(sc) -> float:
    """σ_r / r of the batch CRLB at the truth, at the last step (independent of mle())."""
    sim = simulate(sc, None)
    d = tma_data(sc, sim.measurements, sim.observer)
    p = true_parameters(sc, d.track, d.n_lines)
    S, C = state_track(d, p, np.linalg.inv(fisher_information(d, p)), sc.times[-1:])
    assert C is not None
    g = S[0, :2] - sim.observer.position[-1]
    r = np.hypot(*g)
    return float(np.sqrt(g @ C[0, :2, :2] @ g) / r / r)


def test_relative_range_std_is_the_crlb_at_the_estimate() -> None:
    # noise-free bearings: the MLE is the truth, so its own relative range std is the CRLB's
    sc = loads(_far_text())
    sim = simulate(sc, None)
    res = mle(tma_data(sc, sim.measurements, sim.observer))
    want = _relative_range_std_at_truth(sc)
    assert 0.05 < want < 1.0  # nominally observable, the range barely determined
    assert res.status == "converged" and res.success
    assert res.relative_range_std == pytest.approx(want, rel=0.02)
    # the threshold is a parameter: below the estimate's own value the run is unobservable
    low = mle(tma_data(sc, sim.measurements, sim.observer),
              MLEConfig(max_relative_range_std=0.5 * want))
    assert low.status == "unobservable" and not low.success
    assert "range not determined" in low.message
    assert run(MLEEstimator(config=MLEConfig(max_relative_range_std=0.5 * want)), sc,
               sim).status == "unobservable"


@pytest.mark.parametrize("value", [0.0, -1.0, np.inf, np.nan])
def test_threshold_must_be_a_positive_finite_number(value: float) -> None:
    with pytest.raises(ArgumentError, match="max_relative_range_std"):
        MLEConfig(max_relative_range_std=value)


def test_far_contact_rmse_over_the_determined_runs_only() -> None:
    sc = loads(_far_text())
    res = monte_carlo(sc, "mle", runs=100, seed=0)
    # (before the fix: range RMSE ~5e23 m against a bound of 18 km, every run counted)
    st = np.array(res.statuses)
    unobs = st == "unobservable"
    used = ~np.isin(st, NOT_USED)
    assert unobs.any() and used.sum() >= 50
    # finite and of the order of the bound (it was ~1e20 m with the runs off to absurd ranges)
    assert np.isfinite(res.rmse_range[-1]) and np.isfinite(res.rmse_position[-1])
    assert res.rmse_range[-1] < 3.0 * res.bound_range[-1]
    assert res.rmse_position[-1] < 3.0 * res.bound_position[-1]
    np.testing.assert_allclose(
        res.rmse_position[-1], np.sqrt(np.mean(res.position_errors[used, -1] ** 2)), rtol=1e-12)
    # no absurd estimate is counted as determined
    assert (res.position_errors[used, -1] < 100 * RANGE).all()
    # the unobservable runs count as divergent and are counted in the JSON
    assert res.divergence_rate >= unobs.mean()
    assert res.to_json()["unobservable"] == int(unobs.sum())


def test_normal_case_unchanged() -> None:
    # ristic-bot-moderate (5 km): the criterion never bites, the results are those with it off
    sc = load_problem("ristic-bot-moderate")
    on = monte_carlo(sc, "mle", runs=10, seed=3)
    off = monte_carlo(sc, MLEConfig(max_relative_range_std=1e300), runs=10, seed=3)
    assert "unobservable" not in on.statuses and on.statuses == off.statuses
    np.testing.assert_array_equal(on.rmse_position, off.rmse_position)
    assert on.divergence_rate == off.divergence_rate
    sim = simulate(sc, np.random.default_rng(3))
    res = mle(tma_data(sc, sim.measurements, sim.observer))
    assert res.relative_range_std < 0.1  # far from the threshold (10)


def test_cli_track_says_the_undetermined_runs(tmp_path, capsys) -> None:
    path = tmp_path / "far.toml"
    path.write_text(_far_text(), encoding="utf-8")
    assert main(["track", str(path), "--estimator", "mle", "--runs", "40", "--no-figure",
                 "--json", str(tmp_path / "t.json")]) == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if "range not determined" in ln]
    assert len(lines) == 1 and "of 40 runs: range not determined: relative range std > 10; " \
        "left out of the RMSE" in lines[0], out
    rmse = float(out.split("final range RMSE ")[1].split(" m")[0])
    bound = float(out.split("final range RMSE ")[1].split("bound ")[1].split(" m")[0])
    assert rmse < 3.0 * bound, out
