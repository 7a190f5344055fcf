"""run_closed_loop (tmaplan.evaluation.closed_loop): bad input is refused before any work."""

from __future__ import annotations

import numpy as np
import pytest

from tmaplan.errors import ArgumentError
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.policies import Combined, Straight
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth


@pytest.fixture(scope="module")
def scenario():
    return load_problem("default")


def _bad_target(scenario, kind):
    tgt = draw_truth(scenario, np.random.default_rng(0), from_prior=True)
    if kind == "short":
        return tgt[:-1]          # was an IndexError at the last step
    if kind == "positions":
        return tgt[:, :2]        # was a broadcasting error
    tgt[5, 0] = np.nan           # was flown: NaN bearings and a "degenerate" filter
    return tgt


@pytest.mark.parametrize(("change", "field"), [
    ({"target": "short"}, "target"),
    ({"target": "positions"}, "target"),
    ({"target": "nan"}, "target"),
    ({"filter_q": -1.0}, "filter_q"),        # was floored to 1e-8 without a word
    ({"filter_q": float("nan")}, "filter_q"),
    ({"filter_q": "1e-5"}, "filter_q"),
    ({"noise_rng": 0}, "noise_rng"),          # was an AttributeError
    ({"filter_rng": None}, "filter_rng"),
])
def test_run_closed_loop_refuses_bad_input_naming_the_field(scenario, change, field):
    kw = {"noise_rng": np.random.default_rng(1), "filter_rng": np.random.default_rng(2),
          "n_particles": 100}
    target = draw_truth(scenario, np.random.default_rng(0), from_prior=True)
    if "target" in change:
        target = _bad_target(scenario, change["target"])
    else:
        kw |= change
    with pytest.raises(ArgumentError) as info:
        run_closed_loop(scenario, Combined(manoeuvre=Straight()), target, **kw)
    assert info.value.field == field
