"""Simulation: truth, observer track and noisy measurements for a scenario.

The one place where measurements are generated: :func:`measure` for a whole run (open loop),
:func:`measure_step` for one step of a closed loop (the observer track is not known in
advance), both through :func:`reading`. The filters consume :class:`Measurement` records
(:func:`measurement_batches` groups a run's measurements by step).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from tmaplan.display import short_repr
from tmaplan.errors import ScenarioError
from tmaplan.geometry import bearing_of, range_of, wrap_angle, wrap_half_angle
from tmaplan.models.faults import apply_manoeuvres, corrupt_bearings, dropped
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.prior import sample_prior, true_initial_state
from tmaplan.models.sensors import doppler_frequency
from tmaplan.models.target import ncv_matrices, target_track
from tmaplan.scenario import (
    BearingSensor,
    FrequencySensor,
    RangeSensor,
    Scenario,
    measurement_steps,
)

__all__ = [
    "CommonNoise",
    "ContactsSimulation",
    "Measurement",
    "MeasurementSet",
    "Simulation",
    "StepSensors",
    "check_truth_source",
    "draw_common_noise",
    "draw_truth",
    "measure",
    "measure_step",
    "measurement_batches",
    "ping_sensors",
    "reading",
    "simulate",
    "simulate_contacts",
]


@dataclasses.dataclass(frozen=True, kw_only=True)
class Measurement:
    """One scalar (or multi-line) measurement at the current step, as a filter consumes it.

    Attributes
    ----------
    kind : {"bearing", "range", "frequency"}
    value : float or ndarray, shape (P,)
        Bearing [rad] (from North, clockwise), range [m] or frequencies [Hz] (one per line).
    sigma : float or ndarray, shape (P,)
        Noise std in the same unit.
    ambiguity : {"none", "pi"}
        Bearings only: known modulo π.
    c : float
        Sound speed [m/s] (frequency only).
    velocity_offset : ndarray, shape (2,)
        Frequency only: observer instantaneous minus mean velocity [m/s] at this step, so that
        the Doppler uses the instantaneous relative velocity ``X[2:] − offset``.
    ping : bool
        Range only: an active ping, so informative against the belief that a particle filter
        assimilates it by progressive correction
        (:func:`tmaplan.estimators.particle_filter.update`).
    """

    kind: Literal["bearing", "range", "frequency"]
    value: float | np.ndarray
    sigma: float | np.ndarray
    ambiguity: Literal["none", "pi"] = "none"
    c: float = 1500.0
    velocity_offset: np.ndarray | None = None
    ping: bool = False


@dataclasses.dataclass(frozen=True, kw_only=True)
class MeasurementSet:
    """Measurements of one sensor.

    Attributes
    ----------
    sensor : int
        Index of the sensor in ``scenario.sensors``.
    kind : str
        "bearing", "range" or "frequency".
    steps : ndarray, shape (n,)
        Grid steps of the measurements.
    times : ndarray, shape (n,)
        [s].
    values : ndarray, shape (n,) or (n, P)
        Measured values: true bearing from North [rad], range [m] or frequencies [Hz].
    truth : ndarray, same shape as ``values``
        Noise-free values.
    relative : ndarray or None, shape (n,)
        Bearings relative to own heading [rad] (bearing sensors only), in (−π, π].
    sigma : ndarray, shape () or (P,)
        Noise std per component.
    contact : str
        The contact measured (association known; ``"contact"`` for a one-contact scenario).
    """

    sensor: int
    kind: str
    steps: np.ndarray
    times: np.ndarray
    values: np.ndarray
    truth: np.ndarray
    relative: np.ndarray | None
    sigma: np.ndarray
    contact: str = "contact"


@dataclasses.dataclass(frozen=True, kw_only=True)
class Simulation:
    """One simulated run.

    Attributes
    ----------
    scenario : Scenario
    times : ndarray, shape (K + 1,)
        [s].
    target : ndarray, shape (K + 1, 4)
        Absolute target state [x, y, v_x, v_y].
    observer : ObserverTrack
    relative : ndarray, shape (K + 1, 4)
        ``target − observer.state`` (observer mean velocity, docs/conventions.md).
    measurements : tuple of MeasurementSet
        One per sensor, in scenario order.
    """

    __repr__ = short_repr

    scenario: Scenario
    times: np.ndarray
    target: np.ndarray
    observer: ObserverTrack
    relative: np.ndarray
    measurements: tuple[MeasurementSet, ...]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (docs/cli.md: ``times, target, observer, measurements``), SI units."""
        return {
            "problem": self.scenario.name,
            "times": self.times.tolist(),
            "target": self.target.tolist(),
            "observer": self.observer.state.tolist(),
            "observer_heading": self.observer.heading.tolist(),
            "relative": self.relative.tolist(),
            "measurements": [
                {
                    "sensor": m.sensor,
                    "kind": m.kind,
                    "steps": m.steps.tolist(),
                    "times": m.times.tolist(),
                    "values": m.values.tolist(),
                    "truth": m.truth.tolist(),
                    **({"relative": m.relative.tolist()} if m.relative is not None else {}),
                    "sigma": np.asarray(m.sigma).tolist(),
                }
                for m in self.measurements
            ],
        }


