"""How much can any open-loop plan gain over the best single turn on several contacts? (issue 40)

Flies on a several-contact problem, in one paired campaign (the same targets and noise for
every plan), open-loop own-ship plans of five families, each fixed before the run from the
contacts' priors:

* ``planned``: the joint plan (``all-contacts-time-to-accuracy``, what ``compare``'s
  ``planned`` flies);
* ``planned-half-accuracy``: the joint plan of the same problem with every contact's
  ``required_accuracy`` halved (a stricter threshold in the objective; the metric keeps the
  problem's accuracies);
* ``single-turn``: the best single turn of the baseline grid by the joint objective (what
  ``compare``'s ``single-turn`` flies), and the next ``--turns`` turns of that ranking
  (``turn2``, ``turn3``, …);
* ``zigzag``: the best zig-zag of the grid by the joint objective;
* ``planned:NAME`` (each contact's own plan) and ``alternate``;

and prints, per plan, its joint objective on the priors (what the planner predicts, the
expected time until every contact is localised plus the turn penalty) next to the campaign's
mean time until every contact is within its required accuracy (a run in which one never is
counts as the horizon plus one step), the fraction of runs that localised all, and the paired
95 % t interval of the difference to ``single-turn`` [min], negative when the plan localises
all contacts sooner. It answers whether a better open-loop plan exists to be found (a plan
that beats the best single turn by more than the interval's half-width), not which policy to
fly: its runs are exploratory, read a decision only from a campaign fixed before its runs.
docs/results/several-contacts-decided.md records its output.

Run: python benchmarks/contacts_open_loop.py P [P ...] [--runs 200] [--seed 9090]
     [--turns 5] [--particles 3000] [--workers 1]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from typing import Any, cast

import numpy as np

from tmaplan.evaluation.campaigns import CampaignSpec, run_campaign
from tmaplan.evaluation.metrics import censor_time, paired_difference
from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.policies import Combined, NoPing, Planned, SingleTurn, Zigzag
from tmaplan.policies import contacts as pc
from tmaplan.scenario import Scenario, load

METRIC = "time_to_accuracy_all_runs"


def candidates(sc: Scenario, turns: int) -> tuple[dict[str, Any], dict[str, float]]:
    """The open-loop policies flown on ``sc`` and their joint objective on the priors [s]
    (the joint planner's evaluator, the one ``single-turn`` ranks its grid by)."""
    pl = pc.contacts_planner(sc)
    ev = pl.joint.evaluator(cast(Any, pl.contacts.beliefs()))
    grid = evaluate_baselines(pl.contacts.views[0], evaluator=ev)
    pols: dict[str, Any] = {"planned": pc.parse_contacts_policy("planned", sc)}
    half = dataclasses.replace(sc, contacts=tuple(
        dataclasses.replace(c, required_accuracy=sc.contact_view(c.name).required_accuracy / 2)
        for c in sc.contacts))
    pols["planned-half-accuracy"] = Combined(
        manoeuvre=Planned(plan=pc.joint_plan(half), name="planned-half-accuracy"),
        ping=NoPing())
    pols["single-turn"] = pc.parse_contacts_policy("single-turn", sc)
    for i, b in enumerate(grid["single-turn"][1:turns + 1], 2):
        pols[f"turn{i}"] = Combined(manoeuvre=SingleTurn.from_baseline(b.params, sc),
                                    ping=NoPing())
    if "zigzag" in grid:
        pols["zigzag"] = Combined(manoeuvre=Zigzag.from_baseline(grid["zigzag"][0].params, sc),
                                  ping=NoPing())
    for n in sc.contact_names:
        pols[f"planned:{n}"] = pc.parse_contacts_policy(f"planned:{n}", sc)
    pols["alternate"] = pc.parse_contacts_policy("alternate", sc)
    pred = {n: float(ev(p.manoeuvre.nominal_track(sc))[0]) for n, p in pols.items()}
    return pols, pred


def describe(sc: Scenario, pols: dict[str, Any]) -> dict[str, str]:
    """A few words on each plan's shape: a turn's angle and time, a zig-zag's legs, a plan's
    first and last heading and the total it turns, ``alternate``'s leg courses [°, min]."""
    out = {}
    for n, p in pols.items():
        m = p.manoeuvre
        if isinstance(m, SingleTurn):
            out[n] = (f"{_deg(np.degrees(m.angle), '+')}° at "
                      f"{(m.time - sc.time.t0) / 60:.1f} min")
        elif isinstance(m, Zigzag):
            out[n] = (f"first leg {_deg(np.degrees(m.angle), '+')}°, then "
                      f"{_deg(-np.degrees(m.angle), '+')}°…, legs {m.leg_duration / 60:.1f} min")
        elif isinstance(m, Planned):
            h = np.degrees(np.unwrap(m.plan.heading))
            turned = float(np.sum(np.abs(np.diff(h))))
            out[n] = (f"heading {_deg(h[0])}° → {_deg(h[-1])}° (turned {_deg(turned)}°)")
        else:  # alternate: its legs' courses from the initial course
            out[n] = ("legs " + ", ".join(f"{_deg(np.degrees(a), '+')}°" for a in m.angles)
                      + f"…, from {(m.start - sc.time.t0) / 60:.1f} min")
    return out


def _deg(x: float, sign: str = "") -> str:
    """``x`` [°] rounded to a whole degree, never "-0"."""
    return f"{round(float(x)) + 0:{sign}d}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("problems", nargs="+", metavar="P",
                    help="several-contact problems (built-in names or .toml paths)")
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=9090, help="the campaigns' root seed")
    ap.add_argument("--turns", type=int, default=5,
                    help="single turns after the best of the joint objective's ranking")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=1)
    a = ap.parse_args()
    if a.runs < 2:
        ap.error(f"--runs: at least 2 paired runs, got {a.runs}")
    if a.turns < 0:
        ap.error(f"--turns: >= 0, got {a.turns}")
    for name in a.problems:
        sc = load(name)
        if len(sc.contacts) < 2:
            ap.error(f"{name}: a problem with several contacts, got {len(sc.contacts)}")
        t = time.perf_counter()
        pols, pred = candidates(sc, a.turns)
        spec = CampaignSpec(scenario=sc, policies=tuple(pols), runs=a.runs, seed=a.seed,
                            n_particles=a.particles)
        res = run_campaign(spec, workers=a.workers, policies=pols)
        cens = censor_time(res.times)
        tt = {n: np.where(np.isposinf(r := np.asarray(res.summary[n][METRIC], float)), cens, r)
              for n in pols}
        shape = describe(sc, pols)
        print(f"\n{sc.name}: {a.runs} paired runs, seed {a.seed}, "
              f"{time.perf_counter() - t:.0f} s")
        print("| plan | shape | joint objective [min] | mean time until all [min] | all "
              "localised | − single-turn [min] |")
        print("|---|---|---|---|---|---|")
        for n in sorted(pols, key=lambda k: float(np.mean(tt[k]))):
            d = paired_difference({"a": tt[n] / 60, "b": tt["single-turn"] / 60}, "a", "b",
                                  "minutes")
            diff = "—" if n == "single-turn" else \
                f"{d.mean:+.2f} [{d.ci_low:+.2f}, {d.ci_high:+.2f}]"
            print(f"| {n} | {shape[n]} | {pred[n] / 60:.2f} | {np.mean(tt[n]) / 60:.2f} | "
                  f"{np.mean(tt[n] < cens):.1%} | {diff} |", flush=True)


if __name__ == "__main__":
    main()
