"""Generalised likelihood-ratio test for a target velocity jump over a sliding window.

The CUSUM of :mod:`tmaplan.estimators.consistency` looks for a constant drift of the
normalised bearing innovations; after an unmodelled course change the filter absorbs much of
the drift into its cloud, so the CUSUM is slow or silent. This test asks the question
directly, Willsky & Jones (1976) style, on the measurements of the last ``L`` steps:

* **no jump** (H0): the relative state at the window start ``x₀`` has the filter's posterior
  there as a Gaussian prior ``N(m₀, P₀)`` and moves without noise,
  ``X_{k+1} = F X_k − [dt·Δv_k; Δv_k]`` (the particle filter's dynamics, Δv the observer's
  velocity increments); its MAP is found by Gauss–Newton on the bearings and ranges;
* **a jump at step j** (H1_j): the same plus a target velocity offset ``δv`` from ``t_j`` on,
  so the positions after it move by ``(t_k − t_j)·δv`` (the fault model of
  :mod:`tmaplan.models.faults`), ``δv`` unknown (flat).

Linearised at the H0 MAP, with ``A`` the whitened Jacobian in ``x₀`` (prior rows included),
``b`` the whitened residual and ``G_j`` the whitened Jacobian in ``δv``, the GLR of H1_j
against H0 is ``T_j = bᵀ G̃_j (G̃_jᵀ G̃_j)⁺ G̃_jᵀ b``, ``G̃_j = (I − Π_A) G_j`` (the jump
seen after the nuisance ``x₀`` has taken what it can); under H0 each ``T_j`` is χ² with
``rank G̃_j ≤ 2`` degrees of freedom, so ``max_j T_j`` over the ``C`` candidate onsets is
tested against the χ²₂ quantile at ``α/C`` (Bonferroni: a false-alarm probability per step
of at most α). The estimate ``δv̂`` of the best onset comes with it.

Everything is a few small dense matrices per step (measurements × 4 and candidates × rows × 2,
batched over the candidates); the particles enter only through the posterior's mean and
covariance at the window start.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from tmaplan.errors import ArgumentError, finite_real, is_integer
from tmaplan.geometry import wrap_angle

__all__ = ["JumpTest", "glr_threshold", "velocity_jump_glr"]

#: floor added to the diagonal of P₀ [m², m², (m/s)², (m/s)²]: a collapsed cloud still lets
#: the state move a little
_P_FLOOR = np.array([1.0, 1.0, 1e-4, 1e-4])


@dataclasses.dataclass(frozen=True, kw_only=True)
class JumpTest:
    """Result of :func:`velocity_jump_glr`.

    Attributes
    ----------
    statistic : float
        ``max_j T_j`` (module docstring).
    candidates : int
        Number of candidate onsets C.
    back : int
        Steps from the best onset to now (the change point, as the CUSUM's ``onset``).
    dv : ndarray, shape (2,)
        Estimated target velocity jump at that onset [m/s].
    """

    statistic: float
    candidates: int
    back: int
    dv: np.ndarray


def glr_threshold(alpha: float, candidates: int) -> float:
    """χ²₂ quantile at ``alpha / candidates`` (Bonferroni over the onsets)."""
    if not 0.0 < alpha < 0.5:
        raise ArgumentError("alpha", "a probability in (0, 0.5)", alpha)
    if candidates < 1:
        raise ArgumentError("candidates", "an integer >= 1", candidates)
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    return float(stats.chi2.isf(alpha / candidates, 2))


def _rows(history: Sequence[Any], dt: float) -> tuple[np.ndarray, ...]:
    """Measurement rows of the window: step offset s ≥ 1, kind (0 bearing, 1 range), value,
    σ, and the observer-driven state offset o_s (the noise-free state from x₀ = 0)."""
    n = len(history)
    off = np.zeros((n + 1, 4))
    s, kind, z, sig = [], [], [], []
    for i, (_, dv, _, meas) in enumerate(history):
        d = np.asarray(dv, float).reshape(2)
        o = off[i]
        off[i + 1] = (o[0] + dt * (o[2] - d[0]), o[1] + dt * (o[3] - d[1]),
                      o[2] - d[0], o[3] - d[1])
        for m in meas:
            if m.kind not in ("bearing", "range") or getattr(m, "ambiguity", "none") == "pi":
                continue
            s.append(i + 1)
            kind.append(0 if m.kind == "bearing" else 1)
            z.append(float(m.value))
            sig.append(float(m.sigma))
    si = np.asarray(s, int)
    return si, np.asarray(kind, int), np.asarray(z), np.asarray(sig), off[si]


def _model(x0: np.ndarray, tau: np.ndarray, off: np.ndarray, kind: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """Predicted measurements and their position gradients, shapes (R,) and (R, 2)."""
    px = x0[0] + tau * x0[2] + off[:, 0]
    py = x0[1] + tau * x0[3] + off[:, 1]
    r2 = px * px + py * py
    r = np.sqrt(r2)
    bearing = kind == 0
    h = np.where(bearing, np.arctan2(px, py), r)
    grad = np.where(bearing[:, None], np.column_stack([py, -px]) / r2[:, None],
                    np.column_stack([px, py]) / r[:, None])
    return h, grad


def velocity_jump_glr(history: Sequence[Any], dt: float, *, min_after: int = 2,
                      max_back: int | None = None, iterations: int = 3) -> JumpTest | None:
    """The sliding-window velocity-jump GLR (module docstring).

    Parameters
    ----------
    history : sequence
        The window, oldest first: entries ``(posterior at step i, Δv_i, v̄_i, measurements at
        step i + 1)`` as :class:`tmaplan.estimators.consistency.MonitoredState` stores them;
        the first posterior (with ``mean`` and ``cov``) is the prior of x₀.
    dt : float
        Step [s], finite and > 0.
    min_after : int
        Measurement steps needed after a candidate onset, >= 1.
    max_back : int, optional
        Candidate onsets at most this many steps back (default: the whole window); the steps
        before them still anchor the no-jump fit.
    iterations : int
        Gauss–Newton iterations of the H0 fit (>= 0).

    Returns
    -------
    JumpTest or None
        None when the window has fewer than ``min_after`` + 1 steps or no measurement.
    """
    finite_real("dt", dt, "a finite step > 0 s", lower=0.0, strict=True)
    if not is_integer(min_after, 1):
        raise ArgumentError("min_after", "an integer >= 1", min_after)
    if max_back is not None and not is_integer(max_back, min_after + 1):
        raise ArgumentError("max_back", f"an integer > min_after = {min_after}", max_back)
    if not is_integer(iterations, 0):
        raise ArgumentError("iterations", "an integer >= 0", iterations)
    n = len(history)
    if n < min_after + 1:
        return None
    s, kind, z, sig, off = _rows(history, dt)
    if s.size == 0:
        return None
    post = history[0][0]
    m0 = np.asarray(post.mean, float)
    P0 = np.asarray(post.cov, float) + np.diag(_P_FLOOR)
    W = np.linalg.cholesky(np.linalg.inv(P0)).T  # WᵀW = P0⁻¹
    tau = s * dt
    x0 = m0.copy()
    for _ in range(iterations + 1):
        h, grad = _model(x0, tau, off, kind)
        res = z - h
        res[kind == 0] = wrap_angle(res[kind == 0])  # wrap bearing residuals
        J = np.column_stack([grad, grad * tau[:, None]]) / sig[:, None]
        A = np.vstack([J, W])
        b = np.concatenate([res / sig, W @ (m0 - x0)])
        if _ == iterations:
            break
        x0 = x0 + np.linalg.lstsq(A, b, rcond=None)[0]
    first = 0 if max_back is None else max(n - max_back, 0)
    onsets = np.arange(first, n - min_after + 1)  # onset steps after the window start
    lag = np.clip(tau[None, :] - onsets[:, None] * dt, 0.0, None)  # (C, R)
    G = np.zeros((onsets.size, A.shape[0], 2))
    G[:, : s.size, :] = (grad / sig[:, None])[None] * lag[:, :, None]
    Q, _r = np.linalg.qr(A)
    Gp = G - Q[None] @ (Q.T[None] @ G)
    g = np.einsum("crk,r->ck", Gp, b)
    M = np.einsum("crk,crl->ckl", Gp, Gp)
    Mi = np.linalg.pinv(M, rcond=1e-9, hermitian=True)
    dv = np.einsum("ckl,cl->ck", Mi, g)
    T = np.einsum("ck,ck->c", g, dv)
    c = int(np.argmax(T))
    return JumpTest(statistic=float(T[c]) if math.isfinite(T[c]) else 0.0,
                    candidates=int(onsets.size), back=int(n - onsets[c]), dv=dv[c])
