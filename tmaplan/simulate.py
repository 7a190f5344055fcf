"""Simulation: truth, observer track and noisy measurements for a scenario."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from tmaplan.geometry import bearing_of, range_of, wrap_angle, wrap_half_angle
from tmaplan.models.observer import ObserverTrack, observer_track
from tmaplan.models.sensors import doppler_frequency
from tmaplan.models.target import target_track
from tmaplan.scenario import (
    BearingSensor,
    FrequencySensor,
    RangeSensor,
    Scenario,
    measurement_steps,
)

__all__ = ["MeasurementSet", "Simulation", "measure", "simulate"]


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
    """

    sensor: int
    kind: str
    steps: np.ndarray
    times: np.ndarray
    values: np.ndarray
    truth: np.ndarray
    relative: np.ndarray | None
    sigma: np.ndarray


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
        ``target − observer.state`` (observer mean velocity, DESIGN §1).
    measurements : tuple of MeasurementSet
        One per sensor, in scenario order.
    """

    scenario: Scenario
    times: np.ndarray
    target: np.ndarray
    observer: ObserverTrack
    relative: np.ndarray
    measurements: tuple[MeasurementSet, ...]

    def to_json(self) -> dict[str, Any]:
        """JSON-ready dict (DESIGN §4: ``times, target, observer, measurements``), SI units."""
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
        Xk = rel_inst[steps]
        rel = None
        if isinstance(sensor, BearingSensor):
            truth = bearing_of(Xk)
            sigma = np.asarray(sensor.sigma)
            noise = rng.normal(0.0, sensor.sigma, truth.shape) if rng is not None else 0.0
            wrap = wrap_half_angle if sensor.ambiguity == "pi" else wrap_angle
            truth = wrap(truth)
            values = wrap(truth + noise)
            rel = wrap_angle(wrap_angle(truth + noise) - obs.heading[steps])
        elif isinstance(sensor, RangeSensor):
            truth = range_of(Xk)
            sigma = np.asarray(sensor.sigma)
            noise = rng.normal(0.0, sensor.sigma, truth.shape) if rng is not None else 0.0
            values = truth + noise
        elif isinstance(sensor, FrequencySensor):
            truth = doppler_frequency(Xk, np.asarray(sensor.f0), sensor.c)
            sigma = np.asarray(sensor.sigma)
            noise = rng.normal(0.0, 1.0, truth.shape) * sigma if rng is not None else 0.0
            values = truth + noise
        else:  # pragma: no cover - the scenario schema admits no other kind
            raise TypeError(f"unknown sensor {sensor!r}")
        out.append(MeasurementSet(sensor=i, kind=sensor.kind, steps=steps, times=times[steps],
                                  values=np.asarray(values, float), truth=truth, relative=rel,
                                  sigma=sigma))
    return tuple(out)


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
        Override the true target track (e.g. a truth drawn from the prior).

    Returns
    -------
    Simulation
    """
    obs = observer if observer is not None else observer_track(scenario.observer, scenario.time)
    tgt = target if target is not None else target_track(scenario.target, scenario.time, rng)
    meas = measure(scenario, tgt, obs, rng)
    return Simulation(scenario=scenario, times=scenario.times, target=tgt, observer=obs,
                      relative=tgt - obs.state, measurements=meas)
