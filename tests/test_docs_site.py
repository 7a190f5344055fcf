"""The generated pages of the documentation site cover the code they are generated from.

The full site is built by ``make docs`` (warnings are errors); these checks are the quick part:
every scenario field appears in the scenario-file reference with its SI unit, and the CLI
reference is generated from the parser that knows every verb. Skipped without the ``docs``
extra (Sphinx, numpydoc).
"""

from __future__ import annotations

import dataclasses
import sys
import typing
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parent.parent / "docs"


@pytest.fixture(scope="module")
def ext(request):
    pytest.importorskip("sphinx")
    pytest.importorskip("numpydoc")
    sys.path.insert(0, str(DOCS / "_ext"))
    request.addfinalizer(lambda: sys.path.remove(str(DOCS / "_ext")))
    import scenario_reference
    import tmaplan_cli_parser

    return scenario_reference, tmaplan_cli_parser


def _scenario_classes():
    import tmaplan.scenario as sc

    return [getattr(sc, n) for n in sc.__all__ if dataclasses.is_dataclass(getattr(sc, n))]


def test_scenario_reference_lists_every_field_with_its_unit(ext):
    scenario_reference, _ = ext
    lines = scenario_reference.scenario_reference_lines()
    text = "\n".join(lines)
    titles = [i for i in range(len(lines) - 1)
              if lines[i] and lines[i + 1] == "-" * len(lines[i])]
    sections = {lines[i].rsplit("— ", 1)[1]: "\n".join(lines[i:j])
                for i, j in zip(titles, [*titles[1:], len(lines)])}
    for cls in _scenario_classes():
        body = sections.get(cls.__name__)
        assert body is not None, f"no section for {cls.__name__}"
        for f in dataclasses.fields(cls):
            assert f"* - ``{f.name}``" in body, f"{cls.__name__}.{f.name}"
    # units come from the field annotations: a length, a time, a speed, an angular rate
    assert "length [m]" in text and "time [s]" in text and "speed [m/s]" in text
    assert "angular rate [rad/s]" in text and "process noise [m^2/s^3]" in text


def test_scenario_reference_types(ext):
    scenario_reference, _ = ext
    from tmaplan.scenario import Observer, TimeGrid

    hints = typing.get_type_hints(TimeGrid, include_extras=True)
    assert scenario_reference.describe_type(hints["dt"]).startswith("time [s], > 0")
    hints = typing.get_type_hints(Observer, include_extras=True)
    assert scenario_reference.describe_type(hints["speed_min"]).startswith("speed [m/s], ≥ 0")
    assert scenario_reference.describe_type(hints["position"]).startswith("array of 2 (length")


def test_cli_reference_parser_has_every_verb(ext):
    _, cli = ext
    from tmaplan.cli import VERBS

    parser = cli.parser()
    sub = next(a for a in parser._actions if a.dest == "verb")
    assert "problems" in sub.choices and set(sub.choices) <= set(VERBS)
    for verb, p in sub.choices.items():
        assert p.description, verb
        assert any("--json" in a.option_strings for a in p._actions), verb
