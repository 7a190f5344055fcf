"""Benchmark: closed-form LPC PCRB vs Monte Carlo PCRB, and batched ping-schedule throughput.

Prints measured medians on ``brehard2005-s1`` (1000 steps) in the same run:
* the closed form for one observer track and schedule, prior moments and J₀ given (moment
  propagation + D-terms + Tichavský recursion + inverse diagonals): compiled path (casadi
  step functions compiled to C, cached) and, for reference, the casadi-VM path;
* the full ``closed_form_pcrb`` call (which also draws the 1e5 prior samples of eq. 56 and
  computes the side-assumption diagnostic);
* the Monte Carlo PCRB in LPC with 1000 samples (brehard2005, §5), same prior, unchanged code;
* batched evaluation of random ping schedules (schedules of 1000 steps per second): the C
  kernel and the numpy reference loop. Both start from the per-track quantities (moments,
  D-terms, J₀: computed once per observer track, timed above) and include everything that
  depends on the schedule (the whole Tichavský recursion and the eq. 58 bound at every step).
* the one-off JIT compile time (once per machine; cached under ``~/.cache/tmaplan/jit``).
Targets (issue 4): closed form ≤ 10 ms, ≥ 200× faster than Monte Carlo, ≥ 10 000 schedules/s.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
import warnings

import casadi as ca
import numpy as np

from tmaplan.bounds import lpc_codegen as _jit
from tmaplan.bounds import lpc_terms as _lpc_terms
from tmaplan.bounds.closed_form import ClosedFormEngine, closed_form_model, closed_form_pcrb
from tmaplan.bounds.inputs import prepare
from tmaplan.bounds.pcrb import SideAssumptionWarning, monte_carlo_pcrb
from tmaplan.models.target import ncv_matrices
from tmaplan.scenario import load_problem


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def compile_seconds() -> float:
    """Cold JIT: generate + compile both libraries into an empty cache directory."""
    A, Q = ncv_matrices(6.0, 0.0025)
    old = os.environ.get("TMAPLAN_CACHE_DIR")
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["TMAPLAN_CACHE_DIR"] = tmp
        try:
            t0 = time.perf_counter()
            cg = ca.CodeGenerator("x.c", {"with_header": False})
            for f in _lpc_terms.step_functions(A, Q):
                cg.add(f)
            _jit.compile_c(cg.dump(), "lpc_steps", native=False)
            body = _jit._emit_body(_jit._schedule_step_sx())
            _jit.compile_c(_jit._kernel_source(body), "lpc_schedules")
            return time.perf_counter() - t0
        finally:
            if old is None:
                del os.environ["TMAPLAN_CACHE_DIR"]
            else:
                os.environ["TMAPLAN_CACHE_DIR"] = old


def main() -> None:
    warnings.simplefilter("ignore", SideAssumptionWarning)
    sc = load_problem("brehard2005-s1")
    jit = _jit.jit_enabled()
    model = closed_form_model(sc)
    inp = prepare(sc)

    def core(backend: str) -> None:  # moments + D-terms + recursion for one observer track
        ClosedFormEngine.build(
            mean=inp.m0, second_moment=inp.S0, prior_information=model.prior_information,
            observer=inp.observer, dt=inp.dt, q=sc.target.q, bearing_info=inp.bearing_info,
            ping_sigma=inp.range_sigma, backend=backend).evaluate(backend=backend)

    backend = "auto"
    core(backend)
    core("casadi")
    t_core = median_time(lambda: core(backend), 50)
    t_vm = median_time(lambda: core("casadi"), 30)
    t_full = median_time(lambda: closed_form_pcrb(sc), 5)
    t_mc = median_time(lambda: monte_carlo_pcrb(sc, samples=1000, rng=np.random.default_rng(0),
                                                coords="lpc"), 3)
    label = "compiled C" if jit else "casadi VM (no compiler)"
    print(f"brehard2005-s1, 1000 steps   (JIT available: {jit})")
    print(f"  closed form core, {label:<24} median {t_core * 1e3:8.3f} ms   (target <= 10 ms)")
    print(f"  closed form core, casadi VM                median {t_vm * 1e3:8.3f} ms")
    print(f"  closed_form_pcrb (incl. 1e5 prior + diag.) median {t_full * 1e3:8.2f} ms")
    print(f"  Monte Carlo PCRB, 1000 samples             median {t_mc * 1e3:8.2f} ms")
    print(f"  ratio MC / closed form core:    {t_mc / t_core:8.1f}x   (target >= 200x)")
    print(f"  ratio MC / closed form core VM: {t_mc / t_vm:8.1f}x")
    print(f"  ratio MC / closed_form_pcrb:    {t_mc / t_full:8.1f}x")
    rng = np.random.default_rng(1)
    S = 10_000
    U = (rng.uniform(size=(S, model.n_steps + 1)) < 0.05).astype(float)
    print("  batched schedules (from the per-track moments/D-terms/J0 above; the whole")
    print("  schedule-dependent recursion and eq. 58 bound at every step are timed):")
    for be in (["compiled"] if jit else []) + ["numpy"]:
        model.evaluate_schedules(U[:100], reduce="mean", backend=be)
        t_b = median_time(lambda be=be: model.evaluate_schedules(U, reduce="mean", backend=be),
                          5 if be == "compiled" else 3)
        print(f"    {be:<9} {S} x 1000 steps in {t_b:6.3f} s -> {S / t_b:>10,.0f} schedules/s"
              "   (target >= 10 000/s)")
    if jit:
        a = model.evaluate_schedules(U[:500], reduce="mean", backend="compiled")
        b = model.evaluate_schedules(U[:500], reduce="mean", backend="numpy")
        print(f"    max |compiled/numpy - 1| over 500 schedules: {np.max(np.abs(a / b - 1)):.1e}")
        print(f"  JIT compile, once per machine (cold cache): {compile_seconds():.2f} s")


if __name__ == "__main__":
    main()
