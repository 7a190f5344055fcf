"""The built-in problems are package data: found from a wheel, an editable install and a checkout.

Each case copies the source tree to a temporary folder, installs it into a fresh virtual
environment *outside* the checkout, and runs the ``tmaplan`` command there. Nothing is downloaded:
the wheel is built without build isolation (setuptools comes from the ``dev`` extra) and installed
with ``--no-deps``; the new environment sees the current environment's packages through a
``.pth`` file, so only ``tmaplan`` itself comes from the wheel.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

import tmaplan

ROOT = Path(__file__).resolve().parent.parent
PROBLEM_NAMES = sorted(p.stem for p in (ROOT / "problems").glob("*.toml"))
_IGNORE = shutil.ignore_patterns(".git", ".venv", "__pycache__", "build", "dist", "*.egg-info",
                                 "out", "_build", ".pytest_cache", ".ruff_cache", ".mypy_cache",
                                 ".hypothesis")


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None,
         timeout: float = 180) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)
    assert proc.returncode == 0, f"{' '.join(cmd)} failed:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


def _source_copy(tmp: Path) -> Path:
    src = tmp / "src"
    shutil.copytree(ROOT, src, symlinks=True, ignore=_IGNORE)
    return src


def _venv(tmp: Path) -> tuple[Path, dict[str, str]]:
    """A fresh venv (no pip) that sees the current environment's packages after its own."""
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)], cwd=tmp)
    py = venv / "bin" / "python"
    site = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=tmp).strip())
    parents = {sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]}
    (site / "_tmaplan_test_parent_env.pth").write_text("\n".join(sorted(parents)) + "\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "TMAPLAN_PROBLEMS", "VIRTUAL_ENV")}
    env["MPLBACKEND"] = "Agg"
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    return venv, env


def _pip(venv: Path, *args: str, cwd: Path) -> str:
    return _run([sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"),
                 "--disable-pip-version-check", "--no-input", *args], cwd=cwd, timeout=300)


def _imported_from(venv: Path, env: dict[str, str], cwd: Path) -> Path:
    out = _run([str(venv / "bin" / "python"), "-c", "import tmaplan; print(tmaplan.__file__)"],
               cwd=cwd, env=env)
    return Path(out.strip()).resolve()


def _listed(venv: Path, env: dict[str, str], cwd: Path) -> list[str]:
    out = _run([str(venv / "bin" / "tmaplan"), "problems", "--json", "-"], cwd=cwd, env=env)
    return [p["name"] for p in json.loads(out)]


def test_problems_are_declared_package_data():
    """The link tmaplan/problems -> ../problems and the package-data glob that ships it."""
    link = ROOT / "tmaplan" / "problems"
    assert link.is_symlink() and link.resolve() == (ROOT / "problems").resolve()
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "problems/*.toml" in cfg["tool"]["setuptools"]["package-data"]["tmaplan"]
    assert len(PROBLEM_NAMES) >= 10 and "default" in PROBLEM_NAMES


def test_wheel_install_outside_the_checkout(tmp_path):
    src = _source_copy(tmp_path)
    dist = tmp_path / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
          "--disable-pip-version-check", "-q", "-w", str(dist), "."], cwd=src, timeout=300)
    (wheel,) = dist.glob("tmaplan-*.whl")
    assert wheel.name.startswith(f"tmaplan-{tmaplan.__version__}-")
    with zipfile.ZipFile(wheel) as zf:
        shipped = sorted(Path(n).stem for n in zf.namelist() if n.startswith("tmaplan/problems/"))
        data = [n for n in zf.namelist() if n.startswith("tmaplan/data/")]
    assert shipped == PROBLEM_NAMES
    assert data == ["tmaplan/data/demo_stored.json"]  # the demo's stored result (issue 38)

    shutil.rmtree(src)  # nothing of the checkout is left to be found by accident
    venv, env = _venv(tmp_path)
    _pip(venv, "install", "--no-deps", "--no-index", "-q", str(wheel), cwd=tmp_path)
    work = tmp_path / "elsewhere"
    work.mkdir()
    assert _imported_from(venv, env, work).is_relative_to(venv.resolve())
    assert _listed(venv, env, work) == PROBLEM_NAMES
    # the table form too (it used to fail with "max() arg is an empty sequence")
    assert "default" in _run([str(venv / "bin" / "tmaplan"), "problems"], cwd=work, env=env)

    sim = json.loads(_run([str(venv / "bin" / "tmaplan"), "simulate", "default", "--no-plot",
                           "--json", "-"], cwd=work, env=env))
    assert len(sim["times"]) == len(sim["target"]) > 1
    plan = json.loads(_run([str(venv / "bin" / "tmaplan"), "plan", "default", "--horizon", "600",
                            "--no-plot", "--json", "-"], cwd=work, env=env))
    assert plan["times"][-1] == pytest.approx(600.0)
    assert plan["solver"]["status"] and plan["objective"] is not None
    # --no-plot draws nothing; the plan's navigator exports (issue 41) are its only files
    written = sorted(p.name for p in (work / "out").iterdir()) if (work / "out").exists() else []
    assert written and all(n.endswith(("_legs.csv", "_track.gpx", "_track.csv"))
                           for n in written), written
    stored = _run([str(venv / "bin" / "python"), "-c", "from tmaplan.headline import "
                   "load_stored; print(load_stored().campaigns[0].command)"], cwd=work, env=env)
    assert stored.startswith("tmaplan compare default --policies ")


def test_editable_install_outside_the_checkout(tmp_path):
    src = _source_copy(tmp_path)
    venv, env = _venv(tmp_path)
    _pip(venv, "install", "--no-deps", "--no-build-isolation", "--no-index", "-q", "-e", str(src),
         cwd=tmp_path)
    work = tmp_path / "elsewhere"
    work.mkdir()
    assert _imported_from(venv, env, work).is_relative_to(src.resolve())
    assert _listed(venv, env, work) == PROBLEM_NAMES


def test_plain_checkout_without_install(tmp_path):
    src = _source_copy(tmp_path)
    venv, env = _venv(tmp_path)
    env["PYTHONPATH"] = str(src)
    out = _run([str(venv / "bin" / "python"), "-m", "tmaplan.cli", "problems", "--json", "-"],
               cwd=tmp_path, env=env)
    assert [p["name"] for p in json.loads(out)] == PROBLEM_NAMES
