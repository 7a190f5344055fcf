"""Coverage of ``tmaplan advise``'s 95 % intervals on an independent simulator's recordings.

``tests/independent_recording.py`` (numpy + ``pyproj.Geod``, no tmaplan code) simulates a
recording per seed, writes the bearings CSV and the own ship's navigation, and this script
runs ``tmaplan advise`` on them and counts, per estimator (the reported particle filter,
``pf``, and the batch ``mle``), contact and quantity, how often the truth lies outside the
stated 95 % interval, with the rms of (truth − estimate)/σ.

    python benchmarks/independent_coverage.py --seeds 0:30 --nav csv \\
        --sim '{"lat0": 60, "lon0": 5, "own_speed": 15.4333, "own_course": 90,
                "leg1": 2400, "leg2": 2400, "intervals": [10, 10]}'

(docs/results/recorded-data.md).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import independent_recording as ir

from tmaplan.cli import main as tmaplan_main

WRITERS = {"csv": ir.write_ownship_csv, "nmea": ir.write_ownship_nmea,
           "gpx": ir.write_ownship_gpx}


def main() -> None:
    """Run the sweep and print the table."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0:10", help="A:B, the seeds A to B-1")
    ap.add_argument("--nav", choices=sorted(WRITERS), default="csv")
    ap.add_argument("--sim", default="{}", help="JSON keywords of independent_recording.simulate")
    args = ap.parse_args()
    a, b = (int(x) for x in args.seeds.split(":"))
    kw = {k: tuple(v) if isinstance(v, list) else v for k, v in json.loads(args.sim).items()}
    z: dict[str, list[list[float]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(a, b):
            rec = ir.simulate(seed, **kw)
            d = Path(tmp) / str(seed)
            d.mkdir()
            bfile = ir.write_bearings(rec, d / "bearings.csv")
            nfile = WRITERS[args.nav](rec, d / f"ownship.{args.nav}")
            with contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()):
                tmaplan_main(["advise", str(bfile), "--ownship", str(nfile), "--no-advice",
                              "--no-figure", "--seed", str(seed), "--json",
                              str(d / "a.json")])
            got = json.loads((d / "a.json").read_text())
            for name, c in got["contacts"].items():
                for est in ("pf", "mle"):
                    e = c[est]
                    truth = rec.truth(name, e["time"])
                    row = []
                    for q in ("range", "course", "speed"):
                        err = (math.radians(truth[q]) if q == "course" else truth[q]) - e[q]
                        if q == "course":
                            err = (err + math.pi) % (2 * math.pi) - math.pi
                        row.append(err / e["std"][q])
                    z.setdefault(f"{est} {name}", []).append(row)
    print(f"seeds {a}..{b - 1}, nav {args.nav}, sim {kw}")
    print("estimator contact | runs | misses range/course/speed | rms z range/course/speed")
    for key, rows in sorted(z.items()):
        arr = np.asarray(rows)
        miss = (np.abs(arr) > 1.959963984540054).sum(axis=0)
        rms = np.sqrt((arr ** 2).mean(axis=0))
        print(f"{key} | {len(arr)} | {'/'.join(str(int(m)) for m in miss)} | "
              f"{'/'.join(f'{r:.2f}' for r in rms)}")


if __name__ == "__main__":
    main()
