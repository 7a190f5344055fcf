"""Belief on the relative target state that a planner optimises against.

A :class:`Belief` holds the moments (and optionally weighted samples) of the relative state
``X = target − observer = [r_x, r_y, v_x, v_y]`` at a time t, relative to the observer's state
``[position, velocity]`` at that time (docs/conventions.md). The planners turn it into

* the raw moments ``m₀ = E X``, ``S₀ = E X Xᵀ`` that seed the exact moment propagation of the
  closed-form PCRB (brehard2005, docs/errata.md),
* the LPC prior information ``J₀`` (brehard2005 eq. 56: inverse of the LPC covariance of the
  samples, bearing centred on its circular mean),
* the Cartesian prior information ``Cov(X)⁻¹`` for the ``logdet`` objective (lecadre1997).

Beliefs without samples (moments only, e.g. from a Gaussian filter) get deterministic Gaussian
samples (fixed seed) for J₀, truncated to ranges above :data:`MIN_SAMPLE_RANGE`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from tmaplan.bounds.inputs import lpc_prior_information
from tmaplan.display import short_repr
from tmaplan.errors import (
    ArgumentError,
    ObservabilityError,
    PlanningError,
    ScenarioError,
    as_real,
    is_integer,
)
from tmaplan.geometry import range_of
from tmaplan.models.prior import relative_prior_samples

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["MIN_SAMPLE_RANGE", "Belief"]

#: Samples closer than this to the observer are dropped when forming J₀ [m].
MIN_SAMPLE_RANGE = 1.0
#: Samples drawn for J₀ when a belief has moments only.
_GAUSS_SAMPLES = 20_000


@dataclasses.dataclass(frozen=True, kw_only=True)
class Belief:
    """Belief on the relative state at time ``t``.

    Attributes
    ----------
    mean : ndarray, shape (4,)
        ``E X`` [m, m, m/s, m/s].
    cov : ndarray, shape (4, 4)
        ``Cov X`` [m², m²/s, m²/s²], positive definite.
    samples : ndarray, shape (n, 4), optional
        Samples of X (e.g. particles).
    weights : ndarray, shape (n,), optional
        Normalised sample weights (None: equal weights).
    t : float
        Time of the belief [s].
    assimilated : bool
        True if the belief already holds the measurements taken at ``t`` (a filter's
        posterior after its update at t, e.g. at a re-plan): the planners then count the
        sensors from the step after t. False (a prior, or a prediction to t): the
        measurements at t count at plan step 0, as in
        :func:`tmaplan.bounds.closed_form.closed_form_pcrb` from the prior
        (:func:`tmaplan.planning.objectives.plan_bearing_information`).
    """

    __repr__ = short_repr

    mean: np.ndarray
    cov: np.ndarray
    samples: np.ndarray | None = None
    weights: np.ndarray | None = None
    t: float = 0.0
    assimilated: bool = False

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_samples(cls, samples: np.ndarray, weights: np.ndarray | None = None, *,
                     t: float = 0.0, assimilated: bool = False) -> Belief:
        """Belief from (weighted) samples of the relative state.

        Parameters
        ----------
        samples : ndarray, shape (n, 4)
            [m, m, m/s, m/s].
        weights : ndarray, shape (n,), optional
            Non-negative weights (normalised here).
        t : float
            [s].
        assimilated : bool
            The samples already hold the measurements at ``t`` (:attr:`assimilated`).

        Raises
        ------
        PlanningError
            No samples, non-finite samples, weights with no mass, or a degenerate covariance
            ("a target prior with no mass").
        """
        X = _samples(samples)
        if weights is None:
            w = np.full(X.shape[0], 1.0 / X.shape[0])
        else:
            w = np.asarray(weights, dtype=float).reshape(-1)
            if w.shape[0] != X.shape[0] or np.any(~np.isfinite(w)) or np.any(w < 0):
                raise PlanningError("belief: weights must be finite, >= 0, one per sample")
            tot = float(w.sum())
            if tot <= 0.0:
                raise PlanningError("belief: the weights sum to zero: the target prior has no "
                                    "mass to plan against")
            w = w / tot
        mean = w @ X
        d = X - mean
        cov = (d * w[:, None]).T @ d
        cov = 0.5 * (cov + cov.T)
        _check_cov(cov)
        return cls(mean=mean, cov=cov, samples=X, weights=w, t=_time(t),
                   assimilated=bool(assimilated))

    @classmethod
    def from_particles(cls, particles: np.ndarray, weights: np.ndarray, *, t: float = 0.0,
                       max_samples: int = 2000, assimilated: bool = False) -> Belief:
        """Belief from a particle filter's weighted particles, at most ``max_samples`` kept.

        With more particles than ``max_samples``, a deterministic systematic subsample
        (offset 0.5) of ``max_samples``, equally weighted; otherwise every particle with its
        weight (a filter between resamplings has unequal weights).

        Parameters
        ----------
        particles : ndarray, shape (n, 4)
            Relative states [m, m, m/s, m/s].
        weights : ndarray, shape (n,)
            Non-negative weights (normalised here).
        t : float
            [s].
        max_samples : int
            Samples kept, >= 5.
        assimilated : bool
            The filter has updated on the measurements at ``t`` (:attr:`assimilated`).

        Raises
        ------
        PlanningError
            As :meth:`from_samples` (also when subsampling: particles of the wrong shape or
            not one weight per particle), or ``max_samples`` below 5.
        """
        if not is_integer(max_samples, 5):
            raise PlanningError(f"belief: max_samples must be an integer >= 5, received "
                                f"{max_samples!r}")
        X = _samples(particles)
        w = np.asarray(weights, dtype=float).reshape(-1)
        if w.shape[0] != X.shape[0]:  # subsampling would pick rows by the wrong weights
            raise PlanningError(f"belief: one weight per particle expected ({X.shape[0]}), "
                                f"received {w.shape[0]} weights")
        if w.size <= max_samples:
            return cls.from_samples(X, w, t=t, assimilated=assimilated)
        if np.any(~np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
            raise PlanningError("belief: weights must be finite, >= 0, with mass")
        c = np.cumsum(w / w.sum())
        c[-1] = 1.0
        idx = np.searchsorted(c, (np.arange(max_samples) + 0.5) / max_samples)
        return cls.from_samples(X[idx], t=t, assimilated=assimilated)

    @classmethod
    def from_moments(cls, mean: np.ndarray, cov: np.ndarray, *, t: float = 0.0,
                     assimilated: bool = False) -> Belief:
        """Belief from the mean (4,) [m, m, m/s, m/s] and covariance (4, 4) of the relative
        state at ``t`` [s] (``assimilated``: it holds the measurements at t,
        :attr:`assimilated`).

        Raises
        ------
        PlanningError
            A non-finite mean or time, or a covariance that is not positive definite.
        """
        m = np.asarray(mean, dtype=float).reshape(4)
        if not np.all(np.isfinite(m)):
            raise PlanningError(f"belief: mean: expected finite values, received {m.tolist()}")
        C = np.asarray(cov, dtype=float).reshape(4, 4)
        C = 0.5 * (C + C.T)
        _check_cov(C)
        return cls(mean=m, cov=C, t=_time(t), assimilated=bool(assimilated))

    @classmethod
    def from_prior(cls, scenario: Scenario, *, n: int | None = None,
                   rng: np.random.Generator | None = None) -> Belief:
        """Belief of the relative initial state from ``scenario.prior`` (at ``scenario.time.t0``;
        not :attr:`assimilated`: a sensor measuring at t0 counts at plan step 0).

        Parameters
        ----------
        scenario : Scenario
        n : int, optional
            Number of samples, >= 5 (default ``min(scenario.prior.samples, 20000)``).
        rng : numpy.random.Generator, optional
            Default ``default_rng(scenario.prior.seed)`` (reproducible).

        Raises
        ------
        PlanningError
            No prior, or a prior with no mass.
        ArgumentError
            ``n`` not an integer >= 5 (a float was truncated, a bool taken as 0 or 1).
        """
        if scenario.prior is None:
            raise PlanningError(f"{scenario.name}: the scenario has no [prior]: nothing to "
                                "plan against")
        if n is not None and not is_integer(n, 5):
            raise ArgumentError("n", "an integer >= 5 (None: the prior's samples)", n)
        n = min(scenario.prior.samples, _GAUSS_SAMPLES) if n is None else int(n)
        rng = np.random.default_rng(scenario.prior.seed) if rng is None else rng
        try:
            X = relative_prior_samples(scenario, n, rng)
        except (ScenarioError, ValueError) as exc:
            raise PlanningError(f"{scenario.name}: cannot sample the target prior ({exc})"
                                ) from exc
        return cls.from_samples(X, t=float(scenario.time.t0))

    # ------------------------------------------------------------------- derived values
    @property
    def second_moment(self) -> np.ndarray:
        """``S = E X Xᵀ = Cov + m mᵀ``, shape (4, 4)."""
        return self.cov + np.outer(self.mean, self.mean)

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` samples (n, 4): resampled from ``samples`` if any, else Gaussian."""
        if self.samples is not None:
            idx = rng.choice(self.samples.shape[0], size=n, p=self.weights)
            return self.samples[idx]
        return rng.multivariate_normal(self.mean, self.cov, size=n)

    def representative_samples(self, n: int) -> np.ndarray:
        """Deterministic ``n`` samples for sample-averaged objectives, shape (n, 4).

        ``n = 1`` gives the mean; otherwise a fixed-seed draw (so re-planning with an
        unchanged belief gives the same objective).
        """
        if n <= 1:
            return self.mean[None, :].copy()
        return self.draw(n, np.random.default_rng(20240601))

    def lpc_information(self) -> np.ndarray:
        """LPC prior information ``J₀`` (4, 4) of brehard2005 eq. 56 (weighted samples), by
        :func:`tmaplan.bounds.inputs.lpc_prior_information` (samples within
        :data:`MIN_SAMPLE_RANGE` of the observer are dropped).

        Raises
        ------
        PlanningError
            If the LPC covariance is not positive definite.
        """
        if self.samples is not None:
            X, w = self.samples, self.weights
        else:
            X = np.random.default_rng(7).multivariate_normal(self.mean, self.cov,
                                                             size=_GAUSS_SAMPLES)
            w = None
        keep = range_of(X) > MIN_SAMPLE_RANGE
        X = X[keep]
        if w is not None:
            w = w[keep]
            if w.sum() <= 0:
                raise PlanningError("belief: all the mass is at zero range")
        try:
            return lpc_prior_information(X, w)[1]
        except ObservabilityError as exc:
            raise PlanningError(f"belief: the LPC covariance of the belief is singular ({exc})"
                                ) from exc

    def cartesian_information(self) -> np.ndarray:
        """``Cov(X)⁻¹`` (4, 4) [1/m², ...]."""
        J = np.linalg.inv(self.cov)
        return 0.5 * (J + J.T)

    def mean_range(self) -> float:
        """Range of the mean relative position [m]."""
        return float(range_of(self.mean))


def _samples(samples: np.ndarray) -> np.ndarray:
    """``samples`` as a finite (n >= 5, 4) float array, or PlanningError."""
    X = np.asarray(samples, dtype=float)
    if X.ndim != 2 or X.shape[1] != 4 or X.shape[0] < 5:
        raise PlanningError(f"belief: samples of shape (n >= 5, 4) expected, received "
                            f"{X.shape}: the target prior has no mass to plan against")
    if not np.all(np.isfinite(X)):
        raise PlanningError("belief: non-finite samples")
    return X


def _time(t: float) -> float:
    """The belief's time ``t`` [s] as a finite float, or PlanningError."""
    v = as_real(t)
    if not np.isfinite(v):
        raise PlanningError(f"belief: t: expected a finite time [s], received {t!r}")
    return v


def _check_cov(cov: np.ndarray) -> None:
    if not np.all(np.isfinite(cov)):
        raise PlanningError("belief: non-finite covariance")
    try:
        np.linalg.cholesky(cov)
    except np.linalg.LinAlgError as exc:
        raise PlanningError(
            "belief: the covariance of the relative state is not positive definite "
            f"(variances {np.diag(cov).tolist()}): the target prior has no mass in some "
            "direction, so no bound can be planned against it") from exc
