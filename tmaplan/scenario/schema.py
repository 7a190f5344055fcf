"""The scenario schema: frozen dataclasses of the time grid, target, prior, observer, settings.

A :class:`Scenario` holds the time grid, the target's motion model (and prior), the
observer's initial state, constraints and scripted manoeuvres, the sensors
(:mod:`tmaplan.scenario.sensors`), optional planning and estimation settings and the faults
(:mod:`tmaplan.scenario.faults`). Constructing one validates each value (the field types of
:mod:`tmaplan.scenario.quantities`); :func:`tmaplan.scenario.from_dict` and
:meth:`Scenario.replace` then check the rules across fields (:mod:`tmaplan.scenario.checks`).
"""

from __future__ import annotations

import dataclasses
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import AfterValidator, StrictBool

from tmaplan.errors import ScenarioError
from tmaplan.scenario.checks import check
from tmaplan.scenario.faults import Faults
from tmaplan.scenario.names import (
    DEFAULT_CONTACT,
    DEFAULT_OBJECTIVE,
    DEFAULT_REQUIRED_ACCURACY,
    OBJECTIVE_NAMES,
)
from tmaplan.scenario.quantities import (
    Accuracy,
    Angle,
    AngularRate,
    Length,
    NonNegAngle,
    NonNegInt,
    NonNegLength,
    NonNegProcessNoise,
    NonNegSpeed,
    NonNegTime,
    PositiveAngularRate,
    PositiveInt,
    PositiveLength,
    PositiveSpeed,
    PositiveTime,
    PositiveWeight,
    Speed,
    Time,
    Vec2Length,
    Vec2Speed,
    frozen,
)
from tmaplan.scenario.sensors import Sensor, measurement_steps

__all__ = [
    "Contact",
    "Estimation",
    "Observer",
    "ObserverLeg",
    "Planning",
    "Prior",
    "Scenario",
    "Target",
    "TargetLeg",
    "TimeGrid",
    "measurement_steps",
]


# --------------------------------------------------------------------------------------------
# Dataclasses
# --------------------------------------------------------------------------------------------


@frozen
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


@frozen
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


@frozen
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


@frozen
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
        """Fields that take the truth (:attr:`truth_means`, ``course_mode`` when "true"): the
        target's true initial value, in file order."""
        if self.kind == "gaussian":
            return ("mean",) if self.mean is None else ()
        out = []
        if self.bearing_mean is None:
            out.append("bearing_mean")
        if self.range_distribution == "normal" and self.range_mean is None:
            out.append("range_mean")
        if self.velocity_distribution == "normal":
            if self.velocity_mean is None:
                out.append("velocity_mean")
        else:
            if self.speed_distribution == "normal" and self.speed_mean is None:
                out.append("speed_mean")
            if self.course_mode == "true":
                out.append("course_mode")
        return tuple(out)

    @property
    def truth_means(self) -> tuple[str, ...]:
        """Omitted means of normal distributions (or gaussian ``mean``), in file order."""
        return tuple(f for f in self.truth_fields if f != "course_mode")


@frozen
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


@frozen
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



def _objective_name(name: str) -> str:
    if name not in OBJECTIVE_NAMES:
        raise ValueError(f"one of {', '.join(repr(n) for n in OBJECTIVE_NAMES)}")
    return name


@frozen
class Planning:
    """Optional planning settings.

    Attributes
    ----------
    horizon : float, optional
        Planning horizon [s], whole control intervals (default: the scenario's).
    objective : str
        Default heading objective (:data:`tmaplan.scenario.names.OBJECTIVE_NAMES`:
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
    required_accuracy : float, optional
        Relative range accuracy [-] in (0, 1) at which a contact counts as localised (the
        time-to-accuracy objectives and metrics); None: :data:`tmaplan.scenario.names.
        DEFAULT_REQUIRED_ACCURACY` (10 %). A contact's own ``required_accuracy`` overrides it.
    """

    horizon: PositiveTime | None = None
    objective: Annotated[str, AfterValidator(_objective_name)] = DEFAULT_OBJECTIVE
    ping_budget: NonNegInt = 0
    ping_sigma: PositiveLength | None = None
    ping_min_spacing: NonNegTime = 0.0
    ping_forbidden: tuple[tuple[NonNegTime, NonNegTime], ...] = ()
    keep_out_range: NonNegLength = 0.0
    control_interval: PositiveTime | None = None
    replan_interval: PositiveTime | None = None
    required_accuracy: Accuracy | None = None


@frozen
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


@frozen
class Contact:
    """One contact of a several-contact scenario (a ``[[contacts]]`` table of a file).

    A file with one ``[target]`` (and ``[prior]``) is one contact named
    :data:`tmaplan.scenario.names.DEFAULT_CONTACT` (``"contact"``). Association is known:
    every bearing is tagged with its contact (docs/several-contacts.md).

    Attributes
    ----------
    name : str
        Unique, non-empty name (the key of the contact in JSON output).
    target : Target
        Its motion model and true initial state.
    prior : Prior, optional
        Its prior (required by the verbs that need one, per contact).
    weight : float
        Weight [-], > 0, of the contact in the weighted objectives and metrics (default 1).
    required_accuracy : float, optional
        Relative range accuracy [-] in (0, 1) at which it counts as localised; None: the
        scenario's (``planning.required_accuracy``, default 10 %).
    """

    name: str
    target: Target
    prior: Prior | None = None
    weight: PositiveWeight = 1.0
    required_accuracy: Accuracy | None = None

    @property
    def is_default(self) -> bool:
        """Whether a file gives this contact as a bare ``[target]``/``[prior]`` (the name
        ``"contact"``, weight 1 and the scenario's required accuracy)."""
        return (self.name == DEFAULT_CONTACT and self.weight == 1.0
                and self.required_accuracy is None)


