"""Measurement models, vectorised over particles / samples.

All functions take relative states ``X = target − observer`` of shape (..., 4)
(``[r_x, r_y, v_x, v_y]``, SI) and broadcast over the leading dimensions. The noise-free
bearing and range are :func:`tmaplan.geometry.bearing_of` and :func:`tmaplan.geometry.range_of`.

:func:`default_ping_budget` is the one place where the number of active pings a scenario lets a
schedule spend is read (``planning.ping_budget``; 0 without a ``[planning]`` table).
"""

from __future__ import annotations

import numpy as np

from tmaplan.geometry import Ambiguity, angle_diff, bearing_of, range_of, wrap_half_angle
from tmaplan.scenario import Scenario

__all__ = [
    "bearing_loglik",
    "default_ping_budget",
    "doppler_frequency",
    "range_loglik",
    "range_rate",
]

_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)


def range_rate(X: np.ndarray) -> np.ndarray:
    """Range rate Ṙ = r·v/‖r‖ [m/s] (positive opening), shape (...)."""
    X = np.asarray(X)
    return (X[..., 0] * X[..., 2] + X[..., 1] * X[..., 3]) / range_of(X)


def doppler_frequency(X: np.ndarray, f0: np.ndarray, c: float = 1500.0) -> np.ndarray:
    """Received frequency of each line, first-order Doppler ``f_p (1 − Ṙ/c)`` (clavard2013 eq. 3).

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
                   ambiguity: Ambiguity = "none") -> np.ndarray:
    """Log-likelihood of a bearing ``z`` for each state.

    Unambiguous bearings use the Gaussian of the wrapped residual (valid for σ ≪ π). With the
    π ambiguity the density is the 3-term wrapped Gaussian of brehard2005 eq. 71 on
    (−π/2, π/2], so both the front and the back mode keep their weight.

    Parameters
    ----------
    z : float or ndarray broadcastable to X[..., 0]
        Measured bearing [rad] (with ``"pi"``, any representative modulo π).
    X : ndarray, shape (..., 4)
    sigma : float
        [rad].
    ambiguity : {"none", "pi"}

    Returns
    -------
    ndarray, shape (...)
    """
    b = bearing_of(X, ambiguity)
    if ambiguity == "pi":
        # the measured bearing is known modulo π: its representative in (−π/2, π/2] (the
        # same value for a bearing already there), so that d ± π holds the nearest mode
        d = wrap_half_angle(z) - b
        terms = np.stack([d, d - np.pi, d + np.pi], axis=0)
        ll = -0.5 * (terms / sigma) ** 2
        m = ll.max(axis=0)
        return m + np.log(np.exp(ll - m).sum(axis=0)) - _LOG_SQRT_2PI - np.log(sigma)
    r = angle_diff(np.asarray(z), b)
    return -0.5 * (r / sigma) ** 2 - _LOG_SQRT_2PI - np.log(sigma)


def range_loglik(z: float | np.ndarray, X: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian log-likelihood of a range ``z`` [m] (noise after the norm), shape (...)."""
    r = np.asarray(z) - range_of(X)
    return -0.5 * (r / sigma) ** 2 - _LOG_SQRT_2PI - np.log(sigma)


def default_ping_budget(scenario: Scenario) -> int:
    """The scenario's ping budget: ``planning.ping_budget``, 0 without a ``[planning]`` table.

    The one place the default is resolved: the ping policies, the alarm response's cap, the
    joint planners, ``tmaplan schedule`` and the demo call it when no budget is given.

    Parameters
    ----------
    scenario : Scenario

    Returns
    -------
    int
        Number of active pings, >= 0.
    """
    pl = scenario.planning
    return int(pl.ping_budget) if pl is not None else 0
