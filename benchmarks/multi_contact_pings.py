"""Shared pings for two contacts (issue 40): certified ``exact`` schedules, K ≤ 3, ≤ 200 steps.

Two contacts seen from the own ship of the built-in ``default`` problem on its scripted
track: ``default``'s contact (045°, 5–25 km) and ``contact-astern``'s (185°, 5–20 km), over a
horizon of 200 steps of 15 s (50 min), pings at least 2 min apart (``default``'s spacing), the
``mean-range-bound`` objective of each contact, weighted mean over the contacts. For K = 1, 2, 3
and a ping reach unlimited and of 14 km (one contact in reach part of the time at most):
``method="exact"``'s status, certified gap, where the bound comes from and the wall time
(goal: ``optimal``, gap ≤ 1e-3, ≤ 60 s each). A benchmark, not a timed test.

Run: python benchmarks/multi_contact_pings.py [--budgets 1,2,3] [--steps 200]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

from tmaplan.planning.contacts import ContactSet
from tmaplan.planning.ping_contacts import schedule_contact_pings
from tmaplan.scenario import load_problem


def contacts(steps: int) -> ContactSet:
    d = load_problem("default")
    horizon = steps * float(d.time.dt)
    d = d.replace(time=dataclasses.replace(d.time, horizon=horizon),
                  planning=dataclasses.replace(d.planning, horizon=horizon))
    a = load_problem("contact-astern")
    astern = d.replace(name="astern", target=a.target, prior=a.prior)
    return ContactSet(views=(d, astern), names=("north-east", "astern"))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--budgets", default="1,2,3")
    ap.add_argument("--steps", type=int, default=200)
    args = ap.parse_args()
    cs = contacts(args.steps)
    print(f"two contacts, {cs.views[0].time.n_steps} steps of {cs.views[0].time.dt:g} s")
    for reach in (None, 14_000.0):
        for k in (int(b) for b in args.budgets.split(",")):
            t = time.perf_counter()
            r = schedule_contact_pings(cs, budget=k, method="exact", max_range=reach,
                                       time_limit=60.0)
            sec = time.perf_counter() - t
            s = r.schedule
            label = "unlimited" if reach is None else f"{reach / 1000:g} km"
            print(f"  reach {label:9s} K={k}: {s.status:10s} gap {s.gap:.2e}  {sec:6.2f} s "
                  f"(goal <= 60 s)  objective {s.objective:8.1f} m  lower bound "
                  f"{s.lower_bound:8.1f} m  ({s.gap_reference})  pings at "
                  f"{[round(float(x) / 60, 1) for x in s.times]} min, in reach "
                  f"{r.pings_in_reach}")


if __name__ == "__main__":
    main()
