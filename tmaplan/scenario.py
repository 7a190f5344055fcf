"""Scenarios: frozen dataclasses, TOML load/dump, validation.

A scenario holds the time grid, the target's motion model (and prior), the observer's initial
state, constraints and scripted manoeuvres, the sensors and optional planning settings. Files are
TOML; every dimensional value may be a plain SI number or a string with a unit (``"12 kn"``,
``"3.5 km"``, ``"45 deg"``, ``"10 min"``), see :mod:`tmaplan.units`.

Load -> dump -> load is the identity (SI values, ``repr`` floats). Every invalid value raises
:class:`tmaplan.errors.ScenarioError` naming the field, the expected and the received value.
"""

from __future__ import annotations

import dataclasses
from typing import Annotated, Any, Literal, TypeVar, cast, dataclass_transform

import numpy as np
from pydantic import AfterValidator, ConfigDict, Field, StrictBool
from pydantic.dataclasses import dataclass as _pydantic_dataclass

from tmaplan.models.faults import Faults
from tmaplan.units import si_validator

__all__ = [
    "BearingSensor",
    "Estimation",
    "Faults",
    "FrequencySensor",
    "Observer",
    "ObserverLeg",
    "Planning",
    "Prior",
    "RangeSensor",
    "Scenario",
    "Sensor",
    "Target",
    "TargetLeg",
    "TimeGrid",
    "dump",
    "from_dict",
    "list_problems",
    "load",
    "load_problem",
    "loads",
    "measurement_steps",
    "problems_dir",
    "save",
    "to_dict",
]

_CONFIG = ConfigDict(extra="forbid", arbitrary_types_allowed=False)
_T = TypeVar("_T")


@dataclass_transform(frozen_default=True, kw_only_default=True)
def _frozen(cls: type[_T]) -> type[_T]:
    return cast("type[_T]", _pydantic_dataclass(frozen=True, kw_only=True, config=_CONFIG)(cls))


_unit = si_validator  # SI number or string with a unit; a bool is refused by name


_FINITE = Field(allow_inf_nan=False)
_POS = Field(allow_inf_nan=False, gt=0)
_NONNEG = Field(allow_inf_nan=False, ge=0)
Length = Annotated[float, _unit("length"), _FINITE]
PositiveLength = Annotated[float, _unit("length"), _POS]
NonNegLength = Annotated[float, _unit("length"), _NONNEG]
Time = Annotated[float, _unit("time"), _FINITE]
PositiveTime = Annotated[float, _unit("time"), _POS]
NonNegTime = Annotated[float, _unit("time"), _NONNEG]
Angle = Annotated[float, _unit("angle"), _FINITE]
PositiveAngle = Annotated[float, _unit("angle"), _POS]
NonNegAngle = Annotated[float, _unit("angle"), _NONNEG]
Speed = Annotated[float, _unit("speed"), _FINITE]
NonNegSpeed = Annotated[float, _unit("speed"), _NONNEG]
PositiveSpeed = Annotated[float, _unit("speed"), _POS]
AngularRate = Annotated[float, _unit("angular_rate"), _FINITE]
PositiveAngularRate = Annotated[float, _unit("angular_rate"), _POS]
PositiveFrequency = Annotated[float, _unit("frequency"), _POS]
NonNegProcessNoise = Annotated[float, _unit("process_noise"), _NONNEG]
NonNegInt = Annotated[int, Field(ge=0, strict=True)]
PositiveInt = Annotated[int, Field(gt=0, strict=True)]
Vec2Length = tuple[Length, Length]
Vec2Speed = tuple[Speed, Speed]


# --------------------------------------------------------------------------------------------
# Dataclasses
# --------------------------------------------------------------------------------------------


@_frozen
class TimeGrid:
    """Uniform time grid ``t_k = t0 + k·dt``, ``k = 0..n_steps``.

    Attributes
    ----------
    dt : float
        Sampling period [s], > 0.
    horizon : float
        Duration [s]; must be a whole number of steps.
    t0 : float
        Time of step 0 [s].
    """

    dt: PositiveTime
    horizon: PositiveTime
    t0: Time = 0.0

    @property
    def n_steps(self) -> int:
        """Number of transitions K (the grid has K + 1 instants)."""
        return round(self.horizon / self.dt)

    @property
    def times(self) -> np.ndarray:
        """Grid instants, shape (K + 1,) [s]."""
        return self.t0 + self.dt * np.arange(self.n_steps + 1)


