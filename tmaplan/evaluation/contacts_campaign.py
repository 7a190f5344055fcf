"""Campaigns on several contacts: run records per contact, metrics per contact and aggregated.

Role: issue 40's comparison (DESIGN.md §4 and §6). A run of a several-contact campaign
(:func:`contacts_run_one`, flown by :func:`tmaplan.evaluation.contacts_loop.paired_contacts_run`)
stores, per policy ``P``, one :class:`tmaplan.evaluation.records.PolicyRun` per contact ``c``
under the name ``P@c`` and one aggregate under ``P``, whose metrics over the contacts are:

* ``time_to_accuracy``: the time until EVERY contact is within its required accuracy (and
  stays there) — the latest of the contacts' times, ``inf`` if one never gets there (the
  campaign's ``time_to_accuracy_all``; censored at the horizon + dt in means and differences,
  as the one-contact metric);
* the error arrays and final errors: the worst contact's at each step (the largest);
* ``diverged``: any contact; ``pings_used``: the transmissions (one ping, every contact);
* its tracks (target, estimate): the first contact's; the recoveries: all contacts'.

A contact's required accuracy is its own (``[[contacts]] required_accuracy``), else the
campaign's ``accuracy``. :func:`contacts_aggregate` summarises each contact as a one-contact
campaign on its view and adds the aggregate metrics ``time_to_accuracy_all``,
``weighted_time_to_accuracy`` (per run Σ_c w_c T_c / Σ_c w_c, each T_c censored) and
``worst_final_range_error`` (mean over runs of the largest final range error [m]).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.evaluation.contacts_loop import paired_contacts_run
from tmaplan.evaluation.metrics import (
    PairedDifference,
    RunMetrics,
    censor_time,
    paired_difference,
    run_metrics,
)
from tmaplan.evaluation.records import PolicyRun, RunRecord
from tmaplan.scenario.contacts import weight_fractions

if TYPE_CHECKING:
    from tmaplan.evaluation.campaigns import CampaignSpec
    from tmaplan.evaluation.closed_loop import ClosedLoopRun
    from tmaplan.policies import Policy
    from tmaplan.scenario import Scenario

__all__ = ["accuracy_text", "aggregate_metrics", "contact_accuracy", "contacts_aggregate",
           "contacts_json", "contacts_run_one", "record_names", "several"]

#: Aggregate metric names of the paired differences (one-contact name -> several contacts).
AGGREGATE_METRICS = {"time_to_accuracy": "time_to_accuracy_all",
                     "final_range_error": "worst_final_range_error"}


def several(scenario: Scenario) -> bool:
    """Whether ``scenario`` holds several contacts (a campaign on it runs here)."""
    return len(scenario.contacts) > 1


def record_names(spec: CampaignSpec) -> tuple[str, ...]:
    """The policy entries of a run file: the spec's policies, and for several contacts each
    policy per contact, ``P@c``."""
    names = tuple(spec.policies)
    if not several(spec.scenario):
        return names
    return names + tuple(f"{p}@{c}" for p in names for c in spec.scenario.contact_names)


def contact_accuracy(scenario: Scenario, accuracy: float) -> dict[str, float]:
    """Each contact's required relative range accuracy: its own, else ``accuracy``."""
    return {c.name: float(accuracy if c.required_accuracy is None else c.required_accuracy)
            for c in scenario.contacts}


def accuracy_text(scenario: Scenario, accuracy: float) -> str:
    """The accuracy at which a campaign counts its contacts localised, for a sentence:
    ``"20%"``, or with several contacts of their own ``"20% (charlie: 5%)"``."""
    text = f"{100 * accuracy:.3g}%"
    own = [f"{c.name}: {100 * c.required_accuracy:.3g}%" for c in scenario.contacts
           if c.required_accuracy is not None]
    return text + (f" ({', '.join(own)})" if len(scenario.contacts) > 1 and own else "")


