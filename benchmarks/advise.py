"""``tmaplan advise`` on a long recording (issue 41): a 2-hour log of bearings at 1 s to 3
contacts (21 600 rows) with the own ship's NMEA navigation at 1 Hz (the recording of
``benchmarks/io_read.py``: a zig-zagging own ship, so every contact is observable), read and
solved — per contact the batch ML solution with its CRLB, the particle filter's posterior
(10 000 particles, on the 10 s grid of :class:`tmaplan.advice.Platform`'s ``step_min``),
the verdict and Ekelund's range. Target: read and solved in at most 10 s.

Times in seconds, best of ``--repeat``: ``read`` (``read_recording``), ``solve`` (every
contact's ``contact_problem`` + ``solve_contact``), and their sum; ``--advice`` also times
the advice of one contact and the joint advice of all contacts (``advise_contacts``: one
manoeuvre and two shared pings for all, what ``tmaplan advise`` runs with several contacts;
not part of the target, reported with the total of read, solve and joint advice).

Run: python benchmarks/advise.py [--hours 2] [--contacts 3] [--repeat 2] [--advice] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

from io_read import write_recording  # the same recording as the readers' benchmark

from tmaplan.advice import (
    Platform,
    advise_contact,
    advise_contacts,
    contact_problem,
    contact_rng,
    solve_contact,
)
from tmaplan.io import read_recording


def solve_all(rec, platform):
    """Every contact's solution (the verb's loop)."""
    n = len(rec.contacts)
    return [solve_contact(contact_problem(rec, c, platform), rng=contact_rng(0, i, n),
                          frame=rec.frame, particles=platform.particles)
            for i, c in enumerate(rec.contacts)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=2.0)
    ap.add_argument("--contacts", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--advice", action="store_true")
    ap.add_argument("--json", default=None, metavar="OUT")
    args = ap.parse_args()
    platform = Platform()
    seconds: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        files = write_recording(Path(tmp), args.hours, args.contacts)
        best = {"read": float("inf"), "solve": float("inf"), "total": float("inf")}
        for _ in range(args.repeat):  # timing repeats
            t0 = time.perf_counter()
            rec = read_recording(files["bearings"], files["nmea"])
            t1 = time.perf_counter()
            sols = solve_all(rec, platform)
            t2 = time.perf_counter()
            for k, v in (("read", t1 - t0), ("solve", t2 - t1), ("total", t2 - t0)):
                best[k] = min(best[k], v)
        seconds.update(best)
        if args.advice:
            t = time.perf_counter()
            advise_contact(sols[0], platform, horizon=1200.0, budget=2)
            seconds["advice_one_contact"] = time.perf_counter() - t
            t = time.perf_counter()
            joint = advise_contacts(sols, platform, horizon=1200.0, budget=2)
            seconds["advice_joint"] = time.perf_counter() - t
            seconds["total_with_joint_advice"] = seconds["total"] + seconds["advice_joint"]
            print(f"joint advice: {joint.note}; pings lower bound "
                  f"{joint.pings.schedule.lower_bound:.1f} m <= objective "
                  f"{joint.pings.schedule.objective:.1f} m (gap {joint.pings.schedule.gap:.2%})"
                  if joint.pings is not None else f"joint advice: {joint.note}")
    rows = sum(c.times.size for c in rec.contacts)
    print(f"{args.hours:g} h, {args.contacts} contacts, {rows} bearings at 1 s, "
          f"{platform.particles} particles, {platform.step_min:g} s grid; best of "
          f"{args.repeat}:")
    for name, s in seconds.items():
        print(f"  {name:<20} {s:7.2f} s")
    for s in sols:
        e = s.pf
        print(f"  {s.name}: {s.verdict}; PF range {e.range / 1e3:.2f} ± "
              f"{e.std['range'] / 1e3:.2f} km, ML {s.mle.range / 1e3:.2f} ± "
              f"{s.mle.std['range'] / 1e3:.2f} km ({s.mle.status})")
    print(f"target: read + solve <= 10 s: {'met' if seconds['total'] <= 10.0 else 'NOT met'}")
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "seconds": seconds}, indent=1)
                                   + "\n")


if __name__ == "__main__":
    main()
