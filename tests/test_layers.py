"""The layer order of docs/architecture.md, enforced (issue 39).

Every module of ``tmaplan/`` has a layer (:data:`LAYERS`); an import may point only to the same
or a lower layer, whether it sits at module level, inside a function or under
``if TYPE_CHECKING:``. The packages form no cycle (counting every import kind). A function-level
import never imports ``tmaplan`` (the module-level import says what a module needs); a
function-level import of anything else defers a heavy or optional dependency and says so with a
``# deferred: <reason>`` comment on its line. No private name (``_x``) is used outside the
module that defines it: no ``from m import _x``, no import of a private module from another
module, no ``obj._x`` of a name the module does not define itself.

The checks are AST-based, each with a self-test on planted source. :data:`KNOWN_VIOLATIONS` lists
what other parts of the re-layering are still removing; it can only shrink (an entry that no
longer matches a finding fails).
"""

from __future__ import annotations

import ast
import dataclasses
import re
from collections.abc import Iterable, Mapping
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "tmaplan"

#: Layer of each module or package of tmaplan (bottom 0 → top 13); a module's layer is that of
#: its longest dotted prefix here. ``tmaplan`` alone is the front door (``tmaplan/__init__.py``).
LAYERS: dict[str, int] = {
    "tmaplan.errors": 0, "tmaplan.units": 0, "tmaplan.version": 0, "tmaplan.caching": 0,
    "tmaplan.interrupts": 0, "tmaplan.parallel": 0,
    "tmaplan.geometry": 1,
    "tmaplan.display": 2, "tmaplan.memory": 2,  # memory words its limits with display's text
    "tmaplan.scenario": 3, "tmaplan.io": 3,
    "tmaplan.models": 4,
    "tmaplan.simulate": 5,
    "tmaplan.bounds": 6,
    "tmaplan.estimators": 7,
    "tmaplan.planning": 8,
    "tmaplan.policies": 9,
    "tmaplan.evaluation": 10,
    "tmaplan.experiments": 11, "tmaplan.plotting": 11, "tmaplan.report_tables": 11,
    "tmaplan.headline": 11, "tmaplan.report": 11, "tmaplan.ranking_report": 11,
    "tmaplan.advice": 11,  # recorded data in, advice out: estimators, planner, figures
    "tmaplan.report_contacts": 11,
    "tmaplan.cli": 12,
    "tmaplan": 13, "tmaplan.__main__": 13,
}

#: tmaplan modules a function may import late, with a ``# deferred: <reason>`` comment: each
#: pulls in a slow or optional dependency at import (checked: the dependency is among the
#: module-level imports the module, its packages and what they import bring in).
DEFERRED_MODULES: dict[str, str] = {
    "tmaplan.estimators.pf_numba": "numba",  # the compiled particle-filter kernels
    "tmaplan.estimators.pf_moments": "numba",  # the monitor's innovation on their clouds
    "tmaplan.planning.compiled_objective": "numba",  # the re-plans' compiled objective
    "tmaplan.io": "pyproj",  # recorded data in and out (and pynmea2, gpxpy)
    "tmaplan.plotting": "matplotlib",  # the figures of a verb whose checks every verb runs
    "tmaplan.report": "matplotlib",  # a campaign's report, after the runs
    "tmaplan.report_contacts": "matplotlib",  # the per-contact figure of that report
    "tmaplan.ranking_report": "matplotlib",  # rank-costs' report, after the runs
    "tmaplan.advice.report": "matplotlib",  # advise's figures and page
}

#: Findings tolerated for now, as (file under tmaplan/, stripped text of the offending line):
#: none since issue 39 removed the last. Only shrinks: an entry that matches no finding fails
#: :func:`test_known_violations_still_exist`.
KNOWN_VIOLATIONS: frozenset[tuple[str, str]] = frozenset()


# --------------------------------------------------------------------------------------------
# The checker
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class Import:
    """One import statement and the tmaplan modules it reaches."""

    module: str  # the importing module (dotted)
    line: int
    text: str  # the stripped source line
    kind: str  # "module", "function" or "type-checking"
    targets: tuple[str, ...]  # imported modules (dotted), tmaplan or not
    names: tuple[str, ...]  # the names of ``from m import a, b``
    deferred: bool  # a "# deferred: <reason>" comment on one of its lines


@dataclasses.dataclass(frozen=True, kw_only=True)
class Finding:
    """One broken rule, at ``path:line``."""

    path: str  # relative to tmaplan/
    line: int
    text: str
    message: str

    def __str__(self) -> str:
        return f"tmaplan/{self.path}:{self.line}: {self.message}  [{self.text}]"