def aggregate_metrics(per_contact: Mapping[str, RunMetrics]) -> RunMetrics:
    """The aggregate :class:`RunMetrics` of one run over its contacts (module docstring)."""
    ms = list(per_contact.values())

    def worst(field: str) -> np.ndarray:
        return np.max(np.stack([getattr(m, field) for m in ms]), axis=0)

    return RunMetrics(
        position_error=worst("position_error"), range_error=worst("range_error"),
        rel_range_error=worst("rel_range_error"), course_error=worst("course_error"),
        speed_error=worst("speed_error"),
        time_to_accuracy=float(max(m.time_to_accuracy for m in ms)),
        diverged=any(m.diverged for m in ms), pings_used=int(ms[0].pings_used),
        final_position_error=float(max(m.final_position_error for m in ms)),
        final_range_error=float(max(m.final_range_error for m in ms)),
        final_rel_range_error=float(max(m.final_rel_range_error for m in ms)))


def contacts_run_one(spec: CampaignSpec, policies: Mapping[str, Policy], run: int,
                     policy_run: Callable[[ClosedLoopRun, RunMetrics], PolicyRun]
                     ) -> RunRecord:
    """Run every policy on Monte Carlo run ``run`` of a several-contact campaign
    (:func:`tmaplan.evaluation.contacts_loop.paired_contacts_run`); ``policy_run`` makes the
    record of one contact's run (:func:`tmaplan.evaluation.campaigns.policy_run`)."""
    acc = contact_accuracy(spec.scenario, spec.accuracy)
    out: dict[str, PolicyRun] = {}
    per: dict[str, PolicyRun] = {}
    for name, runs in paired_contacts_run(spec.scenario, policies, seed=spec.seed, run=run,
                                          n_particles=spec.n_particles,
                                          options=spec.filter_options,
                                          from_prior=spec.truth == "prior"):
        rec = {c: policy_run(res, run_metrics(res.times, res.truth, res.estimate,
                                              res.observer.mean_velocity, accuracy=acc[c],
                                              n_pings=len(res.ping_steps)))
               for c, res in runs.items()}
        first = next(iter(rec.values()))
        out[name] = dataclasses.replace(
            first, metrics=aggregate_metrics({c: r.metrics for c, r in rec.items()}),
            recoveries=sum(r.recoveries for r in rec.values()))
        per.update({f"{name}@{c}": r for c, r in rec.items()})
    return RunRecord(run=run, policies={**out, **per})


