"""Range-only Gaussian filter with GvM2 azimuth moments (file 004, Sharma et al. 2024, §VI).

State: the relative ``X = [r_x, r_y, v_x, v_y]`` with a Gaussian ``N(x̂, P)``. Prediction is the
NCV model with the observer increment, ``x̂⁻ = F x̂ − H Δv`` (file 004 eq. 2/56 written with
DESIGN §1's Δv), ``P⁻ = F P F' + Q``. The range update uses the linear-position view of eq. (9):
given the azimuth θ, ``y = r·b(θ)``, ``b = [cos θ, sin θ]`` is a linear measurement of the
position with noise σ_r²I (eq. 6 model), so with ``V = H P⁻ H' + σ_r² I``, ``K = P⁻ H' V⁻¹``:

* ``mode="mixture"`` (default): a Gaussian mixture kept across scans, every component split
  into azimuth sectors each updated with eqs. (12)–(13) restricted to its sector, weighted by
  its marginal range likelihood and reduced by Runnalls merging
  (:mod:`tmaplan.estimators.range_only_gm`). File 004 collapses to one Gaussian after every
  scan (§VI.A step 7, L355) and names the mixture prior as future work (L357); on
  ``sharma2024-range-only`` the collapse loses the second passing side near the closest
  approach: final position RMSE ≈ 2600 m against 1154 m for the mixture (100 runs, seed 4;
  issue-5 report), with NEES in the thousands against ≈ 4. On a single Gaussian state
  (:func:`range_only_update`) the mixture collapses exactly to the moment update below;
* ``mode="moments"`` (the paper's recursion): the exact moment-matched posterior of eqs. (12)–(13),
  ``x̂ = (I−KH)x̂⁻ + r K E[b|r]``, ``P = (I−KH)P⁻ + r² K P_b K'`` with ``E[b|r]`` and ``P_b`` from
  the first two trigonometric moments (eqs. 40–44);
* ``mode="dirac"``: the paper's L-point wrapped Dirac mixture fitted to M moments (eq. 52), one
  Kalman component per point (eqs. 53–54) and a collapse to one Gaussian. The component
  covariance is ``component_cov="exact"`` ``(I−KH)P⁻`` (default) or ``"paper"``
  (eq. 55 as printed, which adds ``r²KP_bK'`` to every component and so double-counts the
  azimuth spread after the collapse, NOTES_004 §3.4).

Moments come from the max-shifted grid/FFT engine by default (``moments="grid"``); the
paper's Bessel series (``moments="series"``, N terms) is unreliable at the concentrations of
tracking (NOTES_004 §2.5) and kept for comparison. Initialisation is the paper's single-point
one (one range and one azimuth, file 004 L389, L396): position from polar coordinates with
``P_pos = J diag(σ_r², σ_β²) J'`` and a velocity prior given by the caller (the paper does not
specify it, NOTES_004 §4.2).
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from tmaplan.errors import ScenarioError
from tmaplan.estimators.gvm_moments import (
    dirac_mixture,
    gvm2_from_gaussian,
    moments_grid,
    moments_series,
)
from tmaplan.estimators.range_only_gm import MixtureConfig
from tmaplan.models.target import ncv_matrices

__all__ = [
    "RangeOnlyConfig",
    "RangeOnlyState",
    "range_only_predict",
    "range_only_update",
    "single_point_prior",
]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeOnlyConfig:
    """Settings of the range-only filter.

    Attributes
    ----------
    dt : float
        [s].
    q : float
        Process-noise intensity of the filter [m²/s³].
    mode : {"mixture", "moments", "dirac"}
        "mixture": Gaussian-mixture filter (ours, default); "moments": file 004's single
        Gaussian with the exact moment update; "dirac": file 004's L-point Dirac mixture and
        collapse.
    component_cov : {"exact", "paper"}
        Dirac mode only.
    moments : {"grid", "series"}
    series_terms : int
        N for the series engine (5 in file 004 Table II).
    n_moments : int
        M (10 in Table II).
    n_points : int
        L (8 in Table II).
    max_components, max_sectors : int
        Mixture mode: components kept after each scan; sectors per component and scan.
    sagitta : float
        Mixture mode: allowed arc sagitta of one sector in units of σ_r.
    """

    dt: float
    q: float
    mode: Literal["mixture", "moments", "dirac"] = "mixture"
    component_cov: Literal["exact", "paper"] = "exact"
    moments: Literal["grid", "series"] = "grid"
    series_terms: int = 5
    n_moments: int = 10
    n_points: int = 8
    max_components: int = 24
    max_sectors: int = 12
    sagitta: float = 1.0

    def __post_init__(self) -> None:
        if not self.dt > 0:
            raise ScenarioError("dt", "> 0 s", self.dt)
        if not self.q >= 0:
            raise ScenarioError("q", ">= 0 m²/s³", self.q)
        if self.mode not in ("mixture", "moments", "dirac"):
            raise ScenarioError("mode", "'mixture', 'moments' or 'dirac'", self.mode)
        if self.component_cov not in ("exact", "paper"):
            raise ScenarioError("component_cov", "'exact' or 'paper'", self.component_cov)
        if self.moments not in ("grid", "series"):
            raise ScenarioError("moments", "'grid' or 'series'", self.moments)

    def mixture(self) -> MixtureConfig:
        """The :class:`~tmaplan.estimators.range_only_gm.MixtureConfig` of mixture mode."""
        return MixtureConfig(dt=self.dt, q=self.q, max_components=self.max_components,
                             max_sectors=self.max_sectors, sagitta=self.sagitta)


@dataclasses.dataclass(frozen=True, kw_only=True)
class RangeOnlyState:
    """Gaussian posterior of the relative state.

    Attributes
    ----------
    step : int
    mean : ndarray, shape (4,)
        [m, m, m/s, m/s].
    cov : ndarray, shape (4, 4)
    """

    step: int
    mean: np.ndarray
    cov: np.ndarray


def single_point_prior(r0: float, bearing0: float, sigma_r: float, sigma_bearing: float,
                       velocity_mean: np.ndarray, velocity_std: float, *, step: int = 0
                       ) -> RangeOnlyState:
    """Single-point initialisation from one range and one bearing (file 004 L389, L444).

    Parameters
    ----------
    r0 : float
        Range [m].
    bearing0 : float
        Bearing [rad], clockwise from North.
    sigma_r, sigma_bearing : float
        [m], [rad].
    velocity_mean : ndarray, shape (2,)
        Relative velocity mean [m/s].
    velocity_std : float
        Per-axis std [m/s].
    step : int

    Returns
    -------
    RangeOnlyState
    """
    s, c = np.sin(bearing0), np.cos(bearing0)
    J = np.array([[s, r0 * c], [c, -r0 * s]])  # ∂(x, y)/∂(r, β)
    P = np.zeros((4, 4))
    P[:2, :2] = J @ np.diag([sigma_r**2, sigma_bearing**2]) @ J.T
    P[2:, 2:] = velocity_std**2 * np.eye(2)
    mean = np.concatenate([[r0 * s, r0 * c], np.asarray(velocity_mean, float)])
    return RangeOnlyState(step=step, mean=mean, cov=P)


def range_only_predict(state: RangeOnlyState, dv: np.ndarray | None, config: RangeOnlyConfig,
                       *, steps: int = 1) -> RangeOnlyState:
    """NCV prediction with the observer increment (``x ← F x − H Δv``), ``steps`` times."""
    F, Q = ncv_matrices(config.dt, config.q)
    x, P = state.mean.copy(), state.cov.copy()
    dvs = np.zeros((steps, 2)) if dv is None else np.asarray(dv, float).reshape(-1, 2)
    for s in range(steps):
        x = F @ x
        if s < dvs.shape[0]:
            x[:2] -= config.dt * dvs[s]
            x[2:] -= dvs[s]
        P = F @ P @ F.T + Q
    return RangeOnlyState(step=state.step + steps, mean=x, cov=0.5 * (P + P.T))


def range_only_update(state: RangeOnlyState, r: float, sigma_r: float,
                      config: RangeOnlyConfig) -> RangeOnlyState:
    """Range update (file 004 eqs. 12–14, or eqs. 52–55 + collapse in ``dirac`` mode).

    A single Gaussian state cannot carry a mixture: in ``mixture`` mode this is the moment
    update (the collapse of the sector mixture, which it equals exactly). Use
    :func:`tmaplan.estimators.range_only_gm.mixture_update` to keep the mixture.

    Parameters
    ----------
    state : RangeOnlyState
        Predicted state.
    r : float
        Measured range [m]; a non-positive range (possible under the truth's additive noise,
        eq. 58) skips the update.
    sigma_r : float
        [m].
    config : RangeOnlyConfig

    Returns
    -------
    RangeOnlyState
    """
    if not r > 0:
        return state
    x, P = state.mean, state.cov
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 1] = 1.0
    yhat = x[:2]
    V = P[:2, :2] + sigma_r**2 * np.eye(2)
    K = P[:, :2] @ np.linalg.inv(V)
    IKH = np.eye(4) - K @ H
    g = gvm2_from_gaussian(yhat, V, r)
    m_max = max(2, config.n_moments if config.mode == "dirac" else 2)
    if config.moments == "series":
        c = moments_series(g, m_max, config.series_terms)
    else:
        c = moments_grid(g, m_max)
    Eb = np.array([c[1].real, c[1].imag])
    Ebb = np.array([[0.5 + 0.5 * c[2].real, 0.5 * c[2].imag],
                    [0.5 * c[2].imag, 0.5 - 0.5 * c[2].real]])  # eqs. 42–44
    Pb = Ebb - np.outer(Eb, Eb)
    base = IKH @ x
    Pc = IKH @ P
    if config.mode in ("moments", "mixture"):
        mean = base + r * K @ Eb
        cov = Pc + r * r * K @ Pb @ K.T
    else:
        d = dirac_mixture(c, config.n_points, g)
        b = np.stack([np.cos(d.theta), np.sin(d.theta)], axis=-1)  # (L, 2)
        comps = base + r * b @ K.T  # (L, 4), eq. 54
        mean = d.gamma @ comps
        dev = comps - mean
        cov = Pc + (dev * d.gamma[:, None]).T @ dev
        if config.component_cov == "paper":
            cov = cov + r * r * K @ Pb @ K.T  # eq. 55 as printed
    return RangeOnlyState(step=state.step, mean=mean, cov=0.5 * (cov + cov.T))
