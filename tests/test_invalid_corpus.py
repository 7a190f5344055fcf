"""The corpus of invalid scenario files: each gets one clear line naming the field.

Each file in ``tests/data/invalid`` starts with ``# expect-field: F`` and ``# expect: TEXT``;
loading it must raise ScenarioError whose one-line message names F and contains TEXT, and the
CLI must exit non-zero with that line and no traceback. ``tests/data/invalid_cli/cases.toml``
holds command lines that cannot work (an estimator without its measurements, a bound not
defined for it, turning policies without a turn-rate limit): each is refused with one line.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from tmaplan.cli import main
from tmaplan.errors import ScenarioError
from tmaplan.scenario import load

CORPUS = sorted((Path(__file__).parent / "data" / "invalid").glob("*.toml"))


def _expect(path: Path) -> tuple[str, str]:
    # the two header lines are text even in the corpus's binary file
    lines = [x.decode("utf-8") for x in path.read_bytes().splitlines()[:2]]
    field = lines[0].removeprefix("# expect-field: ").strip()
    text = lines[1].removeprefix("# expect: ").strip()
    return field, text


def test_corpus_is_large_enough():
    assert len(CORPUS) >= 30


@pytest.mark.parametrize("path", CORPUS, ids=[p.stem for p in CORPUS])
def test_invalid_file(path):
    field, text = _expect(path)
    with pytest.raises(ScenarioError) as exc:
        load(path)
    msg = str(exc.value)
    assert f"field '{field}" in msg or f".{field}" in msg or field in msg, msg
    assert text in msg, msg
    assert str(path) in msg and "\n" not in msg


def test_cli_reports_one_line(tmp_path):
    path = CORPUS[0]
    proc = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", str(path)],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 1
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and _expect(path)[0] in err[0]


# ------------------------------------------------------------ command lines that cannot work
CLI_DIR = Path(__file__).parent / "data" / "invalid_cli"
CLI_CASES = tomllib.loads((CLI_DIR / "cases.toml").read_text(encoding="utf-8"))["case"]


@pytest.mark.parametrize("case", CLI_CASES, ids=[c["id"] for c in CLI_CASES])
def test_invalid_command_line(case, capsys, tmp_path, monkeypatch):
    if "available_gib" in case:  # the memory the run may use, whatever the machine's
        monkeypatch.setattr("tmaplan.memory.available_bytes",
                            lambda: case["available_gib"] * 2.0**30)
    argv = [a.replace("{data}", str(CLI_DIR)) for a in case["argv"]]
    assert main([*argv, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"tmaplan {argv[0]}: error:"), err
    for text in case["expect"]:
        assert text in err[0], err[0]


def test_cli_corpus_covers_every_estimator():
    named = {c["argv"][c["argv"].index("--estimator") + 1] for c in CLI_CASES
             if "--estimator" in c["argv"]}
    assert named == {"mle", "pf", "pf-bearings", "range-only"}
