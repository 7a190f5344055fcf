"""Sampling the scenario's prior on the target's initial state (vectorised).

The papers describe their priors in polar terms (bearing, range, speed, course) centred on the
truth; ``None`` means in each field of :class:`tmaplan.scenario.Prior` "the true value". For
Ristic et al.'s benchmark the bearing mean is the first measurement; sampling it as
N(true bearing, σ_θ²) has the same distribution over runs.
"""

from __future__ import annotations

import numpy as np

from tmaplan.errors import ArgumentError, ScenarioError
from tmaplan.geometry import bearing_of, course_speed, range_of
from tmaplan.models.target import circle_state, initial_velocity
from tmaplan.scenario import Prior, Scenario
from tmaplan.scenario.prior_checks import check_truncated_normal

__all__ = ["prior_relative_moments", "relative_prior_covariance", "relative_prior_samples",
           "sample_prior", "true_initial_state"]


def true_initial_state(scenario: Scenario) -> np.ndarray:
    """Absolute true target state at t0, shape (4,) [m, m, m/s, m/s]."""
    t = scenario.target
    if t.model == "constant-turn":
        return circle_state(t, np.array([scenario.time.t0]))[0]
    return np.concatenate([np.asarray(t.position, float), initial_velocity(t)])


def _truncnorm(mean: float, std: float, lo: float, hi: float, n: int,
               rng: np.random.Generator, name: str, unit: str, source: str,
               truth: bool) -> np.ndarray:
    """``n`` draws of N(mean, std²) truncated to [lo, hi]; a point mass for ``std = 0``,
    which must lie in [lo, hi], else a negligible mass within (:func:`check_truncated_normal`)
    is refused (``name`` "range" or "speed" names the mean, ``source`` the scenario in the
    error; ``truth``: the mean is the target's true value)."""
    if std == 0.0:
        if not lo <= mean <= hi:
            raise ScenarioError(f"prior.{name}_mean", f"a value within [{lo}, {hi}] (the std "
                                "is 0: every sample is the mean)", mean, source=source)
        return np.full(n, float(mean))
    check_truncated_normal(name, mean, std, lo, hi, unit, source, truth=truth)
    from scipy import stats  # deferred: scipy.stats takes ~0.5 s to import

    a, b = (lo - mean) / std, (hi - mean) / std
    return stats.truncnorm.rvs(a, b, loc=mean, scale=std, size=n, random_state=rng)


def sample_prior(scenario: Scenario, n: int, rng: np.random.Generator) -> np.ndarray:
    """Draw ``n`` absolute initial target states from ``scenario.prior``.

    Parameters
    ----------
    scenario : Scenario
        Must have a ``prior``.
    n : int
        Number of samples.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n, 4)
        ``[x, y, v_x, v_y]`` [m, m, m/s, m/s].

    Raises
    ------
    ScenarioError
        If the scenario has no prior.
    """
    p: Prior | None = scenario.prior
    if p is None:
        raise ScenarioError("prior", "a [prior] table (this computation needs a prior)", None,
                            source=scenario.name)
    truth = true_initial_state(scenario)
    obs0 = np.asarray(scenario.observer.position, float)
    if p.kind == "gaussian":
        mean = np.asarray(p.mean, float) if p.mean is not None else truth
        return mean + rng.standard_normal((n, 4)) * np.asarray(p.std, float)
    rel = truth[:2] - obs0
    true_bearing = float(bearing_of(rel))
    true_range = float(range_of(rel))
    b_mean = p.bearing_mean if p.bearing_mean is not None else true_bearing
    bearing = b_mean + p.bearing_std * rng.standard_normal(n)
    hi = p.range_max if p.range_max is not None else np.inf
    if p.range_distribution == "normal":
        r_mean = p.range_mean if p.range_mean is not None else true_range
        rng_ = _truncnorm(r_mean, float(p.range_std or 0.0), p.range_min, hi, n, rng,
                          "range", "m", scenario.name, p.range_mean is None)
    elif p.range_distribution == "uniform":
        rng_ = rng.uniform(p.range_min, hi, n)
    else:
        rng_ = np.exp(rng.uniform(np.log(p.range_min), np.log(hi), n))
    pos = obs0 + rng_[:, None] * np.stack([np.sin(bearing), np.cos(bearing)], axis=-1)
    tv = truth[2:]
    if p.velocity_distribution == "normal":
        vm = np.asarray(p.velocity_mean, float) if p.velocity_mean is not None else tv
        vel = vm + p.velocity_std * rng.standard_normal((n, 2))
    else:
        true_course, true_speed = (float(x) for x in course_speed(tv))
        s_hi = p.speed_max if p.speed_max is not None else np.inf
        if p.speed_distribution == "uniform":
            speed = rng.uniform(p.speed_min, s_hi, n)
        else:
            s_mean = p.speed_mean if p.speed_mean is not None else true_speed
            speed = _truncnorm(s_mean, p.speed_std, p.speed_min, s_hi, n, rng,
                               "speed", "m/s", scenario.name, p.speed_mean is None)
        if p.course_mode == "uniform":
            course = rng.uniform(-np.pi, np.pi, n)
        else:
            if p.course_mode == "true":
                c_mean: np.ndarray | float = true_course
            elif p.course_mode == "given":
                c_mean = float(p.course_mean)  # type: ignore[arg-type]
            else:  # reciprocal-bearing: target heading towards the observer
                c_mean = bearing + np.pi
            course = c_mean + p.course_std * rng.standard_normal(n)
        vel = speed[:, None] * np.stack([np.sin(course), np.cos(course)], axis=-1)
    return np.hstack([pos, vel])


