"""Closed-loop benchmark (issue 15): where the time of one run goes, per policy, old vs new path.

Per policy, seconds per run split into planning (the controller's re-plans), filtering (the
particle filter's init, predict and update) and the rest (simulation, metrics), for

* ``old``: a full IPOPT solve per re-plan on the objective's casadi graph,
  ``Receding(solver="ipopt", compiled=False)``, and the particle filter's numpy kernels
  (``FilterOptions(kernel="numpy")``): the path before issue 42 (when this benchmark
  was written the first solve was cold, from 4 starts; it now starts from the offline plan);
* ``new``: ``Receding(solver=NEW_SOLVER)``, by default the real-time iteration, one condensed
  SQP step per re-plan from the shifted previous plan (``"real-time"``,
  :mod:`tmaplan.planning.rti`), IPOPT only as the fallback; ``--new-solver ipopt``: today's
  ``receding`` (IPOPT on the compiled objective, :mod:`tmaplan.planning.compiled_objective`);
  ``--new-solver sqp``: the converged SQP on it (``receding-sqp``).

Both paths run on the same truths and measurement noise (common random numbers, the
campaign's seeds), so the script also reports the paired difference new − old of the time to
accuracy and of the final range error, with 95 % t intervals, and the ratio new/old of the
seconds per run, measured in the same process. The old path's filter kernel is
``--old-kernel`` (default ``numpy``, the path before issue 42): its filters then draw other
random numbers than the new path's compiled kernels, and the paired differences include that
noise; ``--old-kernel numba`` gives both paths the same filter noise, isolating the re-plans.
``--step`` profiles one re-plan step (objective/gradient/Jacobian, exact Hessian, condensing,
QP per solver) against the IPOPT re-solve.

Run: python benchmarks/closed_loop.py [--path old|new|both] [--runs 4] [--first-run 0]
     [--new-solver real-time|ipopt|sqp]
     [--particles 3000] [--policies straight,planned,receding] [--step] [--json OUT]
     [--old-kernel numpy|numba]
     python benchmarks/closed_loop.py --campaign --runs 200 --workers 2 --rounds 2
         --policies straight,single-turn,planned,receding   (issue 42's 200-run compare)
     python benchmarks/closed_loop.py --pair OLD_JSON NEW_JSON
     python benchmarks/closed_loop.py --gaps --runs 3   (seed 1000 unless --seed)
"""

from __future__ import annotations

import argparse
import json
import time
from collections import defaultdict

import casadi as ca
import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.estimators.particle_filter import ParticleFilter
from tmaplan.evaluation.closed_loop import paired_run
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.evaluation.metrics import censor_time, paired_difference
from tmaplan.planning import Belief, HeadingPlanner
from tmaplan.planning.rti import QP_SOLVERS, RealTimeIteration, reference_model
from tmaplan.policies import (
    CLOSED_LOOP_OBJECTIVE,
    Combined,
    Receding,
    manoeuvres,
    parse_policy,
    receding,
)
from tmaplan.scenario import load_problem

_FILTER_SECONDS = [0.0]


def _timed(fn):
    def wrapper(*args, **kw):
        t = time.perf_counter()
        try:
            return fn(*args, **kw)
        finally:
            _FILTER_SECONDS[0] += time.perf_counter() - t
    return wrapper


# benchmark-only instrumentation: time the filter's three operations
for _name in ("init", "predict", "update"):
    setattr(ParticleFilter, _name, _timed(getattr(ParticleFilter, _name)))


def _policies(scenario, names, path, new_solver="real-time"):
    """Resolved policies (timed: the campaign's once-only work); ``receding``'s re-plans by
    IPOPT on the objective's casadi graph on the ``old`` path, by ``new_solver`` on the
    ``new`` one (the other ``receding-*`` names fly as named on both).

    The offline-plan cache is emptied first, so that the second path's setup is not timed
    on the plans the first one solved."""
    manoeuvres._PLAN_CACHE.clear()
    t = time.perf_counter()
    pols = {}
    for spec in names:
        p = parse_policy(spec, scenario)
        if spec.split("+")[0] == "receding":  # the other receding-* names fly as named
            rec = (Receding(solver="ipopt", compiled=False) if path == "old"
                   else Receding(solver=new_solver))
            p = Combined(manoeuvre=rec, ping=p.ping)
        pols[spec] = p.resolve(scenario)
    return pols, time.perf_counter() - t


