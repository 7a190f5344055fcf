"""What knowing the target would buy: the offline plan against a plan made from the truth.

For each Monte Carlo run the *clairvoyant* plan is the heading OCP solved with the default
objective evaluated on the run's true initial relative state (all the objective's draws at
the truth; the prior information term unchanged), from the planner's own starts and from the
offline plan. Both plans are flown in closed loop with the same truth, noise and filter
seeds (the campaigns' seeds: ``SeedSequence(seed, spawn_key=(run,))``), and the paired
difference of the time to 10 % range accuracy is printed.

No re-planning policy that optimises the same cost can expect more than the clairvoyant plan
gains over the offline plan; where that gain is small, a receding horizon has little to win
(issue 13: ``receding`` against ``planned`` on ``bow-closing``).

Usage::

    python benchmarks/value_of_information.py --problem bow-closing --runs 200 --seed 7 \
        --workers 2 [--json F]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.evaluation.metrics import censor_time, paired_difference, run_metrics
from tmaplan.models.target import initial_velocity
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.objectives import ObjectiveEvaluator
from tmaplan.policies import Combined, Planned
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth

_STATE: dict = {}


@dataclasses.dataclass(frozen=True)
class _AtTruth(Belief):
    """The prior belief whose objective draws are all the true relative state."""

    truth: np.ndarray | None = None

    def representative_samples(self, n: int) -> np.ndarray:
        return np.tile(self.truth, (max(int(n), 1), 1))


def _init(problem: str, particles: int) -> None:
    sc = load_problem(problem)
    obj = sc.planning.objective
    plan = offline_plan(sc, obj)
    _STATE.update(sc=sc, obj=obj, plan=plan, particles=particles,
                  planner=HeadingPlanner(sc, objective=obj), prior=Belief.from_prior(sc))


def _run(args: tuple[int, int]) -> dict:
    seed, i = args
    sc, planner, prior, plan = (_STATE[k] for k in ("sc", "planner", "prior", "plan"))
    s_truth, s_noise, s_filter = np.random.SeedSequence(seed, spawn_key=(i,)).spawn(3)
    with threadpool_limits(limits=1):
        target = draw_truth(sc, np.random.default_rng(s_truth), from_prior=True)
        o = sc.observer
        rel = target[0] - np.concatenate([np.asarray(o.position, float), initial_velocity(o)])
        b = _AtTruth(**{f.name: getattr(prior, f.name) for f in dataclasses.fields(Belief)},
                     truth=rel)
        u0 = plan.turn_rate / planner.u_max
        cands = [planner.solve(b, raise_on_failure=False),
                 planner.solve(b, starts=[u0], raise_on_failure=False)]
        clair = min((c for c in cands if c.success), key=lambda c: c.objective,
                    default=None)
        at_truth = ObjectiveEvaluator(sc, planner.objective, n_steps=planner.K, belief=b)
        out = {"run": i, "seed": seed, "clairvoyant_objective": None,
               "planned_objective_at_truth": at_truth(plan.observer)[0]}
        pols = {"planned": Combined(manoeuvre=Planned(objective=_STATE["obj"], plan=plan))}
        if clair is not None:
            out["clairvoyant_objective"] = clair.objective
            pols["clairvoyant"] = Combined(manoeuvre=Planned(objective=_STATE["obj"],
                                                             plan=clair))
        for name, pol in pols.items():
            res = run_closed_loop(sc, pol, target, noise_rng=np.random.default_rng(s_noise),
                                  filter_rng=np.random.default_rng(s_filter),
                                  n_particles=_STATE["particles"])
            m = run_metrics(res.times, res.truth, res.estimate, res.observer.mean_velocity,
                            accuracy=0.1, n_pings=len(res.ping_steps))
            out[name] = None if not np.isfinite(m.time_to_accuracy) else m.time_to_accuracy
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--problem", default="bow-closing")
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--first-run", type=int, default=0)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    if a.runs < 2:  # a paired interval needs two runs
        ap.error(f"--runs: at least 2 paired runs, got {a.runs}")
    jobs = [(a.seed, i) for i in range(a.first_run, a.first_run + a.runs)]
    with ProcessPoolExecutor(a.workers, initializer=_init,
                             initargs=(a.problem, a.particles)) as ex:
        rows = list(ex.map(_run, jobs))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh)
    sc = load_problem(a.problem)
    censor = censor_time(sc.times)
    ok = [r for r in rows if r["clairvoyant_objective"] is not None]

    def col(name: str) -> np.ndarray:
        return np.array([np.inf if r[name] is None else r[name] for r in ok])

    d = paired_difference({"clairvoyant": col("clairvoyant"), "planned": col("planned")},
                          "clairvoyant", "planned", "time to accuracy [s]", censor=censor)
    print(f"{a.problem}, seed {a.seed}, runs {a.first_run}-{a.first_run + a.runs - 1} "
          f"({len(ok)} with a clairvoyant plan), {a.particles} particles")
    print(f"  clairvoyant - planned, time to 10 % range accuracy: {d.mean / 60:+.2f} min "
          f"[{d.ci_low / 60:+.2f}, {d.ci_high / 60:+.2f}] (n={d.n})")
    for name in ("planned", "clairvoyant"):
        v = np.minimum(col(name), censor)
        print(f"  {name:<12} mean {v.mean() / 60:.1f} min, localised "
              f"{np.isfinite(col(name)).mean():.0%}")


if __name__ == "__main__":
    main()