@_frozen
class TargetLeg:
    """A velocity change of a multi-leg target at a known time.

    Give either ``velocity`` or ``course`` and ``speed``.

    Attributes
    ----------
    start : float
        Time the leg starts [s] (absolute, on the scenario clock), in (t0, t0 + horizon].
    velocity : tuple of float, optional
        (v_x, v_y) [m/s], x East, y North.
    course : float, optional
        Course [rad], clockwise from North.
    speed : float, optional
        Speed [m/s].
    """

    start: NonNegTime
    velocity: Vec2Speed | None = None
    course: Angle | None = None
    speed: NonNegSpeed | None = None


@_frozen
class Target:
    """Target motion model and its true initial state.

    ``model = "ncv"``: nearly constant velocity with white acceleration of intensity ``q``
    [m²/s³] (``q = 0`` is constant velocity). ``"multi-leg"``: piecewise constant velocity
    changing at the known times of ``legs`` (plus optional process noise ``q``).
    ``"constant-turn"``: clavard2013's circle ``P(t) = centre + radius·[sin(ωt+φ), cos(ωt+φ)]``
    (clavard2013 eq.; ω > 0 clockwise).

    Attributes
    ----------
    model : {"ncv", "multi-leg", "constant-turn"}
    position : tuple of float, optional
        Initial position (x, y) [m] (ncv, multi-leg).
    velocity : tuple of float, optional
        Initial velocity (v_x, v_y) [m/s]; or give ``course`` [rad] and ``speed`` [m/s].
    course, speed : float, optional
    q : float
        Process-noise intensity [m²/s³] (docs/conventions.md; brehard2005's σ_max²).
    legs : tuple of TargetLeg
        Known velocity changes (multi-leg).
    centre : tuple of float, optional
        Circle centre (x_C, y_C) [m] (constant-turn).
    radius : float, optional
        ρ_C [m].
    phase : float, optional
        φ [rad]: angular position on the circle at t = 0, clockwise from North.
    omega : float, optional
        ω [rad/s], > 0 clockwise, ≠ 0.
    """

    model: Literal["ncv", "multi-leg", "constant-turn"] = "ncv"
    position: Vec2Length | None = None
    velocity: Vec2Speed | None = None
    course: Angle | None = None
    speed: NonNegSpeed | None = None
    q: NonNegProcessNoise = 0.0
    legs: tuple[TargetLeg, ...] = ()
    centre: Vec2Length | None = None
    radius: PositiveLength | None = None
    phase: Angle | None = None
    omega: AngularRate | None = None