def closed_loop(paths, names, runs, particles, seed=0, problem="default", first_run=0,
                json_out=None, new_solver="real-time", old_kernel="numpy"):
    sc = load_problem(problem)
    records = []
    rows = defaultdict(lambda: defaultdict(list))
    metric = defaultdict(lambda: defaultdict(list))
    setup = {}
    for path in paths:
        pols, setup[path] = _policies(sc, names, path, new_solver)
        print(f"[{path}] campaign setup (offline plans, schedules, RTI model): "
              f"{setup[path]:.1f} s")
        for i in range(first_run, first_run + runs):
            # the campaigns' run (truth, then each policy on the run's streams); a policy's
            # seconds: from the previous result (or the run's start) to its own
            _FILTER_SECONDS[0] = 0.0
            t = time.perf_counter()
            options = FilterOptions(kernel=old_kernel) if path == "old" else FilterOptions()
            for name, res in paired_run(sc, pols, seed=seed, run=i, n_particles=particles,
                                        options=options):
                total = time.perf_counter() - t
                plan = sum(e["seconds"] for e in res.replans)
                r = rows[path][name]
                r.append((total, plan, _FILTER_SECONDS[0], [e["seconds"] for e in res.replans],
                          [e.get("solver", "-") for e in res.replans]))
                m = res.metrics(0.1)
                metric[name]["tta", path].append(m.time_to_accuracy)
                metric[name]["fre", path].append(m.final_range_error)
                records.append({"path": path, "policy": name, "run": i, "seed": seed,
                                "particles": particles, "problem": problem, **m.to_json(),
                                "seconds": total, "plan_seconds": plan})
                if json_out:
                    with open(json_out, "w") as fh:
                        json.dump(records, fh)
                _FILTER_SECONDS[0] = 0.0
                t = time.perf_counter()
    print(f"\n{problem}: {runs} runs, {particles} particles, 1 thread (shared machine: ratios "
          "are the figures to read)")
    print(f"{'policy':<22}{'path':<5}{'s/run':>8}{'plan':>8}{'filter':>8}{'rest':>8}"
          f"{'median re-plan ms':>19}  solvers")
    for name in names:
        for path in paths:
            r = rows[path][name]
            tot, pl, fl = (float(np.mean([x[j] for x in r])) for j in range(3))
            rp = [s for x in r for s in x[3]]
            med = f"{1000 * np.median(rp):.1f}" if rp else "-"
            sol = defaultdict(int)
            for x in r:
                for s in x[4]:
                    sol[s] += 1
            print(f"{name:<22}{path:<5}{tot:8.2f}{pl:8.2f}{fl:8.2f}{tot - pl - fl:8.2f}"
                  f"{med:>19}  {dict(sol) if sol else ''}")
        if len(paths) == 2:
            old = np.mean([x[0] for x in rows["old"][name]])
            new = np.mean([x[0] for x in rows["new"][name]])
            rp_o = [s for x in rows["old"][name] for s in x[3]]
            rp_n = [s for x in rows["new"][name] for s in x[3]]
            extra = (f", median re-plan new/old {np.median(rp_n) / np.median(rp_o):.4f}"
                     if rp_o and rp_n else "")
            print(f"{'':<22}new/old seconds per run {new / old:.3f}{extra}")
            censor = censor_time(sc.times)
            for key, label, cen in (("tta", "time to accuracy [s]", censor),
                                    ("fre", "final range error [m]", None)):
                vals = {p: np.array(metric[name][key, p]) for p in paths}
                d = paired_difference(vals, "new", "old", label, censor=cen)
                print(f"{'':<22}paired new-old {label}: {d.mean:+.1f} "
                      f"[{d.ci_low:+.1f}, {d.ci_high:+.1f}] (n={d.n})")
    per_run = {p: sum(float(np.mean([x[0] for x in rows[p][n]])) for n in names) for p in paths}
    for p in paths:
        print(f"all {len(names)} policies, {p}: {per_run[p]:.2f} s per run (campaign of R runs on "
              f"W workers: about setup {setup[p]:.0f} s + R x {per_run[p]:.2f} s / W)")
    if len(paths) == 2:
        print(f"campaign setup new/old: {setup['new'] / setup['old']:.2f}; seconds per run of "
              f"all policies new/old: {per_run['new'] / per_run['old']:.3f}")


def pair(old_json, new_json, problem="default"):
    """Paired new - old intervals from two ``--json`` files (runs matched by seed and index)."""
    sc = load_problem(problem)
    censor = censor_time(sc.times)
    recs = {}
    for fn in (old_json, new_json):
        with open(fn) as fh:
            for r in json.load(fh):
                recs[r["path"], r["policy"], r["seed"], r["particles"], r["run"]] = r
    keys = {k[1:] for k in recs if k[0] == "old"} & {k[1:] for k in recs if k[0] == "new"}
    for name in sorted({k[0] for k in keys}):
        common = sorted(k for k in keys if k[0] == name)
        sec = {p: np.array([recs[(p, *k)]["seconds"] for k in common]) for p in ("old", "new")}
        print(f"{name}: {len(common)} paired runs, seconds per run new/old "
              f"{sec['new'].mean() / sec['old'].mean():.3f} ({sec['new'].mean():.2f} / "
              f"{sec['old'].mean():.2f})")
        for key, label, cen in (("time_to_accuracy", "time to accuracy [s]", censor),
                                ("final_range_error", "final range error [m]", None)):
            vals = {p: np.array([np.inf if recs[(p, *k)][key] is None else recs[(p, *k)][key]
                                 for k in common]) for p in ("old", "new")}
            d = paired_difference(vals, "new", "old", label, censor=cen)
            print(f"  paired new-old {label}: {d.mean:+.1f} [{d.ci_low:+.1f}, {d.ci_high:+.1f}] "
                  f"(n={d.n})")


