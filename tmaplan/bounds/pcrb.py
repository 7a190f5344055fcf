"""Posterior Cramér–Rao bound by Tichavský's recursion with Monte Carlo D-terms.

The relative state ``X = target − observer`` follows ``X_{t+1} = A X_t + c_t + w_t``
(``c_t = −H Δv_t``, docs/conventions.md). Samples of X are drawn from the scenario's prior
and propagated with process noise; the D-terms of Tichavský's recursion (brehard2005 eq. 29)
are sample averages of outer products of *exact analytic scores*
(:func:`lpc_transition_scores`, checked against finite differences in the tests)::

    J_{t+1} = D22 + D33 − D21 (J_t + D11)⁻¹ D12

with the information ``J_t`` inside the bracket (brehard2005 Prop. 5 prints ``J_t⁻¹`` there, which
is wrong, docs/errata.md).

* ``coords="lpc"``: Y = [β, ln r, β̇, ṙ/r] (full-circle β). The LPC transition density is
  ``p(Y'|Y) = r'⁴ p_X(X'|X)`` (brehard2005 App. B1), so the scores are
  ``∇_Y = J_Xᵀ AᵀQ⁻¹e`` and ``∇_{Y'} = −J_{X'}ᵀQ⁻¹e + 4e₂`` (docs/errata.md; eq. 103–104 print
  inconsistent signs).
* ``coords="cartesian"``: the dynamics are linear-Gaussian, so the recursion reduces exactly to
  ``J_{t+1} = (Q + A J_t⁻¹ Aᵀ)⁻¹ + E[H̃ᵀR⁻¹H̃]`` (Ristic et al.); only the measurement term is
  a Monte Carlo average.

The measurement term D33 is the Monte Carlo average over the propagated X of the *conditional*
Fisher information ``E[s sᵀ | X]`` (Rao–Blackwellised: the expectation over the measurement
noise is analytic), for bearings (1/σ_β²; with the π ambiguity this holds up to the overlap of
the wrapped components, e^{−π²/(2σ²)}, brehard2005 eq. 84), range pings and frequency lines. A
range reading of a sensor with a ``max_range`` counts, sample by sample, only where that
sample's range is within the reach (:func:`measurement_information`). The
frequency lines' emitted tones are treated as *known* here (the bound is then optimistic
compared with clavard2013's unknown-tone CRLB).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Literal

import numpy as np

from tmaplan.bounds.inputs import PCRBInputs, prepare, reached_range_weight
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, ObservabilityError, ScenarioError
from tmaplan.geometry import (
    bearing_of,
    jacobian_cart_wrt_lpc_from_cart,
    range_of,
    wrap_angle,
    wrap_half_angle,
)
from tmaplan.models.observer import ObserverTrack
from tmaplan.models.prior import relative_prior_samples
from tmaplan.scenario import Scenario

__all__ = [
    "PCRBResult",
    "SideAssumptionWarning",
    "bearing_score",
    "cartesian_transition_scores",
    "conditional_information",
    "frequency_score",
    "lpc_transition_scores",
    "measurement_information",
    "monte_carlo_pcrb",
    "predicted_information",
    "range_score",
]

Coords = Literal["cartesian", "lpc"]


class SideAssumptionWarning(UserWarning):
    """The true bearing has non-negligible density at the wrap point (brehard2005 eq. 27).

    The LPC bound is then not valid for β (brehard2005 Prop. 3: the β entry should be scaled by
    (1 − κ)², κ = (wrap period)·p_β(wrap)).
    """


@dataclasses.dataclass(frozen=True, kw_only=True)
class PCRBResult:
    """Posterior CRB over time.

    Attributes
    ----------
    times : ndarray, shape (K + 1,)
        [s].
    coords : {"cartesian", "lpc"}
        Coordinates of ``information`` and ``std``.
    method : str
        ``"monte-carlo"`` or ``"closed-form"``.
    information : ndarray, shape (K + 1, 4, 4)
        Information matrices J_k (units: inverse of the squared state units).
    std : ndarray, shape (K + 1, 4)
        ``sqrt(diag J_k⁻¹)``: [m, m, m/s, m/s] (Cartesian) or [rad, 1, rad/s, 1/s] (LPC:
        β, ln r, β̇, ṙ/r).
    position_std : ndarray, shape (K + 1,)
        ``sqrt(tr)`` of the Cartesian position block of the bound [m] (LPC: delta method,
        ``E[J_X J⁻¹ J_Xᵀ]`` over the propagated state).
    range_std : ndarray, shape (K + 1,)
        Range bound [m]: LPC ``r̂_k·sqrt([J_k⁻¹]_{ln r})`` with ``r̂_k = sqrt(E r_k²)`` (brehard2005
        eq. 58, docs/cli.md); Cartesian ``sqrt(E[ûᵀ P_pos û])``, û the unit line of sight.
    seconds : float
        Wall time [s].
    samples : int
        Monte Carlo samples of the propagation (0 for the closed form).
    prior_samples : int
        Prior samples behind J₀ (brehard2005 eq. 56) and the prior moments.
    ping_steps : ndarray of int
        Steps with a range ping.
    range_bound : ndarray, shape (K + 1,), optional
        Eq. 58 range bound [m] (LPC only; equals ``range_std``).
    side_density : ndarray, shape (K + 1,), optional
        Density of the true bearing at the wrap point [1/rad] (±π/2 for π-ambiguous bearings,
        ±π otherwise).
    side_valid : ndarray of bool, shape (K + 1,), optional
        Where the side assumption holds (κ ≤ tolerance); the β bound is not valid elsewhere.
    warnings : tuple of str
        Warnings raised while computing.
    over : {"prior", "truth"}
        What the bound is averaged over: the prior (the Bayesian PCRB of brehard2005, this
        module and the closed form) or realisations of the scenario's true track
        (:func:`tmaplan.bounds.truth_bound.truth_conditioned_pcrb`, ristic2004, ch. 6).
    """

    __repr__ = short_repr

    times: np.ndarray
    coords: Coords
    method: str
    information: np.ndarray
    std: np.ndarray
    position_std: np.ndarray
    range_std: np.ndarray
    seconds: float
    samples: int = 0
    prior_samples: int = 0
    ping_steps: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, int))
    range_bound: np.ndarray | None = None
    side_density: np.ndarray | None = None
    side_valid: np.ndarray | None = None
    warnings: tuple[str, ...] = ()
    over: Literal["prior", "truth"] = "prior"

    def to_json(self) -> dict[str, object]:
        """docs/cli.md fields (SI units)."""
        out: dict[str, object] = {
            "times": self.times, "coords": self.coords, "method": self.method,
            "over": self.over,
            "std": self.std, "range_std": self.range_std, "position_std": self.position_std,
            "seconds": self.seconds, "samples": self.samples,
            "prior_samples": self.prior_samples, "ping_steps": self.ping_steps,
            "warnings": list(self.warnings)}
        if self.side_density is not None:
            out["side_density"] = self.side_density
            out["side_valid"] = self.side_valid
        return out


# ------------------------------------------------------------------------------- scores
def _e2() -> np.ndarray:
    return np.array([0.0, 1.0, 0.0, 0.0])


def lpc_transition_scores(X: np.ndarray, X_next: np.ndarray, c: np.ndarray, A: np.ndarray,
                          Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact scores of the LPC transition density ``ln p(Y_{t+1} | Y_t)``.

    ``p(Y'|Y) = r'⁴ N(X'; A X + c, Q)`` (brehard2005 App. B1; |det ∂X/∂Y| = r⁴), so with
    ``e = X' − A X − c``: ``∇_Y = J_Xᵀ AᵀQ⁻¹ e`` and ``∇_{Y'} = −J_{X'}ᵀ Q⁻¹ e + [0, 4, 0, 0]``
    (corrected signs of brehard2005 eq. 103–104, docs/errata.md; J is the true ∂X/∂Y, not the
    printed F of eq. 31).

    Parameters
    ----------
    X, X_next : ndarray, shape (..., 4)
        Relative states at t and t+1 [m, m, m/s, m/s].
    c : ndarray, shape (4,)
        ``−H Δv_t``.
    A, Q : ndarray, shape (4, 4)

    Returns
    -------
    grad_t, grad_next : ndarray, shape (..., 4)
        Gradients with respect to Y_t and Y_{t+1} (LPC units).
    """
    P = np.linalg.inv(Q)
    e = X_next - X @ A.T - c
    Pe = e @ P
    g_t = np.einsum("...ki,...k->...i", jacobian_cart_wrt_lpc_from_cart(X), Pe @ A)
    g_n = -np.einsum("...ki,...k->...i", jacobian_cart_wrt_lpc_from_cart(X_next), Pe) + 4 * _e2()
    return g_t, g_n


