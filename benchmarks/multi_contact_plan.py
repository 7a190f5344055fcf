"""Planning for three contacts against one (issue 40): time ratio in one run (goal ≤ 3.5×).

Three contacts seen from the own ship of the built-in ``default`` problem (6 kn, 0.5 °/s,
45 min, 1-min control intervals): ``default``'s contact (045°, 5–25 km), ``contact-astern``'s
(185°, 5–20 km, following) and ``default``'s prior turned to 290°. Each is planned alone
(``expected-time-to-accuracy``, the one-contact planner's default multi-start), then the
three together with each objective over several contacts
(:class:`tmaplan.planning.contacts.ContactsPlanner`: the contacts' own plans, one start each,
then the joint NLP from the screened starts).

A plan's time is build + solve, measured twice: the CPU time of this process
(``time.process_time``, which a loaded machine inflates far less than the wall time) and the
wall time. Each of ``--repeats`` rounds times the three one-contact plans, then the
three-contact plan of each objective; a round's ratio is a three-contact time over the mean
of that round's one-contact times. The table gives the median over the rounds (and the range
of the ratio), with the joint NLP's solves of the last round (start: IPOPT iterations).

Run: python benchmarks/multi_contact_plan.py [--repeats 3] [--objectives NAME,NAME,...]
(default: all of :data:`CONTACTS_OBJECTIVE_NAMES`)
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import statistics
import time

from tmaplan.errors import ArgumentError
from tmaplan.planning.contacts import ContactSet, ContactsPlan, ContactsPlanner
from tmaplan.planning.multi_objectives import CONTACTS_OBJECTIVE_NAMES
from tmaplan.scenario import load_problem

GOAL = 3.5


def contacts() -> ContactSet:
    d = load_problem("default")
    a = load_problem("contact-astern")
    astern = d.replace(name="astern", target=a.target, prior=a.prior)
    west = d.replace(name="west", prior=dataclasses.replace(
        d.prior, bearing_mean=math.radians(290.0)))
    return ContactSet(views=(d, astern, west), names=("north-east", "astern", "west"))


def timed(cs: ContactSet, objective: str | None = None) -> tuple[float, float, ContactsPlan]:
    """CPU and wall time [s] of building and solving one plan, and the plan."""
    c, w = time.process_time(), time.perf_counter()
    plan = ContactsPlanner(cs, objective=objective).solve()
    return time.process_time() - c, time.perf_counter() - w, plan


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--objectives", default=",".join(CONTACTS_OBJECTIVE_NAMES))
    args = ap.parse_args()
    objectives = args.objectives.split(",")
    for obj in objectives:
        if obj not in CONTACTS_OBJECTIVE_NAMES:
            raise ArgumentError("--objectives", f"names from {list(CONTACTS_OBJECTIVE_NAMES)}",
                                obj)
    if args.repeats < 1:
        raise ArgumentError("--repeats", "an integer >= 1", args.repeats)
    cs = contacts()
    print(f"load average at start: {' '.join(f'{v:.2f}' for v in os.getloadavg())} "
          f"({os.cpu_count()} cores)")
    one: list[tuple[float, float]] = []  # per round: mean CPU, mean wall of the one-contact
    three: dict[str, list[tuple[float, float]]] = {o: [] for o in objectives}
    last: dict[str, ContactsPlan] = {}
    for r in range(args.repeats):
        row = []
        for i, name in enumerate(cs.names):
            c, w, p = timed(ContactSet(views=(cs.views[i],), names=(name,)))
            row.append((c, w))
            print(f"round {r}: one contact {name:10s}: CPU {c:6.2f} s  wall {w:6.2f} s  "
                  f"E[T] {p.expected_times[name] / 60:5.1f} min  ({p.plan.status}, "
                  f"{p.plan.iterations} it)", flush=True)
        one.append((statistics.fmean(c for c, _ in row), statistics.fmean(w for _, w in row)))
        for obj in objectives:
            c, w, p = timed(cs, obj)
            three[obj].append((c, w))
            last[obj] = p
            print(f"round {r}: three contacts {obj}: CPU {c:6.2f} s  wall {w:6.2f} s  "
                  f"ratio CPU {c / one[-1][0]:.2f} wall {w / one[-1][1]:.2f}  objective "
                  f"{p.objective / 60:.2f} min  ({p.plan.status}, start {p.start})",
                  flush=True)
    print(f"load average at end: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    med = statistics.median
    print(f"\n{args.repeats} round(s); medians; goal: ratio <= {GOAL}\n")
    print("| plan | CPU [s] | wall [s] | ratio CPU (range) | ratio wall (range) | "
          "joint solves: iterations | objective [min] |")
    print("|---|---|---|---|---|---|---|")
    print(f"| one contact (mean of 3) | {med(c for c, _ in one):.2f} | "
          f"{med(w for _, w in one):.2f} | 1 | 1 | built-in multi-start | |")
    for obj in objectives:
        rc = [c / o[0] for (c, _), o in zip(three[obj], one, strict=True)]
        rw = [w / o[1] for (_, w), o in zip(three[obj], one, strict=True)]
        p = last[obj]
        solves = ", ".join(f"{s}: {it}" + ("" if st == "Solve_Succeeded" else f" ({st})")
                           for s, it, st in p.solves)
        met = "met" if med(rc) <= GOAL else "MISSED"
        print(f"| three, {obj} | {med(c for c, _ in three[obj]):.2f} | "
              f"{med(w for _, w in three[obj]):.2f} | **{med(rc):.2f}** ({min(rc):.2f}–"
              f"{max(rc):.2f}, {met}) | {med(rw):.2f} ({min(rw):.2f}–{max(rw):.2f}) | "
              f"{solves} | {p.objective / 60:.2f} |")
    for obj in objectives:
        p = last[obj]
        per = ", ".join(f"{n} {p.expected_times[n] / 60:.2f}" for n in cs.names)
        alone = ", ".join(f"{n} {p.alone_times[n] / 60:.2f}" for n in cs.names)
        print(f"\n{obj}: E[T] per contact on the joint plan [min]: {per}\n"
              f"    E[T] of each contact on its own plan [min]: {alone}")


if __name__ == "__main__":
    main()
