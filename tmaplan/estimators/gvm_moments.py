"""Trigonometric moments of the azimuth given a range (sharma2024, Sharma et al. 2024).

With a Gaussian predicted relative position ``y ~ N(ŷ, V)`` and a measured range r, the azimuth
θ of ``y = r·[cos θ, sin θ]`` has the generalised von Mises density of order 2 (sharma2024
eq. 24; GvM2 identification of docs/errata.md)::

    p(θ | r) ∝ exp(κ1 cos(θ − μ1) + κ2 cos 2(θ − μ2)),
    κ1 = r‖V⁻¹ŷ‖, μ1 = atan2(q, p), κ2 = r²A3, μ2 = −φ2/2,

with ``[p, q] = V⁻¹ŷ``, ``V⁻¹ = [[a, b], [b, c]]``, ``A3 = ‖((c−a)/4, b/2)‖`` and
``φ2 = atan2(b/2, (c−a)/4)`` (eq. 20; the printed ``tan⁻¹`` must be ``atan2``).
θ here is the angle of ``[cos θ, sin θ]`` in the (x, y) frame of the state; it is only a
parametrisation, so the paper's counter-clockwise convention needs no conversion.

Two engines for ``c_m = E[e^{imθ} | r]``:

* :func:`moments_grid` (default, docs/errata.md / §5.2): periodic trapezoid on
  ``exp(logf − max logf)`` with G ≥ 20·2π·√(κ1 + 4κ2) points, all m at once by FFT. Exact to
  rounding for any κ.
* :func:`moments_series`: the paper's Bessel series, eqs. (29)–(34) with the corrections of
  docs/errata.md — spurious 2π dropped in (33)/(34), the j = 0 term counted once, negative
  orders ``I_{|2j−m|}``, exact ratios ``ive(n, x)/ive(0, x)`` instead of the approximation of
  eq. (35) — in the compact form ``c_m = e^{imμ2} S(m)/S(0)``,
  ``S(m) = Σ_j I_j(κ2) I_{|2j+m|}(κ1) e^{i(2j+m)δ}``, δ = μ1 − μ2. It suffers catastrophic
  cancellation when the two terms compete (≈ loss/ln 10 digits lost, ``loss = κ1 + κ2 −
  max logf``), so it is kept as a cross-check for small κ only; :func:`series_loss` reports it.

:func:`dirac_mixture` fits L weighted points to the first M moments (eq. 52) with
``Σγ = 1`` enforced as an equality constraint (scipy SLSQP) and θ left unbounded (wrapped
afterwards), from a deterministic start at the quantiles of the density.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import minimize
from scipy.special import ive

__all__ = [
    "GvM2",
    "dirac_mixture",
    "grid_size",
    "gvm2_from_gaussian",
    "log_range_density",
    "moments_grid",
    "moments_series",
    "series_loss",
]


@dataclasses.dataclass(frozen=True, kw_only=True)
class GvM2:
    """Generalised von Mises density of order 2 on the angle θ [rad].

    Attributes
    ----------
    kappa1, kappa2 : float
        Concentrations (≥ 0).
    mu1, mu2 : float
        Locations [rad].
    """

    kappa1: float
    mu1: float
    kappa2: float
    mu2: float

    def logf(self, theta: np.ndarray) -> np.ndarray:
        """Unnormalised log-density at ``theta``."""
        return (self.kappa1 * np.cos(theta - self.mu1)
                + self.kappa2 * np.cos(2.0 * (theta - self.mu2)))


def gvm2_from_gaussian(yhat: np.ndarray, V: np.ndarray, r: float) -> GvM2:
    """Azimuth density given range r for ``y ~ N(yhat, V)`` (sharma2024 eqs. 17–24).

    Parameters
    ----------
    yhat : ndarray, shape (2,)
        Predicted relative position [m].
    V : ndarray, shape (2, 2)
        Its covariance plus the measurement noise σ_r²I [m²].
    r : float
        Measured range [m] (> 0).

    Returns
    -------
    GvM2
    """
    Vi = np.linalg.inv(np.asarray(V, float))
    a, b, c = Vi[0, 0], 0.5 * (Vi[0, 1] + Vi[1, 0]), Vi[1, 1]
    p, q = Vi @ np.asarray(yhat, float)
    kappa1 = r * float(np.hypot(p, q))
    mu1 = float(np.arctan2(q, p))
    phi2 = float(np.arctan2(b / 2.0, (c - a) / 4.0))
    kappa2 = r * r * float(np.hypot((c - a) / 4.0, b / 2.0))
    return GvM2(kappa1=kappa1, mu1=mu1, kappa2=kappa2, mu2=-phi2 / 2.0)


def grid_size(g: GvM2, minimum: int = 256) -> int:
    """Grid size G = power of two ≥ 20·2π·√(κ1 + 4κ2) (docs/errata.md)."""
    need = 20.0 * 2.0 * np.pi * np.sqrt(g.kappa1 + 4.0 * g.kappa2 + 1.0)
    return int(2 ** int(np.ceil(np.log2(max(minimum, need)))))


def moments_grid(g: GvM2, m_max: int, n_grid: int | None = None) -> np.ndarray:
    """Trigonometric moments ``c_m = E[e^{imθ}]``, m = 0..m_max, by a max-shifted FFT trapezoid.

    Parameters
    ----------
    g : GvM2
    m_max : int
    n_grid : int, optional
        Number of grid points (default :func:`grid_size`).

    Returns
    -------
    ndarray of complex, shape (m_max + 1,)
        ``c_0 = 1``.
    """
    G = grid_size(g) if n_grid is None else int(n_grid)
    G = max(G, 2 * m_max + 2)
    theta = 2.0 * np.pi * np.arange(G) / G
    lf = g.logf(theta)
    w = np.exp(lf - lf.max())
    # Σ_g w_g e^{imθ_g} = conj(FFT(w)[m]) for real w.
    s = np.conj(np.fft.fft(w)[: m_max + 1])
    return s / s[0].real


def log_range_density(g: GvM2, yhat: np.ndarray, V: np.ndarray, r: float) -> float:
    """``log p(r) = log ∫ N(r b(θ); ŷ, V) r dθ`` [log 1/m] (sharma2024 eqs. 17–25 in logs).

    With ``V⁻¹ = [[a, b], [b, c]]`` the exponent is ``−½ ŷ'V⁻¹ŷ − r²(a + c)/4`` plus the
    GvM2 log-density ``g.logf(θ)``, integrated by the max-shifted periodic trapezoid of
    :func:`moments_grid`.

    Parameters
    ----------
    g : GvM2
        ``gvm2_from_gaussian(yhat, V, r)``.
    yhat : ndarray, shape (2,)
        Predicted relative position [m].
    V : ndarray, shape (2, 2)
        Its covariance plus σ_r²I [m²].
    r : float
        Measured range [m] (> 0).

    Returns
    -------
    float
    """
    Vi = np.linalg.inv(V)
    n = grid_size(g)
    theta = 2.0 * np.pi * np.arange(n) / n
    lf = g.logf(theta)
    top = float(lf.max())
    log_int = top + float(np.log(np.mean(np.exp(lf - top)) * 2.0 * np.pi))
    return float(np.log(r) - np.log(2.0 * np.pi) - 0.5 * np.linalg.slogdet(V)[1]
                 - 0.5 * yhat @ Vi @ yhat - 0.25 * r * r * (Vi[0, 0] + Vi[1, 1]) + log_int)


def series_loss(g: GvM2) -> float:
    """Digits-loss exponent ``κ1 + κ2 − max_θ logf`` of the Bessel series (docs/errata.md)."""
    theta = 2.0 * np.pi * np.arange(4096) / 4096
    return float(g.kappa1 + g.kappa2 - g.logf(theta).max())


def moments_series(g: GvM2, m_max: int, n_terms: int) -> np.ndarray:
    """sharma2024's Bessel series (corrected eqs. 29–34), truncated at ``n_terms`` (j = 1..N).

    Parameters
    ----------
    g : GvM2
    m_max : int
    n_terms : int
        N: number of j ≥ 1 terms (N = 0 is the von Mises(κ1) leading term).

    Returns
    -------
    ndarray of complex, shape (m_max + 1,)
    """
    j = np.arange(-n_terms, n_terms + 1)
    delta = g.mu1 - g.mu2
    i2 = ive(np.abs(j), g.kappa2)  # I_j(κ2) e^{−κ2}
    out = np.empty(m_max + 1, complex)
    for m in range(m_max + 1):
        order = 2 * j + m
        out[m] = np.sum(i2 * ive(np.abs(order), g.kappa1) * np.exp(1j * order * delta))
    return np.exp(1j * np.arange(m_max + 1) * g.mu2) * out / out[0]


@dataclasses.dataclass(frozen=True, kw_only=True)
class DiracMixture:
    """L weighted points on the circle matching moments 1..M.

    Attributes
    ----------
    theta : ndarray, shape (L,)
        Points [rad], wrapped to (−π, π].
    gamma : ndarray, shape (L,)
        Weights, ≥ 0, Σ = 1.
    residual : float
        Euclidean norm of the 2M moment residuals.
    success : bool
        Optimiser status.
    message : str
    """

    theta: np.ndarray
    gamma: np.ndarray
    residual: float
    success: bool
    message: str


def dirac_mixture(moments: np.ndarray, n_points: int, g: GvM2 | None = None,
                  theta0: np.ndarray | None = None) -> DiracMixture:
    """Fit L Dirac points to moments 1..M (sharma2024 eq. 52 with Σγ = 1 enforced).

    Parameters
    ----------
    moments : ndarray of complex, shape (M + 1,)
        ``c_0..c_M`` (c_0 is ignored).
    n_points : int
        L.
    g : GvM2, optional
        The density; its quantiles give the deterministic starting points.
    theta0 : ndarray, shape (L,), optional
        Explicit starting points (else quantiles of g, else uniform).

    Returns
    -------
    DiracMixture
    """
    c = np.asarray(moments)[1:]
    M = c.size
    m = np.arange(1, M + 1)
    L = int(n_points)
    if theta0 is None:
        if g is not None:
            G = max(4096, grid_size(g))
            th = 2 * np.pi * np.arange(G) / G
            lf = g.logf(th)
            w = np.exp(lf - lf.max())
            start = int(np.argmin(w))  # start the CDF at the density minimum (no wrap issue)
            w = np.roll(w, -start)
            th = np.roll(th, -start)
            cdf = np.cumsum(w) / w.sum()
            theta0 = th[np.clip(np.searchsorted(cdf, (np.arange(L) + 0.5) / L), 0, G - 1)]
        else:
            theta0 = 2 * np.pi * np.arange(L) / L
    x0 = np.concatenate([np.full(L, 1.0 / L), np.asarray(theta0, float)])

    def fun(x: np.ndarray) -> tuple[float, np.ndarray]:
        gam, th = x[:L], x[L:]
        E = np.exp(1j * np.outer(m, th))  # (M, L)
        e = E @ gam - c
        f = float(np.sum(np.abs(e) ** 2))
        ce = np.conj(e)[:, None]
        dg = 2.0 * np.real(ce * E).sum(axis=0)
        dth = 2.0 * np.real(ce * 1j * m[:, None] * E).sum(axis=0) * gam
        return f, np.concatenate([dg, dth])

    cons = {"type": "eq", "fun": lambda x: np.sum(x[:L]) - 1.0,
            "jac": lambda x: np.concatenate([np.ones(L), np.zeros(L)])}
    bounds = [(0.0, 1.0)] * L + [(None, None)] * L
    sol = minimize(fun, x0, jac=True, method="SLSQP", bounds=bounds, constraints=[cons],
                   options={"maxiter": 500, "ftol": 1e-16})
    gam = np.clip(sol.x[:L], 0.0, 1.0)
    gam = gam / gam.sum()
    th = np.mod(sol.x[L:] + np.pi, 2 * np.pi) - np.pi
    res = float(np.sqrt(fun(np.concatenate([gam, th]))[0]))
    return DiracMixture(theta=th, gamma=gam, residual=res, success=bool(sol.success),
                        message=str(sol.message))