def reading(sensor: Any, X: np.ndarray, z: np.ndarray | None
            ) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free and noisy values of one sensor (the one measurement model of the package).

    Parameters
    ----------
    sensor : BearingSensor, RangeSensor or FrequencySensor
    X : ndarray, shape (n, 4)
        Relative states with the observer's *instantaneous* velocity [m, m/s].
    z : ndarray, shape (n,) or (n, P), or None
        Standard normal draws (None: noise-free); the noise is ``σ·z``.

    Returns
    -------
    truth, values : ndarray, shape (n,) or (n, P)
        Bearings [rad] wrapped to (−π, π] ((−π/2, π/2] for ``ambiguity = "pi"``), ranges [m]
        or frequencies [Hz].
    """
    if isinstance(sensor, BearingSensor):
        wrap = wrap_half_angle if sensor.ambiguity == "pi" else wrap_angle
        truth = wrap(bearing_of(X))
        values = truth if z is None else wrap(truth + sensor.sigma * z)
    elif isinstance(sensor, RangeSensor):
        truth = range_of(X)
        values = truth if z is None else truth + sensor.sigma * z
    elif isinstance(sensor, FrequencySensor):
        truth = doppler_frequency(X, np.asarray(sensor.f0), sensor.c)
        values = truth if z is None else truth + z * np.asarray(sensor.sigma)
    else:  # pragma: no cover - the scenario schema admits no other kind
        raise TypeError(f"unknown sensor {sensor!r}")
    return truth, np.asarray(values, float)


def measure(scenario: Scenario, target: np.ndarray, obs: ObserverTrack,
            rng: np.random.Generator | None) -> tuple[MeasurementSet, ...]:
    """Noisy measurements of every sensor for a given truth and observer track.

    Parameters
    ----------
    scenario : Scenario
    target : ndarray, shape (K + 1, 4)
        Absolute target states.
    obs : ObserverTrack
    rng : numpy.random.Generator or None
        ``None`` returns noise-free values.

    Returns
    -------
    tuple of MeasurementSet
    """
    times = scenario.times
    rel_inst = target - np.hstack([obs.position, obs.velocity])
    out = []
    for i, sensor in enumerate(scenario.sensors):
        steps = measurement_steps(sensor, scenario.time)
        shape = (steps.size, len(sensor.f0)) if isinstance(sensor, FrequencySensor) \
            else (steps.size,)
        z = rng.standard_normal(shape) if rng is not None else None
        truth, values = reading(sensor, rel_inst[steps], z)
        rel = None
        if isinstance(sensor, BearingSensor):
            noisy = truth if z is None else wrap_angle(truth + sensor.sigma * z)
            rel = wrap_angle(noisy - obs.heading[steps])
        out.append(MeasurementSet(sensor=i, kind=sensor.kind, steps=steps, times=times[steps],
                                  values=values, truth=truth, relative=rel,
                                  sigma=np.asarray(sensor.sigma)))
    if scenario.faults is not None:
        out = [_with_faults(scenario, ms, obs, rng) for ms in out]
    return tuple(_in_reach(scenario, ms) for ms in out)


def _in_reach(scenario: Scenario, ms: MeasurementSet) -> MeasurementSet:
    """``ms`` without the ranges beyond its range sensor's ``max_range`` (true range; the draws
    are made for every step, so the reach changes no other value)."""
    reach = getattr(scenario.sensors[ms.sensor], "max_range", None)
    if reach is None:
        return ms
    keep = ms.truth <= reach
    return dataclasses.replace(ms, steps=ms.steps[keep], times=ms.times[keep],
                               values=ms.values[keep], truth=ms.truth[keep])


def _with_faults(scenario: Scenario, ms: MeasurementSet, obs: ObserverTrack,
                 rng: np.random.Generator | None) -> MeasurementSet:
    """``ms`` with the scenario's sensor faults (bias, wild bearings, dropouts, missed pings;
    :mod:`tmaplan.models.faults`). Uniform draws come after all the noise, sensor by sensor
    (none with ``rng`` None: no wild bearing, no missed ping)."""
    faults, sensor = scenario.faults, scenario.sensors[ms.sensor]
    n = ms.steps.size
    values, rel = ms.values, ms.relative
    keep = ~dropped(faults, ms.times, ms.kind)
    if isinstance(sensor, BearingSensor):
        u = rng.random((n, 2)) if rng is not None else np.ones((n, 2))
        values = corrupt_bearings(faults, values, ms.truth, u, ambiguity=sensor.ambiguity)
        rel = wrap_angle(corrupt_bearings(faults, wrap_angle(ms.relative + obs.heading[ms.steps]),
                                          ms.truth, u) - obs.heading[ms.steps])
    elif isinstance(sensor, RangeSensor) and sensor.active and faults is not None:
        u = rng.random(n) if rng is not None else np.ones(n)
        keep &= u >= faults.missed_ping_probability
    return dataclasses.replace(ms, steps=ms.steps[keep], times=ms.times[keep],
                               values=values[keep], truth=ms.truth[keep],
                               relative=None if rel is None else rel[keep])


def simulate(scenario: Scenario, rng: np.random.Generator | None, *,
             observer: ObserverTrack | None = None,
             target: np.ndarray | None = None) -> Simulation:
    """Simulate truth and measurements.

    Random draws happen in a fixed order (target process noise, then each sensor in scenario
    order), so a given ``rng`` state gives identical results on every machine.

    Parameters
    ----------
    scenario : Scenario
    rng : numpy.random.Generator or None
        ``None``: noise-free truth and measurements.
    observer : ObserverTrack, optional
        Override the scenario's scripted observer (closed loop).
    target : ndarray, shape (K + 1, 4), optional
        Override the true target track (e.g. a truth drawn from the prior), taken as is;
        otherwise the scenario's track with its faults' ``target_manoeuvres``. The sensor
        faults of ``scenario.faults`` are applied to the measurements either way.

    Returns
    -------
    Simulation
    """
    obs = observer if observer is not None else observer_track(scenario.observer, scenario.time)
    tgt = target if target is not None else apply_manoeuvres(
        scenario.faults, target_track(scenario.target, scenario.time, rng), scenario.times)
    meas = measure(scenario, tgt, obs, rng)
    return Simulation(scenario=scenario, times=scenario.times, target=tgt, observer=obs,
                      relative=tgt - obs.state, measurements=meas)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsSimulation:
    """One simulated run of a scenario with one or several contacts: one own-ship track, one
    truth per contact, measurements tagged by contact (association known).

    Attributes
    ----------
    scenario : Scenario
    times : ndarray, shape (K + 1,)
        [s].
    observer : ObserverTrack
    runs : dict of str to Simulation
        Per contact name, in file order: its run on its view
        (:meth:`tmaplan.scenario.Scenario.contact_view`) with this own-ship track; each
        :class:`MeasurementSet` carries the contact's name.
    """

    __repr__ = short_repr

    scenario: Scenario
    times: np.ndarray
    observer: ObserverTrack
    runs: dict[str, Simulation]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict, SI units: the own ship's ``times, observer, observer_heading`` and
        ``contacts: {name: {target, relative, measurements}}`` (each measurement with its
        ``contact``); a one-contact scenario gives :meth:`Simulation.to_json`'s shape."""
        if len(self.runs) == 1:
            return next(iter(self.runs.values())).to_json()
        out: dict[str, Any] = {"problem": self.scenario.name}
        contacts: dict[str, Any] = {}
        for name, run in self.runs.items():
            one = run.to_json()
            for key in ("problem", "times", "observer", "observer_heading"):
                out.setdefault(key, one.pop(key))
            contacts[name] = {**one, "measurements": [{**m, "contact": name}
                                                      for m in one["measurements"]]}
        out["contacts"] = contacts
        return out


