"""Deterministic target-track models and measurement Jacobians (batch CRLB and batch MLE).

The one implementation of the cv / multi-leg / constant-turn parametrisations: the batch CRLB
(:mod:`tmaplan.bounds.crlb`) and the batch maximum-likelihood estimator
(:mod:`tmaplan.estimators.mle`) both evaluate tracks and Jacobians here.

A *track model* maps a parameter vector ``θ`` to the target position and velocity at given
times, with analytic Jacobians ``∂p/∂θ`` and ``∂v/∂θ``:

* ``cv``            — constant velocity, ``θ = [x, y, v_x, v_y]`` at a reference time.
* ``multi-leg``     — piecewise constant velocity with known change times,
  ``θ = [x, y, v_x¹, v_y¹, …, v_x^ℓ, v_y^ℓ]`` (lecadre1997 eq. 24; position at the
  reference time, then one velocity per leg; ``cv`` is the one-leg case).
* ``constant-turn`` — clavard2013's circle ``θ = [x_C, y_C, ρ_C, φ, ω]``.

Measurement Jacobians (rows ``∂h_k/∂θ``) are formed by the chain rule from the relative
position ``d = p − p_obs`` and velocity ``w = v − v_obs``:

* bearing ``β = atan2(d_x, d_y)``: ``∂β/∂d = [d_y, −d_x]/R²`` (clavard2013);
* range ``R``: ``∂R/∂d = d/R``;
* range rate ``Ṙ = d·w/R``: ``∂Ṙ/∂d = (w − Ṙ d/R)/R``, ``∂Ṙ/∂w = d/R``.

All arrays are SI (m, s, rad, m/s). Time loops are avoided: everything is vectorised over
the measurement times.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from typing import Literal

import numpy as np

from tmaplan.errors import ArgumentError
from tmaplan.geometry import range_of

__all__ = [
    "TrackModel",
    "bearing_rows",
    "constant_turn_model",
    "cv_model",
    "multi_leg_model",
    "range_rate_rows",
    "range_rows",
    "relative_kinematics",
]

ModelKind = Literal["cv", "multi-leg", "constant-turn"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class TrackModel:
    """A deterministic target-track parametrisation.

    Attributes
    ----------
    kind : {"cv", "multi-leg", "constant-turn"}
    names : tuple of str
        Parameter names, in order.
    units : tuple of str
        SI unit of each parameter.
    t_ref : float
        Reference time [s] of the position parameters (cv, multi-leg); unused for
        constant-turn (whose phase refers to t = 0 of the scenario clock, clavard2013).
    change_times : tuple of float
        Velocity change times [s] (multi-leg), increasing; leg j+1 starts at
        ``change_times[j]``.
    """

    kind: ModelKind
    names: tuple[str, ...]
    units: tuple[str, ...]
    t_ref: float = 0.0
    change_times: tuple[float, ...] = ()

    @property
    def dim(self) -> int:
        """Number of parameters."""
        return len(self.names)

    # -- kinematics ----------------------------------------------------------------------
    def _leg_durations(self, t: np.ndarray) -> np.ndarray:
        """Signed time spent on each leg between t_ref and t, shape (n, ℓ) [s]."""
        edges = np.concatenate([[-np.inf], np.asarray(self.change_times, float), [np.inf]])
        lo, hi = edges[:-1], edges[1:]
        clip_t = np.clip(t[:, None], lo, hi)
        clip_ref = np.clip(self.t_ref, lo, hi)
        d = clip_t - clip_ref
        return np.where(np.isfinite(d), d, 0.0)

    def track(self, theta: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Target position and velocity.

        Parameters
        ----------
        theta : ndarray, shape (dim,)
        t : ndarray, shape (n,)
            Times [s].

        Returns
        -------
        position, velocity : ndarray, shape (n, 2)
            [m], [m/s].
        """
        theta = np.asarray(theta, float)
        t = np.asarray(t, float)
        if self.kind == "constant-turn":
            xc, yc, rho, phi, om = theta
            u = om * t + phi
            s, c = np.sin(u), np.cos(u)
            pos = np.stack([xc + rho * s, yc + rho * c], axis=-1)
            vel = np.stack([rho * om * c, -rho * om * s], axis=-1)
            return pos, vel
        tau = self._leg_durations(t)  # (n, ℓ)
        v = theta[2:].reshape(-1, 2)  # (ℓ, 2)
        pos = theta[:2] + tau @ v
        leg = np.searchsorted(np.asarray(self.change_times, float), t, side="right")
        return pos, v[leg]

    def track_many(self, thetas: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities for many parameter vectors at once (coarse grids).

        Parameters
        ----------
        thetas : ndarray, shape (G, dim)
        t : ndarray, shape (n,)
            Times [s].

        Returns
        -------
        position, velocity : ndarray, shape (G, n, 2)
            [m], [m/s].
        """
        th = np.asarray(thetas, float)
        t = np.asarray(t, float)
        if self.kind == "constant-turn":
            xc, yc, rho, phi, om = (th[:, i, None] for i in range(5))
            u = om * t + phi
            s, c = np.sin(u), np.cos(u)
            return (np.stack([xc + rho * s, yc + rho * c], -1),
                    np.stack([rho * om * c, -rho * om * s], -1))
        tau = self._leg_durations(t)  # (n, ℓ)
        v = th[:, 2:].reshape(th.shape[0], -1, 2)  # (G, ℓ, 2)
        pos = th[:, None, :2] + np.einsum("nj,gjk->gnk", tau, v)
        leg = np.searchsorted(np.asarray(self.change_times, float), t, side="right")
        return pos, v[:, leg]

    def jacobian(self, theta: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Analytic Jacobians of position and velocity with respect to the parameters.

        Returns
        -------
        dpos, dvel : ndarray, shape (n, 2, dim)
            ``dpos[k, i, j] = ∂p_i(t_k)/∂θ_j``.
        """
        theta = np.asarray(theta, float)
        t = np.asarray(t, float)
        n = t.shape[0]
        if self.kind == "constant-turn":
            _, _, rho, phi, om = theta
            u = om * t + phi
            s, c = np.sin(u), np.cos(u)
            one, zero = np.ones(n), np.zeros(n)
            dpos = np.stack([
                np.stack([one, zero, s, rho * c, t * rho * c], axis=-1),
                np.stack([zero, one, c, -rho * s, -t * rho * s], axis=-1),
            ], axis=1)
            dvel = np.stack([
                np.stack([zero, zero, om * c, -rho * om * s, rho * c - t * rho * om * s],
                         axis=-1),
                np.stack([zero, zero, -om * s, -rho * om * c, -rho * s - t * rho * om * c],
                         axis=-1),
            ], axis=1)
            return dpos, dvel
        tau = self._leg_durations(t)  # (n, ℓ)
        n_legs = tau.shape[1]
        eye = np.eye(2)
        dpos = np.zeros((n, 2, self.dim))
        dpos[:, :, :2] = eye
        dpos[:, :, 2:] = (tau[:, None, :, None] * eye[None, :, None, :]).reshape(n, 2,
                                                                                 2 * n_legs)
        leg = np.searchsorted(np.asarray(self.change_times, float), t, side="right")
        dvel = np.zeros((n, 2, self.dim))
        dvel[np.arange(n), 0, 2 + 2 * leg] = 1.0
        dvel[np.arange(n), 1, 3 + 2 * leg] = 1.0
        return dpos, dvel


def cv_model(t_ref: float = 0.0) -> TrackModel:
    """Constant-velocity model ``[x, y, v_x, v_y]`` at ``t_ref`` [s]."""
    return TrackModel(kind="cv", names=("x", "y", "vx", "vy"), units=("m", "m", "m/s", "m/s"),
                      t_ref=float(t_ref))


def multi_leg_model(change_times: Sequence[float], t_ref: float = 0.0) -> TrackModel:
    """Multi-leg model with known velocity change times [s] (lecadre1997 eq. 24).

    Parameters are the position at ``t_ref`` and one velocity per leg.
    """
    ct = tuple(float(x) for x in change_times)
    if any(b <= a for a, b in itertools.pairwise(ct)) or not np.all(np.isfinite(ct)):
        raise ArgumentError("change_times", "finite, strictly increasing times [s]", ct)
    names = ["x", "y"]
    for j in range(len(ct) + 1):
        names += [f"vx[{j}]", f"vy[{j}]"]
    units = ("m", "m") + ("m/s",) * (2 * len(ct) + 2)
    if not ct:
        return cv_model(t_ref)
    return TrackModel(kind="multi-leg", names=tuple(names), units=units, t_ref=float(t_ref),
                      change_times=ct)


def constant_turn_model() -> TrackModel:
    """clavard2013's constant-turn model ``Z = [x_C, y_C, ρ_C, φ, ω]``."""
    return TrackModel(kind="constant-turn", names=("xc", "yc", "radius", "phase", "omega"),
                      units=("m", "m", "m", "rad", "rad/s"))


def relative_kinematics(
    model: TrackModel, theta: np.ndarray, t: np.ndarray, observer_position: np.ndarray,
    observer_velocity: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relative position/velocity and their parameter Jacobians at times ``t``.

    Returns
    -------
    d, w : ndarray, shape (n, 2)
        Target − observer position [m] and velocity [m/s] (``w`` uses zero observer
        velocity if none is given).
    dpos, dvel : ndarray, shape (n, 2, dim)
    """
    pos, vel = model.track(theta, t)
    dpos, dvel = model.jacobian(theta, t)
    d = pos - np.asarray(observer_position, float)
    w = vel - (0.0 if observer_velocity is None else np.asarray(observer_velocity, float))
    return d, w, dpos, dvel


def bearing_rows(d: np.ndarray, dpos: np.ndarray) -> np.ndarray:
    """Rows ``∂β_k/∂θ``, shape (n, dim), for ``β = atan2(d_x, d_y)``."""
    r2 = np.sum(d * d, axis=-1)
    g = np.stack([d[:, 1], -d[:, 0]], axis=-1) / r2[:, None]
    return np.einsum("ni,nij->nj", g, dpos)


def range_rows(d: np.ndarray, dpos: np.ndarray) -> np.ndarray:
    """Rows ``∂R_k/∂θ``, shape (n, dim)."""
    r = range_of(d)
    return np.einsum("ni,nij->nj", d / r[:, None], dpos)


def range_rate_rows(d: np.ndarray, w: np.ndarray, dpos: np.ndarray,
                    dvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Range rate ``Ṙ_k`` [m/s], shape (n,), and its rows ``∂Ṙ_k/∂θ``, shape (n, dim)."""
    r = range_of(d)
    u = d / r[:, None]
    rdot = np.sum(u * w, axis=-1)
    gp = (w - rdot[:, None] * u) / r[:, None]
    return rdot, np.einsum("ni,nij->nj", gp, dpos) + np.einsum("ni,nij->nj", u, dvel)
