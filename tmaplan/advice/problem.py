"""A recorded contact as an estimation problem: the :class:`Platform` settings (what the
recording does not hold) and :func:`contact_problem` (a scenario, measurement sets and the own
ship's track on a time grid, the inputs of :func:`tmaplan.estimators.run`).

**Grid.** ``dt`` is the median interval between the contact's distinct bearing times, or its
smallest multiple ``m·interval`` of at least ``Platform.step_min`` (10 s); each step is at
the centre of its ``m`` bearings, counted back from the last bearing (:func:`_grid_steps`:
each step's bearings straddle its time), step 0 is one ``dt`` before the first bearings' step
when the navigation covers it
(as ``simulate --export`` writes: bearings from step 1), else that step. Each bearing is
taken at its nearest step (a warning says by how much when a bearing is more than a tenth of
its own interval off the grid, another when a step's bearings are on average more than a tenth
of the interval off its time), and the
bearings of one step and one σ are one, their circular mean with σ/√m
(:func:`combine_bearings`: the same likelihood; a 2-hour log at 1 s is 720 steps);
the own ship's position at each step is interpolated from the fixes
(:func:`tmaplan.io.ownship_at`) and its mean velocity over a step is the displacement over it
divided by ``dt`` (:attr:`tmaplan.models.observer.ObserverTrack.mean_velocity`).

**Prior** (docs/recordings.md): bearing ``N(first bearing, bearing_std²)``, range uniform on
``[range_min, range_max]``, speed uniform on ``[0, speed_max]`` with a uniform course. The
scenario's ``[target]`` is a placeholder at the prior's centre at rest: the estimators never
read it (every prior mean is given), and there is no truth.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.errors import DataError, UnitError
from tmaplan.geometry import course_speed, wrap_angle
from tmaplan.io.faults import warn
from tmaplan.io.recording import RecordedContact, Recording, ownship_at
from tmaplan.models.observer import ObserverTrack
from tmaplan.scenario import (
    BearingSensor,
    Contact,
    Observer,
    Planning,
    Prior,
    RangeSensor,
    Scenario,
    Target,
    TimeGrid,
)
from tmaplan.scenario.names import DEFAULT_CONTACT
from tmaplan.simulate import MeasurementSet
from tmaplan.units import to_si

__all__ = ["PLATFORM_KEYS", "ContactProblem", "Platform", "bearings_problem", "combine_bearings",
           "contact_problem", "grid_track", "read_platform"]

KNOT = 1852.0 / 3600.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class Platform:
    """What a recording does not hold: the prior on each contact and the own ship's limits.

    Attributes
    ----------
    range_min, range_max : float
        The contact's range interval of the prior [m] (default 1–40 km).
    speed_max : float
        The contact's maximum speed [m/s] (default 25 kn).
    bearing_std : float
        Spread of the prior's bearing around the first bearing [rad] (default 5°).
    turn_rate_max : float
        The own ship's turn-rate limit [rad/s] (default 0.5°/s).
    keep_out_range : float
        The own ship's closest allowed range to a contact's estimate [m] (default 2 km).
    q : float
        The contact's process noise intensity [m²/s³] (default 1e-5, nearly constant
        velocity).
    ping_sigma : float
        Range standard deviation of an active ping [m] (default 50 m).
    ping_min_spacing : float
        Least time between two pings [s] (default 2 min).
    particles : int
        Particles of the particle filter (default 10 000).
    step_min : float
        Shortest step of the estimators' grid [s] (default 10 s): denser bearings share a
        step (module doc).
    """

    range_min: float = 1000.0
    range_max: float = 40000.0
    speed_max: float = 25.0 * KNOT
    bearing_std: float = float(np.deg2rad(5.0))
    turn_rate_max: float = float(np.deg2rad(0.5))
    keep_out_range: float = 2000.0
    q: float = 1e-5
    ping_sigma: float = 50.0
    ping_min_spacing: float = 120.0
    particles: int = 10_000
    step_min: float = 10.0

    def check(self, source: str) -> Platform:
        """Itself, or a :class:`DataError` naming the first key out of its range."""
        tests = (("range_min", self.range_min > 0, "> 0 m"),
                 ("range_max", self.range_max > self.range_min, "> range_min"),
                 ("speed_max", self.speed_max > 0, "> 0 m/s"),
                 ("bearing_std", 0 < self.bearing_std < np.pi, "in (0, 180) degrees"),
                 ("turn_rate_max", self.turn_rate_max > 0, "> 0 rad/s"),
                 ("keep_out_range", self.keep_out_range >= 0, ">= 0 m"),
                 ("q", self.q >= 0, ">= 0 m^2/s^3"),
                 ("ping_sigma", self.ping_sigma > 0, "> 0 m"),
                 ("ping_min_spacing", self.ping_min_spacing >= 0, ">= 0 s"),
                 ("particles", self.particles >= 2, "an integer >= 2"),
                 ("step_min", self.step_min > 0, "> 0 s"))
        for key, ok, expected in tests:
            value = getattr(self, key)
            if not (ok and np.isfinite(value)):
                raise DataError(source, f"key '{key}': expected {expected}, received {value!r}",
                                field=key, received=value)
        return self


#: ``--platform`` TOML keys and their dimensions (values: SI numbers or strings with a unit).
PLATFORM_KEYS = {"range_min": "length", "range_max": "length", "speed_max": "speed",
                 "bearing_std": "angle", "turn_rate_max": "angular_rate",
                 "keep_out_range": "length", "q": "process_noise", "ping_sigma": "length",
                 "ping_min_spacing": "time", "particles": "count", "step_min": "time"}


def read_platform(path: str | Path, base: Platform | None = None) -> Platform:
    """Read a ``--platform`` TOML file (keys :data:`PLATFORM_KEYS`, values with units).

    Parameters
    ----------
    path : str or Path
    base : Platform, optional
        The values of the keys the file leaves out (default :class:`Platform`'s).

    Returns
    -------
    Platform

    Raises
    ------
    DataError
        Not readable, not TOML, an unknown key, a value without a valid unit or out of range.
    """
    src = str(path)
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise DataError(src, f"cannot read the platform file ({exc.strerror or exc})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DataError(src, f"expected a TOML file: {exc}") from None
    values: dict[str, Any] = {}
    for key, value in data.items():
        if key not in PLATFORM_KEYS:
            raise DataError(src, f"unknown key '{key}' (expected some of "
                            f"{', '.join(PLATFORM_KEYS)})", field=key, received=value)
        if PLATFORM_KEYS[key] == "count":
            if not isinstance(value, int) or isinstance(value, bool):
                raise DataError(src, f"key '{key}': expected an integer, received {value!r}",
                                field=key, received=value)
            values[key] = value
            continue
        try:
            values[key] = to_si(value, PLATFORM_KEYS[key], key)
        except UnitError as exc:
            raise DataError(src, str(exc), field=key, received=value) from None
    return dataclasses.replace(base or Platform(), **values).check(src)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactProblem:
    """One recorded contact on a time grid (module doc).

    Attributes
    ----------
    name : str
        The contact's name.
    scenario : Scenario
        Grid, prior, sensors (one bearing sensor per distinct bearing σ) and limits.
    measurements : tuple of MeasurementSet
        The bearings, one set per sensor.
    observer : ObserverTrack
        The own ship on the grid.
    offset : float
        Largest distance of a bearing's time from its step's time [s].
    times, bearing, sigma : ndarray, shape (n,)
        The bearings as recorded [s, rad, rad] (before :func:`combine_bearings`), the
        bearings as azimuths in the plane (:func:`contact_problem`).
    velocity : ndarray, shape (n, 2)
        The own ship's velocity at ``times`` [m/s] (:func:`tmaplan.io.ownship_at`).
    """

    name: str
    scenario: Scenario
    measurements: tuple[MeasurementSet, ...]
    observer: ObserverTrack
    offset: float
    times: np.ndarray
    bearing: np.ndarray
    sigma: np.ndarray
    velocity: np.ndarray


def grid_track(times: np.ndarray, east: np.ndarray, north: np.ndarray,
               grid: np.ndarray) -> ObserverTrack:
    """The own ship on ``grid`` [s] from its fixes: positions interpolated, the mean velocity
    over each step the step's displacement over ``dt`` (row 0: the velocity at ``grid[0]``).

    Parameters
    ----------
    times, east, north : ndarray, shape (m,)
        Fixes [s, m, m].
    grid : ndarray, shape (K + 1,)
        Uniform times [s] within the fixes' span.

    Returns
    -------
    ObserverTrack
    """
    st = ownship_at(times, east, north, grid)
    mean = st.velocity.copy()
    if grid.size > 1:
        mean[1:] = np.diff(st.position, axis=0) / np.diff(grid)[:, None]
    heading, speed = course_speed(st.velocity)
    return ObserverTrack(times=grid, position=st.position, velocity=st.velocity,
                         mean_velocity=mean, heading=np.asarray(heading),
                         speed=np.asarray(speed))


def combine_bearings(steps: np.ndarray, bearing: np.ndarray, sigma: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The bearings of one step and one σ as one: their mean with σ/√m.

    For m bearings ``z_i`` of one standard deviation σ, all modelled by the bearing ``h`` of
    one step, ``Σ (z_i − h)² = m (z̄ − h)² + Σ (z_i − z̄)²``: the likelihood of ``h`` is that
    of the mean with σ/√m. The mean is taken on the circle's branch of the group's first
    bearing (deviations from it wrapped to (−π, π]), so the identity is exact while the
    bearings and ``h`` lie within π/2 of one another. The estimators then see one
    measurement per step and σ.

    Parameters
    ----------
    steps : ndarray of int, shape (n,)
    bearing, sigma : ndarray, shape (n,)
        [rad].

    Returns
    -------
    steps, bearing, sigma : ndarray, shape (m,)
        Sorted by step; ``bearing`` in (−π, π].
    """
    keys = np.column_stack([steps, sigma])
    uniq, inv, count = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    if uniq.shape[0] == steps.size:
        return steps, bearing, sigma
    inv = inv.ravel()
    ref = np.empty(uniq.shape[0])
    ref[inv[::-1]] = bearing[::-1]  # each group's first bearing
    dev = np.mod(bearing - ref[inv] + np.pi, 2 * np.pi) - np.pi
    mean = ref + np.bincount(inv, weights=dev) / count
    return (uniq[:, 0].astype(int), np.asarray(wrap_angle(mean)),
            uniq[:, 1] / np.sqrt(count))


def contact_problem(recording: Recording, contact: RecordedContact, platform: Platform,
                    ) -> ContactProblem:
    """The estimation problem of one recorded contact (module doc).

    The recorded bearings are true (clockwise from true north); with a geographic frame
    (:attr:`Recording.frame`) each is turned into the plane's azimuth at the own ship's
    position (:meth:`tmaplan.io.frame.LocalFrame.grid_azimuth`: grid north is true north only
    on the plane's central meridian).

    Parameters
    ----------
    recording : Recording
        Its navigation gives the own ship.
    contact : RecordedContact
    platform : Platform

    Returns
    -------
    ContactProblem

    Raises
    ------
    DataError
        Fewer than 5 bearings at distinct times (a constant-velocity contact has 4 unknowns).
    """
    nav = recording.nav
    assert nav.east is not None and nav.north is not None  # every aligned NavTrack has both
    bearing = contact.bearing
    if recording.frame is not None:  # true bearings to the plane's (grid) azimuths
        own = contact.ownship.position
        bearing = recording.frame.grid_azimuth(own[:, 0], own[:, 1], bearing)
    return bearings_problem(contact.name, contact.times, bearing, contact.sigma,
                            nav.times, nav.east, nav.north, platform,
                            source=recording.bearings_source)


def _grid_steps(tb: np.ndarray, interval: float, m: int, nav_first: float
                ) -> tuple[float, np.ndarray, int]:
    """The grid's start ``t0`` [s], each bearing's step and the last step (module doc).

    With ``m`` bearings per step (``dt = m·interval``) each step's time is the centre of its
    ``m`` bearings: bearings at ``±interval/2, ±3·interval/2, …`` (m even) or ``0,
    ±interval, …`` (m odd) of the step's time, whose mean is the bearing at the step's time
    to second order. Taking the first ``m`` bearings at their first one's time instead biases
    the step's bearing by the bearing rate times ``(m − 1)·interval/2`` (and with ``m = 2``
    rounding half to even gave steps one, two or three bearings). The grid is anchored on
    the last bearings (the solution's time, ``(m − 1)·interval/2`` before the last bearing,
    has a full step); the first step may hold fewer (moved later, off its bearings' centre,
    when its centre would fall before the navigation's first fix).
    """
    dt = m * interval
    if m == 1:
        t0 = float(tb[0])
    else:
        last = float(tb[-1]) - 0.5 * (m - 1) * interval
        t0 = last - float(np.rint((last - tb[0]) / dt)) * dt
        t0 += max(0.0, nav_first - t0)
    if t0 - dt >= nav_first - 1e-9 * dt:
        t0 -= dt  # step 0 one step before the first bearings' step (bearings from step 1)
    steps = np.rint((tb - t0) / dt).astype(int)
    return t0, steps, int(steps[-1])


def bearings_problem(name: str, times: np.ndarray, bearing: np.ndarray, sigma: np.ndarray,
                     nav_times: np.ndarray, east: np.ndarray, north: np.ndarray,
                     platform: Platform, *, source: str) -> ContactProblem:
    """:func:`contact_problem` from arrays.

    Parameters
    ----------
    name : str
        The contact.
    times, bearing, sigma : ndarray, shape (n,)
        Bearing times [s] (non-decreasing, within the fixes' span), bearings and their
        standard deviations [rad].
    nav_times, east, north : ndarray, shape (m,)
        The own ship's fixes [s, m, m].
    platform : Platform
    source : str
        The bearings' file, for messages.

    Returns
    -------
    ContactProblem
    """
    tb = np.asarray(times, float)
    bearing = np.asarray(bearing, float)
    sigma = np.asarray(sigma, float)
    distinct = np.unique(tb)
    if distinct.size < 5:
        raise DataError(source, f"contact '{name}': expected at least 5 bearings at "
                        f"different times (4 unknowns), received {distinct.size}",
                        field="contact", received=name)
    interval = float(np.median(np.diff(distinct)))
    m = max(1, int(np.ceil(platform.step_min / interval - 1e-9)))
    dt = interval * m
    t0, steps, K = _grid_steps(tb, interval, m, float(nav_times[0]))
    offset = float(np.max(np.abs(tb - (t0 + steps * dt))))
    own = np.abs((tb - tb[0]) / interval - np.rint((tb - tb[0]) / interval))
    if float(np.max(own)) > 0.1:
        warn(f"{source}: contact '{name}': bearings up to {offset:.3g} s off the {dt:g} s "
             "grid of the estimators; each taken at its nearest step")
    # a step's bearings, combined, are its measurement at the step's time: their mean time
    # must be the step's (a bearing rate times a time bias is a bearing bias); the first and
    # the last step may hold fewer than m bearings (one bearing among hundreds: negligible)
    drift = (np.bincount(steps, weights=tb - (t0 + steps * dt)) / np.maximum(
        np.bincount(steps), 1))[int(steps[0]) + 1:K]
    if drift.size and float(np.max(np.abs(drift))) > 0.1 * interval:
        warn(f"{source}: contact '{name}': the bearings combined on one step of the "
             f"estimators' {dt:g} s grid lie up to {float(np.max(np.abs(drift))):.3g} s off "
             "the step's time on average (irregular bearing times)")
    grid = t0 + dt * np.arange(K + 1)
    # the last grid time may pass the last fix by round-off of t0 + K·dt
    grid = np.minimum(grid, nav_times[-1])
    obs = grid_track(nav_times, east, north, grid)
    ks, zs, ss = combine_bearings(steps, bearing, sigma)
    sigmas = np.unique(ss)
    sensors = tuple(BearingSensor(sigma=float(s), steps=tuple(int(k) for k in np.unique(
        ks[ss == s]))) for s in sigmas)
    meas = tuple(MeasurementSet(sensor=i, kind="bearing", steps=ks[sel],
                                times=grid[ks[sel]], values=zs[sel],
                                truth=np.full(int(sel.sum()), np.nan), relative=None,
                                sigma=np.asarray(float(s)))
                 for i, s in enumerate(sigmas) for sel in [ss == s])
    b0 = float(bearing[0])
    r_mid = 0.5 * (platform.range_min + platform.range_max)
    p0 = obs.position[0]
    top = float(np.max(np.hypot(obs.mean_velocity[:, 0], obs.mean_velocity[:, 1])))
    target = Target(model="ncv", position=(float(p0[0] + r_mid * np.sin(b0)),
                                           float(p0[1] + r_mid * np.cos(b0))),
                    velocity=(0.0, 0.0), q=platform.q)
    prior = Prior(kind="polar", bearing_mean=b0, bearing_std=platform.bearing_std,
                  range_distribution="uniform", range_min=platform.range_min,
                  range_max=platform.range_max, velocity_distribution="speed-course",
                  speed_distribution="uniform", speed_max=platform.speed_max,
                  course_mode="uniform")
    scenario = Scenario(
        name=name, description=f"recorded contact '{name}' ({source})",
        time=TimeGrid(dt=dt, horizon=K * dt, t0=t0),
        contacts=(Contact(name=DEFAULT_CONTACT, target=target, prior=prior),),
        observer=Observer(position=(float(p0[0]), float(p0[1])),
                          velocity=(float(obs.mean_velocity[0, 0]),
                                    float(obs.mean_velocity[0, 1])),
                          speed_max=max(top * (1 + 1e-9), 1e-3),
                          turn_rate_max=platform.turn_rate_max),
        sensors=(*sensors, RangeSensor(sigma=platform.ping_sigma, steps=())),
        planning=Planning(keep_out_range=platform.keep_out_range,
                          ping_min_spacing=platform.ping_min_spacing))
    return ContactProblem(name=name, scenario=scenario, measurements=meas,
                          observer=obs, offset=offset, times=tb, bearing=bearing, sigma=sigma,
                          velocity=ownship_at(nav_times, east, north, tb).velocity)
