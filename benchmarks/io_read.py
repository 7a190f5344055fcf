"""Reading a recording (issue 41): a 2-hour log of bearings at 1 s to 3 contacts (21 600 rows,
ISO 8601 times) with the own ship's navigation at 1 Hz, as NMEA 0183 (RMC + GGA, 14 400
sentences), GPX and CSV.

Times, best of ``--repeat``, in seconds: ``read_bearings``, ``read_nav`` of each navigation
file, and ``read_recording`` (bearings + NMEA: both reads, the local frame and the own ship's
state at the 21 600 bearing times). The files are written first (by tmaplan.io's writers) to a
temporary directory. Target: well under a few seconds for the whole recording.

Run: python benchmarks/io_read.py [--hours 2] [--contacts 3] [--repeat 3] [--json OUT]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from tmaplan.io import (
    LocalFrame,
    read_bearings,
    read_nav,
    read_recording,
    write_bearings,
    write_gpx,
    write_nmea,
    write_ownship_csv,
)

START = dt.datetime(2024, 6, 1, 22, 30, tzinfo=dt.UTC)  # crosses midnight at 2 h


def write_recording(d: Path, hours: float, contacts: int) -> dict[str, Path]:
    """A zig-zagging own ship at 6 kn and ``contacts`` contacts, bearings and fixes at 1 s."""
    rng = np.random.default_rng(41)
    t = np.arange(0.0, hours * 3600.0 + 1.0)
    course = 0.6 * np.sign(np.sin(2 * np.pi * t / 1800.0))
    v = 3.0 * np.column_stack([np.sin(course), np.cos(course)])
    pos = np.vstack([[0.0, 0.0], np.cumsum(v[:-1], axis=0)])
    lat, lon = LocalFrame(lat0=45.0, lon0=-5.0).to_latlon(pos[:, 0], pos[:, 1])
    bt, bb, names = [], [], []
    for k in range(contacts):
        x0 = rng.uniform(-20e3, 20e3, 2)
        vt = rng.uniform(-5.0, 5.0, 2)
        rel = x0 + t[:, None] * vt - pos
        bt.append(t)
        bb.append(np.arctan2(rel[:, 0], rel[:, 1]) + rng.normal(0.0, 0.01, t.size))
        names += [f"C{k + 1}"] * t.size
    order = np.argsort(np.concatenate(bt), kind="stable")
    files = {
        "bearings": write_bearings(d / "bearings.csv", np.concatenate(bt)[order],
                                   np.concatenate(bb)[order], sigma=0.01,
                                   contact=[names[i] for i in order], start=START),
        "nmea": write_nmea(d / "ownship.nmea", t, lat, lon, start=START, course=course,
                           speed=np.full(t.size, 3.0)),
        "gpx": write_gpx(d / "ownship.gpx", t, lat, lon, start=START),
        "csv": write_ownship_csv(d / "ownship.csv", t, lat, lon, start=START),
    }
    return files


def best(fn, repeat: int) -> float:
    """Best wall time [s] of ``repeat`` calls of ``fn``."""
    out = []
    for _ in range(repeat):  # timing repeats
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return min(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=2.0)
    ap.add_argument("--contacts", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", default=None, metavar="OUT")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("error")  # the benchmark's files are clean: no DataWarning
        files = write_recording(Path(tmp), args.hours, args.contacts)
        log = read_bearings(files["bearings"])
        rows = sum(c.times.size for c in log.contacts)
        fixes = read_nav(files["nmea"]).times.size
        seconds = {
            "read_bearings": best(lambda: read_bearings(files["bearings"]), args.repeat),
            **{f"read_nav_{k}": best(lambda k=k: read_nav(files[k]), args.repeat)
               for k in ("nmea", "gpx", "csv")},
            "read_recording": best(lambda: read_recording(files["bearings"], files["nmea"]),
                                   args.repeat),
        }
    print(f"{args.hours:g} h, {args.contacts} contacts: {rows} bearing rows, {fixes} fixes "
          f"(1 Hz); best of {args.repeat}:")
    for name, s in seconds.items():
        print(f"  {name:<16} {s:7.3f} s")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "fixes": fixes,
                                               "seconds": seconds}, indent=1) + "\n")


if __name__ == "__main__":
    main()
