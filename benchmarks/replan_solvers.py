"""Converged re-plans: today's IPOPT re-plan against other solvers on harvested problems (issue 42).

``--harvest``: fly seeded ``receding`` closed-loop runs (the campaign's seeding,
``SeedSequence(seed, spawn_key=(i,))``, 3000 particles) and record what every re-plan hands
the heading planner (the belief, heading, position, warm-start plan and tolerance), pickled to
``--store``.

Default: re-solve every recorded re-plan with each candidate, interleaved in one process
(single thread), and print per candidate the median and p90 wall time, the median ratio to
IPOPT on the same re-plan, the share converged and the objective's relative difference to
IPOPT's optimum.

``--pair``: the paired ``receding-sqp − receding`` time to accuracy (censored at the horizon
plus one step) of a ``tmaplan compare PROBLEM --policies receding,receding-sqp`` campaign
directory, and the ratio of their re-plan seconds.

``--gradient``: the wall and CPU times of the objective, the objective with its gradient and
the SQP's evaluation at every recorded re-plan's start (CPU time: the thread's, which a loaded
machine does not inflate as it does the wall time of the longer calls).

Run: OMP_NUM_THREADS=1 python benchmarks/replan_solvers.py --harvest --problem default --runs 4
     OMP_NUM_THREADS=1 python benchmarks/replan_solvers.py [--candidates a,b] [--repeat 1]
       (candidates: ipopt-compiled, sqp-daqp[-model][-compiled], sqpmethod-daqp, ipopt-ma;
       ``-compiled``: the objective by its compiled kernel, HeadingPlanner(compiled=True))
     OMP_NUM_THREADS=1 python benchmarks/replan_solvers.py --gradient [--repeat 20]
     python benchmarks/replan_solvers.py --pair out/campaign-... --problem bow-closing
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import pickle
import time

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.errors import PlanningError
from tmaplan.evaluation.closed_loop import run_closed_loop
from tmaplan.policies import CLOSED_LOOP_OBJECTIVE, Receding, receding
from tmaplan.scenario import load_problem
from tmaplan.simulate import draw_truth

STORE = "out/replans.pkl"


def harvest(problem: str, runs: int, seed: int, first_run: int, store: str) -> None:
    """Fly ``runs`` receding runs and append every re-plan's planner inputs to ``store``."""
    sc = load_problem(problem)
    pol = Receding().resolve(sc)
    records = []
    solve = receding._RecedingController._solve

    def recorded(self, b, n, *, heading0, position0):
        records.append({"problem": problem, "run": run, "index": n, "belief": b,
                        "heading0": heading0, "position0": np.asarray(position0),
                        "warm_start": self.plan or self.first, "tol": self.policy.full_tol})
        return solve(self, b, n, heading0=heading0, position0=position0)

    receding._RecedingController._solve = recorded
    try:
        for run in range(first_run, first_run + runs):
            s_truth, s_noise, s_filter = np.random.SeedSequence(seed, spawn_key=(run,)).spawn(3)
            with threadpool_limits(limits=1):
                target = draw_truth(sc, np.random.default_rng(s_truth), from_prior=True)
                t = time.perf_counter()
                res = run_closed_loop(sc, pol, target, noise_rng=np.random.default_rng(s_noise),
                                      filter_rng=np.random.default_rng(s_filter),
                                      n_particles=3000)
            print(f"{problem} run {run}: {len(res.replans)} re-plans, "
                  f"{time.perf_counter() - t:.1f} s", flush=True)
    finally:
        receding._RecedingController._solve = solve
    old = []
    if os.path.exists(store):
        with open(store, "rb") as fh:
            old = pickle.load(fh)
    with open(store, "wb") as fh:
        pickle.dump(old + records, fh)
    print(f"{len(records)} re-plans added to {store} ({len(old) + len(records)} in all)")


def _inputs(pl, rec):
    """(x0, P, bounds, duals) of the planner's warm-started solve of a recorded re-plan, as
    :meth:`HeadingPlanner.solve` forms them (the objective scaled by its value at x0)."""
    b = rec["belief"]
    h0, s0, _ = pl.start_state(rec["heading0"], None, rec["position0"])
    pvec = pl.parameter_vector(b, ())
    x0, duals = pl.shifted_start(rec["warm_start"], b.t, h0, s0)
    P = np.concatenate([pvec, [h0, s0, 1.0, 1.0]])
    f0 = pl.plan_function(x0, P)[0].item()
    P[-2] = max(abs(f0), 1e-3) if np.isfinite(f0) else 1.0
    return x0, P, pl.bounds(h0), duals


