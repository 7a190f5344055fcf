"""Does the plan pay in general? (issue 13, "on geometries you do not see").

Draws K random planning problems from a base problem
(:func:`tmaplan.evaluation.plan_general.random_problems`, seed given on the command line: the
geometries are not chosen by hand), and on each: tunes a single turn by Monte Carlo on seeds
of its own (seed 1000), flies the paired campaign of ``planned`` against straight, the cost's
own single turn, the practitioner tactics and the tuned turn (plus ``receding`` with
``--receding``) on seed 0 (``--eval-seed R``: on a seed of its own per problem, drawn from R,
so that the problems' runs are independent), and prints ``planned − X`` of the mean time to
10 % range accuracy (censored at the horizon + dt) with paired 95 % intervals in minutes
(negative: the plan localises sooner), then the family average of each difference with a t
interval over the problems (the geometry as the random unit) and how many problems meet each
criterion of issue 13. docs/results/unseen-problems.md records its output.

Run: python benchmarks/planning_general.py --seed S [--base default] [--problems 6]
     [--runs 60] [--tune-runs 8] [--particles 3000] [--workers 1] [--receding] [--out DIR]
     [--eval-seed R]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from tmaplan.evaluation.metrics import paired_difference
from tmaplan.evaluation.plan_general import CRITERIA
from tmaplan.evaluation.seeding import run_seed
from tmaplan.experiments import criteria, general_check, random_problems
from tmaplan.scenario import load_problem
from tmaplan.units import KNOT


def evaluation_seed(root: int | None, i: int) -> int:
    """The evaluation seed of problem ``i``: 0 (every problem on the same runs) without a
    root, else a 31-bit seed of its own from run ``i``'s seed, ``SeedSequence(root,
    spawn_key=(i,))`` (:func:`tmaplan.evaluation.seeding.run_seed`; never
    the tuning seed 1000)."""
    if root is None:
        return 0
    s = int(run_seed(root, i).generate_state(1)[0] >> 1)
    return s if s != 1000 else s + 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", default="default")
    ap.add_argument("--problems", type=int, default=6)
    ap.add_argument("--seed", type=int, required=True, help="seed of the random problems")
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--tune-runs", type=int, default=8, help="0: no tuned turn")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--receding", action="store_true", help="also fly receding (slow)")
    ap.add_argument("--out", default=None, help="store runs here and resume from there")
    ap.add_argument("--eval-seed", type=int, default=None,
                    help="evaluate problem i on its own seed, drawn from this root (default: "
                         "every problem on seed 0, so run i of every problem shares its truth "
                         "quantiles and noise, and the problems' means may be correlated)")
    a = ap.parse_args()
    if a.runs < 2:  # a paired interval needs two runs
        ap.error(f"--runs: at least 2 paired runs, got {a.runs}")
    if a.eval_seed is not None and a.eval_seed < 0:
        ap.error(f"--eval-seed: a seed >= 0, got {a.eval_seed}")
    if a.problems < 2:  # the family means' t intervals need two problems
        ap.error(f"--problems: at least 2 problems, got {a.problems}")
    problems = random_problems(load_problem(a.base), a.problems, seed=a.seed)
    rows: dict[str, dict[str, str]] = {}
    met: dict[str, list[bool]] = {k: [] for k in CRITERIA}
    diffs: list[dict] = []
    for i, p in enumerate(problems):
        t = time.perf_counter()
        d = general_check(p, runs=a.runs, seed=evaluation_seed(a.eval_seed, i),
                          tune_runs=a.tune_runs, n_particles=a.particles,
                          receding=a.receding, workers=a.workers, out_dir=a.out)
        diffs.append(d)
        ok = criteria(d)
        for k, v in ok.items():
            met[k].append(v)
        rel = math.degrees(math.remainder(p.prior.bearing_mean - p.observer.course, math.tau))
        print(f"{p.name}: contact {rel:+.0f} deg, {p.prior.range_min / 1e3:.1f}-"
              f"{p.prior.range_max / 1e3:.1f} km, <= {p.prior.speed_max / KNOT:.1f} kn, own "
              f"{p.observer.speed / KNOT:.1f} kn, sigma "
              f"{math.degrees(p.sensors_of('bearing')[0].sigma):.2f} deg, "
              f"{p.time.horizon / 60:.0f} min ({time.perf_counter() - t:.0f} s)", flush=True)
        rows[p.name] = {x: f"{v.mean / 60:+.1f} [{v.ci_low / 60:+.1f}, {v.ci_high / 60:+.1f}]"
                        + (" ✓" if ok.get(c, False) else "")
                        for c, (x, _, _) in CRITERIA.items() if (v := d.get(x)) is not None}
        print("  " + ", ".join(f"{x} {v}" for x, v in rows[p.name].items()), flush=True)
    baselines = [x for _, (x, _, _) in CRITERIA.items() if any(x in r for r in rows.values())]
    print(f"\n{a.runs} paired runs per problem, planned − X [min], paired 95 % CI "
          "(✓: criterion met)")
    print("| problem | " + " | ".join(baselines) + " |")
    print("|---|" + "---|" * len(baselines))
    for name, r in rows.items():
        print(f"| {name} | " + " | ".join(r.get(x, "") for x in baselines) + " |")
    if len(diffs) > 1:
        # the geometry is the random unit: a t interval over the problems' mean differences
        print(f"\nplanned − X averaged over the {len(diffs)} problems [min], 95 % t interval "
              "over problems; problems with a negative mean")
        print("| X | family mean | 95 % CI | problems < 0 |")
        print("|---|---|---|---|")
        for x in baselines:
            m = np.array([d[x].mean for d in diffs if x in d]) / 60
            # the one t interval of the project: each problem mean against zero
            f = paired_difference({x: m, "zero": np.zeros_like(m)}, x, "zero", "minutes")
            print(f"| {x} | {f.mean:+.2f} | [{f.ci_low:+.2f}, {f.ci_high:+.2f}] | "
                  f"{int(np.sum(m < 0))} of {m.size} |")
    print("\n| criterion | problems meeting it |")
    print("|---|---|")
    for k, v in met.items():
        if v:
            print(f"| {k} | {sum(v)} of {len(v)} |")


if __name__ == "__main__":
    main()
