"""One closed-loop run: a policy steers the own ship and pings on the particle filter's belief.

The filter starts from the prior and assimilates the measurements of step 0, if any. At each
step k the controller then sees a :class:`tmaplan.policies.BeliefView` (never the truth)
and returns a turn rate over (t_k, t_{k+1}] and whether to ping at k + 1. The own ship moves on
the exact arc, the sensors measure at k + 1 (:func:`tmaplan.simulate.measure_step`), the filter
predicts with the observer's velocity increment and updates (:func:`tmaplan.estimators.filter
.drive`, the loop every estimator run uses). The run's randomness comes from three generators
(truth, measurement noise, filter), so that different policies in the same run see the *same
truth and the same noise* (common random numbers, :class:`tmaplan.simulate.CommonNoise`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from tmaplan.errors import ArgumentError, finite_real
from tmaplan.estimators.filter import drive
from tmaplan.estimators.particle_filter import PFConfig
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.evaluation.metrics import RunMetrics, run_metrics
from tmaplan.evaluation.seeding import RunStreams, run_streams
from tmaplan.geometry import course_speed, wrap_angle
from tmaplan.models.observer import ObserverTrack, arc_displacement
from tmaplan.models.target import initial_velocity
from tmaplan.policies import BeliefView, Policy
from tmaplan.scenario import Scenario
from tmaplan.simulate import (
    Measurement,
    StepSensors,
    draw_common_noise,
    draw_truth,
    measure_step,
)

__all__ = ["ClosedLoopRun", "OwnShipFlight", "fly", "paired_run", "run_closed_loop"]


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
        Re-planning log of a receding controller, one entry per re-plan (``t`` [s],
        ``status``, ``success``, ``fell_back``, ``infeasible``, ``seconds`` [s], ...:
        :class:`tmaplan.policies.Receding`), counted by
        :class:`tmaplan.evaluation.replans.ReplanCounts`.
    seconds : float
        Wall time of the run.
    recoveries : int
        Track recoveries by the consistency monitor (:mod:`tmaplan.estimators.consistency`).
    alarms : tuple of dict
        The monitor's log (step, test, statistic, threshold, recovered).
    alarm_pings : ndarray, shape (n,)
        Steps of the pings added in answer to alarms (:class:`tmaplan.policies.AlarmResponse`),
        a subset of ``ping_steps``.
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
    recoveries: int = 0
    alarms: tuple[dict[str, Any], ...] = ()
    alarm_pings: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, int))

    def metrics(self, accuracy: float = 0.1) -> RunMetrics:
        """The run's error metrics (:func:`tmaplan.evaluation.metrics.run_metrics`) with
        ``accuracy`` the relative range error that counts as localised."""
        return run_metrics(self.times, self.truth, self.estimate, self.observer.mean_velocity,
                           accuracy=accuracy, n_pings=len(self.ping_steps))


def read_only(a: np.ndarray) -> np.ndarray:
    """A read-only view of the filter's array (a controller must not change the filter)."""
    v = np.asarray(a).view()
    v.flags.writeable = False
    return v


