"""Planning benchmark (issue 6): heading OCP cold/warm solve times, ping-schedule quality.

Prints measured numbers and ratios against baselines measured in the same run:
* heading OCP with 120 control intervals on `default` (30 min at 15 s): cold (1 start and 4
  starts) and warm-started re-solve; targets ≤ 2 s cold, ≤ 0.3 s warm;
* K = 10 pings over 1 000 steps by `relaxed` without certificate, against `greedy`;
* issue 14: for K = 1..6 on `default` and `brehard2005-s1`, each method's objective, certified
  lower bound (cvxpy relaxation or enumeration), relative gap and time. Long (the exact method
  may use its time limit at large K): a benchmark, not a test.
* issue 14 items 4-5 (``--joint``): the joint heading + ping OCP
  (:func:`tmaplan.planning.plan_joint_ocp`) against the alternating method
  (:func:`tmaplan.planning.plan_joint`) on `default`, K = 1..3: objective, certified ping gap,
  seconds; bonmin on a small case; the relaxed OCP's NLP solved by IPOPT, casadi's SQP with
  OSQP and with qrqp (time ratios against IPOPT).

Run: python benchmarks/planning.py [--only-certified] [--budgets 1,2,3] [--time-limit 600]
     python benchmarks/planning.py --joint
"""

from __future__ import annotations

import dataclasses
import time

from tmaplan.planning import Belief, HeadingPlanner, plan_joint, plan_joint_ocp, schedule_pings
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
    p1 = HeadingPlanner(sc, objective="range-bound", horizon=1800.0, control_interval=15.0,
                        n_starts=1)
    p4 = HeadingPlanner(sc, objective="range-bound", horizon=1800.0, control_interval=15.0,
                        n_starts=4)
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
    """K = 10 pings over 1 000 steps without the certificate (the inner loop of the joint
    plan): the default method (greedy + whole-horizon swaps) against greedy."""
    sc = load_problem("default")
    big = sc.replace(time=dataclasses.replace(sc.time, dt=3.0, horizon=3000.0))
    b = Belief.from_prior(big)
    schedule_pings(big, budget=2, method="relaxed", belief=b, gap_reference="none")  # warm-up
    tr, rr = _best_of(lambda: schedule_pings(big, budget=10, method="relaxed", belief=b,
                                             gap_reference="none"), 2)
    tg, rg = _best_of(lambda: schedule_pings(big, budget=10, method="greedy", belief=b,
                                             gap_reference="none"), 1)
    print(f"pings: K = 10 over {big.time.n_steps} steps, no certificate")
    print(f"  relaxed: {tr:6.3f} s  objective {rr.objective:.3f} m, "
          f"uniform {rr.uniform_objective:.3f} m, no pings {rr.no_ping_objective:.3f} m")
    print(f"  greedy : {tg:6.3f} s  objective {rg.objective:.3f} m  (relaxed/greedy time "
          f"{tr / tg:.2f}, objective {rr.objective / rg.objective:.4f})")


def certified(problems: list[str], budgets: list[int], time_limit: float) -> None:
    """Issue 14: each method's objective, certified lower bound, relative gap and time."""
    print("certified ping schedules (mean-range-bound; gap = (objective - bound)/objective)")
    print(f"{'problem':16s} {'K':>2s} {'method':8s} {'objective':>10s} {'bound':>10s} "
          f"{'gap %':>7s} {'time s':>7s} {'bound s':>7s}  status / bound source")
    for name in problems:
        sc = load_problem(name)
        b = Belief.from_prior(sc)
        t0 = time.perf_counter()
        # first call compiles the cvxpy problem (cached by content afterwards)
        schedule_pings(sc, budget=1, method="greedy", belief=b)
        print(f"{name}: relaxation build + first solve {time.perf_counter() - t0:.1f} s "
              "(the compiled cvxpy problem is cached by content and re-solved per budget)")
        for k in budgets:
            for m in ("greedy", "relaxed", "exact"):
                r = schedule_pings(sc, budget=k, method=m, belief=b, time_limit=time_limit)
                print(f"{name:16s} {k:2d} {m:8s} {r.objective:10.3f} {r.lower_bound:10.3f} "
                      f"{100 * r.gap:7.3f} {r.seconds:7.2f} {r.bound_seconds:7.2f}  "
                      f"{r.status} / {r.gap_reference}; pings {r.steps.tolist()}", flush=True)


