"""ScenarioError is for scenario fields; bad arguments raise ArgumentError (tmaplan.errors)."""

from __future__ import annotations

import pytest

from tmaplan.cli import main
from tmaplan.errors import ArgumentError, ScenarioError, TmaplanError
from tmaplan.planning.objectives import make_objective
from tmaplan.policies.manoeuvres import Zigzag
from tmaplan.scenario import from_dict, load_problem


def test_hierarchy_and_message() -> None:
    assert issubclass(ScenarioError, ArgumentError)
    assert issubclass(ArgumentError, TmaplanError)
    assert issubclass(ArgumentError, ValueError)
    err = ArgumentError("samples", ">= 2", 1)
    assert str(err) == "field 'samples': expected >= 2, received 1"
    assert (err.field, err.expected, err.received) == ("samples", ">= 2", 1)


def test_objective_name_is_an_argument_error() -> None:
    with pytest.raises(ArgumentError, match="field 'objective'") as exc:
        make_objective("no-such-objective")
    assert not isinstance(exc.value, ScenarioError)


def test_policy_parameter_is_an_argument_error() -> None:
    with pytest.raises(ArgumentError, match=r"zigzag\.leg_duration") as exc:
        Zigzag(leg_duration=0.0, angle=0.5).controller(load_problem("default"))
    assert not isinstance(exc.value, ScenarioError)


def test_cli_value_is_an_argument_error(capsys) -> None:
    from tmaplan.cli.bound import resolve_over

    with pytest.raises(ArgumentError, match="--over") as exc:
        resolve_over("closed-form", "lpc", "truth")
    assert not isinstance(exc.value, ScenarioError)
    assert main(["bound", "default", "--samples", "1"]) != 0
    assert "--samples" in capsys.readouterr().err


def test_scenario_field_is_a_scenario_error() -> None:
    with pytest.raises(ScenarioError, match="sigma"):
        from_dict({"name": "x", "time": {"dt": 1.0, "horizon": 10.0},
                   "target": {"position": [0.0, 1000.0], "velocity": [0.0, 0.0]},
                   "observer": {"position": [0.0, 0.0], "velocity": [1.0, 0.0]},
                   "sensors": [{"kind": "bearing", "sigma": -1.0}]})


def test_is_integer_is_the_one_integer_test_of_user_input():
    import numpy as np

    from tmaplan.errors import is_integer

    assert is_integer(3, 3) and is_integer(np.int64(7), 0)
    for bad in (True, 3.0, "3", None, 2, np.float64(4.0)):
        assert not is_integer(bad, 3)


def test_as_real_turns_what_is_not_a_real_number_into_nan():
    import math

    import numpy as np

    from tmaplan.errors import as_real

    assert as_real(2) == 2.0 and as_real(np.float32(0.5)) == 0.5 and as_real(-1e300) == -1e300
    for bad in (True, False, np.True_, "0.1", b"1", None, [1.0], object()):
        assert math.isnan(as_real(bad)), bad


def test_finite_real_names_the_field_and_keeps_the_bounds():
    import numpy as np

    from tmaplan.errors import finite_real

    assert finite_real("dt", np.float64(15), "a finite number > 0", lower=0.0, strict=True) == 15
    assert finite_real("q", 0, "a finite number >= 0", lower=0.0) == 0.0
    assert finite_real("t_ref", -1e9, "a finite time [s]") == -1e9
    for value, kw in ((0.0, {"lower": 0.0, "strict": True}), (-1e-12, {"lower": 0.0}),
                      (float("nan"), {}), (float("inf"), {}), (True, {}), ("1", {})):
        with pytest.raises(ArgumentError) as exc:
            finite_real("dt", value, "a finite number", source="default", **kw)
        assert str(exc.value) == (f"default: field 'dt': expected a finite number, received "
                                  f"{value!r}")


