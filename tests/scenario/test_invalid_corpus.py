"""The corpus of invalid scenario files: each gets one clear line naming the field.

Each file in ``tests/data/invalid`` starts with ``# expect-field: F`` and ``# expect: TEXT``;
loading it and checking it as the command line does (:func:`tmaplan.scenario.load`, then the
rules that need the motion model, :func:`tmaplan.models.checks.check_scenario`) must raise
ScenarioError whose one-line message names F and contains TEXT, and the CLI must exit non-zero
with that line and no traceback. ``tests/data/invalid_cli/cases.toml``
holds command lines that cannot work (an estimator without its measurements, a bound not
defined for it, turning policies without a turn-rate limit): each is refused with one line.
``tests/data/invalid_data/cases.toml`` holds recorded data files with a fault (bearings CSV,
own-ship CSV, NMEA and GPX, leg tables, ``advise --platform`` files): each raises a one-line
``DataError`` naming the file and line, or reads with one-line ``DataWarning`` s saying what
was done.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from repo_paths import DATA

from tmaplan.cli import main
from tmaplan.errors import ScenarioError
from tmaplan.models.checks import check_scenario
from tmaplan.scenario import load

CORPUS = sorted((DATA / "invalid").glob("*.toml"))


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
        check_scenario(load(path), source=str(path))
    msg = str(exc.value)
    assert f"field '{field}" in msg or f".{field}" in msg or field in msg, msg
    assert text in msg, msg
    assert str(path) in msg and "\n" not in msg


@pytest.mark.parametrize("path", [CORPUS[0], *(p for p in CORPUS if "inside_previous_turn"
                                               in p.stem)], ids=lambda p: p.stem)
def test_cli_reports_one_line(tmp_path, path):
    # the first file (a schema rule), and one that only the motion model refuses
    proc = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", str(path)],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 1
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and _expect(path)[0] in err[0] and str(path) in err[0], err


def test_the_schema_alone_takes_what_only_the_motion_model_refuses():
    # tmaplan.scenario sits below the models: a leg inside the previous turn loads, and the
    # model-level check (run by the command line on every scenario it loads) refuses it
    path = next(p for p in CORPUS if "inside_previous_turn" in p.stem)
    scenario = load(path)
    with pytest.raises(ScenarioError, match=r"observer\.legs\[1\]\.start"):
        check_scenario(scenario)


# ------------------------------------------------------------ command lines that cannot work
CLI_DIR = DATA / "invalid_cli"
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


# ------------------------------------------------------------ recorded data (tmaplan.io)
DATA_DIR = DATA / "invalid_data"
DATA_CASES = tomllib.loads((DATA_DIR / "cases.toml").read_text(encoding="utf-8"))["case"]


def _read_data(case: dict) -> object:
    from tmaplan import io

    path = DATA_DIR / case["file"]
    if case["read"] == "recording":
        return io.read_recording(path, DATA_DIR / case["nav"])
    if case["read"] == "platform":
        from tmaplan.advice import read_platform

        return read_platform(path)
    return {"bearings": io.read_bearings, "nav": io.read_nav,
            "legs": io.read_legs_csv}[case["read"]](path)


@pytest.mark.parametrize("case", DATA_CASES, ids=[c["file"] for c in DATA_CASES])
def test_invalid_data_file(case):
    import warnings

    from tmaplan.errors import DataError
    from tmaplan.io import DataWarning

    path = str(DATA_DIR / case["file"])
    if "error" in case:
        with pytest.raises(DataError) as exc:
            _read_data(case)
        msg = str(exc.value)
        assert "\n" not in msg and msg.startswith(path), msg
        where = f"{path}:{case['line']}: " if "line" in case else f"{path}: "
        assert msg.startswith(where), (where, msg)
        for text in case["error"]:
            assert text in msg, (text, msg)
        return
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        _read_data(case)
    msgs = [str(w.message) for w in rec if issubclass(w.category, DataWarning)]
    assert all("\n" not in m and m.startswith(path) for m in msgs), msgs
    if not case["warn"]:
        assert not msgs, msgs
    for text in case["warn"]:
        assert any(text in m for m in msgs), (text, msgs)


def test_data_corpus_covers_every_kind_of_fault():
    errors = {c["file"] for c in DATA_CASES if "error" in c}
    warned = {c["file"] for c in DATA_CASES if c.get("warn")}
    assert len(errors) >= 20 and len(warned) >= 8
    kinds = {c["file"].rsplit(".", 1)[1] for c in DATA_CASES}
    assert kinds == {"csv", "nmea", "gpx", "toml"}
    assert {c["read"] for c in DATA_CASES} == {"bearings", "nav", "legs", "platform",
                                               "recording"}
    on_disk = {p.name for p in DATA_DIR.iterdir() if p.name != "cases.toml"}
    named = {c["file"] for c in DATA_CASES} | {c["nav"] for c in DATA_CASES if "nav" in c}
    assert on_disk == named, on_disk ^ named
