"""Measurement model of the batch maximum-likelihood TMA (clavard2013, Clavard et al. 2013).

Role: everything :mod:`tmaplan.estimators.mle` needs to *evaluate* a parameter vector, kept
apart from the search (coarse grid, Gauss–Newton, Levenberg–Marquardt, acceptance test) that
lives there:

* :class:`TMAData` / :func:`tma_data`: the measurements of a run and the observer geometry;
* :func:`kinematics`: target position and velocity of the cv, multi-leg and constant-turn
  parametrisations (clavard2013's ``Z = [x_C, y_C, ρ_C, φ, ω]``) with analytic
  Jacobians, from :mod:`tmaplan.models.tracks` (the same models as the batch CRLB);
* :func:`residuals`: whitened bearing, range and frequency-line residuals (unknown tones as
  nuisance parameters, clavard2013 eq. 3, §IV) and their Jacobian (clavard2013);
* :func:`fisher_information` (clavard2013 eqs. 11–16) and :func:`acceptance_threshold`
  (clavard2013, generalised as in the :mod:`~tmaplan.estimators.mle` notes);
* :func:`state_track`: absolute states and their covariance by the delta method.

The public names are re-exported by :mod:`tmaplan.estimators.mle`; import them from there.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from tmaplan.geometry import bearing_of, range_of, wrap_angle, wrap_half_angle
from tmaplan.models.tracks import (
    TrackModel,
    bearing_rows,
    constant_turn_model,
    cv_model,
    multi_leg_model,
    range_rate_rows,
    range_rows,
)
from tmaplan.scenario import BearingSensor, FrequencySensor

if TYPE_CHECKING:
    from tmaplan.models.observer import ObserverTrack
    from tmaplan.scenario import Scenario
    from tmaplan.simulate import MeasurementSet

__all__ = [
    "Model",
    "TMAData",
    "acceptance_threshold",
    "fisher_information",
    "kinematics",
    "residuals",
    "state_track",
    "tma_data",
    "track_model",
]

Model = Literal["cv", "multi-leg", "constant-turn"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class TMAData:
    """Measurements and observer geometry for a batch estimate (SI units).

    Attributes
    ----------
    model : {"cv", "multi-leg", "constant-turn"}
    leg_starts : ndarray, shape (m,)
        Start times of legs 2..m+1 [s] (multi-leg).
    t0 : float
        Reference time of the cv / multi-leg initial position [s].
    b_times, b_values, b_sigma : ndarray, shape (nb,)
        Bearing times [s], values [rad], std [rad].
    b_obs : ndarray, shape (nb, 2)
        Observer positions at the bearing times [m].
    ambiguity : {"none", "pi"}
    r_times, r_values, r_sigma : ndarray, shape (nr,)
    r_obs : ndarray, shape (nr, 2)
    f_times : ndarray, shape (nf,)
    f_values : ndarray, shape (nf, P)
        [Hz].
    f_sigma : ndarray, shape (P,)
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

    @property
    def n_geom(self) -> int:
        """Number of geometric (target-track) parameters."""
        return {"cv": 4, "constant-turn": 5}.get(self.model, 2 + 2 * (self.leg_starts.size + 1))

    @property
    def n_lines(self) -> int:
        """Number of frequency lines P."""
        return self.f_values.shape[1] if self.f_values.ndim == 2 else 0

    @property
    def n_params(self) -> int:
        """Geometric parameters plus one tone per line."""
        return self.n_geom + self.n_lines


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
    model : {"cv", "multi-leg", "constant-turn"}, optional
        Default: from ``scenario.target.model`` ("ncv" → "cv").
    frequencies : int, optional
        Use only the first ``frequencies`` lines (0 = bearings only); default all.
    """
    t = scenario.target
    mdl: Model = model or ("cv" if t.model == "ncv" else t.model)
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


# --------------------------------------------------------------------------------------------
# Kinematics and residuals
# --------------------------------------------------------------------------------------------


def track_model(data: TMAData) -> TrackModel:
    """The :class:`~tmaplan.models.tracks.TrackModel` of the data's parametrisation
    (position parameters at ``data.t0``; legs change at ``data.leg_starts``)."""
    if data.model == "constant-turn":
        return constant_turn_model()
    if data.model == "multi-leg":
        return multi_leg_model(tuple(float(x) for x in data.leg_starts), t_ref=data.t0)
    return cv_model(data.t0)


def kinematics(data: TMAData, theta: np.ndarray, t: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Target position and velocity and their Jacobians w.r.t. the geometric parameters.

    Parameters
    ----------
    data : TMAData
    theta : ndarray, shape (n_geom,)
    t : ndarray, shape (n,)
        Times [s].

    Returns
    -------
    P, V : ndarray, shape (n, 2)
        [m], [m/s].
    dP, dV : ndarray, shape (n, 2, n_geom)
    """
    model = track_model(data)
    th = np.asarray(theta, float)[: data.n_geom]
    t = np.asarray(t, float)
    P, V = model.track(th, t)
    dP, dV = model.jacobian(th, t)
    return P, V, dP, dV


