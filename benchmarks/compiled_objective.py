"""The compiled objective's kernel with its loops split for the vectoriser, against the kernel
as it was before (``tests/oracles/compiled_objective_reference.py``), in one run.

``kernel``: ``tmaplan.planning.compiled_objective._value_grad`` and the reference on
``default``'s sizes (121 steps, 128 belief draws; the reference's random inputs in the
kernel's scaled units), median seconds per call of a forward pass alone (a value), a forward
pass with the reverse sweep (a value and its gradient) and a reverse sweep alone (the
gradient at the last value's point), the two kernels called in turn, each mode's calls
interleaved with the others', with the ratio old/new per mode. Both are compiled (or loaded
from numba's cache) before the timing; one thread (numba's kernel runs on the calling
thread; BLAS limited to one).

``--replans N``: the re-plan seconds (``ClosedLoopRun.replans``) of ``receding`` on
``default`` over runs 0..N-1 (seed 0, 3000 particles), each run flown with the new kernel and
with the reference patched in, in turn; the median of each and their ratio. The two fly the
same re-plans (the kernels give the same bits), so the difference is the kernel's time.

Run: python benchmarks/compiled_objective.py [--calls 2000] [--replans 0] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.interrupts import compiled_entry
from tmaplan.planning import compiled_objective

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from oracles.compiled_objective_reference import _value_grad as _reference
from oracles.compiled_objective_reference import random_inputs, workspace

K1, NS = 121, 128  # default's re-plan: 120 steps of 15 s, 128 belief draws
MODES = {"forward": (True, True, False), "forward+reverse": (True, True, True),
         "reverse": (False, False, True)}


def kernel_medians(calls: int) -> dict[str, dict[str, float]]:
    """Median seconds per call of each kernel in each mode, calls interleaved."""
    args = random_inputs(K1, NS, 0)
    kernels = {"old": _reference, "new": compiled_objective._value_grad}
    spaces = {name: workspace(K1, NS) for name in kernels}
    for name, fn in kernels.items():  # compile (or load) and store a forward pass
        fn(*args, *spaces[name], True, True, True)
    times: dict[tuple[str, str], list[float]] = {(n, m): [] for n in kernels for m in MODES}
    for _ in range(calls):
        for mode, flags in MODES.items():
            for name, fn in kernels.items():
                if mode == "reverse":  # what a reverse-only call reads: a forward pass
                    fn(*args, *spaces[name], True, True, False)
                t0 = time.perf_counter()
                fn(*args, *spaces[name], *flags)
                times[name, mode].append(time.perf_counter() - t0)
    return {m: {n: float(np.median(times[n, m])) for n in kernels} for m in MODES}


def replan_medians(runs: int) -> dict[str, float]:
    """Median re-plan seconds of ``receding`` on ``default`` with each kernel, runs in turn."""
    from tmaplan.evaluation.campaigns import resolve_policies
    from tmaplan.evaluation.closed_loop import paired_run
    from tmaplan.scenario import load_problem

    sc = load_problem("default")
    pols = resolve_policies(sc, ("receding",), workers=1)
    new, old = compiled_objective._value_grad, compiled_entry(_reference)
    seconds: dict[str, list[float]] = {"old": [], "new": []}
    try:
        for run in range(-1, runs):  # run -1: compilation and caches, not counted
            for name, fn in (("old", old), ("new", new)):
                compiled_objective._value_grad = fn
                for _, res in paired_run(sc, pols, seed=0, run=max(run, 0), n_particles=3000):
                    if run >= 0:
                        seconds[name].extend(e["seconds"] for e in res.replans)
    finally:
        compiled_objective._value_grad = new
    return {name: float(np.median(s)) for name, s in seconds.items()} | {
        "replans": len(seconds["new"])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=2000, help="calls per kernel and mode")
    ap.add_argument("--replans", type=int, default=0,
                    help="closed-loop runs on default for the re-plan medians (0: none)")
    ap.add_argument("--json", help="write the medians here")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    out: dict[str, object] = {}
    with threadpool_limits(1):
        out["kernel"] = kernel = kernel_medians(args.calls)
        print(f"kernel on {K1} steps x {NS} draws, median of {args.calls} calls:")
        for mode, m in kernel.items():
            print(f"  {mode:16s} old {m['old'] * 1e6:7.0f} us   new {m['new'] * 1e6:7.0f} us"
                  f"   old/new {m['old'] / m['new']:.2f}")
        if args.replans:
            out["replans"] = rp = replan_medians(args.replans)
            print(f"re-plans of receding on default, {args.replans} runs ({rp['replans']} "
                  f"re-plans each): median old {rp['old'] * 1e3:.1f} ms, new "
                  f"{rp['new'] * 1e3:.1f} ms, old/new {rp['old'] / rp['new']:.2f}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
