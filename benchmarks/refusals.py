"""How fast an impossible plan is refused (issue 38): the wall time of a fresh ``tmaplan``
process from its start to its one-line error, for the three inputs that used to reach the
solver: a keep-out range of 20 km with the contact at 12 km (``planning.keep_out_range``), a
turn-rate limit of 90 °/s (``observer.turn_rate_max``) and a 30-day horizon
(``planning.horizon``; refused where it does not fit in memory, which on a machine with more
than about 40 GiB free it may), each with ``plan`` and ``compare --policies
straight,planned``. Each is ``default`` with the one field changed.

Baseline in the same run: a Python process that imports numpy and exits (the floor of any
command). Goal: every refusal under 2 s on an idle machine, about ten times the baseline.
Printed: best of ``--repeat`` wall times [s] and their ratio to the baseline.

Run: python benchmarks/refusals.py [--repeat 3] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import tomli_w

from tmaplan.scenario import problems_dir

CASES: dict[str, dict[str, dict[str, str]]] = {
    "keep-out 20 km": {"planning": {"keep_out_range": "20 km"}},
    "turn rate 90 deg/s": {"observer": {"turn_rate_max": "90 deg/s"}},
    "horizon 30 d": {"time": {"horizon": "30 d"}, "planning": {"horizon": "30 d"}},
}
VERBS: dict[str, list[str]] = {"plan": ["plan"],
                               "compare": ["compare", "--policies", "straight,planned"]}


def _file(directory: Path, name: str, change: dict[str, dict[str, str]]) -> Path:
    data = tomllib.loads((problems_dir() / "default.toml").read_text(encoding="utf-8"))
    for table, fields in change.items():
        data[table].update(fields)
    path = directory / f"{name.split()[0]}.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    return path


def _best(cmd: list[str], repeat: int, *, refused: bool) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        run = subprocess.run(cmd, capture_output=True, text=True)
        best = min(best, time.perf_counter() - t0)
        if refused and (run.returncode != 1 or "field '" not in run.stderr):
            raise SystemExit(f"not refused with a field named: {cmd}: {run.stderr.strip()}")
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    tmaplan = [sys.executable, "-m", "tmaplan"]
    base = _best([sys.executable, "-c", "import numpy"], args.repeat, refused=False)
    print(f"baseline (python -c 'import numpy'): {base:.2f} s")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, change in CASES.items():
            path = _file(Path(tmp), name, change)
            for verb, words in VERBS.items():
                cmd = [*tmaplan, words[0], str(path), *words[1:], "--out", tmp]
                t = _best(cmd, args.repeat, refused=True)
                rows.append({"case": name, "verb": verb, "seconds": t, "ratio": t / base})
                print(f"{name:<20} {verb:<8} {t:5.2f} s  ({t / base:4.1f}x baseline)")
    if args.json:
        Path(args.json).write_text(json.dumps({"baseline": base, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
