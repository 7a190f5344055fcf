"""The corpus of invalid scenario files: each gets one clear line naming the field.

Each file in ``tests/data/invalid`` starts with ``# expect-field: F`` and ``# expect: TEXT``;
loading it must raise ScenarioError whose one-line message names F and contains TEXT, and the
CLI must exit non-zero with that line and no traceback.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

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
