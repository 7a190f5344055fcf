"""Memory of the large computations against the number of time steps (issue 38).

Each computation runs in a fresh process on ``default`` stretched to K steps of 15 s (its
``time.horizon`` and ``planning.horizon`` K·15 s, the control interval 1 min), and reports
its peak resident memory above the process's resident memory after the imports and the load
(``resource.getrusage``; Linux reports kB). The fit of these numbers is
:data:`tmaplan.memory.MODELS` (bytes = fixed + per_step·K + per_step2·K²); the script prints
the measured numbers next to the model's prediction (``plan``: its planner and baselines
added up, as ``tmaplan plan`` checks), so a change that makes a computation hungrier shows
here.

Computations
    ``heading``: :class:`tmaplan.planning.HeadingPlanner` built and solved once (IPOPT, 5
    iterations: its storage is allocated at the first iteration) from the straight start,
    the ``plan``, ``compare`` and ``demo`` verbs' planner;
    ``heading-dt``: the same with a control interval of one step (four times the
    variables);
    ``baselines``: its :meth:`~tmaplan.planning.HeadingPlanner.evaluator` and the baseline
    grids (:func:`tmaplan.planning.evaluate_baselines`), ``plan``'s comparison and the
    multi-start's single turns;
    ``plan``: what ``tmaplan plan`` computes: the planner solved to convergence from every
    start of the multi-start (:func:`tmaplan.policies.plan_starts.plan_from_prior`), then
    the baselines (a check of the two models above, not a model of its own: 0.051 GiB
    measured at 180 steps against 0.082 GiB added up; from 720 steps every start of the
    stretched ``default`` stops at IPOPT's 300 iterations and the plan fails);
    ``bound``: the closed-form PCRB (:func:`tmaplan.bounds.closed_form.closed_form_pcrb`),
    ``tmaplan bound``;
    ``schedule``: 4 pings along the straight track (:func:`tmaplan.planning.schedule_pings`,
    ``relaxed``), ``tmaplan schedule``.

Run: python benchmarks/memory.py [--steps 180,360,720,1440,2880] [--only heading,bound]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

KINDS = ("heading", "heading-dt", "baselines", "plan", "bound", "schedule")


def _child(kind: str, k: int) -> dict[str, float]:
    import dataclasses
    import resource
    import time

    import numpy as np

    from tmaplan.scenario import load_problem  # deferred: the child's memory is measured

    sc = load_problem("default")
    h = 15.0 * k
    sc = sc.replace(time=dataclasses.replace(sc.time, horizon=h),
                    planning=dataclasses.replace(sc.planning, horizon=h))

    def rss() -> float:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0

    from tmaplan.bounds.closed_form import closed_form_pcrb  # deferred: measured, as above
    from tmaplan.planning import (  # deferred: measured, as above
        Belief,
        HeadingPlanner,
        evaluate_baselines,
        schedule_pings,
    )

    belief = Belief.from_prior(sc)
    base = rss()
    t = time.perf_counter()
    if kind in ("heading", "heading-dt"):
        ci = {"control_interval": sc.time.dt, "horizon": h} if kind == "heading-dt" else {}
        planner = HeadingPlanner(sc, solver_options={"max_iter": 5}, **ci)
        planner.solve(belief, starts=[np.zeros(planner.n)], raise_on_failure=False)
    elif kind == "baselines":
        planner = HeadingPlanner(sc)
        evaluate_baselines(sc, planner.objective, evaluator=planner.evaluator(belief))
    elif kind == "plan":
        from tmaplan.policies.plan_starts import plan_from_prior  # deferred: measured

        planner = HeadingPlanner(sc)
        plan_from_prior(sc, planner=planner)
        evaluate_baselines(sc, planner.objective, evaluator=planner.evaluator(belief))
    elif kind == "bound":
        closed_form_pcrb(sc)
    else:
        schedule_pings(sc, budget=4, belief=belief)
    return {"kind": kind, "steps": k, "peak": rss() - base, "base": base,
            "seconds": time.perf_counter() - t}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", default="180,360,720,1440,2880")
    ap.add_argument("--only", default=",".join(KINDS))
    ap.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_child(args.child[0], int(args.child[1]))))
        return
    from tmaplan.memory import estimate  # deferred: not in the measured --child process

    gib = 2.0**30
    for kind in args.only.split(","):
        for k in (int(s) for s in args.steps.split(",")):
            proc = subprocess.run([sys.executable, __file__, "--child", kind, str(k)],
                                  capture_output=True, text=True, check=False)
            if proc.returncode != 0:
                print(f"{kind:<10} K={k:>6}: failed: {proc.stderr.strip().splitlines()[-1:]}")
                continue
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            parts = {"heading-dt": [("heading", 1)],
                     "plan": [("heading", 1), ("baselines", 1)]}.get(kind, [(kind, 1)])
            model = estimate(k, parts)
            print(f"{kind:<10} K={k:>6}: peak {r['peak'] / gib:8.3f} GiB above "
                  f"{r['base'] / gib:.3f} GiB, model {model / gib:8.3f} GiB, "
                  f"{r['seconds']:7.1f} s", flush=True)


if __name__ == "__main__":
    main()