class OwnShipFlight:
    """The own ship of a closed loop, flown one step at a time at its initial speed on the
    exact arcs of the turn rates a controller commands (:func:`run_closed_loop`,
    :func:`tmaplan.evaluation.contacts_loop.run_contacts_loop`).

    Parameters
    ----------
    scenario : Scenario
        Its observer gives the start (position, initial velocity) and the turn-rate limit;
        its time grid the ``K`` steps of ``dt``.

    Attributes
    ----------
    heading : float
        Current heading [rad], not wrapped.
    speed : float
        Constant speed [m/s].
    position : ndarray, shape (2,)
        Current position [m].
    v0 : ndarray, shape (2,)
        Initial velocity [m/s].
    positions, velocity, mean_velocity : ndarray, shape (K + 1, 2)
        Position [m], instantaneous velocity [m/s] and mean velocity over the step ending at
        each time [m/s] (row 0: the initial velocity), filled up to the last step flown.
    headings : ndarray, shape (K + 1,)
        Heading at each time [rad], not wrapped.
    turn_rate : ndarray, shape (K,)
        Applied (clipped) turn rate of each step flown [rad/s].
    """

    def __init__(self, scenario: Scenario) -> None:
        K = scenario.n_steps
        self.dt = scenario.time.dt
        self.u_max = scenario.observer.turn_rate_max
        self.v0 = initial_velocity(scenario.observer)
        self.heading, self.speed = (float(x) for x in course_speed(self.v0))
        self.position = np.asarray(scenario.observer.position, float).copy()
        self.positions = np.empty((K + 1, 2))
        self.velocity = np.empty((K + 1, 2))
        self.mean_velocity = np.empty((K + 1, 2))
        self.headings = np.empty(K + 1)
        self.positions[0], self.velocity[0], self.mean_velocity[0], self.headings[0] = (
            self.position, self.v0, self.v0, self.heading)
        self.turn_rate = np.zeros(K)

    def advance(self, k: int, turn_rate: float) -> None:
        """Fly step ``k`` (from t_k to t_{k+1}) at ``turn_rate`` clipped to the limit.

        Parameters
        ----------
        k : int
            Step index, 0 <= k < K, flown in order.
        turn_rate : float
            Commanded turn rate [rad/s].
        """
        u = float(turn_rate)
        if self.u_max is not None:  # as np.clip (NaN stays NaN)
            u = float(min(max(u, -self.u_max), self.u_max))
        self.turn_rate[k] = u
        dt = self.dt
        disp = arc_displacement(self.heading, u, self.speed, dt)
        self.position = self.position + disp
        self.heading = h = self.heading + u * dt
        self.mean_velocity[k + 1] = disp / dt
        self.velocity[k + 1] = (self.speed * np.sin(h), self.speed * np.cos(h))
        self.positions[k + 1], self.headings[k + 1] = self.position, h

    def state(self, k: int) -> np.ndarray:
        """The own ship's state ``[x, y, v_x, v_y]`` [m, m/s] at step ``k`` (flown), shape (4,)."""
        return np.concatenate([self.positions[k], self.velocity[k]])

    def track(self, times: np.ndarray) -> ObserverTrack:
        """The track flown, at ``times`` [s] (shape (K + 1,), all steps flown)."""
        return ObserverTrack(times=times, position=self.positions, velocity=self.velocity,
                             mean_velocity=self.mean_velocity,
                             heading=wrap_angle(self.headings),
                             speed=np.full(self.headings.size, self.speed))


def run_closed_loop(scenario: Scenario, policy: Policy, target: np.ndarray, *,
                    noise_rng: np.random.Generator, filter_rng: np.random.Generator,
                    n_particles: int = 5000, filter_q: float | None = None,
                    options: FilterOptions | None = None) -> ClosedLoopRun:
    """Simulate one run of ``policy`` against the true target track ``target``.

    Parameters
    ----------
    scenario : Scenario
        Needs a bearing sensor, a prior and (for manoeuvres) ``observer.turn_rate_max``; pings
        use the first active range sensor's σ.
    policy : Policy
    target : ndarray, shape (K + 1, 4)
        True absolute target track, finite (see :func:`tmaplan.simulate.draw_truth`).
    noise_rng, filter_rng : numpy.random.Generator
        Measurement noise and particle-filter randomness.
    n_particles : int
    filter_q : float, optional
        Filter process-noise intensity [m²/s³], >= 0 (default: the scenario's); either is
        floored at 1e-8.
    options : FilterOptions, optional
        Robust likelihoods, consistency monitoring and the answer to its alarms (default:
        :meth:`FilterOptions.monitored`, the monitor on, no alarm pings).

    Returns
    -------
    ClosedLoopRun

    Raises
    ------
    ArgumentError
        A generator that is not a ``numpy.random.Generator``, a target track of the wrong
        shape or with non-finite values, a negative or non-finite ``filter_q``.
    """
    t_start = time.perf_counter()
    K, dt, times = scenario.n_steps, scenario.time.dt, scenario.times
    for field, g in (("noise_rng", noise_rng), ("filter_rng", filter_rng)):
        if not isinstance(g, np.random.Generator):
            raise ArgumentError(field, "a numpy.random.Generator", type(g).__name__)
    target = np.asarray(target, float)
    if target.shape != (K + 1, 4) or not np.isfinite(target).all():
        raise ArgumentError("target", f"a finite absolute target track of shape ({K + 1}, 4)",
                            f"shape {target.shape}" if target.shape != (K + 1, 4)
                            else "non-finite values")
    if filter_q is not None:
        finite_real("filter_q", filter_q, "a finite intensity >= 0 [m²/s³]", lower=0.0)
    noise = draw_common_noise(scenario, noise_rng)
    own = OwnShipFlight(scenario)
    sensors = StepSensors(scenario)

    q = scenario.target.q if filter_q is None else filter_q
    opts = FilterOptions.monitored() if options is None else options
    pf = opts.build(PFConfig(n_particles=n_particles, dt=dt, q=max(q, 1e-8)))
    ctrl = policy.controller(scenario)
    if opts.monitor is not None and opts.alarm_response is not None:
        ctrl = opts.alarm_response.wrap(ctrl, scenario)
    pings: list[int] = []
    active = any(getattr(s, "active", False) for s in scenario.sensors_of("range"))

    def step(k: int, state: Any) -> tuple[np.ndarray, list[Measurement]]:
        belief = BeliefView(step=k, t=float(times[k]), heading=own.heading,
                            position=own.position.copy(),
                            particles=read_only(state.particles),
                            weights=read_only(state.weights),
                            pings_used=len(pings), alarms=len(getattr(state, "log", ())))
        act = ctrl.act(belief, float(times[k]))
        own.advance(k, act.turn_rate)
        meas = measure_step(scenario, k + 1, target[k + 1] - own.state(k + 1), noise,
                            ping=bool(act.ping), sensors=sensors)
        # a ping counts when transmitted, echo or not (a missed echo, tmaplan.models.faults)
        pings.extend([k + 1] if act.ping and active else [])
        return own.mean_velocity[k + 1] - own.mean_velocity[k], meas

    state0 = pf.init(scenario, filter_rng)
    # the sensors that measure at step 0 (e.g. a first bearing at t0) are assimilated before
    # the controller's first action; with none there, nothing is drawn or changed
    if meas0 := measure_step(scenario, 0, target[0] - own.state(0), noise, sensors=sensors):
        state0 = pf.update(state0, meas0, filter_rng)
    fr = drive(pf, state0, K, step, filter_rng)
    obs = own.track(times)
    return ClosedLoopRun(times=times, truth=target - obs.state, target=target, observer=obs,
                         estimate=fr.estimates, covariance=fr.covariances,
                         ping_steps=np.asarray(pings, dtype=int), turn_rate=own.turn_rate,
                         replans=tuple(getattr(ctrl, "log", [])),
                         seconds=time.perf_counter() - t_start,
                         recoveries=int(getattr(fr.state, "recoveries", 0)),
                         alarms=tuple(getattr(fr.state, "log", ())),
                         alarm_pings=np.asarray(getattr(ctrl, "alarm_pings", []), dtype=int))


