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