def module_name(rel: Path) -> str:
    """``tmaplan.bounds.crlb`` for ``bounds/crlb.py``, ``tmaplan.bounds`` for its ``__init__``,
    ``tmaplan`` for the front door."""
    parts = ["tmaplan", *rel.with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str, layers: Mapping[str, int] = LAYERS) -> int | None:
    """The layer of a dotted tmaplan module (None: none assigned)."""
    if module == "tmaplan":
        return layers["tmaplan"]
    parts = module.split(".")
    for n in range(len(parts), 1, -1):
        if ".".join(parts[:n]) in layers:
            return layers[".".join(parts[:n])]
    return None


def _is_type_checking(test: ast.expr) -> bool:
    return ((isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"))


def _kinds(tree: ast.Module) -> dict[ast.AST, str]:
    """The kind of every import node: inside a function (at any depth), under
    ``if TYPE_CHECKING:``, or at module level."""
    out: dict[ast.AST, str] = {}

    def visit(node: ast.AST, kind: str) -> None:
        for child in ast.iter_child_nodes(node):
            k = kind
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                k = "function"
            elif (isinstance(child, ast.If) and kind == "module"
                  and _is_type_checking(child.test)):
                k = "type-checking"
                for sub in child.orelse:  # the else branch runs
                    visit_stmt(sub, kind)
                for sub in child.body:
                    visit_stmt(sub, k)
                continue
            visit_stmt(child, k)

    def visit_stmt(node: ast.AST, kind: str) -> None:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out[node] = kind
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            kind = "function"
        visit(node, kind)

    visit(tree, "module")
    return out


def _exists(module: str, root: Path) -> bool:
    rel = Path(*module.split(".")[1:])
    return (root / rel).with_suffix(".py").is_file() or (root / rel / "__init__.py").is_file()


def imports(source: str, module: str, root: Path = ROOT) -> list[Import]:
    """Every import statement of ``source`` (the text of ``module``), with its kind and the
    modules it reaches (``from tmaplan.x import y`` reaches ``tmaplan.x.y`` when that is a
    module, else ``tmaplan.x``)."""
    tree = ast.parse(source)
    lines = source.splitlines()
    package = module if module == "tmaplan" else module.rsplit(".", 1)[0]
    out = []
    for node, kind in _kinds(tree).items():
        assert isinstance(node, (ast.Import, ast.ImportFrom))
        if isinstance(node, ast.Import):
            targets = tuple(a.name for a in node.names)
            names: tuple[str, ...] = ()
        else:
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            names = tuple(a.name for a in node.names)
            if base.split(".")[0] == "tmaplan":
                subs = [f"{base}.{n}" for n in names if _exists(f"{base}.{n}", root)]
                targets = tuple(subs) if len(subs) == len(names) else (base, *subs)
            else:
                targets = (base,)
        span = lines[node.lineno - 1:(node.end_lineno or node.lineno)]
        out.append(Import(module=module, line=node.lineno, text=lines[node.lineno - 1].strip(),
                          kind=kind, targets=targets, names=names,
                          deferred=any(re.search(r"#\s*deferred:\s*\S", s) for s in span)))
    return sorted(out, key=lambda i: i.line)


def _rel(module: str) -> str:
    parts = module.split(".")[1:]
    return "/".join(parts) + ".py" if parts else "__init__.py"


def upward_imports(found: Iterable[Import], path: str,
                   layers: Mapping[str, int] = LAYERS) -> list[Finding]:
    """Imports from a lower layer to a higher one (any kind)."""
    out = []
    for imp in found:
        here = layer_of(imp.module, layers)
        for target in imp.targets:
            if target.split(".")[0] != "tmaplan":
                continue
            there = layer_of(target, layers)
            if here is not None and there is not None and there > here:
                out.append(Finding(path=path, line=imp.line, text=imp.text,
                                   message=f"{imp.kind}-level import of {target} (layer {there})"
                                           f" from {imp.module} (layer {here})"))
    return out


def _deferrable(target: str, deferred: Mapping[str, str]) -> bool:
    return any(target == m or target.startswith(m + ".") for m in deferred)


def function_imports(found: Iterable[Import], path: str,
                     deferred: Mapping[str, str] = DEFERRED_MODULES) -> list[Finding]:
    """Function-level imports of tmaplan (but those of :data:`DEFERRED_MODULES` with a
    ``# deferred: <reason>`` comment), and function-level imports of anything else without
    that comment."""
    out = []
    for imp in found:
        if imp.kind != "function":
            continue
        ours = [t for t in imp.targets if t.split(".")[0] == "tmaplan"]
        if ours and imp.deferred and all(_deferrable(t, deferred) for t in ours):
            continue
        if ours:
            out.append(Finding(path=path, line=imp.line, text=imp.text,
                               message="function-level import of tmaplan"))
        elif not imp.deferred:
            out.append(Finding(path=path, line=imp.line, text=imp.text,
                               message="function-level import without '# deferred: <reason>'"))
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _defined(tree: ast.Module) -> set[str]:
    """Every name the module defines: functions, classes, assigned names and attributes,
    arguments, and attributes set with ``setattr(obj, "name", ...)``/``object.__setattr__``."""
    out: set[str] = set()
    for n in ast.walk(tree):
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.add(n.name)
        elif isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store):
            out.add(n.id)
        elif isinstance(n, ast.Attribute) and isinstance(n.ctx, (ast.Store, ast.Del)):
            out.add(n.attr)
        elif isinstance(n, ast.arg):
            out.add(n.arg)
        elif isinstance(n, ast.alias):
            out.add((n.asname or n.name).split(".")[0])
        elif (isinstance(n, ast.Call) and len(n.args) > 1 and isinstance(n.args[1], ast.Constant)
              and isinstance(n.args[1].value, str)
              and ((isinstance(n.func, ast.Name) and n.func.id == "setattr")
                   or (isinstance(n.func, ast.Attribute) and n.func.attr == "__setattr__"))):
            out.add(n.args[1].value)
    return out


#: Private names of other libraries that are their public API (namedtuple's methods).
FOREIGN_PUBLIC = frozenset({"_replace", "_asdict", "_fields", "_make"})


def private_uses(source: str, module: str, path: str, root: Path = ROOT) -> list[Finding]:
    """Private names used outside their module: ``from m import _x``, an import of a private
    module (``tmaplan.x._y``) by another module, and ``obj._x`` where the module defines no
    ``_x`` itself (another module's or class's private member)."""
    tree = ast.parse(source)
    lines = source.splitlines()
    out = []

    def add(node: ast.stmt | ast.expr, message: str) -> None:
        out.append(Finding(path=path, line=node.lineno, text=lines[node.lineno - 1].strip(),
                           message=message))

    for imp in imports(source, module, root):
        for target in imp.targets:
            if (target.split(".")[0] == "tmaplan" and target != module
                    and any(_private(p) for p in target.split("."))):
                out.append(Finding(path=path, line=imp.line, text=imp.text,
                                   message=f"imports the private module {target}"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if _private(alias.name) and not (node.module or "").startswith("__"):
                    add(node, f"imports the private name {alias.name} of {node.module}")
    defined = _defined(tree)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load)
                and _private(node.attr) and node.attr not in defined
                and node.attr not in FOREIGN_PUBLIC):
            add(node, f"uses {ast.unparse(node)}, a private member defined elsewhere")
    return out


def package_of(module: str) -> str:
    """``tmaplan.bounds`` for ``tmaplan.bounds.crlb``; top-level modules are their own node."""
    return ".".join(module.split(".")[:2])


def package_cycles(edges: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one package (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    nodes = sorted(set(edges) | {t for ts in edges.values() for t in ts})

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in nodes:
        if v not in index:
            strong(v)
    return out


# --------------------------------------------------------------------------------------------
# The package as it is
# --------------------------------------------------------------------------------------------


def _sources() -> list[tuple[str, str, str]]:
    """(path under tmaplan/, module name, source) of every module."""
    out = []
    for p in sorted(ROOT.rglob("*.py")):
        rel = p.relative_to(ROOT)
        out.append((rel.as_posix(), module_name(rel), p.read_text(encoding="utf-8")))
    return out


SOURCES = _sources()
IMPORTS = {path: imports(src, mod) for path, mod, src in SOURCES}


def _findings() -> dict[str, list[Finding]]:
    return {
        "upward": [f for path, imps in IMPORTS.items() for f in upward_imports(imps, path)],
        "function": [f for path, imps in IMPORTS.items() for f in function_imports(imps, path)],
        "private": [f for path, mod, src in SOURCES for f in private_uses(src, mod, path)],
    }


FINDINGS = _findings()


def _unknown(found: list[Finding]) -> list[str]:
    return [str(f) for f in found if (f.path, f.text) not in KNOWN_VIOLATIONS]


def package_edges() -> dict[str, set[str]]:
    """Package → packages it imports (every import kind), within tmaplan."""
    edges: dict[str, set[str]] = {}
    for imps in IMPORTS.values():
        for imp in imps:
            for t in imp.targets:
                a, b = package_of(imp.module), package_of(t)
                if t.split(".")[0] == "tmaplan" and a != b:
                    edges.setdefault(a, set()).add(b)
    return edges


def test_every_module_has_a_layer() -> None:
    missing = [path for path, mod, _ in SOURCES if layer_of(mod) is None]
    assert not missing, f"modules without a layer in tests/test_layers.py LAYERS: {missing}"


def test_no_upward_import() -> None:
    bad = _unknown(FINDINGS["upward"])
    assert not bad, "imports pointing up the layers:\n" + "\n".join(bad)


def test_no_cycle_between_packages() -> None:
    assert package_cycles(package_edges()) == []


def test_function_level_imports_only_defer_heavy_dependencies() -> None:
    bad = _unknown(FINDINGS["function"])
    assert not bad, "function-level imports:\n" + "\n".join(bad)


def test_no_private_name_used_outside_its_module() -> None:
    bad = _unknown(FINDINGS["private"])
    assert not bad, "private names used outside their module:\n" + "\n".join(bad)


def test_every_layer_names_a_module() -> None:
    modules = {mod for _, mod, _ in SOURCES}
    stale = [m for m in LAYERS if m not in modules]
    assert not stale, f"LAYERS names modules that do not exist: {stale}"


def module_level_closure(module: str) -> set[str]:
    """Every module that importing ``module`` imports at module level (its parent packages'
    ``__init__`` included), tmaplan or not."""
    by_name = {mod: IMPORTS[path] for path, mod, _ in SOURCES}
    seen: set[str] = set()
    todo = [module]
    while todo:
        m = todo.pop()
        parts = m.split(".")
        for n in range(1, len(parts) + 1):  # importing a.b.c runs a, a.b, a.b.c
            name = ".".join(parts[:n])
            if name in seen:
                continue
            seen.add(name)
            todo += [t for imp in by_name.get(name, ()) if imp.kind == "module"
                     for t in imp.targets]
    return seen


@pytest.mark.parametrize("module", sorted(DEFERRED_MODULES))
def test_a_deferred_module_does_pull_a_slow_dependency(module: str) -> None:
    dependency = DEFERRED_MODULES[module]
    assert any(m.split(".")[0] == dependency for m in module_level_closure(module)), (
        f"{module} no longer imports {dependency}: import it at module level where needed")


def test_known_violations_still_exist() -> None:
    """The allow-list only shrinks: an entry whose violation is gone must be deleted."""
    found = {(f.path, f.text) for fs in FINDINGS.values() for f in fs}
    stale = sorted(KNOWN_VIOLATIONS - found)
    assert not stale, f"fixed, delete from KNOWN_VIOLATIONS: {stale}"


def test_known_violations_are_in_files_other_parts_own() -> None:
    def owned(path: str) -> bool:
        return (path.startswith(("planning/", "policies/", "evaluation/"))
                or path in ("estimators/truth_bound.py", "bounds/pcrb.py", "experiments.py"))

    assert [e for e in KNOWN_VIOLATIONS if not owned(e[0])] == []


# --------------------------------------------------------------------------------------------
# Self-tests: the checker finds planted violations
# --------------------------------------------------------------------------------------------

PLANTED = '''\
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from tmaplan.errors import ScenarioError
from tmaplan.planning import Belief
from tmaplan.bounds._jit import compile_it
from tmaplan.geometry import _wrap
import tmaplan.models.observer

if TYPE_CHECKING:
    from tmaplan.policies import Policy
    from tmaplan.scenario import Scenario
else:
    from tmaplan.evaluation import records


def f(x):
    import casadi as ca  # deferred: casadi takes a second to import
    import scipy.optimize
    from tmaplan.simulate import simulate
    from tmaplan.cli import main
    return x._secret + x._mine + self_defined._replace()


class C:
    def __init__(self):
        self._mine = 1
'''


def test_the_checker_sorts_imports_by_kind() -> None:
    found = imports(PLANTED, "tmaplan.bounds.probe")
    kinds = {i.text: i.kind for i in found}
    assert kinds["from tmaplan.policies import Policy"] == "type-checking"
    assert kinds["from tmaplan.evaluation import records"] == "module"  # the else branch runs
    assert kinds["from tmaplan.cli import main"] == "function"
    assert kinds["from tmaplan.planning import Belief"] == "module"
    deferred = {i.text: i.deferred for i in found}
    assert deferred["import casadi as ca  # deferred: casadi takes a second to import"]
    assert not deferred["import scipy.optimize"]


def test_the_checker_catches_upward_imports_of_every_kind() -> None:
    found = upward_imports(imports(PLANTED, "tmaplan.bounds.probe"), "bounds/probe.py")
    assert sorted((f.line, f.message.split(" import of ")[1].split(" ")[0]) for f in found) == [
        (7, "tmaplan.planning"), (13, "tmaplan.policies"), (16, "tmaplan.evaluation.records"),
        (23, "tmaplan.cli")]
    assert "module-level import of tmaplan.planning (layer 8) from tmaplan.bounds.probe " \
           "(layer 6)" in str(found[0])
    assert "type-checking" in found[1].message and "function" in found[3].message


def test_the_checker_resolves_relative_imports() -> None:
    found = imports("from ..planning import objectives\nfrom . import crlb\n",
                    "tmaplan.bounds.probe")
    assert found[0].targets == ("tmaplan.planning.objectives",)
    assert found[1].targets == ("tmaplan.bounds.crlb",)
    assert len(upward_imports(found, "bounds/probe.py")) == 1


def test_the_checker_catches_function_level_imports() -> None:
    found = function_imports(imports(PLANTED, "tmaplan.bounds.probe"), "bounds/probe.py")
    assert [(f.line, f.message) for f in found] == [
        (21, "function-level import without '# deferred: <reason>'"),
        (22, "function-level import of tmaplan"), (23, "function-level import of tmaplan")]


def test_the_checker_lets_a_function_defer_only_a_slow_module() -> None:
    src = ("def f():\n"
           "    from tmaplan.estimators import pf_numba  # deferred: numba is slow to import\n"
           "    from tmaplan.io.times import parse_utc  # deferred: tmaplan.io loads pyproj\n"
           "    from tmaplan.planning import Belief  # deferred: planning is slow to import\n"
           "    from tmaplan.estimators import pf_numba\n")
    found = function_imports(imports(src, "tmaplan.cli.probe"), "cli/probe.py")
    assert [f.line for f in found] == [4, 5]


def test_the_checker_catches_private_names(tmp_path: Path) -> None:
    found = private_uses(PLANTED, "tmaplan.bounds.probe", "bounds/probe.py")
    assert sorted((f.line, f.message) for f in found) == [
        (8, "imports the private module tmaplan.bounds._jit"),
        (9, "imports the private name _wrap of tmaplan.geometry"),
        (24, "uses x._secret, a private member defined elsewhere")]
    own = "class C:\n    def f(self):\n        self._x = 1\n        return self._x\n"
    assert private_uses(own, "tmaplan.bounds.probe", "bounds/probe.py") == []
    # nor a private module of its own package
    (tmp_path / "estimators").mkdir()
    for name in ("__init__.py", "_hidden.py"):
        (tmp_path / "estimators" / name).write_text("")
    sibling = "from tmaplan.estimators import _hidden\n"
    assert [f.message for f in private_uses(sibling, "tmaplan.estimators.particle_filter",
                                            "estimators/particle_filter.py", tmp_path)] == [
        "imports the private module tmaplan.estimators._hidden",
        "imports the private name _hidden of tmaplan.estimators"]


def test_the_checker_finds_package_cycles() -> None:
    edges = {"tmaplan.a": {"tmaplan.b"}, "tmaplan.b": {"tmaplan.c"}, "tmaplan.c": {"tmaplan.a"},
             "tmaplan.d": {"tmaplan.a"}}
    assert package_cycles(edges) == [["tmaplan.a", "tmaplan.b", "tmaplan.c"]]
    assert package_cycles({"tmaplan.a": {"tmaplan.b"}}) == []


def test_the_checker_flags_a_module_without_a_layer() -> None:
    assert layer_of("tmaplan.newthing") is None
    assert layer_of("tmaplan.bounds.new_module") == LAYERS["tmaplan.bounds"]
    assert layer_of("tmaplan") == 13 and layer_of("tmaplan.scenario.io") == 3


@pytest.mark.parametrize("kind", ["upward", "function", "private"])
def test_known_violations_entries_name_real_lines(kind: str) -> None:
    texts = {(path, ln.strip()) for path, _, src in SOURCES for ln in src.splitlines()}
    assert {e for e in KNOWN_VIOLATIONS if e not in texts} == set(), kind
