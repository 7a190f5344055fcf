"""Does the joint plan pay on several-contact geometries it was not tuned on? (issue 40)

Draws K random several-contact problems from a base problem
(:func:`tmaplan.evaluation.contacts_general.random_contacts_problems`, seed given on the
command line: the geometries are not chosen by hand, and not the built-in ones), flies on each
the paired campaign of the policies (default ``receding``, ``planned``, ``nearest-contact``,
``single-turn``; problem i on a seed of its own drawn from ``--eval-seed``, so that the
problems' runs are independent), and prints per problem the paired differences of the time
until every contact is within its required accuracy (10 %; a run in which one never is counts
as the horizon plus one step) in minutes, negative when the first policy localises all
contacts sooner; then over all problems:

* pooled: the paired 95 % t interval over every (problem, run) pair;
* by problem: the 95 % t interval over the problems' mean differences (the geometry as the
  random unit, wider and the safer reading with few problems).

It also prints, per problem, the joint plan's objective on the priors against the best single
turn's (``all-contacts-time-to-accuracy``, the joint planner's own evaluator): the joint plan
should never be worse in its own objective. ``--objectives P,...`` prints only those
objectives, also on 1024 fresh draws of each prior (out of sample), for the named built-in
problems (``random``: the random ones), and flies no campaign.
docs/results/several-contacts-decided.md records its output.

Run: python benchmarks/contacts_general.py --seed S [--base two-contacts-crossing]
     [--problems 6] [--runs 20] [--eval-seed 0] [--policies P,...] [--particles 3000]
     [--workers 1] [--out DIR] [--objectives P,...]
"""

from __future__ import annotations

import argparse
import math
import time
from itertools import combinations
from typing import Any, cast

import numpy as np

from tmaplan.evaluation.campaigns import CampaignSpec, run_campaign
from tmaplan.evaluation.contacts_general import random_contacts_problems
from tmaplan.evaluation.metrics import censor_time, paired_difference
from tmaplan.evaluation.seeding import run_seed
from tmaplan.planning.baselines import evaluate_baselines
from tmaplan.planning.belief import Belief
from tmaplan.planning.contacts import ContactSet, ContactsPlanner
from tmaplan.planning.multi_objectives import ContactBeliefs, contacts_objective
from tmaplan.planning.objectives import ObjectiveEvaluator
from tmaplan.scenario import load_problem

METRIC = "time_to_accuracy_all"


def evaluation_seed(root: int, i: int) -> int:
    """Problem ``i``'s evaluation seed: 31 bits of ``SeedSequence(root, spawn_key=(i,))``
    (:func:`tmaplan.evaluation.seeding.run_seed`)."""
    return int(run_seed(root, i).generate_state(1)[0] >> 1)


def objectives(problem: Any, fresh: int = 0) -> tuple[float, float, float, float]:
    """The joint plan's and the best single turn's ``all-contacts-time-to-accuracy`` [s]:
    on the priors' draws the planner optimises (its evaluator, as ``single-turn`` chooses its
    turn), then, with ``fresh`` > 0, on ``fresh`` other draws of each prior (seeded 7 + i for
    contact i: out of sample; NaN with ``fresh`` 0)."""
    cs = ContactSet.from_scenario(problem)
    pl = ContactsPlanner(cs)
    plan = pl.solve()
    ev = pl.joint.evaluator(cast(Any, cs.beliefs()))
    turn = evaluate_baselines(cs.views[0], evaluator=ev)["single-turn"][0]
    out = [float(ev(plan.plan.observer)[0]), float(turn.objective), math.nan, math.nan]
    if fresh:
        obj = contacts_objective(pl.objective_name, q=[v.target.q for v in cs.views],
                                 accuracies=cs.required_accuracies, weights=cs.weights,
                                 samples=fresh)
        bel = ContactBeliefs(beliefs=tuple(Belief.from_prior(v, rng=np.random.default_rng(
            7 + i)) for i, v in enumerate(cs.views)), names=cs.names)
        oos = ObjectiveEvaluator(cs.views[0], obj, n_steps=pl.joint.K, belief=cast(Any, bel),
                                 turn_rate_max=pl.joint.u_max, until_end=pl.joint.until_end)
        out[2:] = [float(oos(plan.plan.observer)[0]), float(oos(turn.track)[0])]
    return out[0], out[1], out[2], out[3]


def print_objectives(problems: Any, fresh: int) -> None:
    """The table of :func:`objectives` on ``problems`` [min]."""
    print(f"all-contacts-time-to-accuracy [min]: on the planner's draws / on {fresh} fresh "
          "draws per contact")
    print("| problem | joint plan | best single turn | joint plan (fresh) | best single turn "
          "(fresh) |")
    print("|---|---|---|---|---|")
    for p in problems:
        v = objectives(p, fresh)
        print(f"| {p.name} | " + " | ".join(f"{x / 60:.2f}" for x in v) + " |", flush=True)


