"""Batch Cramér–Rao lower bound of a deterministic target track.

The track models are those of :mod:`tmaplan.models.tracks` (constant velocity, multi-leg with
known change times, clavard2013's constant turn); the measurement model (bearings, range pings,
P frequency lines with unknown tones as nuisance parameters) and the Fisher information
``Σ_k J_kᵀ Σ_k⁻¹ J_k`` (clavard2013 eq. 11, docs/errata.md) are :mod:`tmaplan.bounds.batch_fim`.
With frequency lines the full (dim + P) FIM is inverted; its trajectory block equals the
Schur-complement form of clavard2013 eq. (16) (checked in the tests).

Before inversion the FIM is scaled to unit diagonal; the condition number of the scaled FIM
is reported and a (numerically) singular FIM raises :class:`ObservabilityError` naming the
unobservable direction. Derived quantities use the delta method: the final position
``p(t_N)`` and final range ``R_N`` (clavard2013 §3.1, J_{Z,Z_N}; ``∇R_N = [Δx/R, Δy/R]``).
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence

import numpy as np
from scipy import linalg

from tmaplan.bounds.batch_fim import (
    BearingData,
    FrequencyData,
    RangeData,
    TMAData,
    batch_data,
    fisher_information,
    true_parameters,
)
from tmaplan.errors import (
    ArgumentError,
    ObservabilityError,
    ScenarioError,
    finite_real,
    is_integer,
)
from tmaplan.geometry import range_of
from tmaplan.models.observer import observer_track
from tmaplan.models.target import target_track
from tmaplan.models.tracks import (
    TrackModel,
    constant_turn_model,
    cv_model,
    multi_leg_model,
)
from tmaplan.scenario import (
    BearingSensor,
    FrequencySensor,
    RangeSensor,
    Scenario,
    measurement_steps,
)

__all__ = [
    "BearingData",
    "CRLBResult",
    "FrequencyData",
    "IllConditionedWarning",
    "RangeData",
    "constant_turn_model",
    "crlb",
    "crlb_from_data",
    "cv_model",
    "information_covariance",
    "multi_leg_model",
    "scenario_data",
]

#: Relative eigenvalue threshold of the unit-diagonal FIM below which it is called singular.
SINGULAR_RTOL = 1e-13
#: Condition number of the unit-diagonal FIM above which a warning is issued.
WARN_CONDITION = 1e10


class IllConditionedWarning(RuntimeWarning):
    """The FIM is invertible but badly conditioned; the bound is numerically fragile."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class CRLBResult:
    """Batch CRLB of a deterministic track.

    Attributes
    ----------
    model : str
        "ncv", "multi-leg" or "constant-turn".
    parameters : tuple of str
        Names of the estimated parameters (motion parameters, then tones ``f0[p]``).
    units : tuple of str
    values : ndarray, shape (d,)
        True parameter values (SI).
    fim : ndarray, shape (d, d)
        Fisher information (SI units of ``values``).
    covariance : ndarray, shape (d, d)
        CRLB = FIM⁻¹ (SI).
    std : ndarray, shape (d,)
        √diag CRLB (SI).
    condition_number : float
        Condition number of the unit-diagonal (scaled) FIM.
    final_time : float
        t_N [s].
    final_parameters : tuple of str
        Names of the final-time parametrisation Z_N: the position parameters replaced by the
        target position at t_N (clavard2013 §3.1); the tones and other parameters kept.
    final_values, final_std : ndarray, shape (d,)
        Z_N and its CRLB std (SI).
    final_covariance : ndarray, shape (d, d)
    final_position : ndarray, shape (2,)
        Target position at t_N [m].
    final_range : float
        Observer–target range at t_N [m].
    final_range_std : float
        CRLB std of the final range [m] (delta method).
    final_range_rsd : float
        σ_R / R (dimensionless; clavard2013's RSD).
    n_measurements : dict
        Scalar measurement counts per kind.
    notes : tuple of str
        Modelling caveats (e.g. process noise ignored).
    """

    model: str
    parameters: tuple[str, ...]
    units: tuple[str, ...]
    values: np.ndarray
    fim: np.ndarray
    covariance: np.ndarray
    std: np.ndarray
    condition_number: float
    final_time: float
    final_parameters: tuple[str, ...]
    final_values: np.ndarray
    final_covariance: np.ndarray
    final_std: np.ndarray
    final_position: np.ndarray
    final_range: float
    final_range_std: float
    final_range_rsd: float
    n_measurements: dict[str, int]
    notes: tuple[str, ...] = ()

    def std_of(self, name: str, *, final: bool = True) -> float:
        """CRLB std of one parameter by name (final-time parametrisation by default)."""
        names = self.final_parameters if final else self.parameters
        std = self.final_std if final else self.std
        if name not in names:
            raise KeyError(f"{name!r} not in {names}")
        return float(std[names.index(name)])