def _finite_real_sites():
    """(field, call) of argument checks that went through np.isfinite without as_real."""
    import numpy as np

    from tmaplan.bounds.batch_fim import FrequencyData, batch_data
    from tmaplan.estimators.init_bearings import initialise_from_bearings
    from tmaplan.estimators.manoeuvre_glr import velocity_jump_glr
    from tmaplan.estimators.range_only import (
        RangeOnlyConfig,
        range_only_update,
        single_point_prior,
    )
    from tmaplan.models.tracks import cv_model
    from tmaplan.planning.objectives import ObjectiveEvaluator
    from tmaplan.scenario import load_problem

    def init(**kw):
        args = {"sigma": 0.01, "r_min": 1e3, "r_max": 1e4, "n_particles": 10,
                "rng": np.random.default_rng(0), "q": 1e-4} | kw
        return initialise_from_bearings(60.0 * np.arange(9), np.zeros(9), **args)

    def prior(**kw):
        args = {"r0": 5e3, "bearing0": 0.3, "sigma_r": 10.0, "sigma_bearing": 0.01,
                "velocity_mean": np.zeros(2), "velocity_std": 1.0} | kw
        return single_point_prior(**args)

    def update(**kw):
        args = {"r": 5e3, "sigma_r": 10.0} | kw
        return range_only_update(prior(), config=RangeOnlyConfig(dt=10.0, q=1e-4), **args)

    freq = {"times": np.arange(3.0), "observer_position": np.zeros((3, 2)),
            "observer_velocity": np.zeros((3, 2)), "f0": np.array([100.0]),
            "sigma": np.array([0.1])}
    return [
        ("sigma", lambda v: init(sigma=v)), ("q", lambda v: init(q=v)),
        ("dt", lambda v: init(dt=v)), ("dt", lambda v: velocity_jump_glr([], v)),
        ("dt", lambda v: RangeOnlyConfig(dt=v, q=0.0)),
        ("q", lambda v: RangeOnlyConfig(dt=10.0, q=v)),
        ("sagitta", lambda v: RangeOnlyConfig(dt=10.0, q=0.0, sagitta=v)),
        ("r0", lambda v: prior(r0=v)),
        ("bearing0", lambda v: prior(bearing0=v)), ("sigma_r", lambda v: prior(sigma_r=v)),
        ("velocity_std", lambda v: prior(velocity_std=v)), ("r", lambda v: update(r=v)),
        ("sigma_r", lambda v: update(sigma_r=v)),
        ("frequencies.c", lambda v: batch_data(cv_model(), frequencies=FrequencyData(
            **freq, c=v))),
        ("turn_rate_max", lambda v: ObjectiveEvaluator(load_problem("default"),
                                                       turn_rate_max=v)),
    ]


@pytest.mark.parametrize("site", range(15))
def test_finite_real_sites_refuse_bools_and_strings_naming_the_field(site):
    # these checks used np.isfinite on the raw value: True passed as 1, "1" raised a bare
    # TypeError of numpy; through finite_real both are an ArgumentError naming the field
    field, call = _finite_real_sites()[site]
    for bad in (True, "1"):
        with pytest.raises(ArgumentError) as exc:
            call(bad)
        assert exc.value.field == field and exc.value.received == bad


def test_errors_survive_pickling_so_a_worker_process_can_raise_them():
    # the default pickling rebuilt an ArgumentError (or SolverError) from its message alone
    # and failed: an error raised in a process-pool worker broke the pool (BrokenProcessPool)
    import pickle

    from tmaplan.errors import SolverError, UnitError

    for err in (ArgumentError("runs", ">= 1", 0), ScenarioError("target.model", "'ncv'",
                "constant-turn", source="my.toml"), UnitError("time.dt", "a time", "3 m"),
                SolverError("ipopt", "Infeasible_Problem_Detected", "restoration failed")):
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is type(err) and str(back) == str(err) and vars(back) == vars(err)
    # its notes cross with it, and a received value that does not pickle crosses as its repr
    err = ArgumentError("objective", "a known name", lambda x: x)
    err.add_note("while resolving policy 'planned'")
    back = pickle.loads(pickle.dumps(err))
    assert back.__notes__ == ["while resolving policy 'planned'"]
    assert back.received.startswith("<function") and back.field == "objective"
    solver = SolverError("ipopt", "Maximum_Iterations_Exceeded")
    solver.add_note("re-plan 3")
    assert pickle.loads(pickle.dumps(solver)).__notes__ == ["re-plan 3"]


def test_is_whole_count_is_round_off_tolerant_and_at_least_one():
    from tmaplan.errors import is_whole_count

    assert is_whole_count(180.0) and is_whole_count(2700.0 / 15.0) and is_whole_count(0.3 / 0.1)
    assert not is_whole_count(22.5) and not is_whole_count(0.0) and not is_whole_count(0.4)
    assert not is_whole_count(180.0 + 1e-6)


def test_whole_steps_rules_say_the_same_thing_everywhere():
    # the scenario file, the re-planner and the command line (tests/cli/test_cli_args.py) word
    # "whole steps of dt" once (whole_steps_text); the scenario's said "dt = 15.0 s", the
    # others had no "(>= 1)"
    import dataclasses

    from tmaplan.policies import Receding
    from tmaplan.scenario import load_problem

    sc = load_problem("default")
    with pytest.raises(ScenarioError) as a:
        sc.replace(planning=dataclasses.replace(sc.planning, replan_interval=20.0))
    with pytest.raises(ArgumentError) as b:
        Receding(replan_interval=20.0).resolve(sc)
    with pytest.raises(ScenarioError) as c:
        sc.replace(time=dataclasses.replace(sc.time, horizon=2694.0))
    for exc in (a, b, c):
        assert exc.value.expected == "a whole number (>= 1) of steps of dt = 15 s"