@_frozen
class Prior:
    """Prior on the target's initial state (used by bounds, filters and planners).

    ``kind = "polar"``: bearing ~ N(bearing_mean, bearing_std²) from the observer's initial
    position; range from ``range_distribution`` (``normal``: N(range_mean, range_std²)
    truncated to [range_min, range_max]; ``uniform`` or ``log-uniform`` on [range_min,
    range_max]); velocity Cartesian normal (``velocity_mean``, ``velocity_std`` > 0 per axis)
    or ``speed-course`` (``speed_distribution`` and ``course_mode`` required). ``kind =
    "gaussian"``: absolute N(mean, diag(std²)), [x, y, v_x, v_y]. A key that the kind, the
    distributions or the course mode do not read is refused unless it keeps its default.

    A prior never takes the truth silently (the command line warns on every run): a mean left
    out (:attr:`truth_means`) is the true initial value only with ``centred_on_truth = true``
    (the papers' "prior centred on the truth", brehard2005, ristic2004 B2), else an error
    naming the key; ``course_mode = "true"`` is explicit. A velocity prior is required.

    Attributes
    ----------
    kind : {"polar", "gaussian"}
    bearing_mean : float, optional
        [rad]; None: the true initial bearing.
    bearing_std : float
        [rad], > 0 (give it: 0, the default, leaves the prior without a density).
    range_distribution : {"normal", "uniform", "log-uniform"}
    range_mean, range_std : float, optional
        [m]; range_mean None: the true initial range; range_std 0: a point mass at the mean.
    range_min : float
        Lower truncation / support bound [m] (keeps ln r and 1/r finite).
    range_max : float, optional
        Upper truncation / support bound [m].
    velocity_distribution : {"normal", "speed-course"}
    velocity_mean : tuple of float, optional
        (v_x, v_y) [m/s]; None: true target velocity.
    velocity_std : float
        Per-axis std [m/s].
    speed_distribution : {"normal", "uniform"}
    speed_mean, speed_std, speed_min, speed_max : float
        [m/s]; speed_mean None: true speed; speed_std 0: a point mass at the mean.
    course_mode : {"true", "given", "reciprocal-bearing", "uniform"}, optional
        Course mean: the true course, ``course_mean``, the bearing + π (target heading at the
        observer, Ristic et al. 2004), or uniform on the circle. Required for
        ``speed-course``.
    course_mean, course_std : float, optional
        [rad]; course_std > 0 for course_mode "given" and "true".
    mean, std : tuple of 4 floats, optional
        Gaussian prior, [x, y, v_x, v_y] in [m, m, m/s, m/s]; each std > 0.
    samples : int
        Number of prior samples used where a bound needs prior moments (brehard2005 eq. 56).
    seed : int
        Seed of those samples, so bounds are reproducible.
    centred_on_truth : bool
        Allow :attr:`truth_means` (above); refused when there is none.
    """

    kind: Literal["polar", "gaussian"] = "polar"
    bearing_mean: Angle | None = None
    bearing_std: NonNegAngle = 0.0
    range_distribution: Literal["normal", "uniform", "log-uniform"] = "normal"
    range_mean: PositiveLength | None = None
    range_std: NonNegLength | None = None
    range_min: NonNegLength = 0.0
    range_max: PositiveLength | None = None
    velocity_distribution: Literal["normal", "speed-course"] = "normal"
    velocity_mean: Vec2Speed | None = None
    velocity_std: NonNegSpeed = 0.0
    speed_distribution: Literal["normal", "uniform"] = "normal"
    speed_mean: NonNegSpeed | None = None
    speed_std: NonNegSpeed = 0.0
    speed_min: NonNegSpeed = 0.0
    speed_max: PositiveSpeed | None = None
    course_mode: Literal["true", "given", "reciprocal-bearing", "uniform"] | None = None
    course_mean: Angle | None = None
    course_std: NonNegAngle = 0.0
    mean: tuple[Length, Length, Speed, Speed] | None = None
    std: tuple[NonNegLength, NonNegLength, NonNegSpeed, NonNegSpeed] | None = None
    samples: PositiveInt = 100_000
    seed: NonNegInt = 0
    centred_on_truth: StrictBool = False

    @property
    def truth_fields(self) -> tuple[str, ...]:
        """Fields that take the truth (:attr:`truth_means`, ``course_mode`` when "true")."""
        from tmaplan._scenario_checks import truth_fields
        return truth_fields(self)

    @property
    def truth_means(self) -> tuple[str, ...]:
        """Omitted means of normal distributions (or gaussian ``mean``), in file order."""
        return tuple(f for f in self.truth_fields if f != "course_mode")


@_frozen
class ObserverLeg:
    """A scripted observer leg starting at ``start``.

    Give ``velocity`` or ``course`` (and optionally ``speed``; default: keep the speed).
    ``turn_rate`` None means an instantaneous course change; otherwise the heading turns at
    that rate [rad/s] in ``turn_direction`` until it reaches ``course``.

    Attributes
    ----------
    start : float
        [s]; not before t0 or the end of the previous leg's turn.
    velocity : tuple of float, optional
        (v_x, v_y) [m/s].
    course : float, optional
        [rad], clockwise from North.
    speed : float, optional
        [m/s].
    turn_rate : float, optional
        [rad/s], > 0.
    turn_direction : {"shortest", "starboard", "port"}
        Starboard = clockwise.
    """

    start: NonNegTime
    velocity: Vec2Speed | None = None
    course: Angle | None = None
    speed: NonNegSpeed | None = None
    turn_rate: PositiveAngularRate | None = None
    turn_direction: Literal["shortest", "starboard", "port"] = "shortest"


@_frozen
class Observer:
    """Own ship: initial state, limits, and either scripted legs or a turn-rate sequence.

    Attributes
    ----------
    position : tuple of float
        Initial (x, y) [m].
    velocity : tuple of float, optional
        Initial (v_x, v_y) [m/s]; or give ``course`` [rad] and ``speed`` [m/s].
    course, speed : float, optional
    legs : tuple of ObserverLeg
        Scripted manoeuvres.
    turn_rates : tuple of float
        Turn rate per step [rad/s] at constant speed (length n_steps), an alternative to legs.
    speed_min, speed_max : float
        Speed limits [m/s].
    turn_rate_max : float, optional
        Turn-rate limit [rad/s].
    heading_min, heading_max : float, optional
        Heading limits [rad] (clockwise from North), for planning.
    """

    position: Vec2Length = (0.0, 0.0)
    velocity: Vec2Speed | None = None
    course: Angle | None = None
    speed: NonNegSpeed | None = None
    legs: tuple[ObserverLeg, ...] = ()
    turn_rates: tuple[AngularRate, ...] = ()
    speed_min: NonNegSpeed = 0.0
    speed_max: PositiveSpeed | None = None
    turn_rate_max: PositiveAngularRate | None = None
    heading_min: Angle | None = None
    heading_max: Angle | None = None


