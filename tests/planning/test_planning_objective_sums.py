"""Sums of planning objectives: each term keeps its own meaning (belief sample count)."""

from __future__ import annotations

import pytest

from tmaplan.errors import ArgumentError
from tmaplan.planning.baselines import single_turn_track
from tmaplan.planning.objectives import (
    DEFAULT_OBJECTIVE,
    ObjectiveEvaluator,
    expected_time_to_accuracy,
    logdet,
    make_objective,
    range_bound,
    relative_range_crlb,
    turn_penalty,
)


def test_a_sum_of_terms_over_different_sample_counts_is_refused():
    """logdet(1) + relative_range_crlb(samples=16) evaluated logdet over the 16 samples (the
    sum took the larger count), not at the belief mean it was built for."""
    with pytest.raises(ArgumentError, match="samples"):
        logdet(1) + relative_range_crlb("mean", 16)
    with pytest.raises(ArgumentError, match="samples"):
        2.0 * relative_range_crlb("mean", 16) + expected_time_to_accuracy()
    assert (logdet(8) + logdet(8)).n_samples == 8


def test_a_sum_is_the_sum_of_its_terms(default):
    """Terms that read no samples (closed-form bounds, turn penalty: n_samples None) take the
    other's count; the value of the sum is the sum of the terms' values."""
    sc = default
    track = single_turn_track(sc, 1.0, 300.0, n_steps=40)
    parts = [range_bound("mean"), logdet(8), turn_penalty(2.0)]
    assert [o.n_samples for o in parts] == [None, 8, None]
    total = parts[0] + parts[1] + parts[2]
    assert total.n_samples == 8 and (parts[0] + parts[2]).n_samples is None

    def value(obj):
        return ObjectiveEvaluator(sc, obj, n_steps=40)(track)[0]

    assert value(total) == pytest.approx(sum(value(o) for o in parts), rel=1e-12)


def test_the_default_objective_is_not_a_sum():
    """The default objective builds its turn penalty into its own terms, not by ``+``: its
    128 draws are its own."""
    obj = make_objective(DEFAULT_OBJECTIVE)
    assert "+" not in obj.name and obj.n_samples == 128 and len(obj.terms) == 2