def _casadi_nlp(pl, plugin, opts):
    """A candidate casadi solver on the planner's NLP: solve(rec) -> (objective, success,
    iterations, u)."""
    import casadi as ca

    solver = ca.nlpsol(f"cand_{plugin}", plugin, pl.nlp, opts)
    iu = np.arange(3 * (pl.n + 1), 4 * pl.n + 3)

    def solve(rec):
        x0, P, (lbw, ubw, lbg, ubg), duals = _inputs(pl, rec)
        kw = {"x0": x0, "p": P, "lbx": lbw, "ubx": ubw, "lbg": lbg, "ubg": ubg}
        if duals is not None and plugin == "ipopt":
            kw.update(lam_x0=duals["lam_x"], lam_g0=duals["lam_g"])
        sol = solver(**kw)
        st = solver.stats()
        x = np.asarray(sol["x"]).reshape(-1)
        return (float(sol["f"]) * P[-2], bool(st.get("success", False)),
                int(st.get("iter_count", 0)), x[iu])
    return solve


def candidates(sc, names):
    """Name -> solve(rec) -> (objective, success, iterations, u), the planner shared."""
    from tmaplan.planning.converged_sqp import ConvergedSQP

    pl = receding._planner(sc, CLOSED_LOOP_OBJECTIVE, None)
    iu = np.arange(3 * (pl.n + 1), 4 * pl.n + 3)
    out = {}

    def planner_solve(solve_fn):
        last = {}  # run -> (re-plan index, its Hessian, scale): carried to the next re-plan

        def solve(rec):
            warm = rec["warm_start"]
            prev = last.get(rec["run"])
            if prev is not None and prev[0] == rec["index"] - 1:
                warm = dataclasses.replace(warm, warm={**warm.warm, "hessian": prev[1],
                                                       "hessian_scale": prev[2]})
            p = solve_fn(rec["belief"], heading0=rec["heading0"], position0=rec["position0"],
                         warm_start=warm, tol=rec["tol"], raise_on_failure=False)
            if "hessian" in p.warm:
                last[rec["run"]] = (rec["index"], p.warm["hessian"], p.warm["hessian_scale"])
            return p.objective, p.success, p.iterations, p.warm["x"][iu]
        return solve

    out["ipopt"] = planner_solve(pl.solve)
    model = None
    plc = None  # the planner whose objective is the compiled kernel
    for name in names:
        if name.endswith("-compiled") and plc is None:
            plc = receding._planner(sc, CLOSED_LOOP_OBJECTIVE, None, compiled=True)
        if name == "ipopt-compiled":
            out[name] = planner_solve(plc.solve)
        elif name.startswith("sqp-"):
            if model is None:
                t = time.perf_counter()
                model = receding._rti_model(sc, CLOSED_LOOP_OBJECTIVE, None)
                print(f"RTI model (offline plan and Hessian): {time.perf_counter() - t:.1f} s")
            base = name.removesuffix("-compiled")
            qpsol, carry = base[4:].removesuffix("-model"), not base.endswith("-model")
            out[name] = planner_solve(ConvergedSQP(plc if base != name else pl, model,
                                                   qpsol=qpsol, carry_hessian=carry).solve)
        elif name.startswith("sqpmethod-"):
            out[name] = _casadi_nlp(pl, "sqpmethod", {
                "qpsol": name.split("-", 1)[1], "hessian_approximation": "limited-memory",
                "max_iter": 100, "tol_pr": 1e-4, "tol_du": 1e-4, "print_header": False,
                "print_iteration": False, "print_status": False, "print_time": False,
                "error_on_fail": False, "qpsol_options": {"error_on_fail": False}})
        elif name == "ipopt-ma":  # IPOPT, same options, MUMPS without scaling/reordering
            out[name] = _casadi_nlp(pl, "ipopt", {"print_time": False, "ipopt": {
                "print_level": 0, "sb": "yes", "max_iter": 300, "tol": 1e-4,
                "acceptable_tol": 1e-3, "hessian_approximation": "limited-memory",
                "limited_memory_max_history": 20, "warm_start_init_point": "yes",
                "warm_start_bound_push": 1e-6, "warm_start_mult_bound_push": 1e-6,
                "mu_init": 1e-4, "mu_strategy": "adaptive", "nlp_scaling_method": "none"}})
        elif name != "ipopt":
            raise SystemExit(f"unknown candidate {name!r}")
    return out


