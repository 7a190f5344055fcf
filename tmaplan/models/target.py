"""Target motion models: nearly constant velocity, multi-leg, constant turn (clavard2013).

State order everywhere: ``[x, y, v_x, v_y]`` (x East, y North), SI units.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.errors import ScenarioError
from tmaplan.geometry import velocity_from_course
from tmaplan.scenario import Target, TimeGrid

__all__ = [
    "circle_parameters",
    "circle_state",
    "constant_turn_state",
    "initial_velocity",
    "ncv_matrices",
    "piecewise_velocity_track",
    "target_track",
]


def ncv_matrices(dt: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """Transition and process-noise matrices of the nearly-constant-velocity model.

    ``F = [[I, dt·I], [0, I]]``, ``Q = q·[[dt³/3, dt²/2], [dt²/2, dt]] ⊗ I₂`` (docs/conventions.md;
    brehard2005 with σ_max² = q).

    Parameters
    ----------
    dt : float
        Step [s].
    q : float
        White-acceleration intensity [m²/s³].

    Returns
    -------
    F, Q : ndarray, shape (4, 4)
    """
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    sigma = np.array([[dt**3 / 3.0, dt**2 / 2.0], [dt**2 / 2.0, dt]])
    return F, q * np.kron(sigma, np.eye(2))


def constant_turn_state(
    centre: ArrayLike, radius: ArrayLike, phase: ArrayLike, omega: ArrayLike, t: ArrayLike
) -> np.ndarray:
    """Position and velocity of clavard2013's constant-turn source.

    ``P(t) = P_C + ρ_C [sin(ωt+φ), cos(ωt+φ)]``, ``V(t) = ρ_C ω [cos(ωt+φ), −sin(ωt+φ)]``
    (clavard2013; ω > 0 clockwise).

    Parameters
    ----------
    centre : array_like, shape (2,) or (..., 2)
        Circle centre [m].
    radius : float or ndarray
        ρ_C [m].
    phase : float or ndarray
        φ [rad], clockwise from North.
    omega : float or ndarray
        ω [rad/s].
    t : ndarray, shape (n,)
        Times [s] since the start of the motion.

    Returns
    -------
    ndarray, shape (..., n, 4)
        ``[x, y, v_x, v_y]`` per time.
    """
    tt = np.asarray(t, dtype=float)
    ctr = np.asarray(centre, dtype=float)
    rho = np.asarray(radius, dtype=float)[..., None]
    w = np.asarray(omega, dtype=float)[..., None]
    u = w * tt + np.asarray(phase, dtype=float)[..., None]
    s, c = np.sin(u), np.cos(u)
    out = np.stack(
        [
            ctr[..., 0, None] + rho * s,
            ctr[..., 1, None] + rho * c,
            rho * w * c,
            -rho * w * s,
        ],
        axis=-1,
    )
    return out


def circle_parameters(target: Target) -> tuple[float, float, float, float, float]:
    """``(x_C, y_C, ρ_C, φ, ω)`` [m, m, m, rad, rad/s] of a constant-turn target."""
    c, r, phi, w = target.centre, target.radius, target.phase, target.omega
    if c is None or r is None or phi is None or w is None:
        raise ScenarioError("target", "centre, radius, phase and omega (constant-turn model)",
                            "a missing one")
    return float(c[0]), float(c[1]), float(r), float(phi), float(w)


def circle_state(target: Target, t: ArrayLike) -> np.ndarray:
    """:func:`constant_turn_state` of a constant-turn :class:`~tmaplan.scenario.Target`."""
    cx, cy, r, phi, w = circle_parameters(target)
    return constant_turn_state((cx, cy), r, phi, w, t)


def initial_velocity(obj: object) -> np.ndarray:
    """Velocity (v_x, v_y) [m/s] of a dataclass giving ``velocity`` or ``course``/``speed``."""
    v = getattr(obj, "velocity", None)
    if v is not None:
        return np.asarray(v, dtype=float)
    return velocity_from_course(float(obj.speed), float(obj.course))  # type: ignore[attr-defined]


def piecewise_velocity_track(
    position0: np.ndarray,
    velocity0: np.ndarray,
    change_times: np.ndarray,
    velocities: np.ndarray,
    times: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Exact positions of a piecewise-constant-velocity track on a time grid.

    Parameters
    ----------
    position0, velocity0 : ndarray, shape (2,)
        State at ``times[0]``.
    change_times : ndarray, shape (m,)
        Absolute times at which the velocity becomes ``velocities[i]``.
    velocities : ndarray, shape (m, 2)
    times : ndarray, shape (n,)
        Grid instants.

    Returns
    -------
    position : ndarray, shape (n, 2)
    velocity : ndarray, shape (n, 2)
        Instantaneous velocity at each instant (the new leg's from its start time on).
    """
    times = np.asarray(times, dtype=float)
    knots = np.concatenate([[times[0]], np.asarray(change_times, dtype=float)])
    vels = np.vstack([np.asarray(velocity0, float)[None], np.asarray(velocities, float)
                      .reshape(-1, 2)])
    # position at each knot
    seg = np.diff(knots)
    knot_pos = np.asarray(position0, float) + np.vstack(
        [np.zeros((1, 2)), np.cumsum(seg[:, None] * vels[:-1], axis=0)]
    )
    idx = np.searchsorted(knots, times, side="right") - 1
    idx = np.clip(idx, 0, len(knots) - 1)
    position = knot_pos[idx] + (times - knots[idx])[:, None] * vels[idx]
    return position, vels[idx]


def target_track(target: Target, grid: TimeGrid, rng: np.random.Generator | None) -> np.ndarray:
    """Simulate the true target state on the grid.

    Parameters
    ----------
    target : Target
    grid : TimeGrid
    rng : numpy.random.Generator, optional
        Needed when ``target.q > 0``; ``None`` gives the noise-free track.

    Returns
    -------
    ndarray, shape (K + 1, 4)
        ``[x, y, v_x, v_y]`` [m, m/s].
    """
    times = grid.times
    if target.model == "constant-turn":
        return circle_state(target, times)
    p0 = np.asarray(target.position, float)
    v0 = initial_velocity(target)
    if target.model == "multi-leg":
        ct = np.array([leg.start for leg in target.legs])
        vs = np.array([initial_velocity(leg) for leg in target.legs])
    else:
        ct, vs = np.zeros(0), np.zeros((0, 2))
    pos, vel = piecewise_velocity_track(p0, v0, ct, vs, times)
    x = np.hstack([pos, vel])
    if target.q > 0.0 and rng is not None:
        F, Q = ncv_matrices(grid.dt, target.q)
        w = rng.multivariate_normal(np.zeros(4), Q, size=grid.n_steps, method="cholesky")
        # noise accumulates through the CV dynamics: e_{k+1} = F e_k + w_k
        e = np.zeros((grid.n_steps + 1, 4))
        for k in range(grid.n_steps):  # sequential recursion over time, not over samples
            e[k + 1] = F @ e[k] + w[k]
        x = x + e
    return x
