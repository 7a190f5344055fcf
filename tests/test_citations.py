"""Sources are cited by key (docs/references.md), never by internal file or line numbers.

* Every citation key (author + year, e.g. ``brehard2005``) used in the package, the problem
  files, the notebooks, the documentation and the README has an entry in docs/references.md.
* No scanned file points outside the repository (``../shared/...``), to the team's working
  notes (``NOTES_00x``), to papers by internal number ("file 000") or to line numbers of a
  converted text ("L612").
* Every test that docs/errata.md names exists, so the errata cannot silently lose their checks.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
REFERENCES = ROOT / "docs" / "references.md"
ERRATA = ROOT / "docs" / "errata.md"

#: Files and folders that must cite by key only (no paths outside the repository, no internal
#: file numbers, no line numbers). The one list to extend (``tmaplan`` after its comment pass).
SCANNED = ("problems", "notebooks", "docs", "README.md", "CHANGELOG.md")
#: Where citation keys are collected and must resolve.
KEY_SCANNED = (*SCANNED, "tmaplan")

_SUFFIXES = {".py", ".toml", ".md", ".ipynb", ".rst", ".txt", ".cfg"}
_SKIP_DIRS = {"_build", "__pycache__", ".ipynb_checkpoints", "_generated", "generated"}
KEY = re.compile(r"\b([a-z]{3,}(?:19|20)\d{2}[a-z]?)\b")
FORBIDDEN = {
    "path outside the repository": re.compile(r"shared/|\.\./\.\./|/work/"),
    "internal paper number": re.compile(r"\bfiles? 00[0-4]\b|\b00[0-4]_[0-9a-f]{6,}", re.I),
    "working notes": re.compile(r"NOTES_00[0-4]|BENCHMARK_SCENARIOS"),
    "line number of a converted text": re.compile(r"\bL\d{2,4}(?:\s*[–-]\s*L?\d{2,4})?\b"),
}


def _files(entries: tuple[str, ...]) -> Iterator[Path]:
    for entry in entries:
        path = ROOT / entry
        if path.is_file():
            yield path
        elif path.is_dir():
            for f in sorted(path.rglob("*")):
                if f.is_file() and f.suffix in _SUFFIXES \
                        and not _SKIP_DIRS.intersection(f.relative_to(ROOT).parts):
                    yield f


def _text(path: Path) -> str:
    """The human-readable text of a file; for notebooks, cell sources and text outputs only
    (embedded images are base64 and would match anything)."""
    raw = path.read_text(encoding="utf-8")
    if path.suffix != ".ipynb":
        return raw
    parts = []
    for cell in json.loads(raw)["cells"]:
        parts.append("".join(cell.get("source", [])))
        for out in cell.get("outputs", []):
            parts.append("".join(out.get("text", [])))
            parts.append("".join(out.get("data", {}).get("text/plain", [])))
    return "\n".join(parts)


def reference_keys() -> set[str]:
    """Citation keys with an entry (a ``### key`` heading) in docs/references.md."""
    return set(re.findall(r"^### ([a-z]+\d{4}[a-z]?)\s*$", REFERENCES.read_text(), re.M))


def test_references_have_entries_for_the_papers_and_benchmarks():
    keys = reference_keys()
    assert {"brehard2005", "brehard2004", "clavard2013", "lecadre1997", "sharma2024",
            "gordon1993", "ristic2004"} <= keys
    # each entry says what it is used for
    text = REFERENCES.read_text()
    for key in keys:
        entry = text.split(f"### {key}\n", 1)[1].split("\n### ", 1)[0]
        assert "Used for:" in entry, key


def test_every_citation_key_resolves():
    keys = reference_keys()
    unresolved: dict[str, set[str]] = {}
    for path in _files(KEY_SCANNED):
        for key in KEY.findall(_text(path)):
            if key not in keys:
                unresolved.setdefault(key, set()).add(str(path.relative_to(ROOT)))
    assert not unresolved, f"citation keys without an entry in docs/references.md: {unresolved}"


@pytest.mark.parametrize("what", sorted(FORBIDDEN))
def test_no_internal_references(what):
    pattern = FORBIDDEN[what]
    hits = []
    for path in _files(SCANNED):
        for n, line in enumerate(_text(path).splitlines(), 1):
            if pattern.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()[:100]}")
    assert not hits, f"{what}:\n" + "\n".join(hits)


def test_the_checks_detect_what_they_should():
    """The patterns are not vacuous: each catches its own example and spares a clean line."""
    examples = {
        "path outside the repository": "see ../shared/papers/NOTES.md",
        "internal paper number": "as in file 000 eq. 4",
        "working notes": "NOTES_002 §4.4",
        "line number of a converted text": "(L1098–1115)",
    }
    for what, line in examples.items():
        assert FORBIDDEN[what].search(line), what
    clean = "brehard2005 eq. 43, Table 3; clavard2013 §III.4; 1000 samples; L2 norm"
    assert not any(p.search(clean) for p in FORBIDDEN.values())
    assert KEY.findall("the brehard2005-s1 problem (ristic2004, ch. 6)") == ["brehard2005",
                                                                           "ristic2004"]


def test_errata_name_existing_tests():
    named = set(re.findall(r"`(test_\w+\.py)::(\w+)`", ERRATA.read_text()))
    assert len(named) > 20
    missing = [f"{f}::{fn}" for f, fn in sorted(named)
               if not (ROOT / "tests" / f).is_file()
               or not re.search(rf"^def {fn}\(", (ROOT / "tests" / f).read_text(), re.M)]
    assert not missing, missing
