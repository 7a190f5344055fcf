"""The batch Fisher information of a deterministic target track: one data type, one FIM.

The target track is a deterministic function of a parameter vector θ (constant velocity,
multi-leg with known change times, or clavard2013's constant turn, see
:mod:`tmaplan.models.tracks`), followed by the P emitted tones of the frequency lines
(nuisance parameters). Measurements are independent Gaussian:

* bearings ``β_k = atan2(d_x, d_y) + ε``, σ_β [rad] (optionally known modulo π);
* range pings ``R_k + ε``, σ_R [m];
* P frequency lines ``f_p (1 − Ṙ_k/c) + ε``, σ_fp [Hz] (clavard2013 eq. 3, multi-line form).

:class:`TMAData` holds the measurements and the observer geometry of one batch; it is built from
a simulated run (:func:`tma_data`) or from measurement times and observer positions alone
(:func:`batch_data`, values zero: the FIM does not depend on them). :func:`residuals` gives the
whitened residuals and their analytic Jacobian; :func:`fisher_information` is ``JᵀJ``, i.e.
``Σ_k J_kᵀ Σ_k⁻¹ J_k`` (clavard2013 eq. 11, eqs. 12–16; docs/errata.md). The batch CRLB
(:mod:`tmaplan.bounds.crlb`), the MLE and its covariance (:mod:`tmaplan.estimators.mle`) and the
evaluation's CRLB reference (:mod:`tmaplan.evaluation.tracking`) all use these.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from tmaplan.errors import ArgumentError, finite_real
from tmaplan.geometry import bearing_of, range_of, wrap_angle, wrap_half_angle
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.target import circle_parameters, initial_velocity
from tmaplan.models.tracks import (
    ModelKind,
    TrackModel,
    bearing_rows,
    constant_turn_model,
    cv_model,
    multi_leg_model,
    range_rate_rows,
    range_rows,
)
from tmaplan.scenario import BearingSensor, FrequencySensor, Scenario
from tmaplan.simulate import MeasurementSet

__all__ = [
    "BearingData",
    "FrequencyData",
    "Model",
    "RangeData",
    "TMAData",
    "batch_data",
    "fisher_information",
    "residuals",
    "tma_data",
    "true_parameters",
]

#: The parametrisation's name (:data:`tmaplan.models.tracks.ModelKind`).
Model = ModelKind


@dataclasses.dataclass(frozen=True, kw_only=True)
class TMAData:
    """Measurements and observer geometry of one batch (SI units).

    Attributes
    ----------
    model : {"ncv", "multi-leg", "constant-turn"}
    leg_starts : ndarray, shape (m,)
        Start times of legs 2..m+1 [s] (multi-leg).
    t0 : float
        Reference time of the ncv / multi-leg position parameters [s].
    b_times, b_values, b_sigma : ndarray, shape (nb,)
        Bearing times [s], values [rad], std [rad].
    b_obs : ndarray, shape (nb, 2)
        Observer positions at the bearing times [m].
    ambiguity : {"none", "pi"}
    r_times, r_values, r_sigma : ndarray, shape (nr,)
        Range times [s], values [m], std [m].
    r_obs : ndarray, shape (nr, 2)
    f_times : ndarray, shape (nf,)
    f_values : ndarray, shape (nf, P)
        [Hz].
    f_sigma : ndarray, shape (P,)
        [Hz].
    f_obs, f_obs_vel : ndarray, shape (nf, 2)
        Observer position [m] and instantaneous velocity [m/s].
    c : float
        Sound speed [m/s].
    turn_direction : {"either", "clockwise", "anticlockwise"}
        Known sense of turn of a constant-turn source (``scenario.estimation``); used by
        ``MLEConfig(turn_direction="auto")``.
    """

    model: Model
    leg_starts: np.ndarray
    t0: float
    b_times: np.ndarray
    b_values: np.ndarray
    b_sigma: np.ndarray
    b_obs: np.ndarray
    ambiguity: Literal["none", "pi"] = "none"
    r_times: np.ndarray
    r_values: np.ndarray
    r_sigma: np.ndarray
    r_obs: np.ndarray
    f_times: np.ndarray
    f_values: np.ndarray
    f_sigma: np.ndarray
    f_obs: np.ndarray
    f_obs_vel: np.ndarray
    c: float = 1500.0
    turn_direction: Literal["either", "clockwise", "anticlockwise"] = "either"

    @functools.cached_property
    def track(self) -> TrackModel:
        """The :class:`~tmaplan.models.tracks.TrackModel` of the parametrisation (position
        parameters at ``t0``; legs change at ``leg_starts``)."""
        if self.model == "constant-turn":
            return constant_turn_model()
        if self.model == "multi-leg":
            return multi_leg_model(tuple(float(x) for x in self.leg_starts), t_ref=self.t0)
        return cv_model(self.t0)

    @property
    def n_geom(self) -> int:
        """Number of geometric (target-track) parameters."""
        return self.track.dim

    @property
    def n_lines(self) -> int:
        """Number of frequency lines P."""
        return self.f_values.shape[1] if self.f_values.ndim == 2 else 0

    @property
    def n_params(self) -> int:
        """Geometric parameters plus one tone per line."""
        return self.n_geom + self.n_lines

    @property
    def counts(self) -> dict[str, int]:
        """Number of scalar measurements per kind."""
        return {"bearing": int(self.b_times.size), "range": int(self.r_times.size),
                "frequency": int(self.f_times.size) * self.n_lines}


# --------------------------------------------------------------------------------------------
# Measurement sets given by times and geometry (the batch CRLB's inputs)
# --------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True, kw_only=True)
class BearingData:
    """Bearing measurement times and geometry.

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s].
    observer_position : ndarray, shape (n, 2)
        [m].
    sigma : float or ndarray, shape (n,)
        Bearing noise std [rad], > 0.
    """

    times: np.ndarray
    observer_position: np.ndarray
    sigma: float | np.ndarray


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeData:
    """Range (active ping) measurement times [s], observer positions [m] and ``sigma`` [m]."""

    times: np.ndarray
    observer_position: np.ndarray
    sigma: float | np.ndarray


@dataclasses.dataclass(frozen=True, kw_only=True)
class FrequencyData:
    """Frequency-line measurements (clavard2013 eq. 3, multi-line).

    Attributes
    ----------
    times : ndarray, shape (n,)
        [s].
    observer_position, observer_velocity : ndarray, shape (n, 2)
        [m], instantaneous [m/s].
    f0 : ndarray, shape (P,)
        Emitted tones [Hz] (unknown nuisance parameters of the bound).
    sigma : ndarray, shape (P,)
        Noise std per line [Hz] (clavard2013 uses σ_fp = f_p/1000).
    c : float
        Sound speed [m/s].
    """

    times: np.ndarray
    observer_position: np.ndarray
    observer_velocity: np.ndarray
    f0: np.ndarray
    sigma: np.ndarray
    c: float = 1500.0


def _sigma(sigma: Any, n: int, field: str) -> np.ndarray:
    s = np.asarray(sigma, dtype=float)
    if s.shape not in ((), (1,), (n,)):
        raise ArgumentError(field, f"a scalar or one noise std per measurement ({n})", s.shape)
    s = np.broadcast_to(s, (n,))
    bad = ~np.isfinite(s) | (s <= 0.0)
    if np.any(bad):
        raise ArgumentError(field, "finite noise std > 0 (zero noise gives infinite "
                            "information)", float(s[np.argmax(bad)]))
    return np.array(s)


def _times_positions(times: Any, pos: Any, field: str) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(times, dtype=float).reshape(-1)
    p = np.asarray(pos, dtype=float)
    if p.shape != (t.shape[0], 2):
        raise ArgumentError(f"{field}.observer_position", f"shape ({t.shape[0]}, 2)", p.shape)
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))):
        raise ArgumentError(field, "finite times and observer positions", "nan/inf")
    return t, p


def _stack(sets: Sequence[BearingData | RangeData], field: str
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    ts, ps, ss = [np.zeros(0)], [np.zeros((0, 2))], [np.zeros(0)]
    for i, m in enumerate(sets):
        t, p = _times_positions(m.times, m.observer_position, f"{field}[{i}]")
        ts.append(t)
        ps.append(p)
        ss.append(_sigma(m.sigma, t.size, f"{field}[{i}].sigma"))
    return np.concatenate(ts), np.concatenate(ps), np.concatenate(ss)


def batch_data(track: TrackModel, *, bearings: Sequence[BearingData] = (),
               ranges: Sequence[RangeData] = (),
               frequencies: FrequencyData | None = None) -> TMAData:
    """A :class:`TMAData` from measurement times and geometry (measured values zero).

    Raises
    ------
    ArgumentError
        Non-positive or non-finite noise, mismatched shapes, NaN inputs, tones ≤ 0.
    """
    bt, bp, bs = _stack(bearings, "bearings")
    rt, rp, rs = _stack(ranges, "ranges")
    ft, fp, fv = np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2))
    fs, c = np.zeros(0), 1500.0
    if frequencies is not None and np.size(frequencies.f0):
        fd = frequencies
        ft, fp = _times_positions(fd.times, fd.observer_position, "frequencies")
        fv = np.asarray(fd.observer_velocity, float)
        if fv.shape != fp.shape or not np.all(np.isfinite(fv)):
            raise ArgumentError("frequencies.observer_velocity", f"finite, shape {fp.shape}",
                                fv.shape)
        f0 = np.asarray(fd.f0, float).reshape(-1)
        fs = np.asarray(fd.sigma, float).reshape(-1)
        if fs.shape != f0.shape:
            raise ArgumentError("frequencies.sigma", f"one std per line ({f0.size})", fs.size)
        if not (np.all(np.isfinite(f0)) and np.all(f0 > 0)):
            raise ArgumentError("frequencies.f0", "finite tones > 0 [Hz]", f0)
        finite_real("frequencies.c", fd.c, "sound speed > 0 [m/s]", lower=0.0, strict=True)
        fs, c = _sigma(fs, fs.size, "frequencies.sigma"), float(fd.c)
    return TMAData(model=track.kind, leg_starts=np.asarray(track.change_times, float),
                   t0=track.t_ref, b_times=bt, b_values=np.zeros(bt.size), b_sigma=bs,
                   b_obs=bp, r_times=rt, r_values=np.zeros(rt.size), r_sigma=rs, r_obs=rp,
                   f_times=ft, f_values=np.zeros((ft.size, fs.size)), f_sigma=fs, f_obs=fp,
                   f_obs_vel=fv, c=c)


def tma_data(scenario: Scenario, measurements: Sequence[MeasurementSet],
             observer: ObserverTrack, *, model: Model | None = None,
             frequencies: int | None = None) -> TMAData:
    """Collect the measurements of a run into a :class:`TMAData`.

    Parameters
    ----------
    scenario : Scenario
    measurements : sequence of MeasurementSet
        From :func:`tmaplan.simulate.simulate`.
    observer : ObserverTrack
    model : {"ncv", "multi-leg", "constant-turn"}, optional
        Default: from ``scenario.target.model`` (the scenario's model name).
    frequencies : int, optional
        Use only the first ``frequencies`` lines (0 = bearings only); default all.
    """
    t = scenario.target
    mdl: Model = model or t.model
    legs = np.array([leg.start for leg in t.legs], float) if mdl == "multi-leg" else np.zeros(0)
    e2 = np.zeros((0, 2))
    b = [m for m in measurements if m.kind == "bearing"]
    r = [m for m in measurements if m.kind == "range" and m.steps.size]
    f = [m for m in measurements if m.kind == "frequency"]
    amb: Literal["none", "pi"] = "none"
    if b and isinstance(bs := scenario.sensors[b[0].sensor], BearingSensor):
        amb = bs.ambiguity
    pos, vel = observer.position, observer.velocity

    def cat(ms: list[MeasurementSet], attr: str) -> np.ndarray:
        return np.concatenate([np.asarray(getattr(m, attr), float) for m in ms]) if ms \
            else np.zeros(0)

    def sig(ms: list[MeasurementSet]) -> np.ndarray:
        return np.concatenate([np.full(m.steps.size, float(m.sigma)) for m in ms]) if ms \
            else np.zeros(0)

    b_steps = np.concatenate([m.steps for m in b]).astype(int) if b else np.zeros(0, int)
    r_steps = np.concatenate([m.steps for m in r]).astype(int) if r else np.zeros(0, int)
    if f and (frequencies is None or frequencies > 0):
        fm = f[0]
        P = fm.values.shape[1] if frequencies is None else min(frequencies, fm.values.shape[1])
        sen = scenario.sensors[fm.sensor]
        f_times, f_values = fm.times, fm.values[:, :P]
        f_sigma = np.asarray(fm.sigma, float)[:P]
        c = float(sen.c) if isinstance(sen, FrequencySensor) else 1500.0
        f_obs, f_vel = pos[fm.steps], vel[fm.steps]
    else:
        f_times, f_values, f_sigma = np.zeros(0), np.zeros((0, 0)), np.zeros(0)
        f_obs, f_vel, c = e2, e2, 1500.0
    return TMAData(model=mdl, leg_starts=legs, t0=float(scenario.time.t0),
                   b_times=cat(b, "times"), b_values=cat(b, "values"), b_sigma=sig(b),
                   b_obs=pos[b_steps] if b else e2, ambiguity=amb,
                   r_times=cat(r, "times"), r_values=cat(r, "values"), r_sigma=sig(r),
                   r_obs=pos[r_steps] if r else e2,
                   f_times=np.asarray(f_times, float), f_values=np.asarray(f_values, float),
                   f_sigma=f_sigma, f_obs=f_obs, f_obs_vel=f_vel, c=c,
                   turn_direction=(scenario.estimation.turn_direction
                                   if scenario.estimation is not None and mdl == "constant-turn"
                                   else "either"))


def true_parameters(scenario: Scenario, track: TrackModel, n_lines: int = 0) -> np.ndarray:
    """The scenario's true θ in ``track``'s parametrisation, then its first ``n_lines`` tones.

    ncv / multi-leg: the position at ``track.t_ref`` and one velocity per leg of ``track``
    (the scenario's legs starting at ``track.change_times``); constant turn:
    ``[x_C, y_C, ρ_C, φ, ω]`` (clavard2013).
    """
    tgt = scenario.target
    if track.kind == "constant-turn":
        geom = np.array(circle_parameters(tgt))
    else:
        legs = tgt.legs[: len(track.change_times)]
        geom = np.concatenate([np.asarray(tgt.position, float), initial_velocity(tgt),
                               *[initial_velocity(leg) for leg in legs]])
        t0 = float(scenario.time.t0)
        if track.t_ref != t0:  # move the position parameters to t_ref
            pos, _ = dataclasses.replace(track, t_ref=t0).track(geom, np.array([track.t_ref]))
            geom = np.concatenate([pos[0], geom[2:]])
    tones = [f for s in scenario.sensors if isinstance(s, FrequencySensor) for f in s.f0]
    return np.concatenate([geom, tones[:n_lines]])


# --------------------------------------------------------------------------------------------
# Residuals and FIM
# --------------------------------------------------------------------------------------------


def residuals(data: TMAData, params: np.ndarray, *, jacobian: bool = True
              ) -> tuple[np.ndarray, np.ndarray | None]:
    """Whitened residuals ``(z − h(θ))/σ`` and their Jacobian ``∂r/∂θ``.

    Parameters
    ----------
    data : TMAData
    params : ndarray, shape (n_params,)
        Geometric parameters followed by the P tones [Hz].
    jacobian : bool

    Returns
    -------
    r : ndarray, shape (m,)
        Bearing residuals (wrapped), range residuals, frequency residuals (line-major).
    J : ndarray, shape (m, n_params) or None
        ``∂r/∂params``; the frequency rows are ``∂f_p/∂f_p = 1 − Ṙ/c`` and
        ``∇_θ f_p = −(f_p/c) ∇_θ Ṙ`` (clavard2013 eqs. 12–15).
    """
    ng = data.n_geom
    th = np.asarray(params, float)
    out_r: list[np.ndarray] = []
    out_j: list[np.ndarray] = []
    npar = data.n_params
    model = data.track

    def kin(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, Any, Any]:
        # Jacobians only when asked: the LM cost evaluations skip them (hot path).
        P, V = model.track(th[:ng], t)
        if not jacobian:
            return P, V, None, None
        dP, dV = model.jacobian(th[:ng], t)
        return P, V, dP, dV

    if data.b_times.size:
        P, _, dP, _ = kin(data.b_times)
        d = P - data.b_obs
        wrap = wrap_half_angle if data.ambiguity == "pi" else wrap_angle
        out_r.append(wrap(data.b_values - bearing_of(d)) / data.b_sigma)
        if jacobian:
            J = np.zeros((P.shape[0], npar))
            J[:, :ng] = -bearing_rows(d, dP) / data.b_sigma[:, None]
            out_j.append(J)
    if data.r_times.size:
        P, _, dP, _ = kin(data.r_times)
        d = P - data.r_obs
        out_r.append((data.r_values - range_of(d)) / data.r_sigma)
        if jacobian:
            J = np.zeros((P.shape[0], npar))
            J[:, :ng] = -range_rows(d, dP) / data.r_sigma[:, None]
            out_j.append(J)
    if data.n_lines:
        P, V, dP, dV = kin(data.f_times)
        d, w = P - data.f_obs, V - data.f_obs_vel
        if jacobian:
            rdot, ddot = range_rate_rows(d, w, dP, dV)
        else:
            rdot = np.sum(d * w, axis=-1) / range_of(d)
        a = 1.0 - rdot / data.c
        for p in range(data.n_lines):  # loop over the (≤ 4) lines, vectorised over time
            fp = th[ng + p]
            s = data.f_sigma[p]
            out_r.append((data.f_values[:, p] - fp * a) / s)
            if jacobian:
                J = np.zeros((a.shape[0], npar))
                J[:, :ng] = fp * ddot / data.c / s
                J[:, ng + p] = -a / s
                out_j.append(J)
    r = np.concatenate(out_r) if out_r else np.zeros(0)
    return r, (np.vstack(out_j) if jacobian and out_j else np.zeros((0, npar)) if jacobian
               else None)


def fisher_information(data: TMAData, params: np.ndarray) -> np.ndarray:
    """Batch FIM ``JᵀJ`` of the whitened residuals at ``params``, shape (n_params, n_params).

    At the true parameters this is the CRLB information of clavard2013 (eq. 11, eqs. 12–16);
    its inverse is the CRLB including the nuisance tones.
    """
    _, J = residuals(data, params)
    if J is None:  # pragma: no cover - residuals(jacobian=True) always returns J
        raise RuntimeError("no Jacobian")
    return J.T @ J
