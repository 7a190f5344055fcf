"""Re-fly the ``receding`` policy on chosen runs of a several-contact campaign and count its
re-plans (issue 40; the re-plan accounting of issue 38).

Run ``i`` of a ``tmaplan compare P`` campaign of seed ``S`` flying ``receding`` depends only on
``S`` and ``i`` (:func:`tmaplan.evaluation.seeding.run_streams`; every policy flies on fresh
generators from the run's streams), so ``receding`` alone on run ``i`` flies exactly the campaign's
``receding`` run ``i``. A change that only acts after a failed re-plan (the fallback starts of
:class:`tmaplan.policies.contacts.ContactsReceding`) leaves every run without a failed re-plan
unchanged: re-flying the runs that had one counts the campaign's re-plans under the change.

For each run: the re-plans converged / not converged / infeasible (the estimate inside the
keep-out range, or IPOPT infeasible from every start) / fallen back (a start other than the
warm one), each re-plan's wall time, and the time until all contacts are localised. With
``--store DIR`` (a campaign's ``campaign-*`` directory) the stored run's counts are printed
next to the new ones.

``--graph``: each run flown again with the re-plans' objective on the casadi graph
(``ContactsReceding(compiled=False)``, the path before the compiled kernels), the two in turn
run by run in one process; the median re-plan wall time of each and their ratio (the speed
goal's measurement: a ratio in one run), and how many runs gave the same time until all
contacts are localised (IPOPT takes the same steps on both but for the last bits, which can
lead a later re-plan elsewhere).

Run: python benchmarks/contacts_replans.py three-contacts-screen --seed 40 --runs 7,14,23
     [--store out/campaign-...] [--particles 3000] [--graph]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from tmaplan.evaluation.campaigns import CampaignSpec, resolve_policies, run_one
from tmaplan.evaluation.metrics import censor_time
from tmaplan.policies.combine import Combined
from tmaplan.scenario import load_problem


def counts(converged: np.ndarray, fell_back: np.ndarray, infeasible: np.ndarray) -> str:
    """``converged/not converged/infeasible/fell back`` of one run's re-plans."""
    bad = ~converged & ~infeasible
    return (f"{int(converged.sum())}/{int(bad.sum())}/{int(infeasible.sum())}/"
            f"{int((fell_back & converged).sum())}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("problem")
    ap.add_argument("--seed", type=int, default=40)
    ap.add_argument("--runs", required=True, help="comma-separated run indices")
    ap.add_argument("--store", type=Path, default=None)
    ap.add_argument("--particles", type=int, default=3000)
    ap.add_argument("--graph", action="store_true",
                    help="also fly each run with the re-plans on the casadi graph; the ratio")
    a = ap.parse_args()
    runs = [int(x) for x in a.runs.split(",")]
    sc = load_problem(a.problem)
    spec = CampaignSpec(scenario=sc, policies=("receding",), runs=max(runs) + 1, seed=a.seed,
                        n_particles=a.particles)
    pols = resolve_policies(sc, ["receding"])
    print(f"{a.problem}, seed {a.seed}, receding; re-plans converged/not converged/"
          f"infeasible/converged after a fallback")
    print("run | stored | now | re-plan seconds (now) | all localised [min] | CPU [s]")
    tot_old, tot_new = np.zeros(4, int), np.zeros(4, int)
    for r in runs:
        t0 = time.process_time()
        p = run_one(spec, pols, r).policies["receding"]
        new = counts(p.replan_converged, p.replan_fell_back, p.replan_infeasible)
        tot_new += [int(x) for x in new.split("/")]
        old = "-"
        if a.store is not None:
            z = np.load(a.store / "runs" / f"run_{r:05d}.npz")
            old = counts(z["receding/replan_converged"], z["receding/replan_fell_back"],
                         z["receding/replan_infeasible"])
            tot_old += [int(x) for x in old.split("/")]
        secs = ", ".join(f"{s:.1f}" for s in p.replan_seconds)
        print(f"{r} | {old} | {new} | {secs} | {p.metrics.time_to_accuracy / 60:.2f} | "
              f"{time.process_time() - t0:.0f}", flush=True)
    print(f"total | {'/'.join(map(str, tot_old)) if a.store else '-'} | "
          f"{'/'.join(map(str, tot_new))} |  |  |")
    if a.graph:
        compare_graph(spec, pols, runs)


def compare_graph(spec: CampaignSpec, pols: dict, runs: list[int]) -> None:
    """Each run with the compiled re-plans and with the graph's, in turn: median re-plan
    seconds, their ratio, the runs with the same time until all localised."""
    rec = pols["receding"]
    if not isinstance(rec, Combined):  # (resolve_policies wraps every policy)
        raise TypeError(f"expected a combined policy, got {rec!r}")
    paths = {name: {"receding": dataclasses.replace(
        rec, manoeuvre=dataclasses.replace(rec.manoeuvre, compiled=flag))}
        for name, flag in (("compiled", True), ("graph", False))}
    secs: dict[str, list[float]] = {name: [] for name in paths}
    times: dict[str, list[float]] = {name: [] for name in paths}
    for r in runs:
        for name, p in paths.items():
            pr = run_one(spec, p, r).policies["receding"]
            secs[name].extend(pr.replan_seconds)
            times[name].append(pr.metrics.time_to_accuracy)
    med = {name: float(np.median(v)) for name, v in secs.items()}
    print(f"re-plan wall time, median of {len(secs['compiled'])}: compiled "
          f"{med['compiled'] * 1e3:.0f} ms, graph {med['graph'] * 1e3:.0f} ms, graph/compiled "
          f"{med['graph'] / med['compiled']:.2f}")
    same = sum(a == b for a, b in zip(times["compiled"], times["graph"], strict=True))
    never = censor_time(np.arange(spec.scenario.n_steps + 1) * spec.scenario.time.dt)
    t = {name: np.where(np.isposinf(v), never, v) for name, v in times.items()}
    diff = float(np.mean(t["compiled"] - t["graph"])) / 60  # (never: the horizon plus a step)
    print(f"runs with the same time until all localised: {same} of {len(runs)}; "
          f"mean compiled − graph {diff:+.2f} min")


if __name__ == "__main__":
    main()
