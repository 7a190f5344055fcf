"""Particle-filter throughput and accuracy: tmaplan's numba and numpy kernels vs Stone Soup 1.9.1.

On ristic-bot-moderate, three bootstrap particle filters with systematic resampling when
ESS < N/2 run on the same measurements (R seeded simulations), from the same prior particles,
with N = 10³, 10⁴, 10⁵ particles: tmaplan with ``PFConfig(kernel="numba")``,
tmaplan with ``kernel="numpy"`` (the reference kernel) and Stone Soup. Prints, per N, in one
run (so the ratios compare like with like on a shared machine):

* particle-steps per second of each (total filtering time over the R runs; the prior draw, the
  simulation and the numba compilation (or cache load, timed and printed first) are outside
  the timed loop) and the ratios numba/numpy and numba/Stone Soup;
* the final-step position RMSE over the R runs with its Monte Carlo standard error (delta
  method, ``se = sd(e²) / (2·RMSE·√R)``), and the paired z of the mean squared errors of
  numba against numpy and against Stone Soup (the filters see the same runs, so the paired
  test is the sharp one): "equal within MC error" means |z| < 2.

BLAS runs on one thread (as in the campaigns); each N starts with one untimed run of each
kernel. Also printed: the load average before and after (other processes share the cores),
numba's thread count, and what the random numbers cost per particle-step at each N: the
numba kernel's normals (Philox4x32-10, float32 Box–Muller) against drawing the 4 normals with
the numpy Generator.

Stone Soup's state order is [x, vx, y, vy] and its bearing model measures atan2(Δy, Δx)
(counter-clockwise from +x), so the measured bearings are converted with
β_ss = π/2 − β_tmaplan. Skips Stone Soup gracefully when it is not installed
(``pip install stonesoup==1.9.1``, the ``bench`` extra). Not a unit test.

Usage: ``python benchmarks/particle_filter.py [--runs R] [--sizes 1000,10000,100000]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np

from tmaplan.estimators import ParticleFilter, PFConfig, measurement_batches
from tmaplan.evaluation.seeding import run_seeds
from tmaplan.models.prior import relative_prior_samples
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate

SIZES = (1_000, 10_000, 100_000)


def run_tmaplan(sc: Any, sim: Any, X0: np.ndarray, rng: np.random.Generator,
                kernel: str = "numba") -> tuple[float, float]:
    """Filtering wall time [s] and final position error [m] of one run."""
    cfg = PFConfig(n_particles=X0.shape[0], dt=sc.time.dt, q=sc.target.q, variant="bootstrap",
                   kernel=kernel)  # type: ignore[arg-type]
    pf = ParticleFilter(cfg)
    batches = measurement_batches(sc, sim.measurements, sim.observer)
    dv = sim.observer.velocity_increments
    st = pf.from_particles(X0)
    t0 = time.perf_counter()
    for k in range(sc.n_steps):
        st = pf.predict(st, dv[k], rng)
        st = pf.update(st, batches.get(k + 1, []), rng)
    dt = time.perf_counter() - t0
    err = float(np.hypot(*(st.mean[:2] - sim.relative[-1, :2])))
    return dt, err


_SS_NAMES = {
    "stonesoup.models.measurement.nonlinear": ("Cartesian2DToBearing",),
    "stonesoup.models.transition.linear": ("CombinedLinearGaussianTransitionModel",
                                           "ConstantVelocity"),
    "stonesoup.predictor.particle": ("ParticlePredictor",),
    "stonesoup.resampler.particle": ("ESSResampler", "SystematicResampler"),
    "stonesoup.types.array": ("StateVectors",),
    "stonesoup.types.detection": ("Detection",),
    "stonesoup.types.hypothesis": ("SingleHypothesis",),
    "stonesoup.types.state": ("ParticleState",),
    "stonesoup.updater.particle": ("ParticleUpdater",),
}


def _stonesoup() -> dict[str, Any] | None:
    """Stone Soup's classes by name, or None when it is not installed."""
    import importlib

    out: dict[str, Any] = {}
    try:
        for mod, names in _SS_NAMES.items():
            m = importlib.import_module(mod)
            out.update({nm: getattr(m, nm) for nm in names})
    except ImportError:
        return None
    return out