def interval(d: np.ndarray) -> str:
    """``mean [low, high]`` of a paired t interval of ``d`` [s], in minutes."""
    f = paired_difference({"a": d / 60, "b": np.zeros_like(d)}, "a", "b", "minutes")
    return f"{f.mean:+.2f} [{f.ci_low:+.2f}, {f.ci_high:+.2f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="two-contacts-crossing")
    ap.add_argument("--problems", type=int, default=6)
    ap.add_argument("--seed", type=int, required=True, help="seed of the random problems")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--eval-seed", type=int, default=0, help="root of the problems' seeds")
    ap.add_argument("--policies", default="receding,planned,nearest-contact,single-turn")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", default=None, help="store runs here and resume from there")
    ap.add_argument("--objectives", default=None, metavar="P,...",
                    help="only print the objectives of these problems (built-in names; "
                         "'random': the --problems random ones), on the planner's draws and "
                         "on 1024 fresh ones; no campaign")
    a = ap.parse_args()
    if a.runs < 2:
        ap.error(f"--runs: at least 2 paired runs, got {a.runs}")
    if a.problems < 2:
        ap.error(f"--problems: at least 2 problems, got {a.problems}")
    if a.eval_seed < 0:
        ap.error(f"--eval-seed: a seed >= 0, got {a.eval_seed}")
    policies = tuple(p.strip() for p in a.policies.split(",") if p.strip())
    if len(policies) < 2:
        ap.error(f"--policies: at least two policies, got {a.policies!r}")
    pairs = list(combinations(policies, 2))
    problems = random_contacts_problems(load_problem(a.base), a.problems, seed=a.seed)
    if a.objectives is not None:
        names = [n.strip() for n in a.objectives.split(",") if n.strip()]
        print_objectives([q for n in names for q in (
            problems if n == "random" else (load_problem(n),))], 1024)
        return
    pooled: dict[tuple[str, str], list[np.ndarray]] = {p: [] for p in pairs}
    rows = []
    for i, p in enumerate(problems):
        t = time.perf_counter()
        joint, turn, _, _ = objectives(p)
        spec = CampaignSpec(scenario=p, policies=policies, runs=a.runs,
                            seed=evaluation_seed(a.eval_seed, i), n_particles=a.particles)
        res = run_campaign(spec, workers=a.workers, out_dir=a.out)
        cens = censor_time(res.times)
        tt = {n: np.where(np.isposinf(res.summary[n][f"{METRIC}_runs"]), cens,
                          res.summary[n][f"{METRIC}_runs"]) for n in policies}
        cells = []
        for x, y in pairs:
            d = tt[x] - tt[y]
            pooled[(x, y)].append(d)
            cells.append(interval(d))
        print(f"{p.name} ({time.perf_counter() - t:.0f} s, seed {spec.seed}): {p.description}",
              flush=True)
        print(f"  objective on the priors: joint {joint / 60:.2f} min, best single turn "
              f"{turn / 60:.2f} min; mean time until all localised: "
              + ", ".join(f"{n} {np.mean(tt[n]) / 60:.2f}" for n in policies) + " min",
              flush=True)
        rows.append((p.name, len(p.contacts), joint - turn, cells))
    print(f"\n{a.runs} paired runs per problem, seed {a.seed} (problems), eval-seed "
          f"{a.eval_seed}; time until all contacts localised, X − Y [min], paired 95 % CI")
    print("| problem | contacts | joint − single-turn objective [min] | "
          + " | ".join(f"{x} − {y}" for x, y in pairs) + " |")
    print("|---|---|---|" + "---|" * len(pairs))
    for name, n, dobj, cells in rows:
        print(f"| {name} | {n} | {dobj / 60:+.2f} | " + " | ".join(cells) + " |")
    print(f"\nOver the {len(problems)} problems [min]: pooled (paired t interval over the "
          f"{len(problems) * a.runs} problem × run pairs) and by problem (t interval over the "
          "problems' means); problems with a negative mean")
    print("| difference | pooled | by problem | problems < 0 |")
    print("|---|---|---|---|")
    for (x, y), ds in pooled.items():
        means = np.array([np.mean(d) for d in ds])
        print(f"| {x} − {y} | {interval(np.concatenate(ds))} | {interval(means)} | "
              f"{int(np.sum(means < 0))} of {means.size} |")


if __name__ == "__main__":
    main()
