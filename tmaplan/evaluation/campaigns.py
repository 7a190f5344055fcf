"""Monte Carlo comparison of policies with common random numbers.

A campaign runs every policy on the same ``runs`` truths and noise sequences: run ``i`` derives
its generators from ``SeedSequence(seed, spawn_key=(i,))`` (truth, measurement noise, filter:
:func:`tmaplan.evaluation.seeding.run_streams`), and every policy re-creates them from the
same seeds, so differences between policies are paired. A run's result depends only on
``(spec, i)``: BLAS is limited to one thread inside a run, so serial, process-pool and Dask
backends with any worker count give bit-identical results.

Runs (:class:`tmaplan.evaluation.records.RunRecord`) are written to
``<out>/campaign-<key>/runs/run_XXXXX.npz`` as they finish (atomically); re-running the same
campaign loads them and computes only the missing runs. The key hashes the scenario's content
(:func:`tmaplan.evaluation.records.scenario_hash`), the other settings, the run-file format,
the tmaplan version and, for policy objects passed in, what they fly
(:func:`tmaplan.evaluation.records.policy_fingerprint`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import signal
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import Executor, as_completed
from pathlib import Path
from typing import Any, Literal

import numpy as np

from tmaplan.bounds.truth_bound import closed_loop_truth_bounds
from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError, PlanningError, as_real, is_integer
from tmaplan.estimators.applicability import warn_filter_model
from tmaplan.estimators.particle_filter import DEFAULT_KERNEL
from tmaplan.evaluation.closed_loop import ClosedLoopRun, paired_run
from tmaplan.evaluation.contacts_campaign import (
    contacts_aggregate,
    contacts_json,
    contacts_run_one,
    record_names,
    several,
)
from tmaplan.evaluation.filter_options import FilterOptions
from tmaplan.evaluation.metrics import (
    PairedDifference,
    RunMetrics,
    censor_time,
    paired_difference,
)
from tmaplan.evaluation.records import (
    FORMAT,
    PolicyRun,
    RunRecord,
    policy_fingerprint,
    scenario_hash,
)
from tmaplan.evaluation.replans import ReplanCounts, replan_flags, warn_not_converged
from tmaplan.interrupts import Interrupted, as_interrupt, checkpoint, interruptible
from tmaplan.parallel import SharedPayload, call_with_payload, close_pool, process_pool
from tmaplan.policies import Planned, Policy, Receding, parse_policy
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.scenario import Scenario, dump
from tmaplan.version import __version__

__all__ = [
    "CampaignResult",
    "CampaignSpec",
    "policy_run",
    "resolve_policies",
    "run_campaign",
    "run_one",
]

Backend = Literal["serial", "processes", "dask"]


@dataclasses.dataclass(frozen=True, kw_only=True)
class CampaignSpec:
    """Everything that defines a campaign (and its cache key).

    Attributes
    ----------
    scenario : Scenario
    policies : tuple of str
        Policy specs, ``manoeuvre[+ping]`` (:func:`tmaplan.policies.parse_policy`).
    runs : int
        Number of Monte Carlo runs.
    seed : int
        Root seed.
    n_particles : int
        Particle-filter size.
    truth : {"prior", "scenario"}
        Draw each run's target initial state from the prior, or use the scenario's.
    accuracy : float
        Relative range error that counts as localised.
    filter_options : FilterOptions, optional
        Closed-loop filter options (default: the monitored filter of
        :func:`tmaplan.evaluation.closed_loop.run_closed_loop`).
    """

    __repr__ = short_repr

    scenario: Scenario
    policies: tuple[str, ...]
    runs: int
    seed: int = 0
    n_particles: int = 3000
    truth: Literal["prior", "scenario"] = "prior"
    accuracy: float = 0.1
    filter_options: FilterOptions | None = None

    def key(self, policies: Mapping[str, Policy] | None = None) -> str:
        """Hash of everything but ``runs`` (extending a campaign reuses its runs), plus the
        run-file format and the tmaplan version, so that runs stored by another release are
        never reused.

        Parameters
        ----------
        policies : dict, optional
            Policy objects passed to :func:`run_campaign` instead of being resolved from the
            specs: their :func:`tmaplan.evaluation.records.policy_fingerprint` enters the key,
            so that runs of another policy stored under the same name (another tuned turn,
            another objective's plan) are never reused.
        """
        text = json.dumps(self._meta(policies), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def _meta(self, policies: Mapping[str, Policy] | None = None) -> dict[str, Any]:
        meta = {"scenario": self.scenario.name, "scenario_hash": scenario_hash(self.scenario),
                "policies": list(self.policies), "seed": self.seed,
                "n_particles": self.n_particles, "truth": self.truth, "accuracy": self.accuracy,
                "format": FORMAT, "tmaplan_version": __version__,
                "pf_kernel": (DEFAULT_KERNEL if self.filter_options is None
                              else self.filter_options.kernel)}
        manoeuvres = {p.split("+")[0] for p in self.policies}
        if "receding" in manoeuvres:
            # by name alone (`tmaplan compare`), runs stored while `receding` flew the
            # real-time iteration ("rti") or IPOPT ("ipopt") are not reused for its SQP, nor
            # several contacts' runs re-planned on the graph (ContactsReceding.compiled)
            meta["replan"] = "compiled-joint" if len(self.scenario.contacts) > 1 else "sqp"
        elif any(m.startswith("receding") for m in manoeuvres):
            meta["replan"] = "rti"  # (not the runs stored before re-plans were real-time)
        if self.filter_options is not None:
            meta["filter"] = repr(self.filter_options)
        if policies is not None:
            meta["policy_fingerprints"] = {name: policy_fingerprint(p)
                                           for name, p in sorted(policies.items())}
        return meta


def resolve_policies(scenario: Scenario, specs: Sequence[str], *,
                     workers: int = 1, pool: Executor | None = None) -> dict[str, Policy]:
    """Parse policy specs and precompute what is shared by all runs (offline plans,
    schedules, the best single turn: :meth:`tmaplan.policies.Combined.resolve`), so workers do
    not recompute it.

    Parameters
    ----------
    scenario : Scenario
    specs : sequence of str
        Policy specs (``manoeuvre[+ping]``).
    workers : int
        Processes the offline plans' multi-starts are solved on
        (:func:`tmaplan.policies.manoeuvres.offline_plan`; the same plans whatever the count).
    pool : concurrent.futures.Executor, optional
        Worker processes to solve them on (:func:`tmaplan.parallel.process_pool`) instead of
        a pool of ``workers`` started for them.

    Returns
    -------
    dict
        Policy name -> policy object (picklable).
    """
    return _resolve(scenario, _parse(scenario, specs), workers, pool)


def _parse(scenario: Scenario, specs: Sequence[str]) -> dict[str, Any]:
    """Policy spec -> parsed policy (errors for a bad spec, before anything is computed)."""
    parsed: dict[str, Any] = {}
    for spec in specs:
        if spec in parsed:
            raise PlanningError(f"policy {spec!r} given twice")
        parsed[spec] = parse_policy(spec, scenario)
    return parsed


def _resolve(scenario: Scenario, parsed: Mapping[str, Any], workers: int,
             pool: Executor | None) -> dict[str, Policy]:
    if workers > 1 or pool is not None:  # the offline plans first, their starts on workers
        for pol in parsed.values():
            m = pol.manoeuvre
            if (isinstance(m, Planned) and m.plan is None) or (
                    isinstance(m, Receding) and m.needs_offline_plan):
                offline_plan(scenario, m.objective, workers=workers, pool=pool)
    return {spec: pol.resolve(scenario) for spec, pol in parsed.items()}


def policy_run(res: ClosedLoopRun, metrics: RunMetrics) -> PolicyRun:
    """The stored record of one closed-loop run ``res`` with its ``metrics``."""
    converged, fell_back, infeasible = replan_flags(res.replans)
    return PolicyRun(
        metrics=metrics,
        observer=res.observer.position, target=res.target[:, :2],
        estimate=res.estimate[:, :2] + res.observer.position,
        ping_steps=res.ping_steps,
        replan_seconds=np.array([e["seconds"] for e in res.replans]),
        replan_converged=converged, replan_fell_back=fell_back,
        replan_infeasible=infeasible,
        recoveries=res.recoveries)


def run_one(spec: CampaignSpec, policies: Mapping[str, Policy], run: int) -> RunRecord:
    """Run every policy on Monte Carlo run ``run`` (same truth and noise for all:
    :func:`tmaplan.evaluation.closed_loop.paired_run`; several contacts:
    :func:`tmaplan.evaluation.contacts_campaign.contacts_run_one`)."""
    if several(spec.scenario):
        return contacts_run_one(spec, policies, run, policy_run)
    out: dict[str, PolicyRun] = {}
    for name, res in paired_run(spec.scenario, policies, seed=spec.seed, run=run,
                                n_particles=spec.n_particles, options=spec.filter_options,
                                from_prior=spec.truth == "prior"):
        out[name] = policy_run(res, res.metrics(spec.accuracy))
    return RunRecord(run=run, policies=out)


@dataclasses.dataclass(frozen=True, kw_only=True)
class CampaignResult:
    """Aggregated results of a campaign.

    Attributes
    ----------
    spec : CampaignSpec
    times : ndarray, shape (K + 1,)
        [s].
    policies : tuple of str
    summary : dict
        Per policy: ``bound_position (K+1,)`` and ``bound_range (K+1,)`` [m], the
        truth-conditioned PCRB over the runs' truths, own-ship tracks and pings (ristic2004,
        ch. 6; :func:`tmaplan.bounds.truth_bound.closed_loop_truth_bounds`), the bound the
        filter's RMSE can approach;
        ``rmse_position (K+1,)`` [m], ``rmse_range (K+1,)`` [m],
        ``rmse_course (K+1,)`` [rad] and ``rmse_speed (K+1,)`` [m/s] of the target's velocity,
        ``time_to_accuracy`` (median [s], inf if at least half the runs never get there),
        ``time_to_accuracy_runs (runs,)``, ``reached_fraction``, ``divergence_rate``,
        ``pings_used`` (mean), ``final_range_rmse`` [m], ``final_range_error_runs`` [m],
        ``final_position_error_runs`` [m] and ``final_rel_range_error`` (per run),
        ``replan_seconds`` (mean per re-plan), ``replans``
        (:class:`tmaplan.evaluation.replans.ReplanCounts`, over all runs; zeros for a policy
        that does not re-plan), ``recoveries`` (mean per run; consistency monitor).
    differences : tuple of PairedDifference
        All policy pairs, for ``time_to_accuracy`` (censored at horizon + dt) and
        ``final_range_error``.
    examples : dict
        Run 0's record per policy (tracks: observer, target, estimate positions, pings).
    directory : Path or None
        Where runs are stored.
    computed_runs, loaded_runs : tuple of int
        Which runs were computed now and which were loaded from disk.
    seconds : float
    """

    __repr__ = short_repr

    spec: CampaignSpec
    times: np.ndarray
    policies: tuple[str, ...]
    summary: dict[str, dict[str, Any]]
    differences: tuple[PairedDifference, ...]
    examples: dict[str, PolicyRun]
    directory: Path | None
    computed_runs: tuple[int, ...]
    loaded_runs: tuple[int, ...]
    seconds: float

    def to_json(self) -> dict[str, Any]:
        """docs/cli.md payload (SI units)."""
        pol = {}
        for name in self.policies:
            s = self.summary[name]
            pol[name] = {
                "rmse_position": s["rmse_position"].tolist(),
                "rmse_range": s["rmse_range"].tolist(),
                "bound_position": s["bound_position"].tolist(),
                "bound_range": s["bound_range"].tolist(),
                "rmse_course": s["rmse_course"].tolist(),
                "rmse_speed": s["rmse_speed"].tolist(),
                "time_to_accuracy": s["time_to_accuracy"],
                "time_to_accuracy_runs": s["time_to_accuracy_runs"].tolist(),
                "reached_fraction": s["reached_fraction"],
                "divergence_rate": s["divergence_rate"],
                "pings_used": s["pings_used"],
                "final_range_rmse": s["final_range_rmse"],
                "replan_seconds": s["replan_seconds"],
                "replans": s["replans"].to_json(),
                "recoveries": s["recoveries"],
                **contacts_json(s),  # several contacts (contacts_campaign)
            }
        return {
            "policies": pol,
            "times": self.times.tolist(),
            "runs": self.spec.runs,
            "seed": self.spec.seed,
            "particles": self.spec.n_particles,
            "accuracy": self.spec.accuracy,
            "truth": self.spec.truth,
            "differences": [dataclasses.asdict(d) for d in self.differences],
            "computed_runs": len(self.computed_runs),
            "loaded_runs": len(self.loaded_runs),
        }


def _aggregate(spec: CampaignSpec, runs: list[RunRecord], times: np.ndarray
               ) -> tuple[dict[str, dict[str, Any]], tuple[PairedDifference, ...]]:
    summary: dict[str, dict[str, Any]] = {}
    tta: dict[str, np.ndarray] = {}
    fre: dict[str, np.ndarray] = {}
    for name in spec.policies:
        ms = [r.policies[name].metrics for r in runs]

        def rms(field: str, ms: list[Any] = ms) -> np.ndarray:
            return np.sqrt(np.mean(np.stack([getattr(m, field) for m in ms]) ** 2, axis=0))

        t = np.array([m.time_to_accuracy for m in ms])
        fin = np.array([m.final_range_error for m in ms])
        rs = np.concatenate([r.policies[name].replan_seconds for r in runs])
        tta[name], fre[name] = t, fin
        summary[name] = {
            "rmse_position": rms("position_error"),
            "rmse_range": rms("range_error"),
            "rmse_course": rms("course_error"),
            "rmse_speed": rms("speed_error"),
            **_truth_bound(spec.scenario, [r.policies[name] for r in runs]),
            "time_to_accuracy": float(np.median(t)),
            "time_to_accuracy_runs": t,
            "reached_fraction": float(np.mean(np.isfinite(t))),
            "divergence_rate": float(np.mean([m.diverged for m in ms])),
            "pings_used": float(np.mean([m.pings_used for m in ms])),
            "final_range_rmse": float(np.sqrt(np.mean(fin**2))),
            "final_range_error_runs": fin,
            "final_rel_range_error": np.array([m.final_rel_range_error for m in ms]),
            "final_position_error_runs": np.array([m.final_position_error for m in ms]),
            "replan_seconds": float(rs.mean()) if rs.size else 0.0,
            "replans": ReplanCounts.count((p.replan_converged, p.replan_fell_back,
                                           p.replan_infeasible)
                                          for p in (r.policies[name] for r in runs)),
            "recoveries": float(np.mean([r.policies[name].recoveries for r in runs])),
        }
    censor = censor_time(times)
    diffs = []
    names = list(spec.policies)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            diffs.append(paired_difference(tta, a, b, "time_to_accuracy", censor=censor))
            diffs.append(paired_difference(fre, a, b, "final_range_error"))
    return summary, tuple(diffs)


def _run_shipped(shared: tuple[CampaignSpec, Mapping[str, Policy]],
                 fn: Callable[..., RunRecord], run: int) -> RunRecord:
    return fn(shared[0], shared[1], run)


def _run_packed(fn: Callable[..., RunRecord], shared: tuple[CampaignSpec, Mapping[str, Policy]],
                run: int) -> RunRecord:
    return fn(shared[0], shared[1], run)


def _iter_backend(backend: Backend, workers: int, scheduler: str | None,
                  fn: Callable[..., RunRecord], spec: CampaignSpec,
                  policies: Mapping[str, Policy], todo: list[int],
                  pool: Executor | None = None) -> Iterable[tuple[int, RunRecord]]:
    if backend == "serial" or not todo:
        for i in todo:
            yield i, fn(spec, policies, i)
    elif backend == "processes":
        if pool is None:
            raise PlanningError("backend 'processes': no worker pool")
        # the spec and the resolved policies (offline plans, schedules, RTI models) are
        # shipped to each worker once, through a file each worker reads once (the pool may
        # have served the offline plans' multi-start before), not with every run
        with SharedPayload((spec, policies)) as shared:
            futs = {pool.submit(call_with_payload, _run_shipped, shared.path, fn, i): i
                    for i in todo}
            for f in as_completed(futs):
                yield futs[f], f.result()
    elif backend == "dask":
        from dask.distributed import Client, LocalCluster  # deferred: dask, optional and slow
        from dask.distributed import as_completed as d_as_completed  # deferred: dask

        cluster = None
        if scheduler is None:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(scheduler)
        try:
            # shipped once to every worker (broadcast), then referenced by each run
            [shared] = client.scatter([(spec, policies)], broadcast=True)
            dfuts = [client.submit(_run_packed, fn, shared, i, pure=False,
                                   key=f"run-{spec.key(policies)}-{i}") for i in todo]
            index = {f.key: i for f, i in zip(dfuts, todo)}
            for df in d_as_completed(dfuts):
                yield index[df.key], df.result()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    else:
        raise PlanningError(f"unknown backend {backend!r}: expected serial, processes or dask")


def _load_stored(spec: CampaignSpec, policies: Mapping[str, Policy] | None, directory: Path,
                 results: dict[int, RunRecord], rejected: set[int]) -> None:
    """Create the campaign's directory (its spec and scenario) and load its stored runs into
    ``results`` (a torn or foreign run file is left out, its index added to ``rejected``:
    that run is computed again)."""
    (directory / "runs").mkdir(parents=True, exist_ok=True)
    (directory / "spec.json").write_text(json.dumps(spec._meta(policies), indent=1))
    (directory / "scenario.toml").write_text(dump(spec.scenario))
    for i in range(spec.runs):
        p = directory / "runs" / f"run_{i:05d}.npz"
        if p.exists():
            d = RunRecord.load(p, record_names(spec))
            if d is not None and d.run == i:
                results[i] = d
            else:
                rejected.add(i)


def _compute(backend: Backend, workers: int, scheduler: str | None, spec: CampaignSpec,
             pols: Mapping[str, Policy], todo: list[int], pool: Executor | None,
             progress: bool, results: dict[int, RunRecord], directory: Path | None,
             computed: list[int]) -> None:
    """Compute the runs ``todo`` into ``results`` (each stored in ``directory`` as it
    finishes, its index appended to ``computed``). An interrupted run is never stored."""
    bar = None
    if progress:
        from rich.progress import Progress  # deferred: rich, for a progress bar only

        bar = Progress(transient=True)
        bar.start()
        task = bar.add_task("Monte Carlo runs", total=len(todo))
    try:
        for i, data in _iter_backend(backend, workers, scheduler, run_one, spec, pols, todo,
                                     pool):
            checkpoint()  # a run during which an interrupt was swallowed is not stored
            results[i] = data
            computed.append(i)
            if directory is not None:
                data.save(directory / "runs" / f"run_{i:05d}.npz")
            if bar is not None:
                bar.advance(task)
    finally:
        if bar is not None:
            bar.stop()


def _check_arguments(spec: CampaignSpec, workers: int, backend: str | None,
                     max_new_runs: int | None, policies: Mapping[str, Policy] | None) -> None:
    """ArgumentError for what :func:`run_campaign` would otherwise misread: counts, seed and
    accuracy that are not numbers in range (a string ended in a bare TypeError), a truth
    source other than the two (read as "scenario"), a misspelt backend (found only after the
    policies are resolved), a negative ``max_new_runs`` (a slice from the end), ``policies``
    whose names are not the spec's (extra ones flown and left out of the results)."""
    if isinstance(spec.policies, str) or not spec.policies:
        raise ArgumentError("policies", "a non-empty tuple of policy specs", spec.policies)
    for name, v, least in (("runs", spec.runs, 1), ("n_particles", spec.n_particles, 2),
                           ("seed", spec.seed, 0), ("workers", workers, 1)):
        if not is_integer(v, least):
            raise ArgumentError(name, f"an integer >= {least}", v)
    if not 0 < as_real(spec.accuracy) < 1:
        raise ArgumentError("accuracy", "a relative range error in (0, 1), e.g. 0.1",
                            spec.accuracy)
    if spec.truth not in ("prior", "scenario"):
        raise ArgumentError("truth", "'prior' or 'scenario'", spec.truth)
    if backend not in (None, "serial", "processes", "dask"):
        raise ArgumentError("backend", "'serial', 'processes' or 'dask'", backend)
    if max_new_runs is not None and not is_integer(max_new_runs, 0):
        raise ArgumentError("max_new_runs", "an integer >= 0 or None", max_new_runs)
    if policies is not None and (set(policies) != set(spec.policies)
                                 or len(set(spec.policies)) != len(spec.policies)):
        raise ArgumentError("policies", "one policy object per name of spec.policies "
                            f"{list(spec.policies)}", list(policies))


