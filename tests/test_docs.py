"""Every public callable documents itself (issue 8 §6)."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

import tmaplan
from tmaplan import errors
from tmaplan.scenario import loads


def _public_modules():
    for info in pkgutil.walk_packages(tmaplan.__path__, "tmaplan."):
        name = info.name
        if any(part.startswith("_") for part in name.split(".")[1:]):
            continue
        yield importlib.import_module(name)


def test_every_public_callable_has_a_docstring():
    missing = []
    for mod in _public_modules():
        assert mod.__doc__ and mod.__doc__.strip(), f"module {mod.__name__}"
        for name in getattr(mod, "__all__", []):
            obj = getattr(mod, name)
            if not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue  # constants and type aliases
            if not (inspect.getdoc(obj) or "").strip():
                missing.append(f"{mod.__name__}.{name}")
            if inspect.isclass(obj):
                for meth_name, meth in vars(obj).items():
                    if meth_name.startswith("_") or not callable(meth):
                        continue
                    if not (inspect.getdoc(meth) or "").strip():
                        missing.append(f"{mod.__name__}.{name}.{meth_name}")
    assert not missing, "no docstring: " + ", ".join(sorted(set(missing)))


def test_every_public_module_declares_all():
    lacking = [m.__name__ for m in _public_modules()
               if not hasattr(m, "__all__") and not m.__name__.startswith("tmaplan.cli")]
    assert not lacking, lacking


# ----------------------------------------------------------------------------------------------
# From test_docs_review.py (folded in, issue 39):
# The user documentation agrees with the code: its scenario examples load, and the entry
# points and defaults it names exist.
# ----------------------------------------------------------------------------------------------

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
