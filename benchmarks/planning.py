"""Planning benchmark (issue 6): heading OCP cold/warm solve times, ping-schedule quality.

Prints measured numbers and ratios against baselines measured in the same run:
* heading OCP with 120 control intervals on `default` (30 min at 15 s): cold (1 start and 4
  starts) and warm-started re-solve; targets ≤ 2 s cold, ≤ 0.3 s warm;
* K = 10 pings over 1 000 steps by `relaxed` (target ≤ 2 s), against `greedy`;
* schedule quality vs `exact` (40 candidates, K = 1..3) for `relaxed` and `greedy`.

Run: python benchmarks/planning.py
"""

from __future__ import annotations

import dataclasses
import time

from tmaplan.planning import Belief, HeadingPlanner, schedule_pings
from tmaplan.scenario import load_problem


def _best_of(fn, n=3):
    ts, out = [], None
    for _ in range(n):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return min(ts), out


def heading() -> None:
    sc = load_problem("default")
    b = Belief.from_prior(sc)
    p1 = HeadingPlanner(sc, horizon=1800.0, control_interval=15.0, n_starts=1)
    p4 = HeadingPlanner(sc, horizon=1800.0, control_interval=15.0, n_starts=4)
    print(f"heading OCP: {p1.n} intervals, {p1.K} steps of {p1.dt:g} s")
    p1.solve(b)  # first call builds the IPOPT instance
    t1, plan = _best_of(lambda: p1.solve(b))
    t4, plan4 = _best_of(lambda: p4.solve(b), 1)
    p1.solve(b, warm_start=plan)
    tw, warm = _best_of(lambda: p1.solve(b, warm_start=plan))
    later = Belief.from_samples(b.samples, t=60.0)
    tr, rec = _best_of(lambda: p1.solve(later, warm_start=plan))
    print(f"  cold, 1 start : {t1:6.3f} s  (target <= 2 s)  objective {plan.objective:.2f} m "
          f"({plan.iterations} it)")
    print(f"  cold, 4 starts: {t4:6.3f} s  objective {plan4.objective:.2f} m")
    print(f"  warm, same belief     : {tw:6.3f} s  (target <= 0.3 s)  ratio to cold "
          f"{tw / t1:.2f} ({warm.iterations} it)")
    print(f"  warm, shifted 60 s    : {tr:6.3f} s  ratio to cold {tr / t1:.2f} "
          f"({rec.iterations} it)")
    pb = HeadingPlanner(sc, horizon=1800.0, control_interval=15.0, transcription="bang-bang",
                        n_starts=2)
    pb.solve(b)
    tb, bb = _best_of(lambda: pb.solve(b), 1)
    print(f"  bang-bang (2 starts)  : {tb:6.3f} s  objective {bb.objective:.2f} m "
          f"(direct/bang-bang objective ratio {plan.objective / bb.objective:.3f})")


def pings() -> None:
    sc = load_problem("default")
    big = sc.replace(time=dataclasses.replace(sc.time, dt=3.0, horizon=3000.0))
    b = Belief.from_prior(big)
    schedule_pings(big, budget=2, method="relaxed", belief=b, gap_reference="none")  # warm-up
    tr, rr = _best_of(lambda: schedule_pings(big, budget=10, method="relaxed", belief=b,
                                             gap_reference="none"), 2)
    tg, rg = _best_of(lambda: schedule_pings(big, budget=10, method="greedy", belief=b,
                                             gap_reference="none"), 1)
    print(f"pings: K = 10 over {big.time.n_steps} steps")
    print(f"  relaxed: {tr:6.3f} s (target <= 2 s)  objective {rr.objective:.3f} m, "
          f"uniform {rr.uniform_objective:.3f} m, no pings {rr.no_ping_objective:.3f} m")
    print(f"  greedy : {tg:6.3f} s  objective {rg.objective:.3f} m  (relaxed/greedy time "
          f"{tr / tg:.2f}, objective {rr.objective / rg.objective:.4f})")
    cand = list(range(4, 161, 4))
    bd = Belief.from_prior(sc)
    print("quality vs exact (default, 40 candidates, mean-range-bound):")
    for k in (1, 2, 3):
        ex = schedule_pings(sc, budget=k, method="exact", candidate_steps=cand,
                            min_spacing=0.0, belief=bd)
        row = [f"K={k}: exact {ex.objective:8.3f} m ({ex.seconds:.2f} s)"]
        for m in ("relaxed", "greedy"):
            r = schedule_pings(sc, budget=k, method=m, candidate_steps=cand, min_spacing=0.0,
                               belief=bd, gap_reference="none")
            row.append(f"{m} {r.objective:8.3f} m (+{100 * (r.objective / ex.objective - 1):.2f} %"
                       f", {r.seconds:.2f} s)")
        print("  " + "; ".join(row))


if __name__ == "__main__":
    heading()
    pings()
