"""How detectable an unmodelled target manoeuvre is at all: the noncentrality of ideal tests.

Whether a monitor *could* notice a course change within a window depends on how far the
measurements after it move away from what a straight track predicts. Two ideal tests bound
every detector from above:

* **clairvoyant**: the onset, the target's state and its new velocity are known; the test
  between "straight continuation" and "manoeuvre" is a test between two known Gaussian means,
  the likelihood-ratio statistic is normal with unit variance after scaling and its
  noncentrality is ``λ = Σ_k (Δβ_k/σ_β)² + Σ_pings (Δr_k/σ_r)²`` over the window after the
  onset, ``Δβ_k`` the bearing of the manoeuvring truth minus that of the straight continuation
  seen from the same own-ship positions;
* **state unknown**: as above, but the target's state is not known, so the straight-track
  hypothesis is the best straight track through all measurements up to the end of the window
  (pre-manoeuvre bearings and pings included): ``λ = min_{x₀, v} Σ_k ((β_k − β_k(x₀, v))/σ_β)²
  + Σ_pings ((r_k − r_k(x₀, v))/σ_r)²`` on the noise-free manoeuvring measurements. When the
  own ship holds its leg, a straight track fits the post-turn bearings too (bearings-only
  tracking is unobservable without an own-ship manoeuvre, lecadre1997) and λ collapses. The
  fit ignores the prior's support, so the bound is only as tight as the measurements make it.

For a one-sided test at false-alarm probability α the probability of detection is
``P_D = Φ(√λ − z_{1−α})`` (known signal in white Gaussian noise; Kay 1998, *Fundamentals of
Statistical Signal Processing II*, §4.3). A sequential detector that must keep its false-alarm
rate per step below α over many steps does no better, so the fraction of runs with ``P_D ≥ p``
bounds the fraction of runs any monitor at that α detects within the window.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import optimize, stats

from tmaplan.errors import ArgumentError, as_real, is_integer
from tmaplan.geometry import bearing_of, range_of, wrap_angle

__all__ = ["DetectabilityBound", "detection_probability", "manoeuvre_detectability"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class DetectabilityBound:
    """Noncentralities and detection probabilities of the ideal tests (module docstring).

    Attributes
    ----------
    lam_clairvoyant : float
        λ of the clairvoyant test (known state, onset and new velocity) [dimensionless].
    lam_unknown_state : float
        λ against the best straight track through the measurements [dimensionless].
    pd_clairvoyant, pd_unknown_state : float
        Detection probabilities ``Φ(√λ − z_{1−α})``.
    """

    lam_clairvoyant: float
    lam_unknown_state: float
    pd_clairvoyant: float
    pd_unknown_state: float


def detection_probability(lam: float | np.ndarray, alpha: float) -> np.ndarray:
    """``Φ(√λ − z_{1−α})``: detection probability of a known mean shift of noncentrality λ
    by a one-sided test at false-alarm probability α."""
    if not 0.0 < alpha < 0.5:
        raise ArgumentError("alpha", "a probability in (0, 0.5)", alpha)
    return np.asarray(stats.norm.cdf(np.sqrt(np.maximum(lam, 0.0)) - stats.norm.isf(alpha)))


def _predicted(xy: np.ndarray, own: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bearings (from north, [rad]) and ranges [m] of absolute positions ``xy`` seen from
    ``own``, both shape (K, 2)."""
    d = xy - own
    return np.asarray(bearing_of(d)), np.asarray(range_of(d))