# --------------------------------------------------------------------------------------------
# FIM inversion and CRLB
# --------------------------------------------------------------------------------------------


def _invert(fim: np.ndarray, names: Sequence[str],
            physical: np.ndarray) -> tuple[np.ndarray, float]:
    """Inverse of an SPD FIM after unit-diagonal scaling; raises when singular.

    Singularity is judged on the FIM in *physical* parameter scales (``physical``: a typical
    size of each parameter), because unit-diagonal scaling would inflate a parameter that
    receives only rounding-level information into a unit column.
    """
    diag = np.diag(fim)
    if not np.all(np.isfinite(fim)):  # before eigh, which fails on them
        bad = sorted({names[i] for i, j in zip(*np.nonzero(~np.isfinite(fim)))})
        raise ObservabilityError(f"the Fisher information has non-finite entries for "
                                 f"{', '.join(map(repr, bad))} (an overflow: a measurement "
                                 "at zero range, or a huge time offset?)")
    fp = fim * physical[:, None] * physical[None, :]
    eig_p, vec_p = np.linalg.eigh(fp)
    if np.any(diag <= 0.0):
        k = int(np.argmin(diag))
        raise ObservabilityError(
            f"parameter {names[k]!r} receives no information (FIM diagonal {diag[k]:.3g}); "
            "it is not observable from these measurements")
    scale = 1.0 / np.sqrt(diag)
    fs = fim * scale[:, None] * scale[None, :]
    eig, vec = np.linalg.eigh(fs)
    cond = float(eig[-1] / eig[0]) if eig[0] > 0 else np.inf
    singular_p = eig_p[0] <= SINGULAR_RTOL * eig_p[-1]
    if singular_p:
        cond = max(cond, float(eig_p[-1] / max(eig_p[0], 1e-300)))
        vec, scale = vec_p, physical
    if eig[0] <= SINGULAR_RTOL * eig[-1] or singular_p:
        null = vec[:, 0] * scale
        null = null / np.max(np.abs(null))
        direction = ", ".join(f"{n}: {c:+.3g}" for n, c in zip(names, null) if abs(c) > 1e-3)
        raise ObservabilityError(
            f"the Fisher information is singular (scaled condition number "
            f"{'> 1e16' if cond > 1e16 else format(cond, '.3g')}): the "
            f"track is not observable along the direction [{direction}]")
    if cond > WARN_CONDITION:
        warnings.warn(f"ill-conditioned FIM (scaled condition number {cond:.3g}); the CRLB is "
                      "numerically fragile", IllConditionedWarning, stacklevel=3)
    inv_s = linalg.cho_solve(linalg.cho_factor(fs), np.eye(fs.shape[0]))
    cov = inv_s * scale[:, None] * scale[None, :]
    return 0.5 * (cov + cov.T), cond