def compare(store, names, repeat):
    with open(store, "rb") as fh:
        recs = pickle.load(fh)
    by_problem = {}
    for r in recs:
        by_problem.setdefault(r["problem"], []).append(r)
    names = ["ipopt"] + [n for n in names if n != "ipopt"]
    res = {n: [] for n in names}
    for problem, rs in by_problem.items():
        sc = load_problem(problem)
        cands = candidates(sc, names)
        pl = receding._planner(sc, CLOSED_LOOP_OBJECTIVE, None)
        iu = np.arange(3 * (pl.n + 1), 4 * pl.n + 3)
        for j, rec in enumerate(rs):
            order = names[j % len(names):] + names[:j % len(names)]  # rotated
            row = {}
            for name in order:
                ts, cs = [], []
                for _ in range(repeat):
                    t, c = time.perf_counter(), time.thread_time()
                    try:
                        f, ok, it, u = cands[name](rec)
                    except PlanningError as exc:  # refused before a solve (keep-out)
                        print(f"  {name}: {exc}")
                        f, ok, it, u = np.nan, False, 0, np.full(len(iu), np.nan)
                    cs.append(time.thread_time() - c)
                    ts.append(time.perf_counter() - t)
                row[name] = (min(ts), f, ok, it, u, min(cs))
            ref = row["ipopt"]
            if not np.isfinite(ref[1]):
                print(f"{problem} run {rec['run']} re-plan {rec['index']}: refused, skipped")
                continue
            for name in names:
                sec, f, ok, it, u, cpu = row[name]
                res[name].append({"problem": problem, "seconds": sec, "ratio": sec / ref[0],
                                  "cpu": cpu, "cpu_ratio": cpu / ref[5],
                                  "ok": ok, "iter": it, "rel": (f - ref[1]) / abs(ref[1]),
                                  "du": float(np.max(np.abs(u - ref[4])))})
            print(f"{problem} run {rec['run']} re-plan {rec['index']}: " + "  ".join(
                f"{n} {1000 * row[n][0]:.0f} ms (CPU {1000 * row[n][5]:.0f}) "
                f"{'ok' if row[n][2] else 'FAIL'} "
                f"it {row[n][3]} rel {(row[n][1] - ref[1]) / abs(ref[1]):+.1e}"
                for n in names), flush=True)
    _table(res, names)


def gradient_cost(store, repeat):
    """Per recorded re-plan at its start point: wall time (minimum and median of ``repeat``
    calls) and CPU time of this thread (median) of the objective alone, the objective with its
    gradient, and the SQP's evaluation (objective, gradient, constraints, their Jacobian)."""
    import casadi as ca

    from tmaplan.planning.casadi_eval import NumpyFunction

    with open(store, "rb") as fh:
        recs = pickle.load(fh)
    rows = {}
    for problem in sorted({r["problem"] for r in recs}):
        pl = receding._planner(load_problem(problem), CLOSED_LOOP_OBJECTIVE, None)
        w, p, f, g = (pl.nlp[k] for k in ("x", "p", "f", "g"))
        fns = {"f": NumpyFunction(ca.Function("f", [w, p], [f])),
               "f+grad": NumpyFunction(ca.Function("fg", [w, p], [f, ca.gradient(f, w)])),
               "sqp eval": NumpyFunction(ca.Function("e", [w, p], [
                   f, ca.gradient(f, w), g, ca.jacobian(g, w)]))}
        for rec in (r for r in recs if r["problem"] == problem):
            x0, P = _inputs(pl, rec)[:2]
            for name, fn in fns.items():
                wall, cpu = [], []
                for _ in range(repeat):
                    t, c = time.perf_counter(), time.thread_time()
                    fn(x0, P)
                    cpu.append(time.thread_time() - c)
                    wall.append(time.perf_counter() - t)
                rows.setdefault((problem, name), []).append(
                    (min(wall), np.median(wall), np.median(cpu)))
    print(f"{'problem':<13}{'function':<10}{'n':>4}{'wall min ms':>13}{'wall med ms':>13}"
          f"{'CPU med ms':>12}{'CPU / f':>9}")
    for (problem, name), v in rows.items():
        a = np.array(v)
        ratio = np.median(a[:, 2] / np.array(rows[(problem, "f")])[:, 2])
        print(f"{problem:<13}{name:<10}{len(a):>4}{1000 * np.median(a[:, 0]):>13.2f}"
              f"{1000 * np.median(a[:, 1]):>13.2f}{1000 * np.median(a[:, 2]):>12.2f}"
              f"{ratio:>9.2f}")


