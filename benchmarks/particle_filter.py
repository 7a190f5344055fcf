"""Particle-filter throughput and accuracy: tmaplan vs Stone Soup 1.9.1 on ristic-bot-moderate.

Both filters are bootstrap particle filters with systematic resampling when ESS < N/2, run on
the same measurements (R seeded simulations), from the same prior particles, with the same
particle counts N = 10³, 10⁴, 10⁵. Prints, per N:

* particle-steps per second of each (total filtering time over the R runs; the prior draw and
  the simulation are outside the timed loop) and their ratio, measured in the same process;
* the final-step position RMSE over the R runs with its Monte Carlo standard error
  (delta method, ``se = sd(e²) / (2·RMSE·√R)``), and the paired difference of the mean
  squared errors with its standard error (the two filters see the same runs, so the paired
  test is the sharp one): "equal within MC error" means |z| < 2.

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
from tmaplan.models.prior import relative_prior_samples
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate

SIZES = (1_000, 10_000, 100_000)


def run_tmaplan(sc: Any, sim: Any, X0: np.ndarray, rng: np.random.Generator
                ) -> tuple[float, float]:
    """Filtering wall time [s] and final position error [m] of one run."""
    cfg = PFConfig(n_particles=X0.shape[0], dt=sc.time.dt, q=sc.target.q, variant="bootstrap")
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20, help="Monte Carlo runs per N (default 20)")
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)))
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")]
    sc = load_problem("ristic-bot-moderate")
    K = sc.n_steps
    ss = _stonesoup()
    if ss is None:
        print("Stone Soup not installed: tmaplan only (pip install stonesoup==1.9.1)")
    seeds = np.random.SeedSequence(args.seed).spawn(args.runs)
    sims = [simulate(sc, np.random.default_rng(s)) for s in seeds]
    print(f"ristic-bot-moderate: {K} steps, {args.runs} runs per N; bootstrap PF, systematic "
          "resampling at ESS < N/2")
    print(f"{'N':>7} | {'tmaplan steps/s':>15} {'Stone Soup':>11} {'ratio':>6} | "
          f"{'final RMSE tmaplan [m]':>22} {'Stone Soup [m]':>15} {'paired z':>8}")
    for n in sizes:
        t_tm = t_ss = 0.0
        e_tm, e_ss = [], []
        for i, sim in enumerate(sims):
            X0 = relative_prior_samples(sc, n, np.random.default_rng([args.seed, i, n]))
            dt, e = run_tmaplan(sc, sim, X0, np.random.default_rng([args.seed, i, n, 1]))
            t_tm += dt
            e_tm.append(e)
            if ss is not None:
                # Stone Soup draws from numpy's global RNG: seed it per run.
                np.random.seed(args.seed * 1000 + i)  # noqa: NPY002
                dt, e = run_stonesoup(ss, sc, sim, X0)
                t_ss += dt
                e_ss.append(e)
        rate_tm = n * K * args.runs / t_tm
        r_tm, se_tm = rmse_with_se(np.array(e_tm))
        if ss is None:
            print(f"{n:>7} | {rate_tm:>15.3g} {'-':>11} {'-':>6} | "
                  f"{r_tm:>12.1f} ± {se_tm:<7.1f} {'-':>15} {'-':>8}")
            continue
        rate_ss = n * K * args.runs / t_ss
        r_ss, se_ss = rmse_with_se(np.array(e_ss))
        d = np.array(e_tm) ** 2 - np.array(e_ss) ** 2
        z = float(d.mean() / (d.std(ddof=1) / np.sqrt(d.size))) if d.size > 1 else np.nan
        print(f"{n:>7} | {rate_tm:>15.3g} {rate_ss:>11.3g} {rate_tm / rate_ss:>6.1f} | "
              f"{r_tm:>12.1f} ± {se_tm:<7.1f} {r_ss:>7.1f} ± {se_ss:<5.1f} {z:>8.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