def run_campaign(spec: CampaignSpec, *, out_dir: str | Path | None = None, workers: int = 1,
                 backend: Backend | None = None, scheduler: str | None = None,
                 progress: bool = False, policies: Mapping[str, Policy] | None = None,
                 max_new_runs: int | None = None, pool: Executor | None = None
                 ) -> CampaignResult:
    """Run (or resume) a campaign.

    Parameters
    ----------
    spec : CampaignSpec
    out_dir : path, optional
        Store runs under ``out_dir/campaign-<key>/`` and resume from there.
    workers : int
        Worker processes (backend "processes" or a local Dask cluster).
    backend : {"serial", "processes", "dask"}, optional
        Default: "dask" with ``scheduler``, "processes" if ``workers > 1``, else "serial".
    scheduler : str, optional
        Address of a Dask scheduler.
    progress : bool
        Show a progress bar (rich) on the terminal.
    policies : dict, optional
        Pre-resolved policies (default: :func:`resolve_policies`).
    max_new_runs : int, optional
        Stop after computing this many new runs (used to test interruption and resume).
    pool : concurrent.futures.Executor, optional
        With backend "processes": worker processes to use (:func:`tmaplan.parallel.
        process_pool`, e.g. shared with an offline plan solved before); default: a pool of
        ``workers`` started at once (they import while the policies are resolved), used for
        the offline plans' multi-starts too.

    Returns
    -------
    CampaignResult

    Warns
    -----
    ReplanWarning
        When more than 1 % of a policy's re-plans did not converge
        (:func:`tmaplan.evaluation.replans.warn_not_converged`).
    ScenarioWarning
        With ``spec.truth == "scenario"``, a contact whose target model the particle filter
        does not model (:func:`tmaplan.estimators.applicability.warn_filter_model`).
    """
    t0 = time.perf_counter()
    _check_arguments(spec, workers, backend, max_new_runs, policies)
    scenario = spec.scenario
    if spec.truth == "scenario":  # a truth the filter does not model (from the prior: refused)
        warn_filter_model(scenario)
    backend = backend or ("dask" if scheduler else ("processes" if workers > 1 else "serial"))
    parsed = _parse(scenario, spec.policies) if policies is None else None
    directory = None if out_dir is None else Path(out_dir) / f"campaign-{spec.key(policies)}"
    results: dict[int, RunRecord] = {}
    computed: list[int] = []
    rejected: set[int] = set()  # stored files that are not this campaign's runs
    own_pool = None
    with interruptible():  # (an interrupt that Python ignored, in a GC callback, is kept)
        try:
            if directory is not None:
                _load_stored(spec, policies, directory, results, rejected)
            loaded = tuple(sorted(results))
            todo = [i for i in range(spec.runs) if i not in results]
            if max_new_runs is not None:
                todo = todo[:max_new_runs]
            if backend == "processes" and pool is None and todo:
                # started before the policies are resolved: the workers import meanwhile
                pool = own_pool = process_pool(workers, warm_up=(__name__,))
            pols: Mapping[str, Policy] = policies if policies is not None else {}
            if parsed is not None and todo:  # nothing to resolve when every run is stored
                pols = _resolve(scenario, parsed, workers if backend == "processes" else 1,
                                pool if backend == "processes" else None)
            _compute(backend, workers, scheduler, spec, pols, todo, pool, progress, results,
                     directory, computed)
        except (KeyboardInterrupt, SystemError) as caught:  # the workers stopped at once;
            if (exc := as_interrupt(caught)) is None:  # what is stored is kept
                raise
            close_pool(own_pool, interrupted=True)
            own_pool = None
            kept = 0 if directory is None else sum(  # (loaded, computed, or not yet loaded)
                (directory / "runs" / f"run_{i:05d}.npz").exists() for i in range(spec.runs)
                if i in results or i not in rejected)
            raise Interrupted(getattr(exc, "signum", signal.SIGINT),
                              f"{kept} of {spec.runs} runs kept in {directory}" if directory
                              else "no runs kept (no out_dir)", directory is not None) from exc
        finally:
            close_pool(own_pool, interrupted=False)
    done = sorted(results)
    if len(done) < spec.runs:
        raise PlanningError(f"campaign incomplete: {len(done)} of {spec.runs} runs done "
                            f"(re-run to resume{' from ' + str(directory) if directory else ''})")
    ordered = [results[i] for i in range(spec.runs)]
    summary, diffs = (contacts_aggregate(spec, ordered, scenario.times, _aggregate)
                      if several(scenario) else _aggregate(spec, ordered, scenario.times))
    warn_not_converged({name: summary[name]["replans"] for name in spec.policies})
    examples = {name: ordered[0].policies[name] for name in spec.policies}
    return CampaignResult(spec=spec, times=scenario.times, policies=tuple(spec.policies),
                          summary=summary, differences=diffs, examples=examples,
                          directory=directory, computed_runs=tuple(sorted(computed)),
                          loaded_runs=loaded, seconds=time.perf_counter() - t0)


def _truth_bound(scenario: Scenario, runs: list[PolicyRun]) -> dict[str, np.ndarray]:
    """``bound_position`` and ``bound_range`` of a policy's runs: the truth-conditioned PCRB
    over their truths, tracks and pings
    (:func:`tmaplan.bounds.truth_bound.closed_loop_truth_bounds`); NaN where it cannot be
    formed (e.g. a prior that is not positive definite)."""
    try:
        pos, rng = closed_loop_truth_bounds(scenario, np.stack([r.observer for r in runs]),
                                            np.stack([r.target for r in runs]),
                                            [r.ping_steps for r in runs])
    except (np.linalg.LinAlgError, ArgumentError):
        pos = rng = np.full(scenario.n_steps + 1, np.nan)
    return {"bound_position": pos, "bound_range": rng}
