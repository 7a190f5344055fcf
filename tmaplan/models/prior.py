"""Sampling the scenario's prior on the target's initial state (vectorised).

The papers describe their priors in polar terms (bearing, range, speed, course) centred on the
truth; ``None`` means in each field of :class:`tmaplan.scenario.Prior` "the true value". For
Ristic et al.'s benchmark the bearing mean is the first measurement; sampling it as
N(true bearing, σ_θ²) has the same distribution over runs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy import stats
from scipy.special import log_ndtr

from tmaplan.errors import ArgumentError, ScenarioError
from tmaplan.geometry import bearing_of, course_speed, range_of
from tmaplan.models.target import circle_state, initial_velocity

if TYPE_CHECKING:
    from tmaplan.scenario import Prior, Scenario

__all__ = ["MIN_TRUNCATED_MASS", "check_truncated_normal", "prior_relative_moments",
           "relative_prior_covariance", "relative_prior_samples", "sample_prior",
           "true_initial_state", "truncated_normal_log_mass", "zero_prior_stds"]

#: least probability mass that a normal range or speed prior must keep within its truncation
#: [min, max]: with less, every draw sits at the nearer bound (a degenerate prior)
MIN_TRUNCATED_MASS = 1e-6


def true_initial_state(scenario: Scenario) -> np.ndarray:
    """Absolute true target state at t0, shape (4,) [m, m, m/s, m/s]."""
    t = scenario.target
    if t.model == "constant-turn":
        return circle_state(t, np.array([scenario.time.t0]))[0]
    return np.concatenate([np.asarray(t.position, float), initial_velocity(t)])


def truncated_normal_log_mass(mean: float, std: float, lo: float, hi: float) -> float:
    """Natural log of the probability mass of N(mean, std²) within [lo, hi] (``hi`` may be
    inf; ``std`` > 0), accurate far in either tail (``scipy.special.log_ndtr``): -inf only
    when the mass underflows even as a logarithm."""
    a, b = (lo - mean) / std, (hi - mean) / std
    if a > 0:  # both bounds in the upper tail: the mirror image lies in the accurate lower one
        a, b = -b, -a
    la, lb = float(log_ndtr(a)), float(log_ndtr(b))
    return lb + math.log1p(-math.exp(la - lb)) if la < lb else -math.inf


def check_truncated_normal(name: str, mean: float, std: float, lo: float, hi: float,
                           unit: str, source: str | None, *, truth: bool = False) -> None:
    """Refuse a normal ``name`` prior ("range" or "speed", ``std`` > 0) whose truncation to
    [lo, hi] keeps less than :data:`MIN_TRUNCATED_MASS` of N(mean, std²) (every draw would
    sit at the nearer bound), naming ``prior.<name>_mean``, the interval and the mass;
    ``truth``: the mean is the target's true value (``centred_on_truth``)."""
    if not std > 0:
        return
    log_mass = truncated_normal_log_mass(mean, std, lo, hi)
    if log_mass >= math.log(MIN_TRUNCATED_MASS):
        return
    mass = math.exp(log_mass)
    kept = f"{mass:.3g}" if mass > 0 else f"10^{log_mass / math.log(10):.4g}"
    raise ScenarioError(
        f"prior.{name}_mean", f"a value leaving at least {MIN_TRUNCATED_MASS:g} of "
        f"N({name}_mean, {name}_std²) within [{name}_min, {name}_max] = [{lo:g}, {hi:g}] "
        f"{unit}: with {name}_std = {std:g} {unit} it keeps {kept} of its mass (every draw "
        "would sit at the nearer bound)" + (f"; the key is left out, so the mean is the "
                                            f"target's true initial {name}" if truth else ""),
        mean, source=source)


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


def zero_prior_stds(prior: Prior, *, point_masses: bool = True) -> tuple[str, ...]:
    """The std fields of ``prior`` that :func:`sample_prior` uses and that are zero.

    Each makes the prior degenerate (no density in that component): the prior information
    ``J0 = P0⁻¹`` of the closed-form bound (brehard2005, eq. 56) does not exist.

    Parameters
    ----------
    prior : Prior
    point_masses : bool
        Include the zeros a scenario may keep (False: the scenario's load check, which
        refuses the others): ``range_std`` / ``speed_std`` of a normal range or speed (a
        point mass at the mean) and ``course_std`` with ``course_mode = "reciprocal-bearing"``
        (the course follows the bearing's spread). The closed-form bound refuses them too.

    Returns
    -------
    tuple of str
        Dotted field names (``"prior.bearing_std"``, ``"prior.std[2]"``, …) in file order;
        empty if every sampled component has a positive std.
    """
    p = prior
    if p.kind == "gaussian":
        return tuple(f"prior.std[{i}]" for i, v in enumerate(p.std or ()) if v == 0)
    out = []
    if p.bearing_std == 0:
        out.append("prior.bearing_std")
    if point_masses and p.range_distribution == "normal" and not p.range_std:
        out.append("prior.range_std")
    if p.velocity_distribution == "normal":
        if p.velocity_std == 0:
            out.append("prior.velocity_std")
    else:
        if point_masses and p.speed_distribution == "normal" and p.speed_std == 0:
            out.append("prior.speed_std")
        kept = ("uniform",) if point_masses else ("uniform", "reciprocal-bearing")
        if p.course_mode not in kept and p.course_std == 0:
            out.append("prior.course_std")
    return tuple(out)


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