def contacts_aggregate(spec: CampaignSpec, runs: list[RunRecord], times: np.ndarray,
                       aggregate: Callable[..., tuple[dict[str, dict[str, Any]],
                                                      tuple[PairedDifference, ...]]]
                       ) -> tuple[dict[str, dict[str, Any]], tuple[PairedDifference, ...]]:
    """Summary and paired differences of a several-contact campaign; ``aggregate`` is the
    one-contact summary (:func:`tmaplan.evaluation.campaigns` ``_aggregate``), run on each
    contact's view (its entries ``P@c``) and on the aggregate entries.

    Returns
    -------
    summary : dict
        Per policy: the one-contact keys of the aggregate entry (``time_to_accuracy`` is the
        median time until all contacts are localised; the truth bounds the largest of the
        contacts'), plus ``time_to_accuracy_all`` (the same median [s]),
        ``time_to_accuracy_all_runs``, ``weighted_time_to_accuracy`` (mean [s], censored),
        ``weighted_time_to_accuracy_runs``, ``worst_final_range_error`` [m] and
        ``contacts: {name: one-contact summary}``.
    differences : tuple of PairedDifference
        Per pair of policies: ``time_to_accuracy_all`` and ``worst_final_range_error``
        (censored as the one-contact metrics) and ``weighted_time_to_accuracy`` (its
        ``both_censored``: the runs in which neither policy localised any contact).
    """
    sc = spec.scenario
    views = sc.contact_views()
    names = list(spec.policies)
    per: dict[str, dict[str, dict[str, Any]]] = {n: {} for n in names}
    acc = contact_accuracy(sc, spec.accuracy)
    for c, view in views.items():
        sub = dataclasses.replace(spec, scenario=view, policies=tuple(f"{n}@{c}" for n in names))
        sub_summary, _ = aggregate(sub, runs, times)
        for n in names:
            per[n][c] = {**sub_summary[f"{n}@{c}"], "example": runs[0].policies[f"{n}@{c}"],
                         "required_accuracy": acc[c]}
    first = next(iter(views.values()))
    summary, diffs = aggregate(dataclasses.replace(spec, scenario=first), runs, times)
    censor = censor_time(times)
    share = dict(zip(sc.contact_names, weight_fractions([c.weight for c in sc.contacts]),
                     strict=True))
    wtta: dict[str, np.ndarray] = {}
    never: dict[str, np.ndarray] = {}  # per run: no contact localised
    for n in names:
        s = summary[n]
        for key in ("bound_position", "bound_range"):
            s[key] = np.max(np.stack([per[n][c][key] for c in views]), axis=0)
        t = {c: np.where(np.isposinf(per[n][c]["time_to_accuracy_runs"]), censor,
                         per[n][c]["time_to_accuracy_runs"]) for c in views}
        wtta[n] = np.asarray(sum(share[c] * t[c] for c in views), float)
        never[n] = np.all([np.isposinf(per[n][c]["time_to_accuracy_runs"]) for c in views],
                          axis=0)
        s.update({"time_to_accuracy_all": s["time_to_accuracy"],
                  "time_to_accuracy_all_runs": s["time_to_accuracy_runs"],
                  "weighted_time_to_accuracy": float(np.mean(wtta[n])),
                  "weighted_time_to_accuracy_runs": wtta[n],
                  "worst_final_range_error": float(np.mean(s["final_range_error_runs"])),
                  "contacts": per[n]})
    out = [dataclasses.replace(d, metric=AGGREGATE_METRICS.get(d.metric, d.metric))
           for d in diffs]
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            # its times are censored per contact: both sides censored where no contact was
            # localised by either policy
            d = paired_difference(wtta, a, b, "weighted_time_to_accuracy")
            out.append(dataclasses.replace(
                d, both_censored=int(np.count_nonzero(never[a] & never[b]))))
    return summary, tuple(out)


#: Per-contact summary keys of ``compare``'s JSON (scalars; per step: the RMSE arrays).
CONTACT_KEYS = ("required_accuracy", "time_to_accuracy", "reached_fraction", "divergence_rate",
                "final_range_rmse", "recoveries")


def contacts_json(summary: Mapping[str, Any]) -> dict[str, Any]:
    """The several-contact keys of one policy in ``compare``'s JSON: ``time_to_accuracy_all``,
    ``time_to_accuracy_all_runs``, ``weighted_time_to_accuracy``,
    ``worst_final_range_error`` and ``contacts: {name: {required_accuracy (the relative range
    accuracy it is localised at), time_to_accuracy, time_to_accuracy_runs, reached_fraction,
    divergence_rate, final_range_rmse, recoveries, rmse_position, rmse_range}}`` (SI units);
    empty for one contact."""
    if "contacts" not in summary:
        return {}
    return {
        "time_to_accuracy_all": summary["time_to_accuracy_all"],
        "time_to_accuracy_all_runs": summary["time_to_accuracy_all_runs"].tolist(),
        "weighted_time_to_accuracy": summary["weighted_time_to_accuracy"],
        "worst_final_range_error": summary["worst_final_range_error"],
        "contacts": {c: {**{k: s[k] for k in CONTACT_KEYS},
                         "time_to_accuracy_runs": s["time_to_accuracy_runs"].tolist(),
                         "rmse_position": s["rmse_position"].tolist(),
                         "rmse_range": s["rmse_range"].tolist()}
                     for c, s in summary["contacts"].items()},
    }