def simulate_contacts(scenario: Scenario, rng: np.random.Generator | None, *,
                      observer: ObserverTrack | None = None) -> ContactsSimulation:
    """Simulate the truth of every contact and its measurements.

    Bearing sensors measure every contact at their steps; a range reading (a ping) returns the
    range of every contact whose true range is within the sensor's ``max_range``. The draws
    come in a fixed order: each contact's target process noise (file order), then each
    contact's measurements as :func:`simulate` draws them; for one contact exactly
    :func:`simulate`'s draws (``runs["contact"]`` is bit for bit ``simulate(scenario, rng)``).

    Parameters
    ----------
    scenario : Scenario
    rng : numpy.random.Generator or None
        ``None``: noise-free truths and measurements.
    observer : ObserverTrack, optional
        Override the scenario's scripted observer (closed loop).

    Returns
    -------
    ContactsSimulation
    """
    obs = observer if observer is not None else observer_track(scenario.observer, scenario.time)
    views = scenario.contact_views()
    tracks = {name: apply_manoeuvres(scenario.faults, target_track(view.target, scenario.time,
                                                                   rng), scenario.times)
              for name, view in views.items()}
    runs = {}
    for name, view in views.items():
        run = simulate(view, rng, observer=obs, target=tracks[name])
        meas = tuple(dataclasses.replace(m, contact=name) for m in run.measurements)
        runs[name] = dataclasses.replace(run, measurements=meas)
    return ContactsSimulation(scenario=scenario, times=scenario.times, observer=obs, runs=runs)