def gaps(runs, particles, seed=1000, problem="default"):
    """How far the optimum moves between re-plans: per re-plan index, the objective of the
    shifted previous plan (the real-time iteration's start) minus the IPOPT optimum from it,
    along the new path's runs (tuning seeds, default 1000: not the evaluation seeds)."""
    sc = load_problem(problem)
    pol = parse_policy("receding-realtime", sc).resolve(sc)
    out = defaultdict(list)
    replan = receding._RecedingController._replan

    def recorded(self, belief, t):
        b = Belief.from_particles(belief.particles, belief.weights, t=t,  # a posterior
                                  max_samples=self.policy.max_particles, assimilated=True)
        pl = self.planner
        prev = self.plan or self.first
        opt = pl.solve(b, heading0=belief.heading, position0=belief.position, warm_start=prev)
        h0, s0, _ = pl.start_state(belief.heading, None, None)
        x0, _ = pl.shifted_start(prev, t, h0, s0)
        P = np.concatenate([pl.parameter_vector(b, ()), [h0, s0, 1.0, 1.0]])
        out[len(self.log)].append(pl.plan_function(x0, P)[0].item() - opt.objective)
        return replan(self, belief, t)

    receding._RecedingController._replan = recorded
    try:
        for i in range(runs):
            for _ in paired_run(sc, {"receding-realtime": pol}, seed=seed, run=i,
                                n_particles=particles):
                pass
    finally:
        receding._RecedingController._replan = replan
    print(f"{problem}: objective of the shifted previous plan - IPOPT optimum, {runs} runs "
          f"(seed {seed})")
    for k in sorted(out):
        v = np.array(out[k])
        print(f"  re-plan {k}: median {np.median(v):8.2f}  mean {v.mean():8.2f}  "
              f"max {v.max():8.2f}")


def step_profile(problem="default"):
    """Where the time of one re-plan goes (one RTI step against the IPOPT re-solve)."""
    sc = load_problem(problem)
    prior = Belief.from_prior(sc)
    planner = HeadingPlanner(sc, objective=CLOSED_LOOP_OBJECTIVE)
    plan = planner.solve(prior)
    t = time.perf_counter()
    model = reference_model(planner, plan, prior)
    t_model = time.perf_counter() - t
    later = Belief.from_samples(prior.samples[:2000], t=sc.planning.replan_interval)

    def best(fn, n=5):
        ts = []
        for _ in range(n):
            t = time.perf_counter()
            out = fn()
            ts.append(time.perf_counter() - t)
        return 1000 * min(ts), out

    with threadpool_limits(limits=1):
        print(f"one re-plan on {problem} ({CLOSED_LOOP_OBJECTIVE}, {planner.n} intervals, "
              f"{planner.K} steps), best of 5 [ms]:")
        rti = RealTimeIteration(planner, model)
        P = np.concatenate([planner.parameter_vector(later, ()), [0.0, planner.speed0, model.scale,
                                                             1.0]])
        x0 = plan.warm["x"]
        lbw, ubw, lbg, ubg = planner.bounds(0.0)
        t_ev, _ = best(lambda: rti._eval(x0, P))
        t_cd, (_, _, qp) = best(lambda: rti.condensed(x0, P, lbw, ubw, lbg, ubg))
        nlp = planner.nlp
        lam = ca.MX.sym("lam", nlp["g"].shape[0])
        hfn = ca.Function("h", [nlp["x"], nlp["p"], lam],
                          [ca.hessian(nlp["f"] + ca.dot(lam, nlp["g"]), nlp["x"])[0]])
        t_h, _ = best(lambda: hfn(x0, P, plan.warm["lam_g"]), 1)
        print(f"  objective + gradient + constraint Jacobian : {t_ev:8.2f}")
        print(f"  condensing (incl. the evaluation above)    : {t_cd:8.2f}")
        print(f"  exact Lagrangian Hessian (MX, per re-plan)  : {t_h:8.1f}  (not used: the "
              f"RTI model's Hessian is computed once, {t_model:.1f} s)")
        whole = {}
        for q in QP_SOLVERS:
            r = RealTimeIteration(planner, model, qpsol=q)
            t_qp, _ = best(lambda r=r: r._qp(**qp))
            whole[q], _ = best(lambda r=r: r.solve(later, previous=plan))
            print(f"  condensed QP {q:<6}: {t_qp:8.2f}   whole RTI re-plan: {whole[q]:8.2f}")
        t_ip, _ = best(lambda: planner.solve(later, warm_start=plan), 3)
        print(f"  IPOPT warm re-solve (today's path)         : {t_ip:8.1f}   RTI (daqp)/IPOPT "
              f"{whole['daqp'] / t_ip:.4f}")


