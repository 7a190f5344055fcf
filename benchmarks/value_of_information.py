"""What knowing the target would buy: the offline plan against a plan made from the truth.

For each Monte Carlo run the *clairvoyant* plan is the heading OCP solved with the default
objective evaluated on the run's true initial relative state (all the objective's draws at
the truth; the prior information term unchanged), from the planner's own starts and from the
offline plan. Both plans are flown in closed loop with the same truth, noise and filter
seeds (the campaigns' seeds: :func:`tmaplan.evaluation.seeding.run_streams`), and the paired
difference of the time to 10 % range accuracy is printed.

No re-planning policy that optimises the same cost can expect more than the clairvoyant plan
gains over the offline plan; where that gain is small, a receding horizon has little to win
(issue 13: ``receding`` against ``planned`` on ``bow-closing``).

``--waiting`` asks *when* that knowledge must come, on the objective alone (no closed loop):
per run, the true initial bearing rate, the side the clairvoyant plan turns to first, and
the objective at the truth of holding course for w = 0…5 min and then flying the best (at
the truth) of the offline plan, its mirror image and the clairvoyant plan, each delayed by
w, against the offline plan: what deciding the side after w minutes of bearings can win when
the decision is taken with the truth itself (the shapes are delayed, not re-optimised after
the hold).

Usage::

    python benchmarks/value_of_information.py --problem bow-closing --runs 200 --seed 7 \
        --workers 2 [--json F]
    python benchmarks/value_of_information.py --problem bow-closing --runs 40 --seed 9 \
        --waiting --workers 2
    python benchmarks/value_of_information.py --problem default --family 2028:0 --runs 200 \
        --seed 16 --workers 2    # problem default-s2028-0 of planning_general.py --seed 2028
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from concurrent.futures import ProcessPoolExecutor

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.evaluation.closed_loop import fly
from tmaplan.evaluation.metrics import censor_time, paired_difference
from tmaplan.evaluation.seeding import run_streams
from tmaplan.experiments import random_problems
from tmaplan.models.observer import turn_rate_track
from tmaplan.models.target import initial_velocity
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.objectives import ObjectiveEvaluator
from tmaplan.policies import Combined, Planned
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.scenario import Scenario, load_problem
from tmaplan.simulate import draw_truth

_STATE: dict = {}


@dataclasses.dataclass(frozen=True)
class _AtTruth(Belief):
    """The prior belief whose objective draws are all the true relative state."""

    truth: np.ndarray | None = None

    def representative_samples(self, n: int) -> np.ndarray:
        return np.tile(self.truth, (max(int(n), 1), 1))


def _problem(problem: str, family: tuple[int, int] | None) -> Scenario:
    """The built-in ``problem``, or problem ``i`` of the random family ``(seed, i)`` drawn
    from it (:func:`tmaplan.experiments.random_problems`, as ``planning_general.py``)."""
    if family is None:
        return load_problem(problem)
    seed, i = family
    return random_problems(load_problem(problem), i + 1, seed=seed)[i]


def _init(problem: str, family: tuple[int, int] | None, particles: int) -> None:
    sc = _problem(problem, family)
    obj = sc.planning.objective
    plan = offline_plan(sc, obj)
    _STATE.update(sc=sc, obj=obj, plan=plan, particles=particles,
                  planner=HeadingPlanner(sc, objective=obj), prior=Belief.from_prior(sc))


#: holds of ``--waiting`` [min]
HOLDS = (0, 1, 2, 3, 4, 5)


def _clairvoyant(seed: int, i: int, mirror: bool = False) -> tuple:
    """Run ``i``'s truth (its first stream), the belief at it and the clairvoyant plan (None
    if no start converged); ``mirror`` adds the offline plan's mirror image to the starts."""
    sc, planner, prior, plan = (_STATE[k] for k in ("sc", "planner", "prior", "plan"))
    target = draw_truth(sc, np.random.default_rng(run_streams(seed, i).truth), from_prior=True)
    o = sc.observer
    rel = target[0] - np.concatenate([np.asarray(o.position, float), initial_velocity(o)])
    b = _AtTruth(**{f.name: getattr(prior, f.name) for f in dataclasses.fields(Belief)},
                 truth=rel)
    u0 = plan.turn_rate / planner.u_max
    cands = [planner.solve(b, raise_on_failure=False),
             planner.solve(b, starts=[u0], raise_on_failure=False)]
    if mirror:
        cands.append(planner.solve(b, starts=[-u0], raise_on_failure=False))
    clair = min((c for c in cands if c.success), key=lambda c: c.objective, default=None)
    return target, rel, b, clair


def turn_rates(track, dt: float) -> np.ndarray:
    """Per-step turn rates [rad/s] of ``track``, shape (K,): differences of the *unwrapped*
    headings (``ObserverTrack.heading`` is wrapped to ±π; a plain difference turns 352° in
    one step where a track crosses south)."""
    return np.diff(np.unwrap(track.heading)) / dt