def check_truth_source(scenario: Scenario, from_prior: bool) -> None:
    """Whether :func:`draw_truth` can draw this scenario's truths (``from_prior``: from its
    prior), else :class:`ScenarioError`: a constant-turn target's circle (centre, radius,
    phase, ω) is given, not an initial state a prior could replace. Callers that fly many runs
    check it before they plan (``tmaplan compare``, ``rank-costs``)."""
    model = scenario.target.model
    if from_prior and scenario.prior is not None and model == "constant-turn":
        raise ScenarioError("target.model", "'ncv' or 'multi-leg' to draw the truth from the "
                            "prior (a constant-turn circle is given, not drawn; the "
                            "scenario's truth: from_prior=False, compare --truth scenario)",
                            model, source=scenario.name)


def draw_truth(scenario: Scenario, rng: np.random.Generator, *, from_prior: bool = True
               ) -> np.ndarray:
    """True absolute target track of a closed-loop run, shape (K + 1, 4).

    With ``from_prior`` (and a prior) the initial state is drawn from the scenario's prior (one
    draw); otherwise it is the scenario's. Either way the scenario's target model moves it: an
    NCV target is propagated with the NCV model of intensity ``scenario.target.q``; a
    multi-leg target flies its legs (velocity changes at known times) from that initial state;
    a constant-turn target flies its circle (scenario truth only). The NCV noise of intensity
    ``q`` is added to a multi-leg or constant-turn track through the same dynamics. The
    faults' ``target_manoeuvres`` (unknown to the filter) are applied to the track.

    Raises
    ------
    ScenarioError
        ``from_prior`` with a prior and a constant-turn target: its circle (centre, radius,
        phase, ω) is given, not an initial state a prior could replace.
    """
    check_truth_source(scenario, from_prior)
    prior = from_prior and scenario.prior is not None
    model = scenario.target.model
    x0 = sample_prior(scenario, 1, rng)[0] if prior else true_initial_state(scenario)
    K, dt = scenario.n_steps, scenario.time.dt
    F, Q = ncv_matrices(dt, scenario.target.q)
    L = np.linalg.cholesky(Q + 1e-30 * np.eye(4)) if scenario.target.q > 0 else np.zeros((4, 4))
    w = rng.standard_normal((K, 4)) @ L.T
    x = np.empty((K + 1, 4))
    # ncv: x0 through the NCV dynamics; else the legs or circle plus the noise through them
    x[0] = x0 if model == "ncv" else 0.0
    for k in range(K):  # recursion over time
        x[k + 1] = F @ x[k] + w[k]
    if model != "ncv":
        target = scenario.target if not prior else dataclasses.replace(
            scenario.target, position=(float(x0[0]), float(x0[1])),
            velocity=(float(x0[2]), float(x0[3])), course=None, speed=None)
        x += target_track(target, scenario.time, None)
    return apply_manoeuvres(scenario.faults, x, scenario.times)


