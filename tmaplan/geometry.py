"""Angle conventions and coordinate maps: the single home of both.

Conventions (docs/conventions.md)
---------------------------------
* Frame: x = East, y = North, metres.
* Bearings, courses and headings are measured from North, clockwise:
  ``β = atan2(Δx, Δy)`` in (−π, π] rad.
* Relative state ``X = target − observer = [r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s).
* Log-polar coordinates (LPC, brehard2005 eq. 6–8): ``Y = [β, ln r, β̇, ṙ/r]``
  (rad, ln m, rad/s, 1/s). The full-circle bearing is used, so ``lpc_to_cart`` needs no
  ± branch; ``ambiguity="pi"`` reproduces the paper's ``arctan(r_x/r_y)``.
* Modified polar coordinates (MP, brehard2004 eq. 5, its order): ``Y = [β̇, ṙ/r, β, 1/r]``
  (rad/s, 1/s, rad, 1/m).

Every function is vectorised over leading dimensions: states have shape ``(..., 4)``,
Jacobians ``(..., 4, 4)`` with ``J[..., i, j] = ∂out_i/∂in_j``. Scalar inputs give scalar
(numpy float) outputs. Functions that divide by the range raise :class:`ValueError` when
any range is zero (observer at the target) instead of returning inf or nan.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "Ambiguity",
    "angle_diff",
    "bearing_of",
    "cart_to_lpc",
    "cart_to_mp",
    "course_speed",
    "jacobian_cart_wrt_lpc",
    "jacobian_cart_wrt_lpc_from_cart",
    "jacobian_cart_wrt_mp",
    "jacobian_lpc_wrt_cart",
    "jacobian_mp_wrt_cart",
    "lpc_to_cart",
    "lpc_to_mp",
    "mp_to_cart",
    "mp_to_lpc",
    "range_of",
    "velocity_from_course",
    "wrap_angle",
    "wrap_half_angle",
]

Ambiguity = Literal["none", "pi"]
"""Bearing ambiguity: ``"none"`` (full circle) or ``"pi"`` (known modulo π, brehard2005 eq. 4)."""

FloatArray = NDArray[np.float64]

_PI = np.pi
_TWO_PI = 2.0 * np.pi
_HALF_PI = 0.5 * np.pi
_ZERO_RANGE = "range is zero: observer at the target"


# ----------------------------------------------------------------------------- helpers
def _scalar_or_array(x: FloatArray) -> FloatArray:
    """Turn a 0-d array into a numpy scalar, leave other arrays alone."""
    return x[()] if x.ndim == 0 else x


def _as_state(X: ArrayLike, name: str = "X") -> FloatArray:
    """Return ``X`` as a float array of shape (..., 4) or raise ``ValueError``."""
    arr = np.asarray(X, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 4:
        raise ValueError(f"{name} must have shape (..., 4), got {arr.shape}")
    return arr


def _check_ambiguity(ambiguity: str) -> None:
    if ambiguity not in ("none", "pi"):
        raise ValueError(f"ambiguity must be 'none' or 'pi', got {ambiguity!r}")


def _range_squared(X: FloatArray) -> FloatArray:
    """``r_x² + r_y²`` of states ``X`` (..., 4); raise if any is zero."""
    r2 = X[..., 0] ** 2 + X[..., 1] ** 2
    if np.any(r2 == 0.0):
        raise ValueError(_ZERO_RANGE)
    return r2


def _lpc_rates(X: FloatArray) -> tuple[FloatArray, ...]:
    """``(r_x, r_y, v_x, v_y, r², β̇, ṙ/r)`` of states ``X`` (..., 4); raise if any range is 0."""
    r2 = _range_squared(X)
    rx, ry, vx, vy = np.moveaxis(X, -1, 0)
    return rx, ry, vx, vy, r2, (vx * ry - vy * rx) / r2, (vx * rx + vy * ry) / r2


def _polar_to_cart(r: FloatArray, beta: FloatArray, beta_dot: FloatArray,
                   rho: FloatArray) -> FloatArray:
    """``r·[sin β, cos β, β̇ cos β + ρ sin β, −β̇ sin β + ρ cos β]``, shape (..., 4)."""
    s, c = np.sin(beta), np.cos(beta)
    return np.stack(
        [r * s, r * c, r * (beta_dot * c + rho * s), r * (-beta_dot * s + rho * c)], axis=-1
    )


def _check_inverse_range(u: FloatArray) -> None:
    if np.any(u <= 0.0):
        raise ValueError(
            "inverse range 1/r must be > 0 (zero means infinite range, negative is invalid)"
        )


# ------------------------------------------------------------------------------ angles
def wrap_angle(a: ArrayLike) -> FloatArray:
    """Wrap angles to (−π, π].

    Parameters
    ----------
    a
        Angles [rad], any shape.

    Returns
    -------
    ndarray or numpy scalar
        Angles [rad], same shape, congruent to ``a`` modulo 2π. Values already in
        (−π, π] are returned unchanged (bit for bit); ``−π`` maps to ``π``.
    """
    arr = np.asarray(a, dtype=np.float64)
    if arr.size == 1 and -_PI < arr.item() <= _PI:  # one angle, inside (a closed loop's)
        return _scalar_or_array(arr.copy())
    inside = (arr > -_PI) & (arr <= _PI)
    out = np.array(arr)  # a new array, never the caller's
    outside = ~inside
    if outside.any():  # the modulo only where needed (most angles are already inside)
        x = arr[outside]
        wrapped = _PI - np.mod(_PI - x, _TWO_PI)
        # np.mod can round up to exactly 2π for tiny negative arguments.
        out[outside] = np.where(wrapped <= -_PI, wrapped + _TWO_PI, wrapped)
    return _scalar_or_array(out)


def wrap_half_angle(a: ArrayLike) -> FloatArray:
    """Wrap angles to (−π/2, π/2], i.e. reduce them modulo π.

    This is the range of a bearing known only modulo π (linear array, brehard2005 eq. 4).

    Parameters
    ----------
    a
        Angles [rad], any shape.

    Returns
    -------
    ndarray or numpy scalar
        Angles [rad], same shape, congruent to ``a`` modulo π. Values already in
        (−π/2, π/2] are returned unchanged; both ``±π/2`` map to ``π/2``.
    """
    arr = np.asarray(a, dtype=np.float64)
    wrapped = _HALF_PI - np.mod(_HALF_PI - arr, _PI)
    wrapped = np.where(wrapped <= -_HALF_PI, wrapped + _PI, wrapped)
    inside = (arr > -_HALF_PI) & (arr <= _HALF_PI)
    return _scalar_or_array(np.where(inside, arr, wrapped))


def angle_diff(a: ArrayLike, b: ArrayLike) -> FloatArray:
    """Wrapped difference ``a − b`` in (−π, π], e.g. a bearing residual.

    Parameters
    ----------
    a, b
        Angles [rad], broadcastable shapes.

    Returns
    -------
    ndarray or numpy scalar
        ``wrap_angle(a − b)`` [rad], broadcast shape. ``angle_diff(179°, −179°) = −2°``.
    """
    return wrap_angle(np.subtract(a, b, dtype=np.float64))


def bearing_of(X: ArrayLike, ambiguity: Ambiguity = "none") -> FloatArray:
    """Bearing of the target seen from the observer: the one bearing function of tmaplan.

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), shape (..., 4), or
        displacements ``[Δx, Δy]`` (East, North), shape (..., 2); only ``X[..., :2]`` is used.
    ambiguity
        ``"none"``: full-circle bearing ``atan2(r_x, r_y)`` in (−π, π] (docs/conventions.md).
        ``"pi"``: bearing modulo π in (−π/2, π/2], i.e. ``arctan(r_x/r_y)`` of brehard2005
        eq. 4 (``π/2`` when ``r_y = 0``).

    Returns
    -------
    ndarray or numpy scalar
        Bearings [rad], shape (...): 0 = North, π/2 = East, π = South, −π/2 = West.

    Notes
    -----
    Signed zeros: a displacement with ``r_x = −0.0`` is a displacement with ``r_x = 0``.
    Due South (``r_x = ±0``, ``r_y < 0``) is ``+π`` (``atan2(−0.0, −1)`` would give −π,
    outside (−π, π]); due North (``r_x = ±0``, ``r_y > 0``) is ``+0.0``, never ``−0.0``.
    A zero displacement (observer at the target) gives 0 or π, the atan2 convention.
    """
    _check_ambiguity(ambiguity)
    arr = np.asarray(X, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] not in (2, 4):
        raise ValueError(f"X must have shape (..., 4) or (..., 2), got {arr.shape}")
    # + 0.0 turns a −0.0 into +0.0 (IEEE 754); −π, reached only from r_x = −0.0, becomes π.
    b = np.arctan2(arr[..., 0], arr[..., 1]) + 0.0
    if ambiguity == "pi":
        # Exact shifts by π (Sterbenz), so the result equals arctan(r_x/r_y) to rounding.
        b = np.where(b > _HALF_PI, b - _PI, np.where(b <= -_HALF_PI, b + _PI, b)) + 0.0
    else:
        b = np.where(b == -_PI, _PI, b)
    return _scalar_or_array(b)


def range_of(X: ArrayLike) -> FloatArray:
    """Range ``r = sqrt(r_x² + r_y²)`` [m] of relative states: the one range function.

    Parameters
    ----------
    X
        Relative states, shape (..., 4), or displacements, shape (..., 2).

    Returns
    -------
    ndarray or numpy scalar
        Ranges [m], shape (...).

    Raises
    ------
    ValueError
        If the last dimension is not 2 or 4 (as :func:`bearing_of`).
    """
    arr = np.asarray(X, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] not in (2, 4):
        raise ValueError(f"X must have shape (..., 4) or (..., 2), got {arr.shape}")
    return _scalar_or_array(np.hypot(arr[..., 0], arr[..., 1]))


def velocity_from_course(speed: ArrayLike, course: ArrayLike) -> FloatArray:
    """Velocity vector of a given speed and course.

    Parameters
    ----------
    speed
        Speeds [m/s], shape broadcastable with ``course``.
    course
        Courses [rad], from North clockwise.

    Returns
    -------
    ndarray
        ``[speed·sin(course), speed·cos(course)]`` = ``[v_East, v_North]`` [m/s],
        shape (..., 2) where ``...`` is the broadcast shape of the inputs.
    """
    s = np.asarray(speed, dtype=np.float64)
    c = np.asarray(course, dtype=np.float64)
    return np.stack(np.broadcast_arrays(s * np.sin(c), s * np.cos(c)), axis=-1)


def course_speed(v: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Course and speed of velocity vectors (inverse of :func:`velocity_from_course`).

    Parameters
    ----------
    v
        Velocities ``[v_East, v_North]`` [m/s], shape (..., 2).

    Returns
    -------
    course : ndarray or numpy scalar
        Courses [rad] in (−π, π], shape (...) (:func:`bearing_of` of the velocity, signed
        zeros included); 0 for a zero velocity.
    speed : ndarray or numpy scalar
        Speeds [m/s], shape (...).
    """
    arr = np.asarray(v, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise ValueError(f"v must have shape (..., 2), got {arr.shape}")
    return bearing_of(arr), range_of(arr)


# -------------------------------------------------------------------------------- LPC
def cart_to_lpc(X: ArrayLike, ambiguity: Ambiguity = "none") -> FloatArray:
    """Cartesian relative states to log-polar coordinates (brehard2005 eq. 8).

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), shape (..., 4).
    ambiguity
        ``"none"``: β in (−π, π]. ``"pi"``: β = arctan(r_x/r_y) in (−π/2, π/2] as in the
        paper; :func:`lpc_to_cart` then returns ``X`` for ``r_y > 0`` and ``−X`` for
        ``r_y < 0`` (eq. 7's two branches).

    Returns
    -------
    ndarray
        ``Y = [β, ln r, β̇, ṙ/r]`` (rad, ln m, rad/s, 1/s), shape (..., 4), with
        ``β̇ = (v_x r_y − v_y r_x)/r²`` and ``ṙ/r = (v_x r_x + v_y r_y)/r²``.

    Raises
    ------
    ValueError
        If any range is zero.
    """
    X = _as_state(X)
    rx, ry, _, _, _, omega, rho = _lpc_rates(X)
    return np.stack([bearing_of(X, ambiguity), np.log(np.hypot(rx, ry)), omega, rho], axis=-1)


def lpc_to_cart(Y: ArrayLike) -> FloatArray:
    """Log-polar coordinates to Cartesian relative states (brehard2005 eq. 7, r_y > 0 branch).

    Parameters
    ----------
    Y
        ``[β, ln r, β̇, ṙ/r]`` (rad, ln m, rad/s, 1/s), shape (..., 4). Any β is accepted;
        with the full-circle bearing there is no ± branch.

    Returns
    -------
    ndarray
        ``X = r·[sin β, cos β, β̇ cos β + ρ sin β, −β̇ sin β + ρ cos β]`` (m, m, m/s, m/s),
        shape (..., 4), with ``r = exp(ln r)`` and ``ρ = ṙ/r``.
    """
    Y = _as_state(Y, "Y")
    beta, log_r, beta_dot, rho = np.moveaxis(Y, -1, 0)
    return _polar_to_cart(np.exp(log_r), beta, beta_dot, rho)


def jacobian_cart_wrt_lpc_from_cart(X: ArrayLike) -> FloatArray:
    """Jacobian ∂X/∂Y of the LPC → Cartesian map, written as a linear function of X.

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` = ``lpc_to_cart(Y)``, shape (..., 4).

    Returns
    -------
    ndarray
        ``J[..., i, j] = ∂X_i/∂Y_j``, shape (..., 4, 4), columns in the order
        ``[β, ln r, β̇, ṙ/r]``::

            [[ r_y,  r_x,    0,    0],
             [-r_x,  r_y,    0,    0],
             [ v_y,  v_x,  r_y,  r_x],
             [-v_x,  v_y, -r_x,  r_y]]

        Units: row i has the unit of X_i divided by that of Y_j. ``det J = r⁴``.

    Notes
    -----
    J is linear in X (brehard2005, key to the closed-form PCRB), so expectations of quadratic
    forms in J only need the first two moments of X. Because J(−X) = −J(X), the formula
    also holds on the r_y < 0 branch of the π-ambiguous LPC (X = −f(Y)).
    """
    X = _as_state(X)
    rx, ry, vx, vy = np.moveaxis(X, -1, 0)
    zero = np.zeros_like(rx)
    rows = [
        [ry, rx, zero, zero],
        [-rx, ry, zero, zero],
        [vy, vx, ry, rx],
        [-vx, vy, -rx, ry],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def jacobian_cart_wrt_lpc(Y: ArrayLike) -> FloatArray:
    """Jacobian ∂X/∂Y of :func:`lpc_to_cart`.

    Parameters
    ----------
    Y
        ``[β, ln r, β̇, ṙ/r]`` (rad, ln m, rad/s, 1/s), shape (..., 4).

    Returns
    -------
    ndarray
        ``J[..., i, j] = ∂X_i/∂Y_j``, shape (..., 4, 4); equal to
        ``jacobian_cart_wrt_lpc_from_cart(lpc_to_cart(Y))``. ``det J = r⁴ = exp(4 Y_2)``.
    """
    return jacobian_cart_wrt_lpc_from_cart(lpc_to_cart(Y))


def jacobian_lpc_wrt_cart(X: ArrayLike) -> FloatArray:
    """Jacobian ∂Y/∂X of :func:`cart_to_lpc` (the inverse of ∂X/∂Y).

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), shape (..., 4).

    Returns
    -------
    ndarray
        ``J[..., i, j] = ∂Y_i/∂X_j``, shape (..., 4, 4), rows in the order
        ``[β, ln r, β̇, ṙ/r]``. With ``ω = β̇`` and ``ρ = ṙ/r``::

            [[ r_y,          -r_x,            0,    0  ],
             [ r_x,           r_y,            0,    0  ],
             [-v_y - 2 r_x ω,  v_x - 2 r_y ω,  r_y, -r_x],
             [ v_x - 2 r_x ρ,  v_y - 2 r_y ρ,  r_x,  r_y]] / r²

        The same for either ambiguity (β modulo π has the same derivative).

    Raises
    ------
    ValueError
        If any range is zero.
    """
    rx, ry, vx, vy, r2, omega, rho = _lpc_rates(_as_state(X))
    zero = np.zeros_like(rx)
    rows = [
        [ry, -rx, zero, zero],
        [rx, ry, zero, zero],
        [-vy - 2.0 * rx * omega, vx - 2.0 * ry * omega, ry, -rx],
        [vx - 2.0 * rx * rho, vy - 2.0 * ry * rho, rx, ry],
    ]
    J = np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)
    return J / r2[..., None, None]


# --------------------------------------------------------------------------------- MP
def cart_to_mp(X: ArrayLike, ambiguity: Ambiguity = "none") -> FloatArray:
    """Cartesian relative states to modified polar coordinates (brehard2004 eq. 81).

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), shape (..., 4).
        (brehard2004 orders X as velocity first; tmaplan always uses position first.)
    ambiguity
        Bearing convention for ``Y_3``, as in :func:`bearing_of`.

    Returns
    -------
    ndarray
        ``Y = [β̇, ṙ/r, β, 1/r]`` (rad/s, 1/s, rad, 1/m), shape (..., 4).

    Raises
    ------
    ValueError
        If any range is zero.
    """
    lpc = cart_to_lpc(X, ambiguity)
    return lpc_to_mp(lpc)


def mp_to_cart(Y: ArrayLike) -> FloatArray:
    """Modified polar coordinates to Cartesian relative states (brehard2004 eq. 80).

    Parameters
    ----------
    Y
        ``[β̇, ṙ/r, β, 1/r]`` (rad/s, 1/s, rad, 1/m), shape (..., 4), with ``1/r > 0``.

    Returns
    -------
    ndarray
        ``X = (1/Y_4)·[sin Y_3, cos Y_3, Y_1 cos Y_3 + Y_2 sin Y_3,
        −Y_1 sin Y_3 + Y_2 cos Y_3]`` (m, m, m/s, m/s), shape (..., 4).

    Raises
    ------
    ValueError
        If any ``Y_4 = 1/r`` is not positive.
    """
    Y = _as_state(Y, "Y")
    beta_dot, rho, beta, u = np.moveaxis(Y, -1, 0)
    _check_inverse_range(u)
    return _polar_to_cart(1.0 / u, beta, beta_dot, rho)


def jacobian_cart_wrt_mp(Y: ArrayLike) -> FloatArray:
    """Jacobian ∂X/∂Y of :func:`mp_to_cart`.

    Parameters
    ----------
    Y
        ``[β̇, ṙ/r, β, 1/r]`` (rad/s, 1/s, rad, 1/m), shape (..., 4), with ``1/r > 0``.

    Returns
    -------
    ndarray
        ``J[..., i, j] = ∂X_i/∂Y_j``, shape (..., 4, 4). With ``X = mp_to_cart(Y)`` and
        ``u = Y_4``::

            [[  0,    0,    r_y, -r_x/u],
             [  0,    0,   -r_x, -r_y/u],
             [ r_y,  r_x,   v_y, -v_x/u],
             [-r_x,  r_y,  -v_x, -v_y/u]]

        ``det J = −1/Y_4⁵`` (so ``|det J| = 1/Y_4⁵``, brehard2004).

    Raises
    ------
    ValueError
        If any ``Y_4`` is not positive.
    """
    Y = _as_state(Y, "Y")
    X = mp_to_cart(Y)
    u = Y[..., 3]
    rx, ry, vx, vy = np.moveaxis(X, -1, 0)
    zero = np.zeros_like(rx)
    rows = [
        [zero, zero, ry, -rx / u],
        [zero, zero, -rx, -ry / u],
        [ry, rx, vy, -vx / u],
        [-rx, ry, -vx, -vy / u],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def jacobian_mp_wrt_cart(X: ArrayLike) -> FloatArray:
    """Jacobian ∂Y/∂X of :func:`cart_to_mp` (the inverse of ∂X/∂Y).

    Parameters
    ----------
    X
        Relative states ``[r_x, r_y, v_x, v_y]`` (m, m, m/s, m/s), shape (..., 4).

    Returns
    -------
    ndarray
        ``J[..., i, j] = ∂Y_i/∂X_j``, shape (..., 4, 4), rows in the order
        ``[β̇, ṙ/r, β, 1/r]``: the rows of :func:`jacobian_lpc_wrt_cart` reordered, with the
        ``ln r`` row replaced by ``∂(1/r)/∂X = −[r_x, r_y, 0, 0]/r³``.
        ``|det J| = Y_4⁵``.

    Raises
    ------
    ValueError
        If any range is zero.
    """
    X = _as_state(X)
    J_lpc = jacobian_lpc_wrt_cart(X)  # checks the range
    u = 1.0 / np.hypot(X[..., 0], X[..., 1])
    # ∂(1/r)/∂X = −(1/r)·∂(ln r)/∂X
    inv_range_row = -u[..., None] * J_lpc[..., 1, :]
    return np.stack([J_lpc[..., 2, :], J_lpc[..., 3, :], J_lpc[..., 0, :], inv_range_row], axis=-2)


# ---------------------------------------------------------------------------- LPC <-> MP
def lpc_to_mp(Y: ArrayLike) -> FloatArray:
    """Log-polar to modified polar coordinates.

    Parameters
    ----------
    Y
        LPC ``[β, ln r, β̇, ṙ/r]`` (rad, ln m, rad/s, 1/s), shape (..., 4).

    Returns
    -------
    ndarray
        MP ``[β̇, ṙ/r, β, 1/r]`` (rad/s, 1/s, rad, 1/m), shape (..., 4), ``1/r = exp(−ln r)``.
    """
    Y = _as_state(Y, "Y")
    return np.stack([Y[..., 2], Y[..., 3], Y[..., 0], np.exp(-Y[..., 1])], axis=-1)


def mp_to_lpc(Y: ArrayLike) -> FloatArray:
    """Modified polar to log-polar coordinates.

    Parameters
    ----------
    Y
        MP ``[β̇, ṙ/r, β, 1/r]`` (rad/s, 1/s, rad, 1/m), shape (..., 4), with ``1/r > 0``.

    Returns
    -------
    ndarray
        LPC ``[β, ln r, β̇, ṙ/r]`` (rad, ln m, rad/s, 1/s), shape (..., 4),
        ``ln r = −ln(1/r)``.

    Raises
    ------
    ValueError
        If any ``Y_4`` is not positive.
    """
    Y = _as_state(Y, "Y")
    _check_inverse_range(Y[..., 3])
    return np.stack([Y[..., 2], -np.log(Y[..., 3]), Y[..., 0], Y[..., 1]], axis=-1)
