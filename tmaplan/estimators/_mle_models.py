"""Measurement model of the batch maximum-likelihood TMA (file 002, Clavard et al. 2013).

Role: everything :mod:`tmaplan.estimators.mle` needs to *evaluate* a parameter vector, kept
apart from the search (coarse grid, Gauss–Newton, Levenberg–Marquardt, acceptance test) that
lives there:

* :class:`TMAData` / :func:`tma_data`: the measurements of a run and the observer geometry;
* :func:`kinematics`: target position and velocity of the cv, multi-leg and constant-turn
  parametrisations (file 002's ``Z = [x_C, y_C, ρ_C, φ, ω]``, L108, L141) with analytic
  Jacobians;
* :func:`residuals`: whitened bearing, range and frequency-line residuals (unknown tones as
  nuisance parameters, file 002 eq. 3, §IV) and their Jacobian (file 002 §1.6 of the notes);
* :func:`fisher_information` (file 002 eqs. 11–16) and :func:`acceptance_threshold`
  (file 002 L265, L577, generalised as in the :mod:`~tmaplan.estimators.mle` notes);
* :func:`state_track`: absolute states and their covariance by the delta method.

The public names are re-exported by :mod:`tmaplan.estimators.mle`; import them from there.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

import numpy as np

from tmaplan.geometry import wrap_angle, wrap_half_angle

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
    mdl: Model = model or ("cv" if t.model == "ncv" else t.model)  # type: ignore[assignment]
    legs = np.array([leg.start for leg in t.legs], float) if mdl == "multi-leg" else np.zeros(0)
    e2 = np.zeros((0, 2))
    b = [m for m in measurements if m.kind == "bearing"]
    r = [m for m in measurements if m.kind == "range" and m.steps.size]
    f = [m for m in measurements if m.kind == "frequency"]
    amb = "none"
    if b:
        amb = scenario.sensors[b[0].sensor].ambiguity
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
        f_obs, f_vel, c = pos[fm.steps], vel[fm.steps], float(sen.c)
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
    t = np.asarray(t, float)
    n = t.shape[0]
    th = np.asarray(theta, float)
    if data.model == "constant-turn":
        xc, yc, rho, phi, om = th[:5]
        u = om * t + phi
        s, c = np.sin(u), np.cos(u)
        P = np.stack([xc + rho * s, yc + rho * c], axis=-1)
        V = np.stack([rho * om * c, -rho * om * s], axis=-1)
        dP = np.zeros((n, 2, 5))
        dV = np.zeros((n, 2, 5))
        dP[:, 0, 0] = 1.0
        dP[:, 1, 1] = 1.0
        dP[:, 0, 2], dP[:, 1, 2] = s, c
        dP[:, 0, 3], dP[:, 1, 3] = rho * c, -rho * s
        dP[:, 0, 4], dP[:, 1, 4] = t * rho * c, -t * rho * s
        dV[:, 0, 2], dV[:, 1, 2] = om * c, -om * s
        dV[:, 0, 3], dV[:, 1, 3] = -rho * om * s, -rho * om * c
        dV[:, 0, 4] = rho * c - rho * om * t * s
        dV[:, 1, 4] = -rho * s - rho * om * t * c
        return P, V, dP, dV
    knots = np.concatenate([[data.t0], data.leg_starts]) if data.model == "multi-leg" \
        else np.array([data.t0])
    m = knots.size
    ends = np.concatenate([knots[1:], [np.inf]])
    # time spent in each leg up to t (legs before t0 are not modelled)
    overlap = np.clip(np.minimum(t[:, None], ends[None]) - knots[None], 0.0, None)
    if data.model == "cv":
        overlap = (t - data.t0)[:, None]
    vel = th[2:].reshape(m, 2)
    seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, m - 1)
    P = th[:2] + overlap @ vel
    V = vel[seg]
    dP = np.zeros((n, 2, 2 + 2 * m))
    dV = np.zeros((n, 2, 2 + 2 * m))
    dP[:, 0, 0] = dP[:, 1, 1] = 1.0
    for j in range(m):
        dP[:, 0, 2 + 2 * j] = overlap[:, j]
        dP[:, 1, 3 + 2 * j] = overlap[:, j]
        dV[:, 0, 2 + 2 * j] = seg == j
        dV[:, 1, 3 + 2 * j] = seg == j
    return P, V, dP, dV


def _positions(data: TMAData, th: np.ndarray, t: np.ndarray, *, velocity: bool = False
               ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Batched positions (and velocities) for many parameter vectors, shape (G, n, 2)."""
    if data.model == "constant-turn":
        xc, yc, rho, phi, om = (th[:, i, None] for i in range(5))
        u = om * t + phi
        s, c = np.sin(u), np.cos(u)
        P = np.stack([xc + rho * s, yc + rho * c], -1)
        V = np.stack([rho * om * c, -rho * om * s], -1)
    else:
        knots = np.concatenate([[data.t0], data.leg_starts]) if data.model == "multi-leg" \
            else np.array([data.t0])
        ends = np.concatenate([knots[1:], [np.inf]])
        ov = np.clip(np.minimum(t[:, None], ends[None]) - knots[None], 0.0, None)
        if data.model == "cv":
            ov = (t - data.t0)[:, None]
        vel = th[:, 2:].reshape(th.shape[0], -1, 2)
        P = th[:, None, :2] + np.einsum("nj,gjk->gnk", ov, vel)
        seg = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 1)
        V = vel[:, seg]
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
    if data.b_times.size:
        P, _, dP, _ = kinematics(data, th[:ng], data.b_times)
        d = P - data.b_obs
        R2 = d[:, 0] ** 2 + d[:, 1] ** 2
        beta = np.arctan2(d[:, 0], d[:, 1])
        wrap = wrap_half_angle if data.ambiguity == "pi" else wrap_angle
        out_r.append(wrap(data.b_values - beta) / data.b_sigma)
        if jacobian:
            db = (d[:, 1, None] * dP[:, 0] - d[:, 0, None] * dP[:, 1]) / R2[:, None]
            J = np.zeros((P.shape[0], npar))
            J[:, :ng] = -db / data.b_sigma[:, None]
            out_j.append(J)
    if data.r_times.size:
        P, _, dP, _ = kinematics(data, th[:ng], data.r_times)
        d = P - data.r_obs
        R = np.hypot(d[:, 0], d[:, 1])
        out_r.append((data.r_values - R) / data.r_sigma)
        if jacobian:
            dR = (d[:, 0, None] * dP[:, 0] + d[:, 1, None] * dP[:, 1]) / R[:, None]
            J = np.zeros((P.shape[0], npar))
            J[:, :ng] = -dR / data.r_sigma[:, None]
            out_j.append(J)
    if data.n_lines:
        P, V, dP, dV = kinematics(data, th[:ng], data.f_times)
        d = P - data.f_obs
        v = V - data.f_obs_vel
        R = np.hypot(d[:, 0], d[:, 1])
        rdot = (d[:, 0] * v[:, 0] + d[:, 1] * v[:, 1]) / R
        a = 1.0 - rdot / data.c
        if jacobian:
            ddot = ((v[:, 0, None] * dP[:, 0] + v[:, 1, None] * dP[:, 1]
                     + d[:, 0, None] * dV[:, 0] + d[:, 1, None] * dV[:, 1]) / R[:, None]
                    - rdot[:, None] * (d[:, 0, None] * dP[:, 0] + d[:, 1, None] * dP[:, 1])
                    / (R * R)[:, None])
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

    At the true parameters this is the CRLB information of file 002 (eqs. 11–16, §3.1–3.2 of
    the notes); its inverse is the CRLB including the nuisance tones.
    """
    _, J = residuals(data, params)
    assert J is not None
    return J.T @ J


def acceptance_threshold(data: TMAData) -> float:
    """File 002's acceptance threshold (L265, L577), generalised as in the module notes."""
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
