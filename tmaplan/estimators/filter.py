"""The interface every recursive filter implements, and the one loop that drives a filter.

A filter (:class:`Filter`) is a frozen configuration with four methods: ``init`` (a state from
the scenario's prior), ``predict`` (one grid step with the observer's velocity increment),
``update`` (the measurements of the current step) and ``diagnostic`` (one number per state to
record: the particle filter's effective sample size, the range-only filter's number of mixture
components). Its state (:class:`FilterState`) carries the step and the posterior mean and
covariance of the relative state ``X = [r_x, r_y, v_x, v_y]``. Implementations:
:class:`tmaplan.estimators.particle_filter.ParticleFilter` and
:class:`tmaplan.estimators.range_only.RangeOnlyFilter`.

:func:`drive` is the only loop that steps a filter through time; the open-loop estimator runs
(:func:`tmaplan.estimators.run`) and the closed loop (:mod:`tmaplan.evaluation.closed_loop`) both
use it, the latter with a ``step`` callback in which the policy acts on the belief before the
sensors measure.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any, ClassVar, Protocol, TypeVar, runtime_checkable

import numpy as np

from tmaplan.interrupts import checkpoint
from tmaplan.scenario import Scenario
from tmaplan.simulate import Measurement

__all__ = ["Filter", "FilterRun", "FilterState", "drive"]


@runtime_checkable
class FilterState(Protocol):
    """Posterior at grid step ``step``: ``mean`` (4,) [m, m, m/s, m/s], ``cov`` (4, 4)."""

    @property
    def step(self) -> int: ...

    @property
    def mean(self) -> np.ndarray: ...

    @property
    def cov(self) -> np.ndarray: ...


S = TypeVar("S", bound=FilterState)


@runtime_checkable
class Filter(Protocol[S]):
    """A recursive Bayesian filter of the relative state (see the module docstring)."""

    name: ClassVar[str]
    #: Sensor kinds ("bearing", "range", "frequency") the filter assimilates.
    applies_to: ClassVar[frozenset[str]]

    def init(self, scenario: Scenario, rng: np.random.Generator) -> S:
        """State at step 0 from ``scenario.prior`` (never the truth)."""

    def predict(self, state: S, dv: np.ndarray | None, rng: np.random.Generator) -> S:
        """One step ahead with the observer velocity increment Δv_k [m/s], shape (2,)."""

    def update(self, state: S, measurements: Sequence[Measurement],
               rng: np.random.Generator) -> S:
        """Assimilate the measurements of ``state.step`` (an empty list changes nothing)."""

    def diagnostic(self, state: S) -> float:
        """One number describing the state's health (ESS, number of components)."""


@dataclasses.dataclass(frozen=True, kw_only=True)
class FilterRun:
    """What :func:`drive` records.

    Attributes
    ----------
    estimates : ndarray, shape (K + 1, 4)
        Posterior means [m, m/s]; NaN at steps the loop did not reach.
    covariances : ndarray, shape (K + 1, 4, 4)
    diagnostics : ndarray, shape (K + 1,)
        :meth:`Filter.diagnostic` per step.
    state : FilterState
        The last state.
    """

    estimates: np.ndarray
    covariances: np.ndarray
    diagnostics: np.ndarray
    state: Any


StepFn = Callable[[int, Any], tuple["np.ndarray | None", "Sequence[Measurement]"]]


def drive(filt: Filter[Any], state: Any, n_steps: int, step: StepFn, rng: np.random.Generator,
          *, record: FilterRun | None = None) -> FilterRun:
    """Step ``filt`` from ``state`` (at step k₀) to step ``n_steps``.

    At each k = k₀ … n_steps − 1, ``step(k, state)`` returns the observer increment Δv_k and
    the measurements taken at k + 1 (a closed loop lets its policy act on ``state`` here); the
    filter predicts to k + 1, updates and the posterior is recorded.

    Parameters
    ----------
    filt : Filter
    state : FilterState
        Posterior at its step k₀ (recorded too).
    n_steps : int
        K, the last grid step.
    step : callable(k, state) -> (dv, measurements)
    rng : numpy.random.Generator
        The filter's randomness.
    record : FilterRun, optional
        Arrays to continue filling (default: new ones, NaN before k₀).

    Returns
    -------
    FilterRun
    """
    if record is None:
        record = FilterRun(estimates=np.full((n_steps + 1, 4), np.nan),
                           covariances=np.full((n_steps + 1, 4, 4), np.nan),
                           diagnostics=np.full(n_steps + 1, np.nan), state=state)
    est, cov, diag = record.estimates, record.covariances, record.diagnostics
    k0 = int(state.step)
    est[k0], cov[k0], diag[k0] = state.mean, state.cov, filt.diagnostic(state)
    for k in range(k0, n_steps):
        checkpoint()  # an interrupt that Python ignored (tmaplan.interrupts) stops here
        dv, meas = step(k, state)
        state = filt.predict(state, dv, rng)
        state = filt.update(state, meas, rng)
        est[k + 1], cov[k + 1], diag[k + 1] = state.mean, state.cov, filt.diagnostic(state)
    return dataclasses.replace(record, state=state)