def _observed(data: TMAData) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(kind, times, observer positions) of each non-empty measurement kind."""
    sets = [("bearings", data.b_times, data.b_obs), ("ranges", data.r_times, data.r_obs),
            ("frequencies", data.f_times, data.f_obs)]
    return [s for s in sets if s[1].size and (s[0] != "frequencies" or data.n_lines)]


def _check_geometry(data: TMAData, theta: np.ndarray) -> dict[str, int]:
    """Measurement counts; raises when they are too few or the observer is at the target."""
    model, counts = data.track, data.counts
    if theta.shape != (model.dim,) or not np.all(np.isfinite(theta)):
        raise ArgumentError("theta", f"{model.dim} finite parameters {model.names}", theta)
    for field, t, p in _observed(data):
        r = range_of(model.track(theta, t)[0] - p)
        # "at the target": within a millionth of the largest range (1 cm at 10 km)
        if np.min(r) <= 1e-6 * max(1.0, float(np.max(r))):
            k = int(np.argmin(r))
            raise ObservabilityError(
                f"{field}: the observer is at the target at t = {t[k]:g} s (range {r[k]:.3g} "
                "m); bearings and range rates are undefined there")
    dim, total = data.n_params, sum(counts.values())
    if total < dim:
        raise ObservabilityError(
            f"too few measurements: {total} scalar measurements for {dim} unknown parameters "
            f"({', '.join(model.names)}{', tones' if data.n_lines else ''}); need at least "
            f"{dim}")
    return counts


def _physical_scales(data: TMAData, theta: np.ndarray) -> np.ndarray:
    """Typical size of each parameter: mean range L for lengths, L/T for speeds, 1 rad,
    1/T for rates (T = observation span), the line's σ for tones."""
    sets = _observed(data)
    t = np.concatenate([s[1] for s in sets])
    pos, _ = data.track.track(theta, t)
    L = max(float(np.mean(np.linalg.norm(pos - np.concatenate([s[2] for s in sets]),
                                         axis=-1))), 1e-9)
    T = max(float(np.ptp(t)), 1e-9)
    per_unit = {"m": L, "m/s": L / T, "rad": 1.0, "rad/s": 1.0 / T}
    return np.asarray([per_unit[u] for u in data.track.units] + list(data.f_sigma))


def crlb_from_data(
    model: TrackModel,
    theta: np.ndarray,
    *,
    bearings: Sequence[BearingData] = (),
    ranges: Sequence[RangeData] = (),
    frequencies: FrequencyData | None = None,
    final_time: float | None = None,
    final_observer_position: np.ndarray | None = None,
    notes: Sequence[str] = (),
) -> CRLBResult:
    """Array-level CRLB of a deterministic track.

    Parameters
    ----------
    model : TrackModel
    theta : ndarray, shape (dim,)
        True motion parameters (SI).
    bearings, ranges, frequencies
        Measurement sets, see :func:`tmaplan.bounds.batch_fim.batch_data`.
    final_time : float, optional
        t_N [s] (default: the last measurement time).
    final_observer_position : ndarray, shape (2,), optional
        Observer position at t_N [m] (default: the observer position of a measurement at
        t_N, to round-off, 1e-9·max(1, |t_N|) s; required when t_N is not a measurement
        time).
    notes : sequence of str
        Caveats copied into the result.

    Returns
    -------
    CRLBResult

    Raises
    ------
    ObservabilityError
        Singular FIM, too few measurements, observer at the target.
    ArgumentError
        Non-positive or non-finite noise, NaN inputs, a non-finite ``final_time`` or
        ``final_observer_position``.
    """
    theta = np.asarray(theta, dtype=float)
    data = batch_data(model, bearings=bearings, ranges=ranges, frequencies=frequencies)
    n_tones = data.n_lines
    names = _names(data)
    units = tuple(model.units) + ("Hz",) * n_tones
    tones = (np.zeros(0) if frequencies is None
             else np.asarray(frequencies.f0, float).reshape(-1)[:n_tones])
    fim, cov, cond, counts = _information(data, theta, tones)
    values = np.concatenate([theta, tones])

    # final time and observer position
    sets = [(s[1], s[2]) for s in _observed(data)]
    t_last = max(float(np.max(s[0])) for s in sets)
    t_n = t_last if final_time is None else finite_real(
        "final_time", final_time, "a finite time [s] (or None: the last measurement time)")
    if final_observer_position is None:
        # the observer position of a measurement at t_N (any measurement, not only the last
        # of a set): in the first set measuring at t_N, its measurement closest to t_N. "At"
        # is to round-off, 1e-9·max(1, |t_N|) s (10 µs at 10⁴ s), not np.isclose's default
        # rtol 1e-5 (0.1 s at 10⁴ s: a neighbouring measurement of a fast set, or a t_N
        # between measurements, passed as "at t_N")
        tol = 1e-9 * max(1.0, abs(t_n))
        cand = [p[np.argmin(np.abs(t - t_n))] for t, p in sets
                if np.min(np.abs(t - t_n)) <= tol]
        if not cand:
            raise ArgumentError("final_observer_position", f"given when final_time ({t_n} s) "
                                "is not a measurement time", None)
        obs_n = cand[0]
    else:
        obs_n = np.asarray(final_observer_position, float)
        if obs_n.shape != (2,) or not np.all(np.isfinite(obs_n)):
            raise ArgumentError("final_observer_position", "a finite position of shape (2,) "
                                "[m]", final_observer_position)

    pos_n, _ = model.track(theta, np.array([t_n]))
    dpos_n, _ = model.jacobian(theta, np.array([t_n]))
    jac_pos = np.zeros((2, len(names)))
    jac_pos[:, : model.dim] = dpos_n[0]
    # Z -> Z_N: position parameters (the first two in every model) replaced by p(t_N).
    T = np.eye(len(names))
    T[:2, :] = jac_pos
    final_cov = T @ cov @ T.T
    final_values = values.copy()
    final_values[:2] = pos_n[0]
    final_names = ("x_final", "y_final", *names[2:])
    d_n = pos_n[0] - obs_n
    r_n = float(range_of(d_n))
    if r_n <= 0.0:
        raise ObservabilityError("the observer is at the target at the final time")
    g = d_n / r_n
    var_r = float(g @ final_cov[:2, :2] @ g)
    std_r = float(np.sqrt(max(var_r, 0.0)))
    return CRLBResult(
        model=model.kind, parameters=names, units=units, values=values, fim=fim,
        covariance=cov, std=np.sqrt(np.clip(np.diag(cov), 0.0, None)), condition_number=cond,
        final_time=t_n, final_parameters=final_names, final_values=final_values,
        final_covariance=final_cov, final_std=np.sqrt(np.clip(np.diag(final_cov), 0.0, None)),
        final_position=pos_n[0], final_range=r_n, final_range_std=std_r,
        final_range_rsd=std_r / r_n, n_measurements=counts, notes=tuple(notes))


