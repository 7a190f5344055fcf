"""House rules of the package layout (issue 12): no private name reached across packages,
modules of at most 600 lines."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "tmaplan"
MAX_LINES = 600
MODULES = sorted(p for p in ROOT.rglob("*.py") if "problems" not in p.parts)


def _package(module: str) -> str:
    """``tmaplan.bounds`` for ``tmaplan.bounds.crlb``; ``tmaplan`` for top-level modules."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 2 else parts[0]


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
        return ".".join(parts) + ".__init__"
    return ".".join(parts)


def _private(dotted: str) -> bool:
    return any(part.startswith("_") and not part.startswith("__") for part in dotted.split("."))


def private_imports(source: str, module: str) -> list[str]:
    """``from tmaplan.x._y import z`` / ``import tmaplan.x._y`` / ``from tmaplan.x import _z``
    in the source of ``module`` where the private module or name belongs to another
    (sub)package."""
    here = _package(module)
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            mods = [node.module]
            names = [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            mods, names = [a.name for a in node.names], []
        else:
            continue
        for dotted in [*mods, *names]:
            if not dotted.startswith("tmaplan.") or not _private(dotted):
                continue
            first_private = next(i for i, p in enumerate(dotted.split("."))
                                 if p.startswith("_") and not p.startswith("__"))
            owner = _package(".".join(dotted.split(".")[:first_private]) + ".x")
            if owner != here:
                out.append(f"{module}:{node.lineno}: {dotted}")
    return out


def test_the_checker_catches_cross_package_private_imports() -> None:
    src = ("from tmaplan.planning._ping_search import x\nimport tmaplan.policies._base\n"
           "from tmaplan.estimators import _private_helper\n"
           "from tmaplan.bounds._jit import ok_same_package\n")
    found = private_imports(src, "tmaplan.bounds.probe")
    assert [f.split(": ")[1] for f in found] == [
        "tmaplan.planning._ping_search", "tmaplan.planning._ping_search.x",
        "tmaplan.policies._base", "tmaplan.estimators._private_helper"]


def test_no_private_name_imported_across_packages() -> None:
    found = [f for p in MODULES
             for f in private_imports(p.read_text(encoding="utf-8"), _module_name(p))]
    assert not found, "private names imported across packages:\n" + "\n".join(found)


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT.parent)))
def test_module_length(path: Path) -> None:
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{path.name}: {n} lines (at most {MAX_LINES})"


# --------------------------------------------------------------------------------------------
# The three extension points of docs/architecture.md: each is named in one place
# --------------------------------------------------------------------------------------------


def test_every_objective_name_is_built_in_objectives_py() -> None:
    # the names live in the scenario's names registry (the schema validates against them);
    # the planner imports that one list and its table builds every name
    from tmaplan.planning.objectives import OBJECTIVE_NAMES, Objective, make_objective
    from tmaplan.scenario import names

    assert OBJECTIVE_NAMES is names.OBJECTIVE_NAMES
    for name in OBJECTIVE_NAMES:
        assert isinstance(make_objective(name), Objective)


def test_every_estimator_name_is_built_in_the_runner() -> None:
    from tmaplan.estimators.filter import Filter
    from tmaplan.estimators.runner import ESTIMATORS, Estimator, FilterEstimator, estimator_for
    from tmaplan.scenario import load_problem

    scenario = load_problem("default")
    for name in ESTIMATORS:
        est = estimator_for(name, scenario, n_particles=100)
        assert isinstance(est, Estimator) and est.name == name
        if isinstance(est, FilterEstimator):
            assert isinstance(est.filter, Filter)


def test_every_policy_name_is_built_in_combine_py() -> None:
    from tmaplan.policies import ManoeuvrePolicy, Policy
    from tmaplan.policies.combine import MANOEUVRES, PINGS
    from tmaplan.policies.parse import parse_policy
    from tmaplan.scenario import load_problem

    scenario = load_problem("default")
    for name, make in PINGS.items():
        assert isinstance(make(), Policy), name
        assert parse_policy(f"straight+{name}", scenario).ping.name == name
    for name in set(MANOEUVRES) - {"single-turn", "zigzag"}:  # those two search a grid
        assert isinstance(MANOEUVRES[name](scenario), ManoeuvrePolicy), name


def test_tmaplan_io_sits_low_in_the_layering() -> None:
    """The recorded-data package imports only errors, units and geometry of tmaplan (and
    itself): the estimators, the planners and the verbs build on it, never the reverse."""
    allowed = ("tmaplan.errors", "tmaplan.units", "tmaplan.geometry", "tmaplan.io")
    found = []
    for path in sorted((ROOT / "io").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = ([node.module] if isinstance(node, ast.ImportFrom) and node.module
                     else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            found += [f"{path.name}: {n}" for n in names
                      if n.startswith("tmaplan") and not n.startswith(allowed)]
    assert not found, found