def fly(scenario: Scenario, policy: Policy, target: np.ndarray, streams: RunStreams, *,
        n_particles: int = 5000, options: FilterOptions | None = None) -> ClosedLoopRun:
    """``policy`` against ``target`` with a run's noise and filter streams
    (:func:`tmaplan.evaluation.seeding.run_streams`), each a new generator, so that every policy
    flown on the run sees the same noise and filter draws (common random numbers).

    Parameters
    ----------
    scenario : Scenario
    policy : Policy
    target : ndarray, shape (K + 1, 4)
        True absolute target track [m, m/s].
    streams : RunStreams
    n_particles : int
    options : FilterOptions, optional
        As for :func:`run_closed_loop`.

    Returns
    -------
    ClosedLoopRun
    """
    return run_closed_loop(scenario, policy, target,
                           noise_rng=np.random.default_rng(streams.noise),
                           filter_rng=np.random.default_rng(streams.filter),
                           n_particles=n_particles, options=options)


def paired_run(scenario: Scenario, policies: Mapping[str, Policy], *, seed: int, run: int,
               n_particles: int = 5000, options: FilterOptions | None = None,
               from_prior: bool = True) -> Iterator[tuple[str, ClosedLoopRun]]:
    """Monte Carlo run ``run`` of root ``seed``: its truth, then every policy flown on it.

    The one per-run loop of the closed-loop Monte Carlo (the campaigns' runs,
    :func:`tmaplan.evaluation.campaigns.run_one`, and the benchmarks): the truth from the run's
    truth stream (:func:`tmaplan.simulate.draw_truth`), each policy by :func:`fly`, with BLAS
    on one thread while the run lasts (also while the caller handles a yielded result), so
    that a run's result depends only on ``(scenario, policies, seed, run)``.

    Parameters
    ----------
    scenario : Scenario
    policies : mapping
        Name -> policy, flown in this order.
    seed : int
        Root seed (:mod:`tmaplan.evaluation.seeding`).
    run : int
        Run index.
    n_particles : int
    options : FilterOptions, optional
    from_prior : bool
        Draw the target's initial state from the prior (else the scenario's).

    Yields
    ------
    name : str
    result : ClosedLoopRun
    """
    streams = run_streams(seed, run)
    with threadpool_limits(limits=1):
        target = draw_truth(scenario, np.random.default_rng(streams.truth),
                            from_prior=from_prior)
        for name, pol in policies.items():
            yield name, fly(scenario, pol, target, streams, n_particles=n_particles,
                            options=options)