def _table(res, names):
    print(f"\n{'candidate':<18}{'problem':<13}{'n':>4}{'median ms':>11}{'p90 ms':>9}"
          f"{'ratio':>8}{'CPU ms':>8}{'CPU ratio':>10}{'conv.':>7}{'|rel| med':>11}"
          f"{'rel<=1e-4':>10}{'rel max':>10}"
          f"{'iter':>6}{'du max':>8}")
    for name in names:
        for problem in [*sorted({r["problem"] for r in res[name]}), "all"]:
            rows = [r for r in res[name] if problem in ("all", r["problem"])]
            sec = np.array([r["seconds"] for r in rows])
            rel = np.array([r["rel"] for r in rows])
            ok = np.array([r["ok"] for r in rows])
            print(f"{name:<18}{problem:<13}{len(rows):>4}{1000 * np.median(sec):>11.0f}"
                  f"{1000 * np.quantile(sec, 0.9):>9.0f}"
                  f"{np.median([r['ratio'] for r in rows]):>8.3f}"
                  f"{1000 * np.median([r['cpu'] for r in rows]):>8.0f}"
                  f"{np.median([r['cpu_ratio'] for r in rows]):>10.3f}{ok.mean():>7.0%}"
                  f"{np.median(np.abs(rel)):>11.1e}{np.mean(rel <= 1e-4):>10.0%}"
                  f"{rel.max():>+10.1e}{np.median([r['iter'] for r in rows]):>6.0f}"
                  f"{max(r['du'] for r in rows):>8.3f}")


def pair(campaign: str, problem: str, old: str, new: str) -> None:
    """Paired ``new − old`` time to accuracy and re-plan time of a ``tmaplan compare``
    campaign directory (its stored runs)."""
    import glob

    from tmaplan.evaluation.metrics import censor_time, paired_difference

    sc = load_problem(problem)
    files = sorted(glob.glob(os.path.join(campaign, "runs", "run_*.npz")))
    tta = {old: [], new: []}
    sec = {old: [], new: []}
    flags = {old: np.zeros(3, int), new: np.zeros(3, int)}
    for fn in files:
        z = np.load(fn, allow_pickle=False)
        for p in (old, new):
            tta[p].append(float(z[f"{p}/time_to_accuracy"]))
            sec[p].append(z[f"{p}/replan_seconds"])
            flags[p] += [z[f"{p}/replan_seconds"].size, int(z[f"{p}/replan_converged"].sum()),
                         int(z[f"{p}/replan_fell_back"].sum())]
    d = paired_difference({p: np.array(v) for p, v in tta.items()}, new, old,
                          "time to accuracy", censor=censor_time(sc.times))
    print(f"{problem}: {len(files)} paired runs ({campaign})")
    print(f"  {new} - {old} time to accuracy: {d.mean / 60:+.2f} [{d.ci_low / 60:+.2f}, "
          f"{d.ci_high / 60:+.2f}] min")
    for p in (old, new):
        allsec = np.concatenate(sec[p])
        n, conv, fell = flags[p]
        mean = np.mean(np.minimum(tta[p], censor_time(sc.times))) / 60
        print(f"  {p}: mean time to accuracy {mean:.2f} min, "
              f"re-plans {n}, converged {conv} ({conv / n:.1%}), fell back {fell}; re-plan "
              f"median {1000 * np.median(allsec):.0f} ms, total {allsec.sum():.0f} s")
    ratio = np.concatenate(sec[new]).sum() / np.concatenate(sec[old]).sum()
    print(f"  re-plan seconds {new}/{old}: {ratio:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--harvest", action="store_true")
    ap.add_argument("--problem", default="default")
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--first-run", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--store", default=STORE)
    ap.add_argument("--candidates", default="sqp-daqp,sqpmethod-daqp,ipopt-ma")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--gradient", action="store_true",
                    help="time the objective, its gradient and the SQP evaluation (wall, CPU)")
    ap.add_argument("--pair", metavar="CAMPAIGN_DIR",
                    help="paired receding-sqp - receding of a compare campaign directory")
    args = ap.parse_args()
    if args.pair:
        pair(args.pair, args.problem, "receding", "receding-sqp")
    elif args.gradient:
        with threadpool_limits(limits=1):
            gradient_cost(args.store, max(args.repeat, 20))
    elif args.harvest:
        harvest(args.problem, args.runs, args.seed, args.first_run, args.store)
    else:
        with threadpool_limits(limits=1):
            compare(args.store, args.candidates.split(","), args.repeat)


if __name__ == "__main__":
    main()
