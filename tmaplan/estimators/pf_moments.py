"""A bearing's innovation moments over a particle cloud, compiled (the compiled kernels' part
of the consistency monitor, :func:`tmaplan.estimators.consistency.innovation`).

The monitor tests every bearing by the innovation ``ν = Σ w_i d_i`` and its variance
``S = σ² + Σ w_i (d_i − ν)²`` over the predicted cloud, with ``d_i = wrap(z − β_i)`` the
residual of particle i (``β_i = atan2(x_i, y_i)``). numpy computed it in five passes over the
cloud (``arctan2``, the wrap, two weighted sums), a tenth of a closed-loop step at 3000
particles; here it is one loop, the wrapped residual read directly as the angle of the
rotated position, ``d_i = atan2(sin z · y_i − cos z · x_i, cos z · y_i + sin z · x_i)``
(the particle filter's bearing likelihood uses the same rotation,
:func:`tmaplan.estimators.pf_blocks.loglik_block`), with the Cephes arctangent of
:mod:`tmaplan.estimators.pf_math` (≈ 1 ulp). The sums run in particle order. The result
equals numpy's to rounding (tested to 1e-12), not bit for bit, so the monitor uses it for
clouds of the compiled kernels only (``PFState.kernel == "numba"``); the numpy kernel's
clouds keep numpy's formula, bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from tmaplan.errors import ArgumentError
from tmaplan.estimators.pf_math import abs_atan2, njit
from tmaplan.geometry import wrap_angle
from tmaplan.interrupts import compiled_entry

__all__ = ["bearing_moments"]


@compiled_entry
@njit(cache=True, fastmath=False, error_model="numpy", nogil=True)
def _bearing_moments(A: np.ndarray, w: np.ndarray, sz: float, cz: float,
                     at_origin: float) -> tuple[float, float]:
    n = A.shape[1]
    d = np.empty(n)
    nu = 0.0
    for j in range(n):
        s = sz * A[1, j] - cz * A[0, j]
        c = cz * A[1, j] + sz * A[0, j]
        a = abs_atan2(s, c)
        d[j] = at_origin if s == 0.0 and c == 0.0 else (-a if s < 0.0 else a)
        nu += w[j] * d[j]
    var = 0.0
    for j in range(n):
        e = d[j] - nu
        var += w[j] * (e * e)
    return nu, var


def bearing_moments(A: np.ndarray, w: np.ndarray, z: float) -> tuple[float, float]:
    """Weighted mean and variance of a bearing's wrapped residuals over a cloud.

    Parameters
    ----------
    A : ndarray, shape (4, N)
        The cloud's C-contiguous rows (x, y, vx, vy) [m, m/s], relative to the own ship
        (:func:`tmaplan.estimators.pf_kernels.particle_rows`).
    w : ndarray, shape (N,)
        Normalised weights.
    z : float
        The bearing [rad], clockwise from north.

    Returns
    -------
    nu, var : float
        ``Σ w_i d_i`` [rad] and ``Σ w_i (d_i − ν)²`` [rad²], ``d_i = wrap(z − atan2(x_i,
        y_i))`` ∈ [−π, π] (``wrap(z)`` for a particle at the own ship, as numpy's
        ``arctan2(0, 0) = 0``). NaN for a cloud with a non-finite coordinate (where
        ``arctan2`` would still give a residual): the caller's numpy formula then,
        :func:`tmaplan.estimators.consistency.innovation`.

    Raises
    ------
    ArgumentError
        ``A`` not of shape (≥ 2, N) or ``w`` not of shape (N,).
    """
    A = np.asarray(A, dtype=float)
    w = np.ascontiguousarray(w, dtype=float)
    if A.ndim != 2 or A.shape[0] < 2 or w.shape != (A.shape[1],):
        raise ArgumentError("bearing_moments cloud and weights",
                            "rows (>= 2, N) and weights (N,)", (A.shape, w.shape))
    zw = float(wrap_angle(z))
    nu, var = _bearing_moments(np.ascontiguousarray(A), w, math.sin(z), math.cos(z), zw)
    return float(nu), float(var)