def cartesian_transition_scores(X: np.ndarray, X_next: np.ndarray, c: np.ndarray,
                                A: np.ndarray, Q: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
    """Scores of ``ln N(X'; A X + c, Q)``: ``(AᵀQ⁻¹e, −Q⁻¹e)``, shapes (..., 4)."""
    P = np.linalg.inv(Q)
    Pe = (X_next - X @ A.T - c) @ P
    return Pe @ A, -Pe


def _bearing_grad(X: np.ndarray, coords: Coords) -> np.ndarray:
    if coords == "lpc":
        g = np.zeros(X.shape)
        g[..., 0] = 1.0
        return g
    r2 = X[..., 0] ** 2 + X[..., 1] ** 2
    z = np.zeros(X.shape[:-1])
    return np.stack([X[..., 1] / r2, -X[..., 0] / r2, z, z], axis=-1)


def _range_grad(X: np.ndarray, coords: Coords) -> np.ndarray:
    r = range_of(X)
    z = np.zeros(X.shape[:-1])
    if coords == "lpc":
        return np.stack([z, r, z, z], axis=-1)
    return np.stack([X[..., 0] / r, X[..., 1] / r, z, z], axis=-1)


def _range_rate_grad(X: np.ndarray, coords: Coords) -> np.ndarray:
    r = range_of(X)
    rdot = (X[..., 0] * X[..., 2] + X[..., 1] * X[..., 3]) / r
    z = np.zeros(X.shape[:-1])
    if coords == "lpc":  # ṙ = e^{ln r}·(ṙ/r): ∂/∂ln r = ṙ, ∂/∂(ṙ/r) = r
        return np.stack([z, rdot, z, r], axis=-1)
    return np.stack([(X[..., 2] - rdot * X[..., 0] / r) / r,
                     (X[..., 3] - rdot * X[..., 1] / r) / r, X[..., 0] / r, X[..., 1] / r],
                    axis=-1)


def bearing_score(z: np.ndarray | float, X: np.ndarray, sigma: float,
                  ambiguity: Literal["none", "pi"] = "none",
                  coords: Coords = "lpc") -> np.ndarray:
    """Score ``∇ ln p(z | X)`` of a bearing, shape (..., 4).

    With ``ambiguity="pi"`` the density is brehard2005 eq. 71's 3-term wrapped Gaussian, whose
    β-derivative is the weighted residual of eq. 104 (third line) without its hard switch.
    """
    b = bearing_of(X, ambiguity)
    if ambiguity == "pi":
        d = np.asarray(z) - b
        terms = np.stack([d, d - np.pi, d + np.pi], axis=0)
        ll = -0.5 * (terms / sigma) ** 2
        w = np.exp(ll - ll.max(axis=0))
        s = (w * terms).sum(axis=0) / w.sum(axis=0) / sigma**2
    else:
        s = wrap_angle(np.asarray(z) - b) / sigma**2
    return s[..., None] * _bearing_grad(X, coords)


def range_score(z: np.ndarray | float, X: np.ndarray, sigma: float,
                coords: Coords = "lpc") -> np.ndarray:
    """Score of a range ping ``z = r + v``, v ~ N(0, σ²) [m], shape (..., 4)."""
    r = range_of(X)
    return ((np.asarray(z) - r) / sigma**2)[..., None] * _range_grad(X, coords)


def frequency_score(z: np.ndarray, X: np.ndarray, f0: np.ndarray, sigma: np.ndarray,
                    c: float = 1500.0, coords: Coords = "lpc") -> np.ndarray:
    """Score of P frequency lines ``f_p(1 − ṙ/c) + v_p`` (clavard2013 eq. 3), known tones.

    Parameters
    ----------
    z : ndarray, shape (..., P)
        Measured frequencies [Hz].
    X : ndarray, shape (..., 4)
    f0, sigma : ndarray, shape (P,)
        Tones and noise std [Hz].
    c : float
        Sound speed [m/s].
    """
    f0, sigma = np.asarray(f0, float), np.asarray(sigma, float)
    r = range_of(X)
    rdot = (X[..., 0] * X[..., 2] + X[..., 1] * X[..., 3]) / r
    f = f0 * (1.0 - rdot[..., None] / c)
    s = ((np.asarray(z) - f) / sigma**2 * (-f0 / c)).sum(axis=-1)
    return s[..., None] * _range_rate_grad(X, coords)


def conditional_information(X: np.ndarray, bearing: float, range_: float,
                            coords: Coords = "cartesian", *, average: bool = False
                            ) -> np.ndarray:
    """Conditional Fisher information ``E[s sᵀ | X] = b ∇β∇βᵀ + w ∇r∇rᵀ``, (..., 4, 4).

    At relative states X (..., 4) [m, m/s] for bearing and range information b = ``bearing``
    [rad⁻²], w = ``range_`` [m⁻²] (:func:`tmaplan.bounds.inputs.information_rates`); the
    π-ambiguous bearing up to the overlap of its wrapped components (brehard2005 eq. 84).
    ``average``: the mean (4, 4) over samples X (N, 4).
    """
    def outer(g: np.ndarray) -> np.ndarray:
        return g.T @ g / g.shape[0] if average else g[..., :, None] * g[..., None, :]

    info = np.zeros((4, 4) if average else (*X.shape[:-1], 4, 4))
    if bearing:
        info += bearing * outer(_bearing_grad(X, coords))
    if range_:
        info += range_ * outer(_range_grad(X, coords))
    return info


def measurement_information(X: np.ndarray, step: int, inputs: PCRBInputs,
                            coords: Coords, ping_weight: float | None = None) -> np.ndarray:
    """Average conditional Fisher information of the measurements at ``step`` (4, 4).

    ``E_X[E[s sᵀ | X]]`` over the samples ``X`` of the relative state: the measurement term
    D33 of Tichavský's recursion (brehard2005 eq. 29; ristic2004, ch. 4). A range reading of a
    sensor with a ``max_range`` exists only where the range is within it (the echo,
    :func:`tmaplan.simulate.simulate`), so its term is ``E_X[1[r(X) ≤ max_range]·∇r∇rᵀ/σ_r²]``:
    each sample counts it at its own range (:func:`tmaplan.bounds.inputs.reached_range_weight`).
    This is the measurement-existence form of the PCRB with a state-dependent detection
    probability, here 0 or 1: the information of the echoes received; the information that
    an echo is *absent* (``r > max_range``, a step in X with no Fisher information) is not
    counted. With every sample within reach (or none) the term is the unlimited one (or no
    ping), bit for bit.

    Parameters
    ----------
    X : ndarray, shape (N, 4)
        Samples of the relative state at ``step`` [m, m, m/s, m/s].
    step : int
        Grid step k.
    inputs : PCRBInputs
        Per-step bearing, range (with their reach) and frequency information.
    coords : {"cartesian", "lpc"}
    ping_weight : float, optional
        Range information Σ 1/σ_r² at ``step`` [m⁻²] counted for every sample (no reach);
        default ``inputs.ping_weight[step]`` with the reach of ``inputs.range_reach``.

    Returns
    -------
    ndarray, shape (4, 4)
        Information in ``coords`` units.
    """
    N = X.shape[0]
    if ping_weight is None:
        wn = reached_range_weight(inputs.ping_weight, inputs.range_reach, range_of(X), step)
        w = float(wn[0]) if np.all(wn == wn[0]) else None
    else:
        w = ping_weight
    info = conditional_information(X, inputs.bearing_info[step], w or 0.0, coords,
                                   average=True)
    if w is None:  # samples in and out of reach: each counts the readings that reach it
        g = _range_grad(X, coords)
        info += (g * wn[:, None]).T @ g / N
    for sensor, steps in inputs.frequency_sensors:
        if step in steps:
            f0, sig = np.asarray(sensor.f0, float), np.asarray(sensor.sigma, float)
            wf = float(np.sum((f0 / sensor.c) ** 2 / sig**2))
            g = _range_rate_grad(X, coords)
            info += wf * (g.T @ g) / N
    return info


# -------------------------------------------------------------------------- Monte Carlo
def _side_density_samples(X: np.ndarray, ambiguity: str, eps: float = 0.05) -> float:
    b = bearing_of(X)
    if ambiguity == "pi":
        near = np.abs(wrap_half_angle(b)) > np.pi / 2 - eps
    else:
        near = np.abs(b) > np.pi - eps
    return float(near.mean() / (2 * eps))


def _inv_pd(J: np.ndarray, what: str, step: int) -> np.ndarray:
    try:
        L = np.linalg.cholesky(J)
    except np.linalg.LinAlgError as exc:
        raise ObservabilityError(f"{what} is not positive definite at step {step}") from exc
    Li = np.linalg.inv(L)
    return Li.T @ Li


def predicted_information(A: np.ndarray, Q: np.ndarray, *,
                          information: np.ndarray | None = None,
                          covariance: np.ndarray | None = None, step: int = 0) -> np.ndarray:
    """Tichavský's prediction step for linear-Gaussian dynamics ``X' = A X + c + w``,
    ``w ~ N(0, Q)``: ``J⁻_{k+1} = (Q + A J_k⁻¹ Aᵀ)⁻¹`` (the D-terms in closed form; ristic2004,
    ch. 4; brehard2005 eq. 29 with Gaussian transitions).

    The one implementation of the step of the Cartesian PCRBs: :func:`monte_carlo_pcrb` (one
    information matrix, prior-averaged) and :func:`tmaplan.bounds.truth_bound.truth_covariance`
    (one per run, along the true trajectories). Each keeps the numerical form it has always
    had, so that its results stay bit-identical: given ``covariance`` (``J_k⁻¹``, already
    formed), the Cholesky inverse of ``Q + A P Aᵀ``; given ``information``, ``(Q + A
    solve(J, Aᵀ))⁻¹``, or ``A⁻ᵀ J A⁻¹`` without process noise (``Q = 0``). The two forms agree
    to rounding (tests/bounds/test_tichavsky.py, with a plain loop as the cross-check).

    Parameters
    ----------
    A : ndarray, shape (4, 4)
        Transition matrix (NCV: :func:`tmaplan.models.target.ncv_matrices`).
    Q : ndarray, shape (4, 4)
        Process-noise covariance [m², m²/s, m²/s²].
    information : ndarray, shape (..., 4, 4), optional
        ``J_k`` (batched over leading axes).
    covariance : ndarray, shape (4, 4), optional
        ``J_k⁻¹`` (exactly one of ``information`` and ``covariance``).
    step : int
        Index k + 1 of the predicted step, named in the error.

    Returns
    -------
    ndarray
        ``J⁻_{k+1}``, the shape of the input.

    Raises
    ------
    ObservabilityError
        With ``covariance``: the predicted covariance is not positive definite.
    """
    if (information is None) == (covariance is None):
        raise ArgumentError("information", "exactly one of information and covariance",
                            "both" if information is not None else "neither")
    if covariance is not None:
        return _inv_pd(Q + A @ covariance @ A.T, "predicted covariance", step)
    J = np.asarray(information)
    if np.any(Q):
        return np.linalg.inv(Q + A @ np.linalg.solve(J, np.broadcast_to(A.T, J.shape)))
    Ai = np.linalg.inv(A)
    return Ai.T @ J @ Ai


def monte_carlo_pcrb(scenario: Scenario, *, samples: int, rng: np.random.Generator,
                     coords: Coords = "cartesian", ping_steps: Sequence[int] | None = None,
                     observer: ObserverTrack | None = None,
                     prior_samples: int | None = None) -> PCRBResult:
    """PCRB by Tichavský's recursion with Monte Carlo D-terms (brehard2005 Fig. 3, corrected).

    Parameters
    ----------
    scenario : Scenario
        NCV target, a prior, bearing / range / frequency sensors.
    samples : int
        Monte Carlo samples of the propagated relative state (brehard2005 uses 1000).
    rng : numpy.random.Generator
        For the propagation samples and the process noise.
    coords : {"cartesian", "lpc"}
    ping_steps : sequence of int, optional
        Range-ping steps; None = the steps of the scenario's range sensors. A range sensor's
        ``max_range`` applies sample by sample: this bound is averaged over the prior, so a
        reading counts in the expectation over the propagated samples whose range is within
        the reach (:func:`measurement_information`), the probability of an echo times its
        information, not at one track's range.
    observer : ObserverTrack, optional
        A (manoeuvring) observer; default the scenario's.
    prior_samples : int, optional
        Samples behind J₀ (default ``scenario.prior.samples``, drawn with the prior's own seed
        so the closed form and the Monte Carlo share J₀).

    Returns
    -------
    PCRBResult
        ``method = "monte-carlo"``.

    Raises
    ------
    ScenarioError
        Bad scenario fields (no prior, ``q = 0`` in LPC, mass at zero range, ...).
    ArgumentError
        Bad arguments (``coords``, ``samples``, ``rng``, ``ping_steps``).
    ObservabilityError
        A non-positive-definite information matrix.
    """
    t_start = time.perf_counter()
    if coords not in ("cartesian", "lpc"):
        raise ArgumentError("coords", "'cartesian' or 'lpc'", coords, source=scenario.name)
    if not isinstance(samples, int | np.integer) or samples < 2:
        raise ArgumentError("samples", "an integer >= 2", samples, source=scenario.name)
    if not isinstance(rng, np.random.Generator):
        raise ArgumentError("rng", "a numpy.random.Generator", type(rng).__name__,
                            source=scenario.name)
    inp = prepare(scenario, ping_steps=ping_steps, observer=observer,
                  prior_samples=prior_samples, lpc=coords == "lpc")
    K, A, Q = inp.n_steps, inp.A, inp.Q
    q = float(scenario.target.q)
    if coords == "lpc" and q <= 0.0:
        raise ScenarioError("target.q", "> 0 for the LPC PCRB (the LPC transition density "
                            "needs process noise)", q, source=scenario.name)
    X = relative_prior_samples(scenario, int(samples), rng, inp.observer.state[0])
    cov0 = inp.cov_lpc0 if inp.cov_lpc0 is not None else inp.cov_cart0
    J = _inv_pd(cov0, "prior covariance", 0)
    J = J + measurement_information(X, 0, inp, coords)
    LQ = np.linalg.cholesky(Q) if q > 0 else np.zeros((4, 4))
    info = np.empty((K + 1, 4, 4))
    cov = np.empty((K + 1, 4, 4))
    er2 = np.empty(K + 1)
    pos_var = np.empty(K + 1)
    rng_var = np.empty(K + 1)
    side = np.empty(K + 1)

    def record(k: int, J: np.ndarray, X: np.ndarray) -> None:
        info[k] = J
        P = _inv_pd(J, "information J", k)
        cov[k] = P
        r2 = X[:, 0] ** 2 + X[:, 1] ** 2
        er2[k] = r2.mean()
        side[k] = _side_density_samples(X, inp.ambiguity)
        if coords == "lpc":
            G = jacobian_cart_wrt_lpc_from_cart(X)[:, :2, :]
            pos_var[k] = np.einsum("nai,ij,naj->", G, P, G) / X.shape[0]
            rng_var[k] = er2[k] * P[1, 1]
        else:
            u = X[:, :2] / np.sqrt(r2)[:, None]
            pos_var[k] = P[0, 0] + P[1, 1]
            rng_var[k] = np.mean(np.einsum("na,ab,nb->n", u, P[:2, :2], u))

    record(0, J, X)
    N = X.shape[0]
    for t in range(K):
        w = rng.standard_normal((N, 4)) @ LQ.T
        Xn = X @ A.T + inp.c[t] + w
        if coords == "lpc":
            g1, g2 = lpc_transition_scores(X, Xn, inp.c[t], A, Q)
            D11 = g1.T @ g1 / N
            D12 = g1.T @ g2 / N
            D22 = g2.T @ g2 / N
            M = J + D11
            try:
                J = D22 - D12.T @ np.linalg.solve(M, D12)
            except np.linalg.LinAlgError as exc:  # the same solve, reported as documented
                raise ObservabilityError(f"J + D11 is singular at step {t + 1}") from exc
        else:
            J = predicted_information(A, Q, covariance=cov[t], step=t + 1)
        J = J + measurement_information(Xn, t + 1, inp, coords)
        J = 0.5 * (J + J.T)
        X = Xn
        record(t + 1, J, X)
    std = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    return PCRBResult(
        times=inp.times, coords=coords, method="monte-carlo", information=info, std=std,
        position_std=np.sqrt(pos_var), range_std=np.sqrt(rng_var),
        seconds=time.perf_counter() - t_start, samples=int(samples),
        prior_samples=inp.prior_samples, ping_steps=inp.ping_steps,
        range_bound=np.sqrt(rng_var) if coords == "lpc" else None, side_density=side,
        side_valid=None)