def relative_prior_samples(scenario: Scenario, n: int, rng: np.random.Generator,
                           observer_state0: np.ndarray | None = None) -> np.ndarray:
    """Prior samples of the relative initial state ``X_0 = target − observer``, shape (n, 4).

    ``observer_state0`` defaults to the scenario's initial observer position and velocity.
    """
    if observer_state0 is None:
        o = scenario.observer
        observer_state0 = np.concatenate([np.asarray(o.position, float), initial_velocity(o)])
    return sample_prior(scenario, n, rng) - np.asarray(observer_state0, float)


def prior_relative_moments(scenario: Scenario, n: int | None = None,
                           rng: np.random.Generator | None = None,
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Mean (4,) and covariance (4, 4) of the relative initial state.

    Exact for a ``gaussian`` prior (``n`` and ``rng`` are then unused: ``rng`` is not
    advanced); else from ``n`` prior samples, the covariance normalised by n
    (:func:`relative_prior_covariance`). Defaults: ``n = scenario.prior.samples`` and
    ``rng = default_rng(scenario.prior.seed)``, so the result is reproducible.
    """
    if scenario.prior is None:
        raise ScenarioError("prior", "a [prior] table (this computation needs a prior)", None,
                            source=scenario.name)
    p = scenario.prior
    if p.kind == "gaussian":  # exact: no sampling error in the prior information
        o = scenario.observer
        mean = np.asarray(p.mean, float) if p.mean is not None else true_initial_state(scenario)
        return (mean - np.concatenate([np.asarray(o.position, float), initial_velocity(o)]),
                relative_prior_covariance(scenario, None))
    n = p.samples if n is None else n
    rng = np.random.default_rng(p.seed) if rng is None else rng
    x = relative_prior_samples(scenario, n, rng)
    return x.mean(axis=0), relative_prior_covariance(scenario, x)


def relative_prior_covariance(scenario: Scenario, samples: np.ndarray | None) -> np.ndarray:
    """Covariance of the relative initial state, shape (4, 4) [m², m²/s, m²/s²].

    Exact for a ``gaussian`` prior (diag(std²); the observer's initial state is a constant),
    else the covariance of ``samples`` (n, 4) of :func:`relative_prior_samples`, normalised
    by n like the LPC prior information (:func:`tmaplan.bounds.inputs.lpc_prior_information`)
    and :attr:`tmaplan.planning.Belief.cov`.
    """
    p = scenario.prior
    if p is not None and p.kind == "gaussian":
        return np.diag(np.square(np.asarray(p.std, float)))
    if samples is None:
        raise ArgumentError("samples", "prior samples (n, 4) for a prior that is not gaussian",
                            None, source=scenario.name)
    return np.cov(np.asarray(samples, float), rowvar=False, bias=True)