def _positions(data: TMAData, th: np.ndarray, t: np.ndarray, *, velocity: bool = False
               ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Batched positions (and velocities) for many parameter vectors, shape (G, n, 2)."""
    P, V = track_model(data).track_many(np.asarray(th, float)[:, : data.n_geom], t)
    return (P, V) if velocity else P


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
        ``∂r/∂params``.
    """
    ng = data.n_geom
    th = np.asarray(params, float)
    out_r: list[np.ndarray] = []
    out_j: list[np.ndarray] = []
    npar = data.n_params
    model = track_model(data)

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
        beta = bearing_of(d)
        wrap = wrap_half_angle if data.ambiguity == "pi" else wrap_angle
        out_r.append(wrap(data.b_values - beta) / data.b_sigma)
        if jacobian:
            J = np.zeros((P.shape[0], npar))
            J[:, :ng] = -bearing_rows(d, dP) / data.b_sigma[:, None]
            out_j.append(J)
    if data.r_times.size:
        P, _, dP, _ = kin(data.r_times)
        d = P - data.r_obs
        R = range_of(d)
        out_r.append((data.r_values - R) / data.r_sigma)
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
        for p in range(data.n_lines):
            fp = th[ng + p]
            s = data.f_sigma[p]
            out_r.append((data.f_values[:, p] - fp * a) / s)
            if jacobian:
                J = np.zeros((a.shape[0], npar))
                J[:, :ng] = fp * ddot / data.c / s
                J[:, ng + p] = -a / s
                out_j.append(J)
    r = np.concatenate(out_r) if out_r else np.zeros(0)
    return r, (np.vstack(out_j) if jacobian and out_j else None)


def fisher_information(data: TMAData, params: np.ndarray) -> np.ndarray:
    """FIM ``J'J`` of the whitened residuals at ``params``, shape (n_params, n_params).

    At the true parameters this is the CRLB information of clavard2013 (eqs. 11–16, §3.1–3.2 of
    the notes); its inverse is the CRLB including the nuisance tones.
    """
    _, J = residuals(data, params)
    assert J is not None
    return J.T @ J


def acceptance_threshold(data: TMAData) -> float:
    """clavard2013's acceptance threshold, generalised as in the module notes."""
    ng = data.n_geom
    dofs = []
    if data.b_times.size:
        dofs.append(data.b_times.size - ng)
    if data.r_times.size:
        dofs.append(data.r_times.size - ng)
    for _ in range(data.n_lines):
        dofs.append(data.f_times.size - ng - 1)
    d = np.maximum(np.asarray(dofs, float), 1.0)
    return float(d.sum() + 3.0 * np.sqrt(2.0 * d).sum())


def state_track(data: TMAData, params: np.ndarray, covariance: np.ndarray | None,
                times: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Absolute target states ``[x, y, v_x, v_y]`` implied by the parameters, and their
    covariance by the delta method.

    Returns
    -------
    states : ndarray, shape (n, 4)
    covs : ndarray, shape (n, 4, 4) or None
    """
    ng = data.n_geom
    P, V, dP, dV = kinematics(data, np.asarray(params)[:ng], np.asarray(times, float))
    S = np.concatenate([P, V], axis=1)
    if covariance is None:
        return S, None
    J = np.concatenate([dP, dV], axis=1)  # (n, 4, ng)
    C = np.asarray(covariance)[:ng, :ng]
    return S, J @ C @ J.transpose(0, 2, 1)


def _check_fd(data: TMAData, params: np.ndarray, h: float = 1e-6) -> float:  # pragma: no cover
    """Max relative difference between the analytic and a central-difference Jacobian."""
    _, J = residuals(data, params)
    assert J is not None
    Jn = np.zeros_like(J)
    for i in range(params.size):
        e = np.zeros_like(params)
        e[i] = h * max(1.0, abs(params[i]))
        Jn[:, i] = (residuals(data, params + e, jacobian=False)[0]
                    - residuals(data, params - e, jacobian=False)[0]) / (2 * e[i])
    return float(np.max(np.abs(J - Jn)) / max(np.max(np.abs(J)), 1e-300))
