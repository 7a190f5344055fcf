"""The README is a door and the results live in the documentation (issue 39, item 4).

The README stays short, opens with the two set-up commands, quotes no confidence interval and
no seed, and its Python snippet runs; the CHANGELOG stays short and in Keep a Changelog form;
every campaign record of ``docs/results/`` is rendered by the docs build (it is in a toctree),
every finding links to a record that exists, and the intervals a finding quotes are those of
its records; ``docs/architecture.md`` names every module of the package.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
CHANGELOG = ROOT / "CHANGELOG.md"
RESULTS = DOCS / "results"

MAX_README_LINES = 250
MAX_CHANGELOG_LINES = 200
MAX_FIGURE_BYTES = 200_000

#: A confidence interval as the docs write them: ``[−0.34, −0.06]``, ``[-1.2, +3.4]``,
#: ``[0.06, 0.34]`` (Unicode minus or ASCII sign, optional).
INTERVAL = re.compile(r"\[\s*[−+-]?\d+(?:\.\d+)?\s*,\s*[−+-]?\d+(?:\.\d+)?\s*\]")
#: A relative Markdown link or image target: ``](docs/findings.md)``, ``](figures/x.png#a)``.
LINK = re.compile(r"\]\((?!https?:|mailto:|#)([^)\s#]+)(#[^)\s]*)?\)")


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _toctree_entries(path: Path) -> list[str]:
    blocks = re.findall(r"```\{toctree\}\n(.*?)```", _text(path), re.S)
    return [line.strip() for block in blocks for line in block.splitlines()
            if line.strip() and not line.strip().startswith(":")]


# --------------------------------------------------------------------------------------------
# README
# --------------------------------------------------------------------------------------------


def test_readme_is_short_and_opens_with_the_two_setup_commands():
    lines = _text(README).splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md: {len(lines)} lines"
    opening = re.match(r"# tmaplan\n+```\n(.*?)```", _text(README), re.S)
    assert opening, "README.md must open with a code block of the set-up commands"
    assert opening.group(1).split("\n")[:2] == ["make demo", "make test"], opening.group(1)


def test_the_interval_pattern_finds_the_intervals_the_docs_write():
    for quoted in ("[−0.34, −0.06]", "[-1.2, +3.4]", "[0.06, 0.34]", "**+0.92 [+0.75, +0.95]**"):
        assert INTERVAL.search(quoted), quoted
    for other in ("[faults]", "[[sensors]]", "[prior]", "(K+1, 4)", "[Findings](docs/x.md)"):
        assert not INTERVAL.search(other), other


def test_readme_quotes_no_confidence_interval_and_no_seed():
    text = _text(README)
    assert not INTERVAL.findall(text), INTERVAL.findall(text)
    assert "seed" not in text.lower()


def test_readme_links_and_figures_exist_and_the_figures_are_small():
    text = _text(README)
    targets = [m.group(1) for m in LINK.finditer(text)]
    figures = [t for t in targets if t.endswith(".png")]
    assert len(figures) >= 3, "one figure for each of the three jobs"
    for target in targets:
        assert (ROOT / target).exists(), target
    for figure in figures:
        size = (ROOT / figure).stat().st_size
        assert size < MAX_FIGURE_BYTES, f"{figure}: {size} bytes"
    for page in ("guide", "scenario-files", "cli", "findings", "results/index", "architecture",
                 "references", "errata"):
        assert f"](docs/{page}.md)" in text, page
    assert "](CHANGELOG.md)" in text


def test_readme_python_snippet_runs(tmp_path, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", _text(README), re.S)
    assert len(blocks) == 1
    assert len(blocks[0].splitlines()) <= 15, "the Python API in about ten lines"
    monkeypatch.chdir(tmp_path)  # whatever it writes goes to a temporary directory
    namespace: dict[str, object] = {"__name__": "readme"}
    exec(compile(blocks[0], str(README), "exec"), namespace)
    plan, pings, result = namespace["plan"], namespace["pings"], namespace["result"]
    assert plan.success and len(pings.steps) == 4  # type: ignore[attr-defined]
    assert set(result.summary) == {"straight", "leg-turn-leg+uniform"}  # type: ignore[attr-defined]


# --------------------------------------------------------------------------------------------
# CHANGELOG
# --------------------------------------------------------------------------------------------


def test_changelog_is_short_and_keeps_a_changelog():
    text = _text(CHANGELOG)
    assert len(text.splitlines()) <= MAX_CHANGELOG_LINES, f"{len(text.splitlines())} lines"
    releases = re.findall(r"^## (.*)$", text, re.M)
    assert releases and releases[0] == "[Unreleased]", releases
    versions = []
    for heading in releases[1:]:
        m = re.fullmatch(r"\[(\d+)\.(\d+)\.(\d+)\] - \d{4}-\d{2}-\d{2}", heading)
        assert m, heading
        versions.append(tuple(int(g) for g in m.groups()))
    assert versions == sorted(versions, reverse=True) and len(set(versions)) == len(versions)
    kinds = set(re.findall(r"^### (.*)$", text, re.M))
    assert kinds <= {"Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"}, kinds


def test_changelog_page_includes_the_changelog():
    assert "```{include} ../CHANGELOG.md" in _text(DOCS / "changelog.md")


# --------------------------------------------------------------------------------------------
# findings and campaign records
# --------------------------------------------------------------------------------------------


def test_every_campaign_record_is_in_a_toctree():
    assert "results/index" in _toctree_entries(DOCS / "index.md")
    listed = set(_toctree_entries(RESULTS / "index.md"))
    pages = {p.stem for p in RESULTS.glob("*.md")} - {"index"}
    assert pages, "no campaign records"
    assert pages == listed, (pages - listed, listed - pages)


def test_every_campaign_record_says_when_what_and_how_it_was_run():
    for page in sorted(RESULTS.glob("*.md")):
        if page.stem == "index":
            continue
        text = _text(page)
        sections = re.split(r"^## ", text, flags=re.M)[1:]
        assert sections, page.name
        for section in sections:
            title = section.splitlines()[0]
            assert re.search(r"\*\*Dates?\*\* \d{4}-\d{2}-\d{2}", section), (page.name, title)
            assert re.search(r"\*\*commits?\*\* `[0-9a-f]{7}`", section), (page.name, title)


def _findings_sections() -> list[str]:
    return re.split(r"^### ", _text(DOCS / "findings.md"), flags=re.M)[1:]


def test_every_finding_links_to_records_that_exist():
    sections = _findings_sections()
    assert len(sections) >= 10
    for section in sections:
        records = re.findall(r"\]\((results/[\w.-]+\.md)(?:#[\w-]*)?\)", section)
        assert records, f"finding without a record: {section.splitlines()[0]}"
        for record in records:
            assert (DOCS / record).exists(), record
    for target in (m.group(1) for m in LINK.finditer(_text(DOCS / "findings.md"))):
        assert (DOCS / target).exists(), target


def test_the_intervals_a_finding_quotes_are_those_of_its_records():
    records = " ".join(" ".join(_text(p).split()) for p in RESULTS.glob("*.md"))
    for section in _findings_sections():
        for interval in INTERVAL.findall(section):
            interval = " ".join(interval.split())  # the same whatever the line breaks
            assert interval in records, (section.splitlines()[0], interval)


def test_records_link_to_findings_that_exist():
    anchors = set()
    for line in _text(DOCS / "findings.md").splitlines():
        if line.startswith(("## ", "### ")):
            title = line.split(" ", 1)[1].strip().lower()
            anchors.add(re.sub(r"\s", "-", re.sub(r"[^\w\- ]", "", title)))
    for page in RESULTS.glob("*.md"):
        for anchor in re.findall(r"\.\./findings\.md#([\w-]+)", _text(page)):
            assert anchor in anchors, (page.name, anchor)


# --------------------------------------------------------------------------------------------
# architecture
# --------------------------------------------------------------------------------------------


def _architecture_words() -> set[str]:
    text = _text(DOCS / "architecture.md")
    block = re.search(r"```\ntmaplan/\n(.*?)```", text, re.S)
    assert block, "docs/architecture.md: no tmaplan/ tree"
    return set(re.findall(r"[A-Za-z_]\w*", block.group(1)))


@pytest.mark.parametrize("path", sorted((ROOT / "tmaplan").rglob("*.py")),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_architecture_names_every_module(path: Path):
    from tmaplan.cli import VERBS

    if path.stem == "__init__":
        return
    if path.parent.name == "cli" and path.stem.replace("_", "-") in VERBS:
        return  # "cli/  one module per verb"
    assert path.stem in _architecture_words(), (
        f"{path.relative_to(ROOT)} is not in the tree of docs/architecture.md")
