"""Benchmark: closed-form LPC PCRB vs Monte Carlo PCRB, and batched ping-schedule throughput.

Prints measured medians on ``brehard2005-s1`` (1000 steps) in the same run:
* the closed form (moments + D-terms + recursion, prior moments given) and the full
  ``closed_form_pcrb`` call (which also draws the 1e5 prior samples of eq. 56);
* the Monte Carlo PCRB in LPC with 1000 samples (file 000 L612), same prior;
* numpy-batched evaluation of random ping schedules (schedules of 1000 steps per second).
Targets (issue 4): closed form ≤ 10 ms, ≥ 200× faster than Monte Carlo, ≥ 10 000 schedules/s.
"""

from __future__ import annotations

import statistics
import time
import warnings

import numpy as np

from tmaplan.bounds.closed_form import closed_form_model, closed_form_pcrb
from tmaplan.bounds.pcrb import SideAssumptionWarning, monte_carlo_pcrb
from tmaplan.scenario import load_problem


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    warnings.simplefilter("ignore", SideAssumptionWarning)
    sc = load_problem("brehard2005-s1")
    model = closed_form_model(sc)

    def core() -> None:  # moments + D-terms + Tichavský recursion for one observer track
        from tmaplan.bounds._lpc_terms import step_functions
        from tmaplan.bounds.closed_form import _accumulated

        mf, _ = step_functions(model.inputs.A, model.inputs.Q)
        _accumulated(mf, model.n_steps)(model.x0, model.inputs.c.T)
        model.evaluate()

    core()
    t_core = median_time(core, 30)
    t_full = median_time(lambda: closed_form_pcrb(sc), 5)
    t_mc = median_time(lambda: monte_carlo_pcrb(sc, samples=1000, rng=np.random.default_rng(0),
                                                coords="lpc"), 3)
    print("brehard2005-s1, 1000 steps")
    print(f"  closed form (moments + recursion)   median {t_core * 1e3:8.2f} ms")
    print(f"  closed_form_pcrb (incl. 1e5 prior)  median {t_full * 1e3:8.2f} ms")
    print(f"  Monte Carlo PCRB, 1000 samples      median {t_mc * 1e3:8.2f} ms")
    print(f"  ratio MC / closed form core: {t_mc / t_core:7.1f}x   (target >= 200x)")
    print(f"  ratio MC / closed_form_pcrb: {t_mc / t_full:7.1f}x")
    rng = np.random.default_rng(1)
    S = 10_000
    U = (rng.uniform(size=(S, model.n_steps + 1)) < 0.05).astype(float)
    model.evaluate_schedules(U[:100], reduce="mean")
    t_b = median_time(lambda: model.evaluate_schedules(U, reduce="mean"), 3)
    print(f"  batched schedules: {S} x 1000 steps in {t_b:.2f} s -> {S / t_b:,.0f} schedules/s"
          "   (target >= 10 000/s)")


if __name__ == "__main__":
    main()
