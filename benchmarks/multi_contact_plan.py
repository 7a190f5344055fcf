"""Planning for three contacts against one (issue 40): time ratio in one run (goal ≤ 3.5×).

Three contacts seen from the own ship of the built-in ``default`` problem (6 kn, 0.5 °/s,
45 min, 1-min control intervals): ``default``'s contact (045°, 5–25 km), ``contact-astern``'s
(185°, 5–20 km, following) and ``default``'s prior turned to 290°. Each is planned alone
(``expected-time-to-accuracy``, the one-contact planner's default multi-start), then the
three together with each objective over several contacts
(:class:`tmaplan.planning.contacts.ContactsPlanner`: the contacts' own plans, one start each,
then the joint NLP from the best two of those plans and the built-in starts). Times are wall
times of build + solve, measured in this run; the ratio is three contacts over the mean of the
one-contact plans.

Run: python benchmarks/multi_contact_plan.py [--objectives all-contacts-time-to-accuracy,...]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.planning.multi_objectives import CONTACTS_OBJECTIVE_NAMES
from tmaplan.scenario import load_problem


def contacts() -> ContactSet:
    d = load_problem("default")
    a = load_problem("contact-astern")
    astern = dataclasses.replace(d, name="astern", target=a.target, prior=a.prior)
    west = dataclasses.replace(d, name="west", prior=dataclasses.replace(
        d.prior, bearing_mean=math.radians(290.0)))
    return ContactSet(views=(d, astern, west), names=("north-east", "astern", "west"))


def timed(cs: ContactSet, objective: str | None = None):
    t = time.perf_counter()
    plan = ContactsPlanner(cs, objective=objective).solve()
    return time.perf_counter() - t, plan


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--objectives", default=",".join(CONTACTS_OBJECTIVE_NAMES))
    args = ap.parse_args()
    cs = contacts()
    one = []
    for i, name in enumerate(cs.names):
        sec, p = timed(ContactSet(views=(cs.views[i],), names=(name,)))
        one.append(sec)
        print(f"one contact  {name:10s}: {sec:6.2f} s  E[T] {p.expected_times[name] / 60:5.1f} "
              f"min  ({p.plan.status}, {p.plan.iterations} it)")
    t1 = sum(one) / len(one)
    print(f"one contact, mean       : {t1:6.2f} s")
    for obj in args.objectives.split(","):
        sec, p = timed(cs, obj)
        per = ", ".join(f"{n} {p.expected_times[n] / 60:.1f}" for n in cs.names)
        alone = ", ".join(f"{n} {p.alone_times[n] / 60:.1f}" for n in cs.names)
        print(f"three contacts, {obj}: {sec:6.2f} s  ratio {sec / t1:.2f} (goal <= 3.5)  "
              f"objective {p.objective / 60:.1f} min  ({p.plan.status}, start {p.start})")
        print(f"    E[T] per contact on the joint plan [min]: {per}")
        print(f"    E[T] of each contact on its own plan [min]: {alone}")


if __name__ == "__main__":
    main()