def campaign(names, runs, workers, particles, seed=0, problem="default", rounds=1):
    """The 200-run compare of issue 42's done-when, both paths, in one run: per round, the
    old path (``receding`` by IPOPT on the casadi graph, the numpy filter kernel; its
    policies resolved in this process, timed with the campaign) and then the new one, exactly
    ``tmaplan compare PROBLEM --policies NAMES --runs RUNS --workers WORKERS --out DIR`` (the
    policies resolved by the campaign on its worker pool), each into a new directory, on the
    same seeds. Wall-clock seconds of each, and the ratio old/new of each round."""
    import tempfile

    from tmaplan.experiments import CampaignSpec, run_campaign

    sc = load_problem(problem)
    out = []
    for r in range(rounds):
        row = {}
        for path in ("old", "new"):
            manoeuvres._PLAN_CACHE.clear()  # no offline plan of the other path reused
            t = time.perf_counter()
            with tempfile.TemporaryDirectory() as d:
                if path == "old":
                    pols, _ = _policies(sc, names, "old")
                    spec = CampaignSpec(scenario=sc, policies=tuple(names), runs=runs,
                                        seed=seed, n_particles=particles,
                                        filter_options=FilterOptions(kernel="numpy"))
                    res = run_campaign(spec, out_dir=d, workers=workers, policies=pols)
                else:
                    spec = CampaignSpec(scenario=sc, policies=tuple(names), runs=runs,
                                        seed=seed, n_particles=particles)
                    res = run_campaign(spec, out_dir=d, workers=workers)
                row[path] = time.perf_counter() - t
            medians = {n: res.summary[n]["time_to_accuracy"] for n in names}
            print(f"round {r} {path}: {row[path]:.1f} s; median time to accuracy "
                  + ", ".join(f"{n} {v / 60:.2f} min" for n, v in medians.items()), flush=True)
        print(f"round {r}: old {row['old']:.1f} s, new {row['new']:.1f} s, "
              f"old/new {row['old'] / row['new']:.2f}", flush=True)
        out.append(row)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--path", choices=("old", "new", "both"), default="both")
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--new-solver", choices=("real-time", "ipopt", "sqp"), default="real-time",
                    help="how the new path's receding re-plans (the old: IPOPT, casadi graph)")
    ap.add_argument("--problem", default="default")
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--old-kernel", choices=("numpy", "numba"), default="numpy",
                    help="the old path's particle-filter kernel (numpy: the path before "
                         "issue 42; numba: the same filter noise as the new path)")
    ap.add_argument("--seed", type=int, default=None,
                    help="root seed of the runs (default 0; with --gaps 1000, tuning seeds)")
    ap.add_argument("--first-run", type=int, default=0, help="index of the first Monte Carlo run")
    ap.add_argument("--policies", default="straight,planned,receding")
    ap.add_argument("--step", action="store_true", help="profile one re-plan step")
    ap.add_argument("--gaps", action="store_true",
                    help="per re-plan index, how far the start is from the IPOPT optimum")
    ap.add_argument("--json", help="write per-run metrics (with seeds and run indices) here")
    ap.add_argument("--pair", nargs=2, metavar=("OLD_JSON", "NEW_JSON"),
                    help="paired new - old intervals from two --json files")
    ap.add_argument("--campaign", action="store_true",
                    help="the compare campaign of both paths on --workers (--rounds times)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=1)
    a = ap.parse_args()
    if a.campaign:
        campaign(a.policies.split(","), a.runs, a.workers, a.particles,
                 seed=0 if a.seed is None else a.seed, problem=a.problem, rounds=a.rounds)
        return
    if a.pair:
        pair(*a.pair)
        return
    if a.gaps:
        gaps(a.runs, a.particles, seed=1000 if a.seed is None else a.seed)
        return
    if a.step:
        step_profile()
        return
    paths = ("old", "new") if a.path == "both" else (a.path,)
    closed_loop(paths, a.policies.split(","), a.runs, a.particles,
                seed=0 if a.seed is None else a.seed, problem=a.problem,
                first_run=a.first_run, json_out=a.json, new_solver=a.new_solver,
                old_kernel=a.old_kernel)


if __name__ == "__main__":
    main()
