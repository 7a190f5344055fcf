"""The tests mirror the package (issue 39; docs/architecture.md, section Tests).

A test of ``tmaplan/<pkg>/`` lives in ``tests/<pkg>/`` and imports from ``tmaplan.<pkg>``; the
root of ``tests/`` holds the tests of the top-level modules and of the whole package. No
directory under ``tests/`` that is not a sub-package (but the helpers' ``data``, ``oracles``
and ``typing``), no ``*_review.py`` file, and every test file name unique (pytest's default
``prepend`` import mode imports a test file by its base name). Each rule has a self-test on a
planted tree.
"""

from __future__ import annotations

import ast
from collections import Counter
from pathlib import Path

from repo_paths import ROOT, TESTS

#: Directories of tests/ that hold helpers, not tests of a sub-package.
HELPER_DIRS = frozenset({"data", "oracles", "typing", "__pycache__"})


def subpackages(package: Path) -> set[str]:
    """The sub-packages of ``package`` (directories with an ``__init__.py``)."""
    return {p.parent.name for p in package.glob("*/__init__.py")}


def stray_directories(tests: Path, package: Path) -> list[str]:
    """Directories of ``tests`` that match no sub-package of ``package`` (helpers aside)."""
    pkgs = subpackages(package)
    return sorted(d.name for d in tests.iterdir()
                  if d.is_dir() and not d.name.startswith(".") and d.name not in HELPER_DIRS
                  and d.name not in pkgs)


def imported_modules(path: Path) -> set[str]:
    """Every module a file imports (at any level)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def misplaced_tests(tests: Path, package: Path) -> list[str]:
    """Test files of ``tests/<pkg>/`` that import nothing of ``<package>.<pkg>``."""
    name = package.name
    bad = []
    for pkg in sorted(subpackages(package)):
        for path in sorted((tests / pkg).glob("test_*.py")):
            mods = imported_modules(path)
            if not any(m == f"{name}.{pkg}" or m.startswith(f"{name}.{pkg}.") for m in mods):
                bad.append(str(path.relative_to(tests)))
    return bad


def review_files(tests: Path) -> list[str]:
    return sorted(str(p.relative_to(tests)) for p in tests.rglob("*_review.py"))


def clashing_names(tests: Path) -> list[str]:
    """Test file names that occur in more than one directory."""
    names = Counter(p.name for p in tests.rglob("test_*.py") if "data" not in p.parts)
    return sorted(n for n, k in names.items() if k > 1)


def test_every_test_directory_is_a_subpackage() -> None:
    stray = stray_directories(TESTS, ROOT / "tmaplan")
    assert not stray, f"tests/ directories that are no tmaplan sub-package: {stray}"


def test_a_test_of_a_subpackage_imports_it() -> None:
    bad = misplaced_tests(TESTS, ROOT / "tmaplan")
    assert not bad, f"test files that import nothing of their directory's package: {bad}"


def test_no_review_file_remains() -> None:
    assert review_files(TESTS) == [], "fold each into the test file of the module it tests"


def test_test_file_names_are_unique() -> None:
    assert clashing_names(TESTS) == []


def test_no_init_file_under_tests_but_the_oracles() -> None:
    inits = sorted(str(p.parent.relative_to(TESTS)) for p in TESTS.rglob("__init__.py"))
    assert inits == ["oracles"]


def test_every_subpackage_has_its_tests() -> None:
    missing = sorted(p for p in subpackages(ROOT / "tmaplan")
                     if not list((TESTS / p).glob("test_*.py")))
    assert not missing, f"sub-packages without a tests/<pkg>/ directory: {missing}"


def test_the_checks_catch_a_planted_layout(tmp_path: Path) -> None:
    package = tmp_path / "pkg"
    for sub in ("bounds", "io"):
        (package / sub).mkdir(parents=True)
        (package / sub / "__init__.py").write_text("")
    tests = tmp_path / "tests"
    for d in ("bounds", "io", "data", "stray"):
        (tests / d).mkdir(parents=True)
    (tests / "bounds" / "test_crlb.py").write_text("from pkg.bounds.crlb import crlb\n")
    (tests / "io" / "test_nav.py").write_text("from pkg.bounds import x\n")  # not pkg.io
    (tests / "io" / "test_crlb.py").write_text("import pkg.io\n")  # name taken in bounds/
    (tests / "test_units_review.py").write_text("")
    (tests / "data" / "test_crlb.py").write_text("")  # data is not tests
    assert stray_directories(tests, package) == ["stray"]
    assert misplaced_tests(tests, package) == ["io/test_nav.py"]
    assert review_files(tests) == ["test_units_review.py"]
    assert clashing_names(tests) == ["test_crlb.py"]
