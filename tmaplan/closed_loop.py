"""One closed-loop run: a policy steers the own ship and pings on the particle filter's belief.

At each step k the controller sees a :class:`tmaplan.policies.BeliefView` (never the truth)
and returns a turn rate over (t_k, t_{k+1}] and whether to ping at k + 1. The own ship moves on
the exact arc, the filter predicts with the observer's velocity increment, the sensors measure
at k + 1 and the filter updates. The run's randomness comes from three generators (truth,
measurement noise, filter), so that different policies in the same run see the *same truth and
the same noise* (common random numbers): noise is drawn once per step and sensor, whether or not
the sensor measures, and a ping's noise does not depend on when other pings happened.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from tmaplan.estimators.particle_filter import Measurement, ParticleFilter, PFConfig
from tmaplan.geometry import bearing_of, course_speed, range_of, wrap_angle
from tmaplan.models.observer import ObserverTrack, arc_displacement
from tmaplan.models.target import initial_velocity, ncv_matrices
from tmaplan.policies import BeliefView
from tmaplan.scenario import BearingSensor, RangeSensor, Scenario, measurement_steps

__all__ = ["ClosedLoopRun", "draw_truth", "run_closed_loop", "tempered_range_update"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class ClosedLoopRun:
    """Result of one closed-loop run.

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    truth : ndarray, shape (K + 1, 4)
        True relative state [m, m/s] (observer mean velocity convention).
    target : ndarray, shape (K + 1, 4)
        True absolute target state.
    observer : ObserverTrack
    estimate : ndarray, shape (K + 1, 4)
        Posterior mean of the relative state.
    covariance : ndarray, shape (K + 1, 4, 4)
        Posterior covariance.
    ping_steps : ndarray, shape (n_pings,)
        Steps at which the own ship pinged.
    turn_rate : ndarray, shape (K,)
        Applied turn rate per step [rad/s].
    replans : tuple of dict
        Re-planning log (time, status, seconds) of a receding controller.
    seconds : float
        Wall time of the run.
    """

    times: np.ndarray
    truth: np.ndarray
    target: np.ndarray
    observer: ObserverTrack
    estimate: np.ndarray
    covariance: np.ndarray
    ping_steps: np.ndarray
    turn_rate: np.ndarray
    replans: tuple[dict[str, Any], ...]
    seconds: float


def tempered_range_update(pf: ParticleFilter, state: Any, z: float, sigma: float,
                          rng: np.random.Generator, *, shrink: float = 2.0) -> Any:
    """Assimilate a very informative range (an active ping) by progressive correction.

    A 50 m ping against a particle cloud spread over kilometres would leave one particle
    standing. The likelihood is split into stages ``L = Π L^{α_i}`` with Gaussian stage
    precisions ``α_i/σ²`` growing geometrically (stage std shrinking by ``shrink``) from about
    half the cloud's RMS range offset from the measurement, with resampling and regularisation
    between stages (Oudjane & Musso's progressive correction). The stage precisions sum to
    ``1/σ²``, so the posterior is unchanged in expectation.

    Parameters
    ----------
    pf : ParticleFilter
    state : PFState
    z : float
        Measured range [m].
    sigma : float
        Range noise std [m].
    rng : numpy.random.Generator
    shrink : float
        Ratio of successive stage standard deviations.
    """
    r = np.hypot(state.particles[:, 0], state.particles[:, 1])
    w = state.weights
    # spread of the cloud about the measurement (a confident but wrong cloud counts as wide)
    spread = float(np.sqrt(max(w @ (r - z) ** 2, 0.0)))
    total = 1.0 / sigma**2
    p = 1.0 / max(spread / 2.0, sigma) ** 2
    precisions = []
    while sum(precisions) + p < total:
        precisions.append(p)
        p *= shrink**2
    precisions.append(total - sum(precisions))
    for prec in precisions:
        state = pf.update(state, [Measurement(kind="range", value=z,
                                              sigma=float(1.0 / np.sqrt(prec)))], rng)
    return state


def draw_truth(scenario: Scenario, rng: np.random.Generator, *, from_prior: bool = True
               ) -> np.ndarray:
    """True absolute target track, shape (K + 1, 4).

    With ``from_prior`` the initial state is drawn from the scenario's prior (one draw), then
    propagated with the NCV model of intensity ``scenario.target.q``; otherwise the scenario's
    own initial state is used.
    """
    from tmaplan.models.prior import sample_prior, true_initial_state

    x0 = (sample_prior(scenario, 1, rng)[0] if from_prior and scenario.prior is not None
          else true_initial_state(scenario))
    K, dt = scenario.n_steps, scenario.time.dt
    F, Q = ncv_matrices(dt, scenario.target.q)
    L = np.linalg.cholesky(Q + 1e-30 * np.eye(4)) if scenario.target.q > 0 else np.zeros((4, 4))
    w = rng.standard_normal((K, 4)) @ L.T
    x = np.empty((K + 1, 4))
    x[0] = x0
    for k in range(K):  # recursion over time
        x[k + 1] = F @ x[k] + w[k]
    return x


def run_closed_loop(scenario: Scenario, policy: Any, target: np.ndarray, *,
                    noise_rng: np.random.Generator, filter_rng: np.random.Generator,
                    n_particles: int = 5000, filter_q: float | None = None) -> ClosedLoopRun:
    """Simulate one run of ``policy`` against the true target track ``target``.

    Parameters
    ----------
    scenario : Scenario
        Needs a bearing sensor, a prior and (for manoeuvres) ``observer.turn_rate_max``; pings
        use the first active range sensor's σ.
    policy : policy with ``controller(scenario)``
    target : ndarray, shape (K + 1, 4)
        True absolute target track (see :func:`draw_truth`).
    noise_rng, filter_rng : numpy.random.Generator
        Measurement noise and particle-filter randomness.
    n_particles : int
    filter_q : float, optional
        Filter process-noise intensity [m²/s³] (default: the scenario's, floored at 1e-8).

    Returns
    -------
    ClosedLoopRun
    """
    t_start = time.perf_counter()
    K, dt, times = scenario.n_steps, scenario.time.dt, scenario.times
    bsens = [s for s in scenario.sensors if isinstance(s, BearingSensor)]
    rsens = [s for s in scenario.sensors if isinstance(s, RangeSensor) and s.active]
    passive_r = [s for s in scenario.sensors if isinstance(s, RangeSensor) and not s.active]
    bsteps = [set(measurement_steps(s, scenario.time).tolist()) for s in bsens]
    psteps = [set(measurement_steps(s, scenario.time).tolist()) for s in passive_r]
    ping_sigma = rsens[0].sigma if rsens else None
    # common random numbers: one standard normal per step and sensor, plus one per ping slot
    e_bearing = noise_rng.standard_normal((K + 1, max(len(bsens), 1)))
    e_range = noise_rng.standard_normal((K + 1, max(len(passive_r), 1)))
    e_ping = noise_rng.standard_normal(K + 1)

    v0 = initial_velocity(scenario.observer)
    heading, speed = (float(x) for x in course_speed(v0))
    pos = np.asarray(scenario.observer.position, float).copy()
    u_max = scenario.observer.turn_rate_max
    positions = np.empty((K + 1, 2))
    vel_inst = np.empty((K + 1, 2))
    vbar = np.empty((K + 1, 2))
    headings = np.empty(K + 1)
    positions[0], vel_inst[0], vbar[0], headings[0] = pos, v0, v0, heading

    q = scenario.target.q if filter_q is None else filter_q
    pf = ParticleFilter(PFConfig(n_particles=n_particles, dt=dt, q=max(q, 1e-8)))
    state = pf.from_prior(scenario, filter_rng)
    ctrl = policy.controller(scenario)
    est = np.empty((K + 1, 4))
    cov = np.empty((K + 1, 4, 4))
    est[0], cov[0] = state.mean, state.cov
    pings: list[int] = []
    rates = np.zeros(K)
    for k in range(K):
        belief = BeliefView(step=k, t=float(times[k]), heading=heading, position=pos.copy(),
                            particles=state.particles, weights=state.weights,
                            pings_used=len(pings))
        act = ctrl.act(belief, float(times[k]))
        u = float(act.turn_rate)
        if u_max is not None:
            u = float(np.clip(u, -u_max, u_max))
        rates[k] = u
        disp = arc_displacement(np.array(heading), np.array(u), np.array(speed), dt)
        pos = pos + disp
        heading = heading + u * dt
        vbar[k + 1] = disp / dt
        vel_inst[k + 1] = speed * np.array([np.sin(heading), np.cos(heading)])
        positions[k + 1], headings[k + 1] = pos, heading
        state = pf.predict(state, vbar[k + 1] - vbar[k], filter_rng)
        rel = target[k + 1] - np.concatenate([pos, vel_inst[k + 1]])
        meas = []
        for j, s in enumerate(bsens):
            if k + 1 in bsteps[j]:
                b = bearing_of(rel, s.ambiguity) + s.sigma * e_bearing[k + 1, j]
                meas.append(Measurement(kind="bearing", value=float(b), sigma=s.sigma,
                                        ambiguity=s.ambiguity))
        for j, s in enumerate(passive_r):
            if k + 1 in psteps[j]:
                meas.append(Measurement(kind="range", value=float(range_of(rel) + s.sigma
                                                                  * e_range[k + 1, j]),
                                        sigma=s.sigma))
        if meas:
            state = pf.update(state, meas, filter_rng)
        if act.ping and ping_sigma is not None:
            pings.append(k + 1)
            z = float(range_of(rel) + ping_sigma * e_ping[k + 1])
            state = tempered_range_update(pf, state, z, ping_sigma, filter_rng)
        est[k + 1], cov[k + 1] = state.mean, state.cov
    obs = ObserverTrack(times=times, position=positions, velocity=vel_inst, mean_velocity=vbar,
                        heading=wrap_angle(headings), speed=np.full(K + 1, speed))
    truth = target - obs.state
    return ClosedLoopRun(times=times, truth=truth, target=target, observer=obs, estimate=est,
                         covariance=cov, ping_steps=np.asarray(pings, dtype=int),
                         turn_rate=rates, replans=tuple(getattr(ctrl, "log", [])),
                         seconds=time.perf_counter() - t_start)
