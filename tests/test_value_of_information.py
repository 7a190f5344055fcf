"""``benchmarks/value_of_information.py`` on one run: the clairvoyant plan sees the truth.

The clairvoyant plan is solved from the offline plan among its starts, so on the objective
evaluated at the run's true initial state it can only be better than the offline plan; and
that objective is not the prior's (the draws really are the truth)."""

from __future__ import annotations

import numpy as np


def test_clairvoyant_plan_is_optimal_at_the_truth(benchmark_script):
    bench = benchmark_script("value_of_information")
    bench._init("bow-closing", 500)
    row = bench._run((11, 0))
    plan = bench._STATE["plan"]
    assert row["clairvoyant_objective"] is not None
    assert row["clairvoyant_objective"] <= row["planned_objective_at_truth"] + 1e-6
    # the truth's objective differs from the prior's (all draws at one state)
    assert abs(row["planned_objective_at_truth"] - plan.objective) > 1.0
    for name in ("planned", "clairvoyant"):
        assert row[name] is None or np.isfinite(row[name])