def run_stonesoup(ss: dict[str, Any], sc: Any, sim: Any, X0: np.ndarray
                  ) -> tuple[float, float]:
    """Same as :func:`run_tmaplan` with Stone Soup (its own global numpy RNG)."""
    from datetime import datetime, timedelta

    # Stone Soup works on an absolute-looking state; we run it on the *relative* state with a
    # sensor at the origin, and apply the observer increments as a state shift each step.
    trans = ss["CombinedLinearGaussianTransitionModel"]([ss["ConstantVelocity"](sc.target.q)] * 2)
    sigma = float(sc.sensors[0].sigma)
    meas_model = ss["Cartesian2DToBearing"](ndim_state=4, mapping=(0, 2),
                                            noise_covar=np.array([[sigma**2]]))
    predictor = ss["ParticlePredictor"](trans)
    updater = ss["ParticleUpdater"](meas_model, resampler=ss["ESSResampler"](
        resampler=ss["SystematicResampler"]()))
    start = datetime(2020, 1, 1)
    sv = ss["StateVectors"](X0[:, [0, 2, 1, 3]].T)  # [x, vx, y, vy]
    n = X0.shape[0]
    prior = ss["ParticleState"](sv, log_weight=np.full(n, -np.log(n)), timestamp=start)
    batches = measurement_batches(sc, sim.measurements, sim.observer)
    dv = sim.observer.velocity_increments
    dt_s = sc.time.dt
    t0 = time.perf_counter()
    for k in range(sc.n_steps):
        ts = start + timedelta(seconds=(k + 1) * dt_s)
        pred = predictor.predict(prior, timestamp=ts)
        shift = np.array([dt_s * dv[k, 0], dv[k, 0], dt_s * dv[k, 1], dv[k, 1]])[:, None]
        pred.state_vector = ss["StateVectors"](pred.state_vector - shift)
        ms = batches.get(k + 1, [])
        if ms:
            z = np.pi / 2 - ms[0].value  # atan2(Δy, Δx) = π/2 − atan2(Δx, Δy)
            det = ss["Detection"](np.array([[z]]), timestamp=ts, measurement_model=meas_model)
            prior = updater.update(ss["SingleHypothesis"](pred, det))
        else:
            prior = pred
    dt = time.perf_counter() - t0
    m = np.asarray(prior.mean).ravel()
    err = float(np.hypot(m[0] - sim.relative[-1, 0], m[2] - sim.relative[-1, 1]))
    return dt, err


def rmse_with_se(e: np.ndarray) -> tuple[float, float]:
    """RMSE of errors ``e`` (R,) and its delta-method Monte Carlo standard error."""
    e2 = np.asarray(e, float) ** 2
    rmse = float(np.sqrt(e2.mean()))
    se = float(e2.std(ddof=1) / (2.0 * rmse * np.sqrt(e2.size))) if e2.size > 1 else np.nan
    return rmse, se


def paired_z(a: list[float], b: list[float]) -> float:
    """z of the paired mean difference of squared errors (a² − b²)."""
    d = np.asarray(a) ** 2 - np.asarray(b) ** 2
    return float(d.mean() / (d.std(ddof=1) / np.sqrt(d.size))) if d.size > 1 else np.nan


def noise_costs(n: int, repeat: int = 20) -> list[tuple[float, float]]:
    """(wall, CPU) ns per particle-step of 4 normals: the numba kernel's (Philox4x32-10 and
    float32 Box–Muller, on numba's threads from PARALLEL_MIN particles on: a prediction of the
    zero cloud, its output recycled), the Generator's (float64 and float32 ziggurat, one
    thread, into a preallocated buffer). The CPU time (all threads) is the sturdier figure on
    a loaded machine."""
    from tmaplan.estimators import pf_numba as _pf_numba  # deferred: numba, compiled on first use

    rng = np.random.default_rng(0)
    key = np.arange(4, dtype=np.uint64)
    buf64, buf32 = np.empty(4 * n), np.empty(4 * n, dtype=np.float32)
    zero, no_dv = np.zeros((4, n)), np.zeros(2)
    out = []
    for f in (lambda: _pf_numba.predict_rows(zero, 0.0, (1.0, 0.0, 1.0), no_dv, key),
              lambda: rng.standard_normal(out=buf64),
              lambda: rng.standard_normal(out=buf32, dtype=np.float32)):
        f()
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(repeat):
            f()
        out.append(((time.perf_counter() - t0) / repeat / n * 1e9,
                    (time.process_time() - c0) / repeat / n * 1e9))
    return out


