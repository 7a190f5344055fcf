"""Interrupts lose nothing and change nothing (issue 38): a campaign interrupted at random
moments, and resumed after each, is the uninterrupted campaign.

The uninterrupted campaign is computed first, in its own directory (the policies resolved
before: the wall time T of its runs alone). The same campaign is then started in another
directory again and again, each attempt interrupted after a delay, until ``--points``
interrupts have been sent; a last resume completes it. The interrupt points are ``--points``
uniform draws over T (a seeded generator), sorted: point k is meant to land at time u_k of
the campaign, so attempt k is interrupted after u_k minus the time the runs already kept
took (T/runs each; a point that this progress has passed lands within the next run, at a
uniform draw over T/runs), and the attempts, each resumed from the runs kept, sweep the
campaign from its first run to its last. Even interrupts are a SIGINT under Python's default
handler (a script, a notebook), odd ones a SIGTERM under the command line's handlers
(:func:`tmaplan.interrupts.signals_interrupt`). After each: no temporary file is left, every
run stored before is untouched, every stored run is the uninterrupted campaign's (every
array but the wall-clock ``replan_seconds``:
:func:`tmaplan.evaluation.records.run_file_digest`), and the interrupt says how many runs
were kept; the last resume loads the runs kept and computes exactly the others, and the
campaign's JSON is the uninterrupted one's but its timings
(:func:`tmaplan.evaluation.records.without_timings`). Printed per interrupt: the delay,
where it landed (serial: inside a solver call, i.e. a solve that casadi or SCS turned into a
failed one, or in Python code, and where), the runs stored; then the verdict.

``--backend processes`` runs the campaign on ``--workers`` worker processes: the interrupt
reaches the main process, which stops the workers (their runs in progress are lost, never
stored). Each attempt starts its pool (:func:`tmaplan.parallel.process_pool`) and waits for
its workers to have imported before the clock starts, so that the delays fall among the
runs, not in the workers' start (T is then the uninterrupted campaign's wall time on started
workers; that campaign must also be the serial one). ``--backend both``: serial, then
processes.

Run: python benchmarks/interrupts.py [--problem bow-closing] [--runs 20] [--points 20]
     [--backend both] [--workers 2] [--particles 3000] [--seed 4] [--rng 38]
     [--policies straight,planned,receding-realtime,receding] [--out DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.evaluation.records import run_file_digest, without_timings
from tmaplan.experiments import CampaignSpec, resolve_policies, run_campaign
from tmaplan.interrupts import Interrupted, signals_interrupt
from tmaplan.parallel import process_pool
from tmaplan.scenario import load


class _Interrupter:
    """Sends ``sig`` to this process after ``delay`` s, unless disarmed first (never after
    :meth:`disarm` returns)."""

    def __init__(self, delay: float, sig: int) -> None:
        self.sig, self.sent, self.armed = sig, False, True
        self.lock = threading.Lock()
        self.timer = threading.Timer(delay, self._fire)

    def _fire(self) -> None:
        with self.lock:
            if self.armed:
                os.kill(os.getpid(), self.sig)
                self.sent = True

    def disarm(self) -> None:
        with self.lock:
            self.armed = False
        self.timer.cancel()


def _digests(out: Path) -> dict[str, dict[str, str]]:
    return {p.name: run_file_digest(p) for p in sorted(out.glob("campaign-*/runs/run_*.npz"))}


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(out.glob("campaign-*/runs/*"))}


def _landed(exc: BaseException) -> str:
    """Where an interrupt landed: inside a solver call (the solver swallowed it), or the
    Python function it interrupted."""
    cause = exc.__cause__ or exc
    frames = traceback.extract_tb(cause.__traceback__)
    if not frames:
        return "?"
    if frames[-1].name == "solver_call":
        caller = frames[-3] if len(frames) >= 3 else frames[-1]  # (contextlib's __exit__)
        return f"solver call ({Path(caller.filename).stem}.{caller.name})"
    if frames[-1].name == "_handler" and len(frames) >= 2:  # tmaplan's handler
        frames = frames[:-1]
    return f"python ({Path(frames[-1].filename).stem}.{frames[-1].name})"


def _started_pool(workers: int) -> Any:
    """``process_pool(workers)`` once its workers have imported (None for one worker)."""
    if workers <= 1:
        return contextlib.nullcontext()
    pool = process_pool(workers)
    list(pool.map(abs, range(workers)))
    return pool


def _attempt(spec: CampaignSpec, out: Path, delay: float, sig: int, workers: int = 1
             ) -> tuple[Any, BaseException | None, bool]:
    """run_campaign interrupted by ``sig`` after ``delay`` s: (result or None, the
    campaign's Interrupted or None, whether the signal was sent)."""
    it = _Interrupter(delay, sig)
    ctx = signals_interrupt() if sig == signal.SIGTERM else contextlib.nullcontext()
    try:
        with ctx, _started_pool(workers) as pool:  # (stopped at once by an interrupt)
            it.timer.start()
            try:
                return run_campaign(spec, out_dir=out, workers=workers, pool=pool), None, \
                    it.sent
            finally:
                it.disarm()
                time.sleep(0.05)  # a signal sent meanwhile is handled here, in the block
    except KeyboardInterrupt as exc:
        resumable = isinstance(exc, Interrupted) and exc.resumable
        return None, (exc if resumable else None), True


def sweep(spec: CampaignSpec, ref: dict[str, dict[str, str]], ref_json: str, seconds: float,
          points: int, rng: np.random.Generator, out: Path, workers: int = 1) -> bool:
    """Interrupt the campaign at ``points`` moments (uniform draws over ``seconds``, the
    uninterrupted campaign's wall time), resume it, compare with ``ref``; True if
    identical."""
    per_run = seconds / spec.runs
    ok, sent, kept = True, 0, _files(out)
    for k, u in enumerate(np.sort(rng.uniform(0.0, seconds, points))):
        sig = signal.SIGINT if k % 2 == 0 else signal.SIGTERM
        gap = u - per_run * len(kept)
        gap = gap if gap > 0 else rng.uniform(0.0, per_run)
        res, exc, was_sent = _attempt(spec, out, gap, sig, workers)
        sent += was_sent
        files, digests = _files(out), _digests(out)
        checks = {
            "no temporary file": all(n.endswith(".npz") for n in files),
            "kept runs untouched": all(files.get(n) == b for n, b in kept.items()),
            "stored = uninterrupted": all(ref[n] == d for n, d in digests.items()),
            "count in the message": exc is None or f"; {len(digests)} of " in str(exc),
        }
        ok &= all(checks.values())
        where = _landed(exc) if exc is not None else ("finished" if res is not None else
                                                       "after the campaign ended")
        print(f"  {k + 1:2d} {signal.Signals(sig).name:7s} at {u:6.1f} s, after {gap:5.2f} s: "
              f"{where:48s} stored {len(digests):2d}/{spec.runs}"
              + ("" if all(checks.values()) else
                 f"  FAILED: {[c for c, v in checks.items() if not v]}"), flush=True)
        kept = files
        if res is not None:  # finished before its interrupt: start it again, from scratch
            for p in out.glob("campaign-*/runs/*"):
                p.unlink()
            kept = {}
    before = {int(n[4:9]) for n in kept}
    with _started_pool(workers) as pool:
        final = run_campaign(spec, out_dir=out, workers=workers, pool=pool)
    exact = (final.loaded_runs == tuple(sorted(before)) and final.computed_runs
             == tuple(i for i in range(spec.runs) if i not in before))
    same_runs = _digests(out) == ref
    same_json = json.dumps(without_timings(final.to_json()), sort_keys=True) == ref_json
    print(f"  {sent} interrupts sent; the resume loaded {len(final.loaded_runs)} runs and "
          f"computed exactly the {len(final.computed_runs)} others: {exact}; stored runs "
          f"identical: {same_runs}; JSON identical (but timings): {same_json}", flush=True)
    return ok and exact and same_runs and same_json


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="bow-closing")
    ap.add_argument("--policies", default="straight,planned,receding-realtime,receding")
    ap.add_argument("--runs", type=int, default=20, help="runs (default 20)")
    ap.add_argument("--points", type=int, default=20, help="interrupts (default 20)")
    ap.add_argument("--backend", choices=("serial", "processes", "both"), default="both")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--particles", type=int, default=3000, help="(default 3000)")
    ap.add_argument("--seed", type=int, default=4, help="campaign seed (default 4)")
    ap.add_argument("--rng", type=int, default=38, help="seed of the interrupt delays "
                                                        "(default 38)")
    ap.add_argument("--out", default=None, help="directory (default: a temporary one)")
    args = ap.parse_args()
    scenario = load(args.problem)
    policies = tuple(args.policies.split(","))
    spec = CampaignSpec(scenario=scenario, policies=policies, runs=args.runs, seed=args.seed,
                        n_particles=args.particles)
    with contextlib.ExitStack() as stack:
        root = Path(args.out) if args.out else Path(
            stack.enter_context(tempfile.TemporaryDirectory(prefix="tmaplan-interrupts-")))
        t0 = time.perf_counter()
        resolve_policies(scenario, policies)  # the offline plans, kept by this process
        print(f"{args.problem}: {', '.join(policies)}; {args.runs} runs, {args.particles} "
              f"particles, seed {args.seed}; policies resolved in "
              f"{time.perf_counter() - t0:.1f} s", flush=True)
        t0 = time.perf_counter()
        reference = run_campaign(spec, out_dir=root / "reference")
        seconds = time.perf_counter() - t0
        ref = _digests(root / "reference")
        ref_json = json.dumps(without_timings(reference.to_json()), sort_keys=True)
        print(f"uninterrupted (serial): {seconds:.1f} s", flush=True)
        rng = np.random.default_rng(args.rng)
        verdicts = {}
        if args.backend in ("serial", "both"):
            print(f"serial: {args.points} interrupts", flush=True)
            verdicts["serial"] = sweep(spec, ref, ref_json, seconds, args.points, rng,
                                       root / "serial")
        if args.backend in ("processes", "both"):
            with _started_pool(args.workers) as pool:
                t0 = time.perf_counter()
                procs = run_campaign(spec, out_dir=root / "processes-reference",
                                     workers=args.workers, pool=pool)
                p_seconds = time.perf_counter() - t0
            same = (_digests(root / "processes-reference") == ref and json.dumps(
                without_timings(procs.to_json()), sort_keys=True) == ref_json)
            print(f"processes ({args.workers} workers): uninterrupted {p_seconds:.1f} s once "
                  f"the workers started (identical to serial: {same}); {args.points} "
                  "interrupts", flush=True)
            verdicts["processes"] = same and sweep(spec, ref, ref_json, p_seconds, args.points,
                                                   rng, root / "processes", args.workers)
    print("verdict: " + ", ".join(f"{b} {'identical' if v else 'DIFFERENT'}"
                                  for b, v in verdicts.items()))
    if not all(verdicts.values()):
        sys.exit(1)


if __name__ == "__main__":
    main()