def _wait(args: tuple[int, int]) -> dict:
    """``--waiting`` for one run: initial bearing rate, the clairvoyant plan's first side and
    the objective gain [s] of each hold in :data:`HOLDS` against the offline plan."""
    seed, i = args
    sc, planner, plan = (_STATE[k] for k in ("sc", "planner", "plan"))
    with threadpool_limits(limits=1):
        _, rel, b, clair = _clairvoyant(seed, i, mirror=True)
        ev = ObjectiveEvaluator(sc, planner.objective, n_steps=planner.K, belief=b)
        track, dt = plan.observer, sc.time.dt
        base = ev(track)[0]
        shapes = [turn_rates(track, dt)]
        shapes.append(-shapes[0])
        if clair is not None:
            shapes.append(turn_rates(clair.observer, dt))
        gains = []
        for w in HOLDS:
            n = round(60.0 * w / dt)
            best = min(ev(turn_rate_track(track.position[0], track.heading[0],
                                          float(track.speed[0]),
                                          np.concatenate([np.zeros(n), u[:u.size - n]]), dt,
                                          track.times[0]))[0] for u in shapes)
            gains.append(best - base)
    r2 = float(rel[:2] @ rel[:2])
    side = None if clair is None else float(np.sign(np.mean(
        np.unwrap(clair.observer.heading)[:round(240.0 / dt) + 1] - track.heading[0])))
    return {"run": i, "seed": seed, "bearing_rate": (rel[1] * rel[2] - rel[0] * rel[3]) / r2,
            "clairvoyant_side": side, "hold_gain": gains}


def _waiting_summary(rows: list[dict]) -> None:
    g = np.array([r["hold_gain"] for r in rows]) / 60.0
    rate = np.degrees([r["bearing_rate"] for r in rows]) * 60.0
    side = np.array([r["clairvoyant_side"] or 0.0 for r in rows])
    stb = side > 0
    print(f"  clairvoyant plan turns to starboard first on {stb.sum()} of {len(rows)} runs "
          f"(initial bearing rate there {np.median(rate[stb]) if stb.any() else np.nan:+.3f} "
          f"deg/min median, elsewhere {np.median(rate[~stb]) if (~stb).any() else np.nan:+.3f})")
    if stb.any() and (~stb).any():
        print(f"  gain of knowing the truth at t0: {g[stb, 0].mean():+.2f} min on those runs, "
              f"{g[~stb, 0].mean():+.2f} on the others")
    for j, w in enumerate(HOLDS):
        se = g[:, j].std(ddof=1) / np.sqrt(len(g))
        print(f"  hold {w} min, then the best shape at the truth, minus the offline plan: "
              f"{g[:, j].mean():+.2f} min (s.e. {se:.2f}; objective, not flown)")


def _run(args: tuple[int, int]) -> dict:
    seed, i = args
    sc, planner, plan = (_STATE[k] for k in ("sc", "planner", "plan"))
    streams = run_streams(seed, i)
    with threadpool_limits(limits=1):
        target, _, b, clair = _clairvoyant(seed, i)
        at_truth = ObjectiveEvaluator(sc, planner.objective, n_steps=planner.K, belief=b)
        out = {"run": i, "seed": seed, "clairvoyant_objective": None,
               "planned_objective_at_truth": at_truth(plan.observer)[0]}
        pols = {"planned": Combined(manoeuvre=Planned(objective=_STATE["obj"], plan=plan))}
        if clair is not None:
            out["clairvoyant_objective"] = clair.objective
            pols["clairvoyant"] = Combined(manoeuvre=Planned(objective=_STATE["obj"],
                                                             plan=clair))
        for name, pol in pols.items():
            # the clairvoyant plan depends on the run's truth: each policy flown alone on
            # the run's streams (the campaigns' per-run loop, tmaplan.evaluation.closed_loop)
            res = fly(sc, pol, target, streams, n_particles=_STATE["particles"])
            out[name] = res.metrics(0.1).to_json()["time_to_accuracy"]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--problem", default="bow-closing")
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--first-run", type=int, default=0)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--family", default=None, metavar="SEED:I",
                    help="problem I of the random family of seed SEED drawn from --problem")
    ap.add_argument("--json", default=None)
    ap.add_argument("--waiting", action="store_true",
                    help="the objective of deciding after a hold (no closed loop)")
    a = ap.parse_args()
    if a.runs < 2:  # a paired interval needs two runs
        ap.error(f"--runs: at least 2 paired runs, got {a.runs}")
    family = None
    if a.family is not None:
        try:
            family = tuple(int(v) for v in a.family.split(":"))
        except ValueError:
            family = ()
        if len(family) != 2 or min(family) < 0:
            ap.error(f"--family: SEED:I, two integers >= 0, got {a.family!r}")
    sc = _problem(a.problem, family)
    jobs = [(a.seed, i) for i in range(a.first_run, a.first_run + a.runs)]
    with ProcessPoolExecutor(a.workers, initializer=_init,
                             initargs=(a.problem, family, a.particles)) as ex:
        rows = list(ex.map(_wait if a.waiting else _run, jobs))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh)
    if a.waiting:
        print(f"{sc.name}, seed {a.seed}, runs {a.first_run}-{a.first_run + a.runs - 1}")
        _waiting_summary(rows)
        return
    censor = censor_time(sc.times)
    ok = [r for r in rows if r["clairvoyant_objective"] is not None]

    def col(name: str) -> np.ndarray:
        return np.array([np.inf if r[name] is None else r[name] for r in ok])

    d = paired_difference({"clairvoyant": col("clairvoyant"), "planned": col("planned")},
                          "clairvoyant", "planned", "time to accuracy [s]", censor=censor)
    print(f"{sc.name}, seed {a.seed}, runs {a.first_run}-{a.first_run + a.runs - 1} "
          f"({len(ok)} with a clairvoyant plan), {a.particles} particles")
    print(f"  clairvoyant - planned, time to 10 % range accuracy: {d.mean / 60:+.2f} min "
          f"[{d.ci_low / 60:+.2f}, {d.ci_high / 60:+.2f}] (n={d.n})")
    for name in ("planned", "clairvoyant"):
        v = np.minimum(col(name), censor)
        print(f"  {name:<12} mean {v.mean() / 60:.1f} min, localised "
              f"{np.isfinite(col(name)).mean():.0%}")


if __name__ == "__main__":
    main()