def manoeuvre_detectability(*, times: np.ndarray, own_position: np.ndarray,
                            target: np.ndarray, straight: np.ndarray, onset: int,
                            window: float, bearing_sigma: float, bearing_steps: np.ndarray,
                            ping_steps: np.ndarray, range_sigma: float,
                            alpha: float = 1e-3) -> DetectabilityBound:
    """The two ideal tests of the module docstring for one run.

    Parameters
    ----------
    times : ndarray, shape (K + 1,)
        Grid [s].
    own_position : ndarray, shape (K + 1, 2)
        Own-ship positions [m] (the run's actual path).
    target, straight : ndarray, shape (K + 1, 4)
        Absolute target track with the manoeuvre, and without it (same track before
        ``onset``) [m, m/s].
    onset : int
        First grid step of the manoeuvre.
    window : float
        Time after the onset in which detection counts [s], > 0.
    bearing_sigma, range_sigma : float
        Measurement standard deviations [rad] / [m], > 0.
    bearing_steps, ping_steps : ndarray of int
        Steps with a bearing / a ping echo, in [0, K].
    alpha : float
        False-alarm probability of the test.

    Returns
    -------
    DetectabilityBound
    """
    times = np.asarray(times, float)
    n = times.size
    if not is_integer(onset, 1) or not onset < n:
        raise ArgumentError("onset", f"an integer step in [1, {n - 1}]", onset)
    if not window > 0:
        raise ArgumentError("window", "a time > 0 [s]", window)
    for name, v in (("bearing_sigma", bearing_sigma), ("range_sigma", range_sigma)):
        if not v > 0:
            raise ArgumentError(name, "> 0", v)
    if not 0.0 < as_real(alpha) < 0.5:
        raise ArgumentError("alpha", "a probability in (0, 0.5)", alpha)
    own = np.asarray(own_position, float)
    target, straight = np.asarray(target, float), np.asarray(straight, float)
    for name, x, cols in (("own_position", own, 2), ("target", target, 4),
                          ("straight", straight, 4)):
        if x.shape != (n, cols):
            raise ArgumentError(name, f"shape ({n}, {cols}), one row per grid time", x.shape)
    bs = np.asarray(bearing_steps, int)
    ps = np.asarray(ping_steps, int)
    for name, st in (("bearing_steps", bs), ("ping_steps", ps)):
        if st.ndim != 1 or ((st < 0) | (st >= n)).any():  # a negative step counts from the end
            raise ArgumentError(name, f"grid steps in [0, {n - 1}]", st.tolist())
    last = int(np.searchsorted(times, times[onset] + window + 1e-9)) - 1
    bs, ps = bs[bs <= last], ps[ps <= last]
    b_m, _ = _predicted(target[bs, :2], own[bs])
    _, r_m = _predicted(target[ps, :2], own[ps])
    b_s, _ = _predicted(straight[bs, :2], own[bs])
    _, r_s = _predicted(straight[ps, :2], own[ps])
    lam_c = float(np.sum((wrap_angle(b_m - b_s) / bearing_sigma) ** 2)
                  + np.sum(((r_m - r_s) / range_sigma) ** 2))

    t0 = float(times[onset])

    def residuals(p: np.ndarray) -> np.ndarray:
        def xy(steps: np.ndarray) -> np.ndarray:
            return p[:2] + np.outer(times[steps] - t0, p[2:])

        b, _ = _predicted(xy(bs), own[bs])
        _, r = _predicted(xy(ps), own[ps])
        return np.concatenate([wrap_angle(b_m - b) / bearing_sigma, (r_m - r) / range_sigma])

    lam_u = lam_c
    # start from the straight continuation and from the post-manoeuvre straight line
    for start in (straight[onset], np.concatenate([target[onset, :2], target[last, 2:]])):
        fit = optimize.least_squares(residuals, np.asarray(start, float),
                                     x_scale=np.array([1e3, 1e3, 1.0, 1.0]))
        lam_u = min(lam_u, float(2.0 * fit.cost))
    pd = detection_probability(np.array([lam_c, lam_u]), alpha)
    return DetectabilityBound(lam_clairvoyant=lam_c, lam_unknown_state=lam_u,
                              pd_clairvoyant=float(pd[0]), pd_unknown_state=float(pd[1]))
