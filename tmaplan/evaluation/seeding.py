"""The one seeding rule of the Monte Carlo runs.

Every Monte Carlo computation of tmaplan is seeded from one root ``seed`` (an integer >= 0)
by one rule: run ``i`` owns the child ``numpy.random.SeedSequence(seed, spawn_key=(i,))``
(:func:`run_seed`), which is the ``i``-th child of ``SeedSequence(seed).spawn(n)`` for any
``n > i``. A run's result therefore depends on ``(seed, i)`` only, never on the number of
runs, on the order they are computed in, or on the worker that computes them.

What a run does with its child is the one documented choice:

* a closed-loop run (a campaign, ``compare``, ``rank-costs``, the benchmarks) splits it into
  three streams, :func:`run_streams`: the truth (drawn once per run), the measurement noise and
  the filter (each re-created for every policy, so that the policies of one run are paired);
* an estimator run (``track``, :func:`tmaplan.evaluation.tracking.monte_carlo`) uses the child
  as one generator, the simulation first, then the estimator; the draws of its bound use the
  child after the last run's (index ``runs``);
* a prior draw of the cost ranking (:func:`tmaplan.evaluation.cost_ranking.cost_functionals`)
  is draw ``i``'s child, used whole.

A computation that is not a run (the cost ranking's prior-averaged PCRB and bootstrap) draws
from the root itself, :func:`root_rng`, which equals ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["RunStreams", "root_rng", "run_seed", "run_seeds", "run_streams"]


def run_seed(seed: int, run: int) -> np.random.SeedSequence:
    """The seed of run ``run`` under root ``seed``: ``SeedSequence(seed, spawn_key=(run,))``.

    Parameters
    ----------
    seed : int
        Root seed, >= 0.
    run : int
        Run index, >= 0.

    Returns
    -------
    numpy.random.SeedSequence
    """
    return np.random.SeedSequence(int(seed), spawn_key=(int(run),))


def run_seeds(seed: int, n_runs: int, *, first: int = 0) -> list[np.random.SeedSequence]:
    """The seeds of runs ``first, ..., first + n_runs - 1`` (:func:`run_seed`; the same as
    ``SeedSequence(seed).spawn(first + n_runs)[first:]``).

    Parameters
    ----------
    seed : int
        Root seed, >= 0.
    n_runs : int
        Number of runs.
    first : int
        Index of the first run.

    Returns
    -------
    list of numpy.random.SeedSequence
        Length ``n_runs``.
    """
    return [run_seed(seed, i) for i in range(int(first), int(first) + int(n_runs))]


@dataclasses.dataclass(frozen=True, kw_only=True)
class RunStreams:
    """The three streams of a closed-loop run (:func:`run_streams`).

    Attributes
    ----------
    truth : numpy.random.SeedSequence
        The true target track (drawn once per run).
    noise : numpy.random.SeedSequence
        The measurement noise (a new generator for every policy).
    filter : numpy.random.SeedSequence
        The particle filter (a new generator for every policy).
    """

    truth: np.random.SeedSequence
    noise: np.random.SeedSequence
    filter: np.random.SeedSequence


def run_streams(seed: int, run: int) -> RunStreams:
    """The truth, noise and filter streams of closed-loop run ``run``: the three children of
    :func:`run_seed` (``SeedSequence(seed, spawn_key=(run,)).spawn(3)``, in that order).

    Parameters
    ----------
    seed : int
        Root seed, >= 0.
    run : int
        Run index, >= 0.

    Returns
    -------
    RunStreams
    """
    truth, noise, filt = run_seed(seed, run).spawn(3)
    return RunStreams(truth=truth, noise=noise, filter=filt)


def root_rng(seed: int) -> np.random.Generator:
    """The generator of a computation that is not a run (a bootstrap, a prior-averaged bound):
    the root ``SeedSequence(seed)`` itself, the same stream as ``numpy.random.default_rng(seed)``.

    Parameters
    ----------
    seed : int
        Root seed, >= 0.

    Returns
    -------
    numpy.random.Generator
    """
    return np.random.default_rng(np.random.SeedSequence(int(seed)))