def _load() -> str:
    import os

    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv: list[str] | None = None) -> int:
    from threadpoolctl import threadpool_limits

    # BLAS on one thread, as in the campaigns: OpenBLAS's threads spin after each call of the
    # numpy kernel and would take the cores from numba's (and the numpy kernel is no faster)
    with threadpool_limits(limits=1, user_api="blas"):
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    import numba

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="Monte Carlo runs per N (default 20)")
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)))
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    if args.runs < 2:
        ap.error(f"--runs: at least 2 (for the Monte Carlo errors), received {args.runs}")
    sizes = [int(s) for s in args.sizes.split(",")]
    sc = load_problem("ristic-bot-moderate")
    K = sc.n_steps
    ss = _stonesoup()
    if ss is None:
        print("Stone Soup not installed: tmaplan only (pip install stonesoup==1.9.1)")
    seeds = run_seeds(args.seed, args.runs)
    sims = [simulate(sc, np.random.default_rng(s)) for s in seeds]
    _warm(sc, sims[0])  # first: numba's threads start after tmaplan set OMP_WAIT_POLICY
    print(f"ristic-bot-moderate: {K} steps, {args.runs} runs per N; bootstrap PF, systematic "
          f"resampling at ESS < N/2; numba {numba.__version__}, {numba.get_num_threads()} "
          f"threads ({numba.threading_layer()} layer); load average {_load()}")
    print(f"{'N':>7} | {'numba steps/s':>13} {'numpy':>9} {'Stone Soup':>10} "
          f"{'nb/np':>6} {'nb/SS':>6} | {'final RMSE numba [m]':>20} {'numpy [m]':>14} "
          f"{'Stone Soup [m]':>14} {'z nb-np':>7} {'z nb-SS':>7}")
    for n in sizes:
        t = {"numba": 0.0, "numpy": 0.0, "ss": 0.0}
        e: dict[str, list[float]] = {"numba": [], "numpy": [], "ss": []}
        for kernel in ("numba", "numpy"):  # untimed: the first large arrays of this size
            run_tmaplan(sc, sims[0], relative_prior_samples(sc, n, np.random.default_rng(0)),
                        np.random.default_rng(0), kernel)
        for i, sim in enumerate(sims):
            X0 = relative_prior_samples(sc, n, np.random.default_rng([args.seed, i, n]))
            for kernel in ("numba", "numpy"):
                dt, err = run_tmaplan(sc, sim, X0, np.random.default_rng([args.seed, i, n, 1]),
                                      kernel)
                t[kernel] += dt
                e[kernel].append(err)
            if ss is not None:
                # Stone Soup draws from numpy's global RNG: seed it per run.
                np.random.seed(args.seed * 1000 + i)  # noqa: NPY002
                dt, err = run_stonesoup(ss, sc, sim, X0)
                t["ss"] += dt
                e["ss"].append(err)
        rate = {k: n * K * args.runs / v if v > 0 else np.nan for k, v in t.items()}
        r = {k: rmse_with_se(np.array(v)) if v else (np.nan, np.nan) for k, v in e.items()}
        z_np = paired_z(e["numba"], e["numpy"])
        z_ss = paired_z(e["numba"], e["ss"]) if e["ss"] else np.nan
        print(f"{n:>7} | {rate['numba']:>13.3g} {rate['numpy']:>9.3g} {rate['ss']:>10.3g} "
              f"{rate['numba'] / rate['numpy']:>6.1f} {rate['numba'] / rate['ss']:>6.1f} | "
              f"{r['numba'][0]:>11.1f} ± {r['numba'][1]:<6.1f} {r['numpy'][0]:>7.1f} ± "
              f"{r['numpy'][1]:<4.1f} {r['ss'][0]:>7.1f} ± {r['ss'][1]:<4.1f} {z_np:>7.2f} "
              f"{z_ss:>7.2f}")
    for n in sizes:
        (nw, nc), (gw, gc), (fw, fc) = noise_costs(n)
        print(f"noise, ns per particle-step (4 normals), wall / CPU, N={n}: numba Philox + "
              f"Box–Muller {nw:.2f} / {nc:.2f}; Generator float64 {gw:.2f} / {gc:.2f}, "
              f"float32 {fw:.2f} / {fc:.2f}")
    print(f"load average after: {_load()}")
    return 0


_WARM: dict[str, float] = {}


def _warm(sc: Any, sim: Any) -> None:
    """Compile (or load from numba's cache) the numba kernels, serial and parallel builds,
    outside the timed loops; prints the time it took."""
    from tmaplan.estimators import pf_numba as _pf_numba  # deferred: numba, compiled on first use

    t0 = time.perf_counter()
    for n in (1000, _pf_numba.PARALLEL_MIN):
        X0 = relative_prior_samples(sc, n, np.random.default_rng(0))
        run_tmaplan(sc, sim, X0, np.random.default_rng(0), "numba")
    _WARM["seconds"] = time.perf_counter() - t0
    print(f"numba kernels compiled or loaded from the cache in {_WARM['seconds']:.1f} s")


if __name__ == "__main__":
    sys.exit(main())
