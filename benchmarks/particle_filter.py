"""Particle-filter throughput: tmaplan vs Stone Soup 1.9.1 on ristic-bot-moderate.

Same scenario, same measurements (one seeded simulation), same particle counts, same prior
particles. Prints particle-steps per second for N = 10³, 10⁴, 10⁵, the ratio tmaplan / Stone
Soup, and the final position error of both. Stone Soup's state order is [x, vx, y, vy] and its
Bearing model measures atan2(Δy, Δx) (counter-clockwise from +x): we convert the measured
bearings with β_ss = π/2 − β_tmaplan. Skips Stone Soup gracefully when it is not installed
(``pip install stonesoup==1.9.1``, the ``bench`` extra). Not a unit test.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from tmaplan.estimators import Measurement, ParticleFilter, PFConfig, measurement_batches
from tmaplan.models.prior import relative_prior_samples
from tmaplan.scenario import load_problem
from tmaplan.simulate import simulate

SIZES = (1_000, 10_000, 100_000)


def run_tmaplan(sc, sim, X0, rng) -> tuple[float, float]:
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


def run_stonesoup(sc, sim, X0, rng) -> tuple[float, float] | None:
    try:
        from datetime import datetime, timedelta

        from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing
        from stonesoup.models.transition.linear import (
            CombinedLinearGaussianTransitionModel,
            ConstantVelocity,
        )
        from stonesoup.predictor.particle import ParticlePredictor
        from stonesoup.resampler.particle import ESSResampler, SystematicResampler
        from stonesoup.types.detection import Detection
        from stonesoup.types.state import ParticleState
        from stonesoup.updater.particle import ParticleUpdater
    except ImportError:
        print("Stone Soup not installed: skipping the comparison "
              "(pip install stonesoup==1.9.1)")
        return None
    # Stone Soup works on an absolute-looking state; we run it on the *relative* state with a
    # sensor at the origin, and apply the observer increments as a state shift each step.
    trans = CombinedLinearGaussianTransitionModel([ConstantVelocity(sc.target.q)] * 2)
    sigma = float(sc.sensors[0].sigma)
    meas_model = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2),
                                      noise_covar=np.array([[sigma**2]]))
    predictor = ParticlePredictor(trans)
    updater = ParticleUpdater(meas_model, resampler=ESSResampler(
        resampler=SystematicResampler()))
    start = datetime(2020, 1, 1)
    from stonesoup.types.array import StateVectors

    sv = StateVectors(X0[:, [0, 2, 1, 3]].T)  # [x, vx, y, vy]
    n = X0.shape[0]
    prior = ParticleState(sv, log_weight=np.full(n, -np.log(n)), timestamp=start)
    batches = measurement_batches(sc, sim.measurements, sim.observer)
    dv = sim.observer.velocity_increments
    dt_s = sc.time.dt
    t0 = time.perf_counter()
    for k in range(sc.n_steps):
        ts = start + timedelta(seconds=(k + 1) * dt_s)
        pred = predictor.predict(prior, timestamp=ts)
        shift = np.array([dt_s * dv[k, 0], dv[k, 0], dt_s * dv[k, 1], dv[k, 1]])[:, None]
        pred.state_vector = StateVectors(pred.state_vector - shift)
        ms: list[Measurement] = batches.get(k + 1, [])
        if ms:
            z = np.pi / 2 - ms[0].value  # atan2(Δy, Δx) = π/2 − atan2(Δx, Δy)
            det = Detection(np.array([[z]]), timestamp=ts, measurement_model=meas_model)
            from stonesoup.types.hypothesis import SingleHypothesis

            prior = updater.update(SingleHypothesis(pred, det))
        else:
            prior = pred
    dt = time.perf_counter() - t0
    m = np.asarray(prior.mean).ravel()
    err = float(np.hypot(m[0] - sim.relative[-1, 0], m[2] - sim.relative[-1, 1]))
    return dt, err


def main() -> int:
    sc = load_problem("ristic-bot-moderate")
    sim = simulate(sc, np.random.default_rng(1))
    K = sc.n_steps
    print(f"ristic-bot-moderate: {K} steps; particle-steps/s (final position error [m])")
    print(f"{'N':>8} {'tmaplan':>22} {'Stone Soup':>22} {'ratio':>7}")
    for n in SIZES:
        X0 = relative_prior_samples(sc, n, np.random.default_rng(2))
        t_tm, e_tm = run_tmaplan(sc, sim, X0, np.random.default_rng(3))
        rate_tm = n * K / t_tm
        ss = run_stonesoup(sc, sim, X0, np.random.default_rng(3))
        if ss is None:
            print(f"{n:>8} {rate_tm:>12.3g} ({e_tm:6.0f}) {'-':>22} {'-':>7}")
            continue
        rate_ss = n * K / ss[0]
        print(f"{n:>8} {rate_tm:>12.3g} ({e_tm:6.0f}) {rate_ss:>12.3g} ({ss[1]:6.0f}) "
              f"{rate_tm / rate_ss:>7.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
