"""The fault matrix of ``benchmarks/faults.py`` at small size: every fault runs, nothing crashes,
and the robust filter holds up against wild bearings where the plain one breaks."""

from __future__ import annotations

import math
import warnings

import pytest

pytestmark = pytest.mark.slow


def test_fault_matrix_small(capsys, benchmark_script):
    bench = benchmark_script("faults")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degeneracy warnings of the plain filter
        rows = bench.matrix(policies=["planned+scheduled"], faults=list(bench.FAULTS),
                            options=["plain", "robust"], runs=4, particles=1000)
    bench.print_matrix(rows, 4)
    out = capsys.readouterr().out
    assert "manoeuvre-60deg" in out and "Traceback" not in out
    assert len(rows) == 2 * len(bench.FAULTS)
    cell = {(r["option"], r["fault"]): r for r in rows}
    for r in rows:
        assert math.isfinite(r["final_range_rmse"]) and 0 <= r["divergence_rate"] <= 1
    assert cell["plain", "none"]["ratio"] == 1.0 and cell["plain", "none"]["recoveries"] == 0
    assert cell["robust", "wild-5%"]["ratio"] < 2.0 < cell["plain", "wild-5%"]["ratio"]
    assert cell["robust", "manoeuvre-60deg"]["recoveries"] >= 1


def test_receding_runs_with_a_fault(benchmark_script):
    bench = benchmark_script("faults")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows = bench.matrix(policies=["receding"], faults=["manoeuvre-60deg"],
                            options=["robust"], runs=1, particles=500)
    assert [r["fault"] for r in rows] == ["none", "manoeuvre-60deg"]


def test_manoeuvre_detection_small(benchmark_script):
    bench = benchmark_script("faults")
    r = bench.manoeuvre(runs=4, particles=1000)
    assert 0 <= r["both"] <= r["detected"] <= 1 and r["detected_ever"] > 0
    assert 0 <= r["unknown_state_pd>=0.9"] <= r["unknown_state_pd>=0.5"] <= 1
    # handled = both, or never disturbed: at least "both", at most "both" + undisturbed
    assert r["both"] <= r["handled"] <= r["both"] + (1 - r["disturbed"]) + 1e-12
    c = r["both_if_clairvoyant_pd>=0.9"]
    assert math.isnan(c) or 0 <= c <= 1


def test_manoeuvre_bound_small(benchmark_script):
    bench = benchmark_script("faults")
    r = bench.bound_only(runs=3)
    assert 0 <= r["clairvoyant_pd>=0.9"] <= r["clairvoyant_pd>=0.5"] <= 1
    # the straight continuation is one of the straight tracks: the unknown-state λ is smaller
    assert r["unknown_state_mean_pd"] <= r["clairvoyant_mean_pd"] + 1e-12
    assert r["median_lambda"][1] <= r["median_lambda"][0] + 1e-9