@dataclasses.dataclass(frozen=True, kw_only=True)
class CommonNoise:
    """Standard normals of a closed-loop run, drawn before it starts (common random numbers):
    one per step and sensor whether or not the sensor measures, one per ping slot, so that all
    policies see the same noise and a ping's noise does not depend on the other pings.

    Attributes
    ----------
    bearing, range : ndarray, shape (K + 1, max(1, number of bearing / passive range sensors))
    ping : ndarray, shape (K + 1,)
    fault : ndarray, shape (K + 1, max(1, number of bearing sensors) + 1, 2), optional
        Uniforms of the scenario's faults (wild bearings per bearing sensor, then the missed
        ping in ``[:, -1, 0]``), drawn after the rest; None without faults.
    """

    bearing: np.ndarray
    range: np.ndarray
    ping: np.ndarray
    fault: np.ndarray | None = None


def ping_sensors(scenario: Scenario) -> list[RangeSensor]:
    """The active range sensors of ``scenario``: a closed-loop ping uses the first of them
    (none: a ping policy cannot ping)."""
    return [s for s in scenario.sensors if isinstance(s, RangeSensor) and s.active]


def _closed_loop_sensors(scenario: Scenario) -> tuple[list[Any], list[Any], list[Any]]:
    """Bearing sensors, passive range sensors and active (ping) range sensors."""
    bs = [s for s in scenario.sensors if isinstance(s, BearingSensor)]
    rs = [s for s in scenario.sensors if isinstance(s, RangeSensor) and not s.active]
    return bs, rs, ping_sensors(scenario)


def draw_common_noise(scenario: Scenario, rng: np.random.Generator) -> CommonNoise:
    """Draw the :class:`CommonNoise` of one closed-loop run (bearings, ranges, pings, in order)."""
    bs, rs, _ = _closed_loop_sensors(scenario)
    K = scenario.n_steps
    bearing = rng.standard_normal((K + 1, max(len(bs), 1)))
    rng_ = rng.standard_normal((K + 1, max(len(rs), 1)))
    ping = rng.standard_normal(K + 1)
    fault = (rng.random((K + 1, max(len(bs), 1) + 1, 2)) if scenario.faults is not None
             else None)
    return CommonNoise(bearing=bearing, range=rng_, ping=ping, fault=fault)


def _measurement(sensor: Any, value: Any, offset: np.ndarray | None = None,
                 ping: bool = False) -> Measurement:
    """The :class:`Measurement` of one reading of ``sensor``."""
    if isinstance(sensor, BearingSensor):
        return Measurement(kind="bearing", value=float(value), sigma=float(sensor.sigma),
                           ambiguity=sensor.ambiguity)
    if isinstance(sensor, RangeSensor):
        return Measurement(kind="range", value=float(value), sigma=float(sensor.sigma),
                           ping=ping)
    return Measurement(kind="frequency", value=np.asarray(value, float),
                       sigma=np.asarray(sensor.sigma, float), c=float(sensor.c),
                       velocity_offset=offset)


