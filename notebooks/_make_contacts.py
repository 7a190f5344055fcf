"""Generate ``notebooks/plan_contacts.ipynb`` (no outputs): run this script."""

from __future__ import annotations

from _notebook import write

CELLS = [
    ("md", """# One own ship, two contacts: the joint plan against each contact's own plan

The built-in problem `two-contacts-crossing` has two contacts on opposite bows, `alpha` at
045° and `bravo` at 315°, crossing ahead (docs/several-contacts.md). A turn towards one
contact's side builds that contact's bearing rate but flattens the other's: the plan that
localises `alpha` soonest leaves `bravo` late, and the other way round. The joint planner
(`tmaplan.planning.contacts.ContactsPlanner`) builds one heading NLP for both, the own ship's
controls shared and one belief block per contact, and minimises the expected time until
*every* contact is localised (`all-contacts-time-to-accuracy`, each contact at its required
accuracy, 10 % of range here). It is multi-started from each contact's own plan
(`expected-time-to-accuracy` for that contact alone), which it plans on the way."""),
    ("code", """import numpy as np
import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt

from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.report_contacts import contact_colour
from tmaplan.scenario import load_problem

sc = load_problem("two-contacts-crossing")
cs = ContactSet.from_scenario(sc)
planner = ContactsPlanner(cs)  # objective all-contacts-time-to-accuracy
beliefs = cs.beliefs()         # each contact's prior
res = planner.solve(beliefs)
print(f"joint plan: {res.objective_name} = {res.objective:.0f} s ({res.plan.status}, "
      f"{res.seconds:.1f} s, kept the start {res.start})")
for name, p in res.alone.items():
    print(f"{name}'s own plan: expected-time-to-accuracy = {p.objective:.0f} s ({p.status})")
assert res.plan.success and all(p.success for p in res.alone.values())"""),
    ("md", """## Each contact on each plan

For every plan, each contact's expected time to its required accuracy and its closed-form
PCRB range bound (brehard2005) along the plan's track, from its prior
(`ContactsPlanner.per_contact`), and the plan's value of the joint objective."""),
    ("code", """plans = {"joint": res.plan, **{f"{n} alone": p for n, p in res.alone.items()}}
each = dict(zip(plans, planner.per_contact(beliefs, [p.observer for p in plans.values()])))
joint_objective = planner.joint.evaluator(beliefs)
print(f"{'plan':<12} {'joint objective':>16}" + "".join(f"{n:>26}" for n in cs.names))
for label, plan in plans.items():
    cells = "".join(f"{t / 60:13.1f} min / {b[-1]:5.0f} m" for t, b in each[label].values())
    print(f"{label:<12} {joint_objective(plan.observer)[0]:14.0f} s{cells}")
print("(each contact: expected time to accuracy / final range bound)")"""),
    ("md", """## The range bound over time

Each contact's range bound on the joint plan (solid) and on each contact's own plan (dashed:
its own; dotted: the other contact's). The right-hand panel draws the tracks: the joint plan
in black, each contact's own plan and its true track in the contact's colour."""),
    ("code", """fig, axes = plt.subplots(1, 3, figsize=(16, 4.8))
for ax, (i, name) in zip(axes[:2], enumerate(cs.names)):
    for label, plan in plans.items():
        t = (plan.observer.times - plan.observer.times[0]) / 60
        own = label == f"{name} alone"
        ls = "-" if label == "joint" else "--" if own else ":"
        ax.plot(t, each[label][name][1], ls, lw=2 if label == "joint" else 1.2,
                color="k" if label == "joint" else contact_colour(cs.names.index(label.split()[0])),
                label=f"{label} plan")
    ax.set_yscale("log"); ax.set_title(f"{name}: closed-form range bound", color=contact_colour(i))
    ax.set_xlabel("time [min]"); ax.set_ylabel("range bound [m]"); ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
cx = axes[2]
for label, plan in plans.items():
    p = plan.observer.position / 1e3
    col = "k" if label == "joint" else contact_colour(cs.names.index(label.split()[0]))
    cx.plot(p[:, 0], p[:, 1], "-" if label == "joint" else "--", color=col, label=f"{label} plan")
for i, v in enumerate(cs.views):
    x0 = np.asarray(v.target.position, float) / 1e3
    cx.plot(*x0, "o", color=contact_colour(i))
    cx.annotate(cs.names[i], x0, color=contact_colour(i))
cx.set_aspect("equal", adjustable="datalim")
cx.set_xlabel("East [km]"); cx.set_ylabel("North [km]")
cx.legend(fontsize=8); cx.grid(alpha=0.3)
plt.tight_layout(); plt.show()"""),
    ("md", """## The outcome

The joint plan cannot score worse than either contact's own plan on the joint objective (it
was started from both). The trade-off it buys: its worse-localised contact is localised well
before the worse contact of either single-contact plan, at a cost of a few minutes for each
contact against its own plan."""),
    ("code", """span = sc.time.horizon + sc.time.dt
worst = {label: max(t for t, _ in each[label].values()) for label in plans}
for label in plans:
    print(f"{label:<12} worse contact localised after {worst[label] / 60:.1f} min (expected)")
for name, p in res.alone.items():
    assert res.objective <= joint_objective(p.observer)[0] + 1e-3 * span
    # the worse contact of the joint plan is better off than the worse of each own plan
    assert worst["joint"] < worst[f"{name} alone"], name"""),
    ("md", """The same from the command line: `tmaplan plan two-contacts-crossing` prints this
table, writes the joint plan's leg table, GPX and CSV and a figure, and `tmaplan schedule
two-contacts-crossing --observer-plan PLAN.json` shares the ping budget between the contacts
along it."""),
]


if __name__ == "__main__":
    write("plan_contacts", CELLS)
