"""Evaluation layer: simulation in the loop, closed loop, estimator Monte Carlo, campaigns,
metrics.

:mod:`~tmaplan.evaluation.closed_loop` (one run of a policy against a truth, the particle filter
driven by :func:`tmaplan.estimators.filter.drive`; its filter options in
:mod:`~tmaplan.evaluation.filter_options`), :mod:`~tmaplan.evaluation.tracking` (an estimator
over Monte Carlo runs against its bound, :func:`~tmaplan.evaluation.tracking.monte_carlo`),
:mod:`~tmaplan.evaluation.campaigns` (paired, resumable policy comparisons; public as
:mod:`tmaplan.experiments`), :mod:`~tmaplan.evaluation.records` (typed run records, scenario
hash) and :mod:`~tmaplan.evaluation.metrics`. Truth and measurements come from
:mod:`tmaplan.simulate` only.

One Monte Carlo core: every run is seeded by :mod:`~tmaplan.evaluation.seeding` (run ``i`` of
root ``seed`` owns ``SeedSequence(seed, spawn_key=(i,))``), and every closed-loop run — a
campaign's, the cost ranking's, a benchmark's — is flown by
:func:`~tmaplan.evaluation.closed_loop.paired_run` (the run's truth, then each policy on the
same noise).
"""

__all__: list[str] = []