def _reaches(sensor: RangeSensor, X: np.ndarray) -> bool:
    """Whether range sensor ``sensor`` reaches the contact at relative state ``X`` (1, 4)."""
    return sensor.max_range is None or float(range_of(X)[0]) <= sensor.max_range


class StepSensors:
    """What :func:`measure_step` reads of a scenario, made once for a closed-loop run: the
    bearing, passive range and ping sensors, the steps at which each measures (sets of int),
    the grid times [s] and the faults."""

    __slots__ = ("bearing", "faults", "passive", "pings", "times")

    def __init__(self, scenario: Scenario) -> None:
        bs, rs, self.pings = _closed_loop_sensors(scenario)
        self.bearing, self.passive = (
            [(j, s, frozenset(measurement_steps(s, scenario.time).tolist()))
             for j, s in enumerate(group)] for group in (bs, rs))
        self.times, self.faults = scenario.times, scenario.faults


def measure_step(scenario: Scenario, k: int, X: np.ndarray, noise: CommonNoise, *,
                 ping: bool = False, sensors: StepSensors | None = None) -> list[Measurement]:
    """Measurements of step ``k`` in a closed loop: bearings, passive ranges and, if ``ping``,
    an active ping (first active range sensor; ``Measurement.ping`` set); a range only within
    its sensor's ``max_range`` (the true range at ``k``). Frequency sensors
    are not simulated in the closed loop. The scenario's sensor faults apply (a missed or
    faded ping's echo is simply absent).

    Parameters
    ----------
    scenario : Scenario
    k : int
        Grid step.
    X : ndarray, shape (4,)
        True relative state with the observer's instantaneous velocity [m, m/s].
    noise : CommonNoise
    ping : bool
    sensors : StepSensors, optional
        ``StepSensors(scenario)``, made once by a loop that measures every step.
    """
    sen = StepSensors(scenario) if sensors is None else sensors
    X = np.asarray(X, float)[None]
    faults, t = sen.faults, float(sen.times[k])
    out = []
    for j, s, steps in sen.bearing:
        if k in steps and not (faults is not None and dropped(faults, t, "bearing")):
            truth, value = reading(s, X, noise.bearing[k, j:j + 1])
            if faults is not None and noise.fault is not None:
                value = corrupt_bearings(faults, value, truth, noise.fault[k, j],
                                         ambiguity=s.ambiguity)
            out.append(_measurement(s, value[0]))
    out += [_measurement(s, reading(s, X, noise.range[k, j:j + 1])[1][0])
            for j, s, steps in sen.passive
            if k in steps and not (faults is not None and dropped(faults, t, "range"))
            and _reaches(s, X)]
    ps = sen.pings
    echo = faults is None or (not dropped(faults, t, "range") and not (
        noise.fault is not None and noise.fault[k, -1, 0] < faults.missed_ping_probability))
    if ping and ps and echo and _reaches(ps[0], X):
        out.append(_measurement(ps[0], reading(ps[0], X, noise.ping[k:k + 1])[1][0], ping=True))
    return out


def measurement_batches(scenario: Scenario, measurements: Sequence[MeasurementSet],
                        observer: ObserverTrack) -> dict[int, list[Measurement]]:
    """Group a run's measurement sets into per-step :class:`Measurement` lists (the readings
    of an active range sensor are pings, ``Measurement.ping``, as in :func:`measure_step`)."""
    out: dict[int, list[Measurement]] = {}
    offset = observer.velocity - observer.mean_velocity
    for ms in measurements:
        for i, k in enumerate(np.asarray(ms.steps, int)):
            sensor = scenario.sensors[ms.sensor]
            m = _measurement(sensor, ms.values[i], offset[k],
                             ping=isinstance(sensor, RangeSensor) and sensor.active)
            out.setdefault(int(k), []).append(m)
    return out