@_frozen
class BearingSensor:
    """Passive bearing sensor: ``z = atan2(Δx, Δy) + v``, v ~ N(0, σ²).

    Measurement steps: ``steps`` if given, else ``first_step, first_step + every, ...``.

    Attributes
    ----------
    kind : "bearing"
    sigma : float
        Bearing noise std [rad].
    first_step : int
        First measurement step (1 by default: no bearing at t0).
    every : int
        Steps between measurements.
    steps : tuple of int, optional
        Explicit measurement steps (``first_step`` and ``every`` then keep their default 1).
    ambiguity : {"none", "pi"}
        "pi": bearing known modulo π, in (−π/2, π/2] (linear array, brehard2005 eq. 4).
    """

    kind: Literal["bearing"] = "bearing"
    sigma: PositiveAngle
    first_step: NonNegInt = 1
    every: PositiveInt = 1
    steps: tuple[NonNegInt, ...] | None = None
    ambiguity: Literal["none", "pi"] = "none"


@_frozen
class RangeSensor:
    """Range sensor: active pings at chosen steps, or continuous range-only measurement.

    ``z = ‖r‖ + v``, v ~ N(0, σ²). Steps: the union of ``steps``; for ``period`` the first
    grid step at or after each multiple of the period (brehard2005 §6's "every 80 s" with
    δ = 6 s gives k = 14, 27, 40, 54, ...); for ``every`` the steps ``first_step + i·every``.
    No steps at all is allowed (a ping sensor left to the scheduler).

    Attributes
    ----------
    kind : "range"
    sigma : float
        Range noise std [m].
    steps : tuple of int
        Explicit ping steps.
    period : float, optional
        Ping period [s].
    every : int, optional
        Continuous ranging every n steps (range-only tracking).
    first_step : int
        First step for ``every`` (without ``every`` it keeps its default 1).
    active : bool
        True for an active sonar ping (reveals own ship; counts against the budget).
    """

    kind: Literal["range"] = "range"
    sigma: PositiveLength
    steps: tuple[NonNegInt, ...] = ()
    period: PositiveTime | None = None
    every: PositiveInt | None = None
    first_step: NonNegInt = 1
    active: StrictBool = True


@_frozen
class FrequencySensor:
    """Narrow-band frequency lines: ``f_p(t) = f_p·(1 − Ṙ(t)/c) + v`` (clavard2013 eq. 3).

    Attributes
    ----------
    kind : "frequency"
    f0 : tuple of float
        Emitted tones f_p [Hz] (unknown to estimators).
    sigma : tuple of float
        Noise std per line [Hz].
    c : float
        Sound speed [m/s].
    first_step, every, steps
        As for :class:`BearingSensor`.
    """

    kind: Literal["frequency"] = "frequency"
    f0: tuple[PositiveFrequency, ...]
    sigma: tuple[PositiveFrequency, ...]
    c: PositiveSpeed = 1500.0
    first_step: NonNegInt = 1
    every: PositiveInt = 1
    steps: tuple[NonNegInt, ...] | None = None


Sensor = Annotated[BearingSensor | RangeSensor | FrequencySensor, Field(discriminator="kind")]


def _objective_name(name: str) -> str:
    from tmaplan.planning.objectives import OBJECTIVE_NAMES  # the one list (planning imports us)

    if name not in OBJECTIVE_NAMES:
        raise ValueError(f"one of {', '.join(repr(n) for n in OBJECTIVE_NAMES)}")
    return name