def information_covariance(data: TMAData, values: np.ndarray) -> np.ndarray:
    """Inverse of the batch Fisher information at ``values``, with :func:`crlb_from_data`'s checks.

    Parameters
    ----------
    data : TMAData
        Measurement sets and track model (:func:`tmaplan.bounds.batch_fim.tma_data`).
    values : ndarray, shape (dim + n_lines,)
        Motion parameters, then the tones [SI].

    Returns
    -------
    ndarray, shape (dim + n_lines, dim + n_lines)
        The CRLB of the parameters.

    Raises
    ------
    ObservabilityError
        Too few measurements, the observer at the target, or a singular FIM (the same
        one-line reasons as :func:`crlb`).
    """
    values = np.asarray(values, dtype=float)
    dim = data.track.dim
    if values.shape != (dim + data.n_lines,):
        raise ArgumentError("values", f"{dim + data.n_lines} parameters "
                            f"{_names(data)}", values)
    return _information(data, values[:dim], values[dim:])[1]


def _information(data: TMAData, theta: np.ndarray, tones: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, float, dict[str, int]]:
    """FIM, its inverse, the scaled condition number and the measurement counts at the motion
    parameters ``theta`` and the ``tones``, after the geometry checks
    (:func:`_check_geometry`, :func:`_invert`)."""
    counts = _check_geometry(data, theta)
    fim = fisher_information(data, np.concatenate([theta, tones]))
    cov, cond = _invert(fim, _names(data), _physical_scales(data, theta))
    return fim, cov, cond, counts


def _names(data: TMAData) -> tuple[str, ...]:
    """Parameter names: the motion model's, then one ``f0[q]`` per tone."""
    return tuple(data.track.names) + tuple(f"f0[{q}]" for q in range(data.n_lines))


# --------------------------------------------------------------------------------------------
# Scenario adapter
# --------------------------------------------------------------------------------------------