_SEVERAL = "several contacts: use scenario.contacts or scenario.contact_view(name)"


@frozen
class Scenario:
    """A complete TMA scenario: one or several contacts seen by one own ship.

    Attributes
    ----------
    name : str
    description : str
    time : TimeGrid
    contacts : tuple of Contact
        At least one (a file's ``[target]``/``[prior]`` is the one contact ``"contact"``).
    observer : Observer
    sensors : tuple of BearingSensor | RangeSensor | FrequencySensor
        Shared by every contact.
    planning : Planning, optional
    estimation : Estimation, optional
    faults : Faults, optional
        Sensor and target faults applied by :mod:`tmaplan.simulate` to the truth and the
        measurements only (:mod:`tmaplan.models.faults`).
    """

    name: str
    description: str = ""
    time: TimeGrid
    contacts: tuple[Contact, ...]
    observer: Observer
    sensors: tuple[Sensor, ...]
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

    @property
    def target(self) -> Target:
        """The target of a one-contact scenario (:class:`ScenarioError` with several:
        use :attr:`contacts` or :meth:`contact_view`)."""
        return self._single().target

    # ``object.__setattr__(s, "target" | "prior", value)`` (the frozen class refuses plain
    # assignment) replaces the one contact's, unvalidated, as it would a field's
    @target.setter
    def target(self, value: Target) -> None:
        self._set_single(target=value)

    @property
    def prior(self) -> Prior | None:
        """The prior of a one-contact scenario, None if none is given (:class:`ScenarioError`
        with several contacts: use :attr:`contacts` or :meth:`contact_view`)."""
        return self._single().prior

    @prior.setter
    def prior(self, value: Prior | None) -> None:
        self._set_single(prior=value)

    def _set_single(self, **change: Any) -> None:
        object.__setattr__(self, "contacts", (dataclasses.replace(self._single(), **change),))

    def _single(self) -> Contact:
        if len(self.contacts) != 1:
            raise ScenarioError("contacts", _SEVERAL,
                                [c.name for c in self.contacts], source=self.name)
        return self.contacts[0]

    @property
    def contact_names(self) -> tuple[str, ...]:
        """Names of the contacts, in file order."""
        return tuple(c.name for c in self.contacts)

    @property
    def required_accuracy(self) -> float:
        """Relative range accuracy [-] at which the (one) contact counts as localised: its
        own ``required_accuracy`` (one contact), else ``planning.required_accuracy``, else
        10 % (a contact's own value in its :meth:`contact_view`)."""
        own = self.contacts[0].required_accuracy if len(self.contacts) == 1 else None
        pl = self.planning
        return own if own is not None else DEFAULT_REQUIRED_ACCURACY if (
            pl is None or pl.required_accuracy is None) else pl.required_accuracy

    def contact(self, name: str) -> Contact:
        """The contact called ``name``.

        Raises
        ------
        ScenarioError
            No such contact; the message lists the names.
        """
        for c in self.contacts:
            if c.name == name:
                return c
        raise ScenarioError("contact", "one of " + ", ".join(repr(n) for n in
                                                            self.contact_names),
                            name, source=self.name)

    def contact_view(self, name: str) -> Scenario:
        """The one-contact scenario of contact ``name``: its target, prior and required
        accuracy (as ``planning.required_accuracy``), everything else shared, written as a
        file with a bare ``[target]``/``[prior]`` would give it (its one contact is
        ``"contact"``, weight 1). Every single-contact computation (bounds, estimators,
        single-contact objectives) runs on it.

        A scenario of one default contact is its own view. Raises :class:`ScenarioError` for
        an unknown name.
        """
        c = self.contact(name)
        if len(self.contacts) == 1 and c.is_default:
            return self
        planning = self.planning
        if c.required_accuracy is not None:
            planning = dataclasses.replace(planning or Planning(),
                                           required_accuracy=c.required_accuracy)
        one = Contact(name=DEFAULT_CONTACT, target=c.target, prior=c.prior)
        return dataclasses.replace(self, contacts=(one,), planning=planning)

    def contact_views(self) -> dict[str, Scenario]:
        """``{name: contact_view(name)}`` in file order."""
        return {c.name: self.contact_view(c.name) for c in self.contacts}

    def sensors_of(self, kind: str) -> tuple[Any, ...]:
        """Sensors of one kind ("bearing", "range", "frequency")."""
        return tuple(s for s in self.sensors if s.kind == kind)

    def replace(self, **changes: Any) -> Scenario:
        """A validated copy with top-level fields replaced.

        ``target=`` and ``prior=`` replace those of a one-contact scenario's contact (a
        :class:`ScenarioError` with several contacts).
        """
        single = {k: changes.pop(k) for k in ("target", "prior") if k in changes}
        if single:
            if "contacts" in changes:
                raise ScenarioError("contacts", "either 'contacts' or 'target'/'prior', not "
                                    "both", sorted(single), source=self.name)
            changes["contacts"] = (dataclasses.replace(self._single(), **single),)
        new = dataclasses.replace(self, **changes)
        check(new, source=self.name)
        return new