@_frozen
class Planning:
    """Optional planning settings.

    Attributes
    ----------
    horizon : float, optional
        Planning horizon [s], whole control intervals (default: the scenario's).
    objective : str
        Default heading objective (:data:`tmaplan.planning.objectives.OBJECTIVE_NAMES`:
        "logdet", "range-bound", "position-bound", "mean-relative-range-bound", ...).
    ping_budget : int
        Maximum number of active pings.
    ping_sigma : float, optional
        Std of a scheduled ping [m] (default: the scenario's range sensor).
    ping_min_spacing : float
        Minimum time between pings [s].
    ping_forbidden : tuple of (float, float)
        Time windows [s] in which pinging is forbidden (counter-detection).
    keep_out_range : float
        Minimum range to the target estimate [m].
    control_interval : float, optional
        Piecewise-constant turn-rate control [s], whole steps of dt (default: dt).
    replan_interval : float, optional
        Receding-horizon re-planning interval [s], whole steps of dt.
    """

    horizon: PositiveTime | None = None
    # tmaplan.planning.objectives.DEFAULT_OBJECTIVE (not imported: no cycle)
    objective: Annotated[str, AfterValidator(_objective_name)] = "expected-time-to-accuracy"
    ping_budget: NonNegInt = 0
    ping_sigma: PositiveLength | None = None
    ping_min_spacing: NonNegTime = 0.0
    ping_forbidden: tuple[tuple[NonNegTime, NonNegTime], ...] = ()
    keep_out_range: NonNegLength = 0.0
    control_interval: PositiveTime | None = None
    replan_interval: PositiveTime | None = None


@_frozen
class Estimation:
    """Optional settings of the batch estimators (``tmaplan track --estimator mle``).

    Attributes
    ----------
    turn_direction : {"either", "clockwise", "anticlockwise"}
        Sense of turn that the constant-turn MLE searches (clockwise = starboard, ω > 0 in
        clavard2013's convention). "either" (default) searches both senses and reports
        indistinguishable mirror solutions (:attr:`tmaplan.estimators.mle.MLEResult.alternatives`);
        a given sense is prior knowledge of the contact's turn, the way clavard2013 §III
        evaluates its clockwise and anticlockwise sources separately.
    """

    turn_direction: Literal["either", "clockwise", "anticlockwise"] = "either"


@_frozen
class Scenario:
    """A complete TMA scenario.

    Attributes
    ----------
    name : str
    description : str
    time : TimeGrid
    target : Target
    observer : Observer
    sensors : tuple of BearingSensor | RangeSensor | FrequencySensor
    prior : Prior, optional
    planning : Planning, optional
    estimation : Estimation, optional
    faults : Faults, optional
        Sensor and target faults applied by :mod:`tmaplan.simulate` to the truth and the
        measurements only (:mod:`tmaplan.models.faults`).
    """

    name: str
    description: str = ""
    time: TimeGrid
    target: Target
    observer: Observer
    sensors: tuple[Sensor, ...]
    prior: Prior | None = None
    planning: Planning | None = None
    estimation: Estimation | None = None
    faults: Faults | None = None

    # -- convenience -------------------------------------------------------------------------
    @property
    def n_steps(self) -> int:
        """Number of transitions K."""
        return self.time.n_steps

    @property
    def times(self) -> np.ndarray:
        """Grid instants, shape (K + 1,) [s]."""
        return self.time.times

    def sensors_of(self, kind: str) -> tuple[Any, ...]:
        """Sensors of one kind ("bearing", "range", "frequency")."""
        return tuple(s for s in self.sensors if s.kind == kind)

    def replace(self, **changes: Any) -> Scenario:
        """A validated copy with top-level fields replaced."""
        from tmaplan._scenario_checks import check

        new = dataclasses.replace(self, **changes)
        check(new, source=self.name)
        return new


# -- Measurement steps -----------------------------------------------------------------------


def measurement_steps(sensor: Any, grid: TimeGrid) -> np.ndarray:
    """Grid steps at which ``sensor`` measures, sorted, unique, shape (n,), dtype int.

    Parameters
    ----------
    sensor : BearingSensor | RangeSensor | FrequencySensor
    grid : TimeGrid
    """
    k_max = grid.n_steps
    if isinstance(sensor, RangeSensor):
        parts = [np.asarray(sensor.steps, dtype=int)]
        if sensor.period is not None:
            m = np.arange(1, int(np.floor(grid.horizon / sensor.period + 1e-9)) + 1)
            k = np.ceil(m * sensor.period / grid.dt - 1e-9).astype(int)
            parts.append(k[k <= k_max])
        if sensor.every is not None:
            parts.append(np.arange(sensor.first_step, k_max + 1, sensor.every))
        return np.unique(np.concatenate(parts)).astype(int)
    if sensor.steps is not None:
        return np.unique(np.asarray(sensor.steps, dtype=int))
    return np.arange(sensor.first_step, k_max + 1, sensor.every, dtype=int)


# Load / dump live in their own module; re-exported here (the public home of the API).
from tmaplan._scenario_io import (  # noqa: E402
    dump,
    from_dict,
    list_problems,
    load,
    load_problem,
    loads,
    problems_dir,
    save,
    to_dict,
)