def scenario_data(
    scenario: Scenario, *, frequencies: int | None = None, t_ref: float | None = None,
) -> tuple[TrackModel, np.ndarray, dict[str, object], list[str]]:
    """Track model, true parameters and measurement sets of a scenario.

    Parameters
    ----------
    scenario : Scenario
    frequencies : int, optional
        Number of frequency lines to use (the first N tones of the scenario's frequency
        sensors; 0 = none). Default: all lines in the scenario.
    t_ref : float, optional
        Reference time of the position parameters (ncv, multi-leg) [s]; default t0.

    Returns
    -------
    model, theta, data, notes
        ``data`` holds keyword arguments for :func:`crlb_from_data`.
    """
    if frequencies is not None and not is_integer(frequencies, 0):
        raise ArgumentError("frequencies", "an integer >= 0 or None (all lines)", frequencies,
                            source=scenario.name)
    grid = scenario.time
    times = grid.times
    tgt = scenario.target
    notes: list[str] = []
    t_ref = float(grid.t0) if t_ref is None else finite_real(
        "t_ref", t_ref, "a finite reference time [s] (or None: t0)", source=scenario.name)
    if tgt.model == "constant-turn":
        model = constant_turn_model()
    else:
        legs = tgt.legs if tgt.model == "multi-leg" else ()
        model = multi_leg_model([float(leg.start) for leg in legs], t_ref=t_ref)
        if tgt.q > 0.0:
            notes.append(f"target process noise q = {tgt.q:g} m²/s³ ignored: the batch CRLB "
                         "is for a deterministic track (use `tmaplan bound` for the PCRB)")
    theta = true_parameters(scenario, model)
    obs = observer_track(scenario.observer, grid)
    bearings: list[BearingData] = []
    ranges: list[RangeData] = []
    lines_f0: list[float] = []
    lines_sigma: list[float] = []
    freq_sensor = None
    for sen in scenario.sensors:
        steps = measurement_steps(sen, grid)
        if isinstance(sen, BearingSensor):
            bearings.append(BearingData(times=times[steps], observer_position=obs.position[steps],
                                        sigma=sen.sigma))
        elif isinstance(sen, RangeSensor):
            if sen.max_range is not None and steps.size:  # the true range decides the reach

                rel = target_track(tgt, grid, None)[steps, :2] - obs.position[steps]
                reached = np.hypot(rel[:, 0], rel[:, 1]) <= sen.max_range
                if not reached.all():
                    notes.append(f"{int((~reached).sum())} range reading(s) beyond the range "
                                 f"sensor's max_range = {sen.max_range:g} m left out (no echo)")
                steps = steps[reached]
            if steps.size:
                ranges.append(RangeData(times=times[steps],
                                        observer_position=obs.position[steps],
                                        sigma=sen.sigma))
        elif isinstance(sen, FrequencySensor):
            if freq_sensor is None:
                freq_sensor = (sen, steps)
            elif not np.array_equal(steps, freq_sensor[1]) or sen.c != freq_sensor[0].c:
                raise ScenarioError("sensors", "frequency sensors sharing steps and sound "
                                    "speed", sen)
            lines_f0 += list(sen.f0)
            lines_sigma += list(sen.sigma)
    n_avail = len(lines_f0)
    n_lines = n_avail if frequencies is None else int(frequencies)
    if n_lines > n_avail:
        raise ArgumentError("frequencies", f"an integer in [0, {n_avail}] (lines in the "
                            "scenario)", frequencies, source=scenario.name)
    freq = None
    if n_lines and freq_sensor is not None:
        sen, steps = freq_sensor
        freq = FrequencyData(times=times[steps], observer_position=obs.position[steps],
                             observer_velocity=obs.velocity[steps],
                             f0=np.array(lines_f0[:n_lines]),
                             sigma=np.array(lines_sigma[:n_lines]), c=sen.c)
    data = {"bearings": bearings, "ranges": ranges, "frequencies": freq,
            "final_time": float(times[-1]), "final_observer_position": obs.position[-1]}
    return model, theta, data, notes


def crlb(scenario: Scenario, *, frequencies: int | None = None,
         t_ref: float | None = None) -> CRLBResult:
    """Batch CRLB of a scenario's deterministic target track.

    Parameters
    ----------
    scenario : Scenario
        Constant-velocity ("ncv"; process noise is ignored with a note), "multi-leg" (known
        change times) or "constant-turn" target; bearing, range and frequency sensors.
    frequencies : int, optional
        Use the first N frequency lines (0 = bearings/ranges only). Default: all lines.
    t_ref : float, optional
        Reference time of the ncv/multi-leg position parameters [s] (default t0). The
        final-time quantities do not depend on it.

    Returns
    -------
    CRLBResult
        With the final time t_N = the scenario's last grid instant.

    Examples
    --------
    >>> from tmaplan.scenario import load_problem
    >>> res = crlb(load_problem("clavard2013-halfturn-cw"), frequencies=0)
    >>> round(res.final_range_rsd, 3)  # clavard2013 Table 1: 0.71 km / 9.76 km  # doctest: +SKIP
    0.073
    """
    model, theta, data, notes = scenario_data(scenario, frequencies=frequencies, t_ref=t_ref)
    return crlb_from_data(model, theta, notes=notes, **data)  # type: ignore[arg-type]
