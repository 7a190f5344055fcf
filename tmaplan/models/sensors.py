"""Measurement models, vectorised over particles / samples.

All functions take relative states ``X = target − observer`` of shape (..., 4)
(``[r_x, r_y, v_x, v_y]``, SI) and broadcast over the leading dimensions.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from tmaplan.geometry import angle_diff, wrap_half_angle

__all__ = [
    "bearing",
    "bearing_loglik",
    "doppler_frequency",
    "range_",
    "range_loglik",
    "range_rate",
]

_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)


def bearing(X: np.ndarray, ambiguity: Literal["none", "pi"] = "none") -> np.ndarray:
    """Noise-free bearing ``atan2(r_x, r_y)`` [rad], in (−π, π] or (−π/2, π/2] for "pi".

    Parameters
    ----------
    X : ndarray, shape (..., 4) or (..., 2)
        Relative state or position [m].
    ambiguity : {"none", "pi"}

    Returns
    -------
    ndarray, shape (...)
    """
    X = np.asarray(X)
    b = np.arctan2(X[..., 0], X[..., 1])
    return wrap_half_angle(b) if ambiguity == "pi" else b


def range_(X: np.ndarray) -> np.ndarray:
    """Range ‖r‖ [m], shape (...)."""
    X = np.asarray(X)
    return np.hypot(X[..., 0], X[..., 1])


def range_rate(X: np.ndarray) -> np.ndarray:
    """Range rate Ṙ = r·v/‖r‖ [m/s] (positive opening), shape (...)."""
    X = np.asarray(X)
    return (X[..., 0] * X[..., 2] + X[..., 1] * X[..., 3]) / range_(X)


def doppler_frequency(X: np.ndarray, f0: np.ndarray, c: float = 1500.0) -> np.ndarray:
    """Received frequency of each line, first-order Doppler ``f_p (1 − Ṙ/c)`` (file 002 eq. 3).

    ``X`` must carry the *instantaneous* relative velocity (target − observer).

    Parameters
    ----------
    X : ndarray, shape (..., 4)
    f0 : ndarray, shape (P,)
        Emitted tones [Hz].
    c : float
        Sound speed [m/s].

    Returns
    -------
    ndarray, shape (..., P)
        [Hz].
    """
    rdot = range_rate(X)
    return np.asarray(f0, dtype=float) * (1.0 - rdot[..., None] / c)


def bearing_loglik(z: float | np.ndarray, X: np.ndarray, sigma: float,
                   ambiguity: Literal["none", "pi"] = "none") -> np.ndarray:
    """Log-likelihood of a bearing ``z`` for each state.

    Unambiguous bearings use the Gaussian of the wrapped residual (valid for σ ≪ π). With the
    π ambiguity the density is the 3-term wrapped Gaussian of file 000 eq. 71 (L704) on
    (−π/2, π/2], so both the front and the back mode keep their weight.

    Parameters
    ----------
    z : float or ndarray broadcastable to X[..., 0]
        Measured bearing [rad].
    X : ndarray, shape (..., 4)
    sigma : float
        [rad].
    ambiguity : {"none", "pi"}

    Returns
    -------
    ndarray, shape (...)
    """
    b = bearing(X, ambiguity)
    if ambiguity == "pi":
        d = np.asarray(z) - b
        terms = np.stack([d, d - np.pi, d + np.pi], axis=0)
        ll = -0.5 * (terms / sigma) ** 2
        m = ll.max(axis=0)
        return m + np.log(np.exp(ll - m).sum(axis=0)) - _LOG_SQRT_2PI - np.log(sigma)
    r = angle_diff(np.asarray(z), b)
    return -0.5 * (r / sigma) ** 2 - _LOG_SQRT_2PI - np.log(sigma)


def range_loglik(z: float | np.ndarray, X: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian log-likelihood of a range ``z`` [m] (noise after the norm), shape (...)."""
    r = np.asarray(z) - range_(X)
    return -0.5 * (r / sigma) ** 2 - _LOG_SQRT_2PI - np.log(sigma)
