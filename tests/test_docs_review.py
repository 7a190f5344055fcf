"""The user documentation agrees with the code: its scenario examples load, and the entry
points and defaults it names exist."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

from tmaplan import errors
from tmaplan.scenario import loads

ROOT = Path(__file__).resolve().parents[1]
DOC_FILES = ("docs/scenario-files.md", "docs/several-contacts.md")


def _toml_blocks(path: str) -> list[str]:
    return re.findall(r"```toml\n(.*?)```", (ROOT / path).read_text(encoding="utf-8"), re.S)


@pytest.mark.parametrize("path", DOC_FILES)
def test_every_toml_example_of_the_docs_loads_without_the_truth(path):
    blocks = _toml_blocks(path)
    assert blocks, path
    for block in blocks:
        s = loads(block, source=path)
        for c in s.contacts:  # each contact's prior (several contacts, issue 40)
            assert c.prior is not None and c.prior.truth_fields == ()


def test_the_error_tree_of_the_architecture_section_is_the_code_s():
    assert issubclass(errors.UnitError, errors.ScenarioError)
    assert issubclass(errors.ScenarioError, errors.ArgumentError)
    assert issubclass(errors.ArgumentError, ValueError)
    assert not issubclass(errors.ObservabilityError, errors.ScenarioError)
    assert not issubclass(errors.EstimationError, errors.ScenarioError)
    assert issubclass(errors.SolverError, errors.PlanningError)
    assert issubclass(errors.PlanningError, RuntimeError)
    text = (ROOT / "docs/architecture.md").read_text(encoding="utf-8")
    assert "ScenarioError ⊃ UnitError;" in text
    assert "ScenarioError ⊃ UnitError, ObservabilityError" not in text


def test_the_api_table_s_crlb_default_and_policy_names():
    from tmaplan.bounds.crlb import crlb

    assert inspect.signature(crlb).parameters["frequencies"].default is None
    import tmaplan.policies.combine as combine

    assert combine.MANOEUVRES and combine.PINGS
    text = (ROOT / "docs/architecture.md").read_text(encoding="utf-8")
    assert "crlb(scenario, *, frequencies=0)" not in text
    assert "`tmaplan.policies.combine` (`MANOEUVRES`, `PINGS`)" in text
