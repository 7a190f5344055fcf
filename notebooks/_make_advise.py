"""Generate ``notebooks/advise_recording.ipynb`` (no outputs): run this script."""

from __future__ import annotations

from _notebook import write

CELLS = [
    ("md", """# From a recording to advice: `simulate --export`, then `advise`

A simulated run is written as recorded data (bearings CSV, own-ship NMEA/GPX/CSV and the
truth), read back as a recording, and each contact is solved: the batch ML solution with its
CRLB, the particle filter's posterior, the observability verdict and Ekelund's range
(ekelund1958). Then the advice: the heading planner started from the posterior, scored by the
expected time to 10 % range accuracy against holding course, and two pings with their
certificate. The own ship of `tests/data/advise/manoeuvre.toml`-like run turns at 20 min:
before the turn the range is unobservable (nardone1981), after it the solution holds the
truth within its 95 % intervals (docs/recordings.md)."""),
    ("code", """import json, math, subprocess, sys
from pathlib import Path

import numpy as np

from tmaplan.advice import Platform, advise_contact, contact_problem, contact_rng, solve_contact
from tmaplan.io import read_recording, read_truth
from tmaplan.io.plans import legs_table
from tmaplan.scenario import load_problem, save

# the built-in `default` problem with a starboard turn to 090 at 20 min
sc = load_problem("default")
import dataclasses
from tmaplan.scenario import ObserverLeg
turn = ObserverLeg(start=1200.0, course=math.radians(90.0), turn_rate=math.radians(0.5),
                   turn_direction="starboard")
sc = sc.replace(name="default-turn", observer=dataclasses.replace(sc.observer, legs=(turn,)))
save(sc, "default-turn.toml", overwrite=True)
run = subprocess.run([sys.executable, "-m", "tmaplan.cli", "simulate", "default-turn.toml",
                      "--seed", "3", "--export", "run", "--no-figure"],
                     capture_output=True, text=True)
print(run.stdout)
assert run.returncode == 0, run.stderr
print(Path("run/bearings.csv").read_text().splitlines()[:3])"""),
    ("md", "## Before the turn: unobservable"),
    ("code", """lines = Path("run/bearings.csv").read_text().splitlines()
early = [lines[0]] + [x for x in lines[1:] if x < "2024-06-01T12:20"]
Path("run/early.csv").write_text("\\n".join(early) + "\\n")
rec = read_recording("run/early.csv", "run/ownship.nmea")
c = rec.contacts[0]
before = solve_contact(contact_problem(rec, c, Platform()), rng=contact_rng(0, 0, 1),
                       frame=rec.frame)
print(before.verdict)
print(f"PF range {before.pf.range / 1e3:.1f} ± {before.pf.std['range'] / 1e3:.1f} km")
assert not before.observable and before.verdict.startswith("unobservable")"""),
    ("md", "## After the turn: the solution and its uncertainty"),
    ("code", """rec = read_recording("run/bearings.csv", "run/ownship.nmea")
c = rec.contacts[0]
sol = solve_contact(contact_problem(rec, c, Platform()), rng=contact_rng(0, 0, 1),
                    frame=rec.frame)
truth = read_truth("run/truth.json").contacts["contact"][-1]
own = np.array([rec.nav.east[-1], rec.nav.north[-1]])
r_true = float(np.hypot(*(truth[:2] - own)))
print(sol.verdict)
for e in (sol.pf, sol.mle):
    lo, hi = e.interval("range")
    print(f"{e.estimator}: range {e.range / 1e3:.2f} km, 95 % [{lo / 1e3:.2f}, {hi / 1e3:.2f}] "
          f"km (truth {r_true / 1e3:.2f}); course {math.degrees(e.course):.0f}°, "
          f"speed {e.speed / 0.5144:.1f} kn; at {e.lat:.5f}, {e.lon:.5f}")
print(f"Ekelund: {sol.ekelund.range / 1e3:.2f} ± {sol.ekelund.std / 1e3:.2f} km at "
      f"{rec.time_text(sol.ekelund.time)}")
assert sol.observable
lo, hi = sol.pf.interval("range")
assert lo <= r_true <= hi"""),
    ("md", "## The advice: manoeuvre, leg table and pings"),
    ("code", """adv = advise_contact(sol, Platform(), horizon=600.0, budget=2)
print(adv.note)
print(legs_table(adv.legs))
print("pings at", [rec.time_text(t) for t in adv.pings.times],
      f"lower bound {adv.pings.lower_bound:.1f} m, gap {adv.pings.gap:.1%}")
assert adv.expected_time_to_accuracy <= adv.hold_course_time_to_accuracy
assert adv.pings.lower_bound <= adv.pings.objective"""),
    ("md", """## The same from the command line

`tmaplan advise` writes the JSON, the figures, the page `advise.html` and, per contact, the
leg table and the recommended track as GPX and CSV."""),
    ("code", """run = subprocess.run([sys.executable, "-m", "tmaplan.cli", "advise",
                      "run/bearings.csv", "--ownship", "run/ownship.gpx", "--horizon",
                      "10 min", "--out", "out", "--json", "advice.json"],
                     capture_output=True, text=True)
print(run.stdout)
assert run.returncode == 0, run.stderr
got = json.loads(Path("advice.json").read_text())
print(sorted(got["exports"]["contact"]))
assert Path(got["report"]).exists()"""),
]


if __name__ == "__main__":
    write("advise_recording", CELLS)