def _certified_alternating(sc, b, k, kw):
    """The alternating plan, its time, and the certificate of its pings on its track."""
    t0 = time.perf_counter()
    alt = plan_joint(sc, budget=k, belief=b, **kw)
    secs = time.perf_counter() - t0
    cert = schedule_pings(sc, budget=k, observer=alt.heading.observer, belief=b)
    lb = min(cert.lower_bound, alt.objective)
    return alt, secs, lb, (alt.objective - lb) / alt.objective


def joint(budgets: list[int]) -> None:
    """Issue 14 items 4-5: joint OCP vs alternating; SQP with OSQP/qrqp vs IPOPT."""
    sc = load_problem("default")
    b = Belief.from_prior(sc)
    schedule_pings(sc, budget=1, belief=b)  # compiles the closed-form kernel
    cases = [("default 45 min, 22 x 120 s, stride 4", {"control_interval": 120.0,
                                                       "n_starts": 1}, 4, ("relaxed",)),
             ("default 15 min, 5 x 180 s, stride 12", {"horizon": 900.0,
                                                       "control_interval": 180.0,
                                                       "n_starts": 1}, 12,
              ("relaxed", "bonmin"))]
    print("joint heading + ping plan (mean-range-bound; gap: certified on the pings along the "
          "returned track; time without the certificate for alternating)")
    print(f"{'case':38s} {'K':>2s} {'method':12s} {'objective':>10s} {'bound':>10s} "
          f"{'gap %':>6s} {'time s':>7s}  pings / notes")
    for label, kw, stride, modes in cases:
        for k in budgets:
            alt, ta, lb, gap = _certified_alternating(sc, b, k, kw)
            print(f"{label:38s} {k:2d} {'alternating':12s} {alt.objective:10.3f} {lb:10.3f} "
                  f"{100 * gap:6.2f} {ta:7.2f}  {alt.pings.steps.tolist()} "
                  f"({alt.iterations} rounds)", flush=True)
            for m in modes:
                r = plan_joint_ocp(sc, budget=k, belief=b, ping_stride=stride, mode=m, **kw)
                print(f"{label:38s} {k:2d} {'joint-' + m:12s} {r.objective:10.3f} "
                      f"{r.lower_bound:10.3f} {100 * r.gap:6.2f} {r.seconds:7.2f}  "
                      f"{r.pings.steps.tolist()} (NLP {r.nlp_seconds:.2f} s, {r.status}, "
                      f"relaxed {r.relaxed_objective:.3f}, rounded {r.rounded_objective:.3f}; "
                      f"joint/alternating objective {r.objective / alt.objective:.4f}, "
                      f"time {r.seconds / ta:.1f})", flush=True)
    # item 5: the relaxed OCP (no binarising continuation) by three NLP solvers
    print("relaxed joint OCP (default 45 min, stride 4, K = 2): NLP solvers")
    kw = {"control_interval": 120.0, "n_starts": 1}
    ref = None
    for solver in ("ipopt", "sqp-osqp", "sqp-qrqp"):
        r = plan_joint_ocp(sc, budget=2, belief=b, ping_stride=4, nlp_solver=solver,
                           binarize=False, init="even", **kw)
        ref = ref or r
        print(f"  {solver:9s} NLP {r.nlp_seconds:6.2f} s ({r.nlp_seconds / ref.nlp_seconds:5.2f}"
              f" x ipopt), {r.iterations:4d} it, {r.status}, relaxed objective "
              f"{r.relaxed_objective:.4f} m (ipopt {ref.relaxed_objective:.4f})", flush=True)


if __name__ == "__main__":
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", default="default,brehard2005-s1")
    ap.add_argument("--budgets", default="1,2,3,4,5,6")
    ap.add_argument("--time-limit", type=float, default=600.0,
                    help="exact method's time limit per run [s]")
    ap.add_argument("--only-certified", action="store_true")
    ap.add_argument("--joint", action="store_true", help="only the joint OCP section")
    a = ap.parse_args()
    if a.joint:
        joint([int(x) for x in a.budgets.split(",") if int(x) <= 3])
        raise SystemExit(0)
    if not a.only_certified:
        heading()
        pings()
    certified(a.problems.split(","), [int(x) for x in a.budgets.split(",")], a.time_limit)
