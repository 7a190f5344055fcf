"""The demo's headline numbers: comparisons decided by paired intervals, stored and live.

``tmaplan demo`` flies a few dozen paired runs in two minutes. At that size most of the
differences that matter are not decided: ``planned`` localises about 1.4 min sooner than the
best single turn on the mean, with a per-run standard deviation of about 13 min, so the paired
95 % interval excludes zero only after about a thousand runs (README, "does the plan pay?").
The demo therefore shows first a **stored result**: the summary of campaigns of the demo's
policies, sized and seeded before they were run (package data ``data/demo_stored.json``,
written by ``benchmarks/demo_stored.py``: each campaign's command, seed, runs, commit, the
per-policy means, every paired difference with its interval, and the per-run values of its
first runs, which ``tests/test_headline_stored.py`` recomputes so the file cannot go stale
silently). Then **this run**, labelled illustrative. Every difference shown carries its paired
95 % interval; a difference whose interval holds zero is "not decided at N runs", never
ranked; a live difference decided opposite to a decided stored one is flagged as chance, not
shown as a ranking.

The comparisons shown are :data:`KEY_DIFFERENCES`, fixed before the stored campaigns were run.
"""

from __future__ import annotations

import dataclasses
import html
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.display import short_repr
from tmaplan.evaluation.metrics import (
    PairedDifference,
    censor_time,
    censored_note,
    paired_difference,
)
from tmaplan.experiments import CampaignResult

__all__ = ["KEY_DIFFERENCES", "STORED_FILE", "Comparison", "StoredResult", "difference_of",
           "key_json", "key_lines", "key_table_html", "live_html", "live_lines", "load_stored",
           "stats_lines", "stored_html", "stored_lines", "stored_payload", "verdict"]

#: The paired differences ``a − b`` the demo shows, in this order: (a, b, metric). Fixed
#: before the stored campaigns were run (issue 38): the plan against each baseline, the
#: re-planning against the plan, pings against none, scheduled pings against uniform ones
#: (time to accuracy, and the final range error that the terminal schedule optimises).
KEY_DIFFERENCES: tuple[tuple[str, str, str], ...] = (
    ("planned", "straight", "time_to_accuracy"),
    ("planned", "single-turn", "time_to_accuracy"),
    ("planned", "zigzag", "time_to_accuracy"),
    ("receding", "planned", "time_to_accuracy"),
    ("planned+uniform", "planned", "time_to_accuracy"),
    ("planned+scheduled", "planned+uniform", "time_to_accuracy"),
    ("receding+scheduled", "planned+scheduled", "time_to_accuracy"),
    ("planned+scheduled", "planned+uniform", "final_range_error"),
    ("planned+scheduled-terminal", "planned+uniform", "final_range_error"),
)

#: The stored result's file inside the package.
STORED_FILE = "data/demo_stored.json"

#: metric -> (words, divisor from SI, display unit, what "smaller" means)
_METRICS = {"time_to_accuracy": ("time to 10 % range accuracy", 60.0, "min", "sooner"),
            "final_range_error": ("final range error", 1.0, "m", "smaller"),
            # several contacts (tmaplan.cli.demo_contacts): the aggregate metrics
            "time_to_accuracy_all": ("time until every contact is localised", 60.0, "min",
                                     "sooner"),
            "worst_final_range_error": ("worst contact's final range error", 1.0, "m",
                                        "smaller")}


def _metric(metric: str) -> tuple[str, float, str, str]:
    return _METRICS.get(metric, (metric.replace("_", " "), 1.0, "", "smaller"))


@dataclasses.dataclass(frozen=True, kw_only=True)
class Comparison:
    """A paired comparison of policies: per-policy statistics and paired differences.

    Attributes
    ----------
    command : str
        The command that reproduces it.
    runs, seed : int
        Paired Monte Carlo runs and root seed.
    policies : tuple of str
    stats : dict
        Policy -> ``mean_time_to_accuracy`` [s] (runs never localised count as the horizon
        plus one step), ``reached_fraction`` (localised by the horizon), ``final_range_rmse``
        [m], ``runs``.
    differences : tuple of PairedDifference
        Paired differences (95 % t intervals), at least those of :data:`KEY_DIFFERENCES`
        among ``policies``.
    first_runs : dict
        Policy -> ``time_to_accuracy`` [s] (None: never localised) and
        ``final_range_error`` [m] of runs 0, 1, ... (stored results; empty for a live run).
    commit : str
        Git commit of the code that ran it ("" when unknown).
    particles : int
        Particle-filter size.
    accuracy : float
        Relative range error that counts as localised.
    truth : {"prior", "scenario"}
        Where each run's target comes from.
    """

    __repr__ = short_repr

    command: str
    runs: int
    seed: int
    policies: tuple[str, ...]
    stats: dict[str, dict[str, float]]
    differences: tuple[PairedDifference, ...]
    first_runs: dict[str, dict[str, list[float | None]]] = dataclasses.field(
        default_factory=dict)
    commit: str = ""
    particles: int = 3000
    accuracy: float = 0.1
    truth: str = "prior"

    @classmethod
    def from_values(cls, *, command: str, seed: int, times_to_accuracy: Mapping[str, Any],
                    final_range_errors: Mapping[str, Any], censor: float, commit: str = "",
                    first_runs: int = 0, particles: int = 3000, accuracy: float = 0.1,
                    truth: str = "prior",
                    metrics: tuple[str, str] = ("time_to_accuracy", "final_range_error"),
                    ) -> Comparison:
        """From per-run values: times to accuracy [s] (+inf: never) and final range errors
        [m], each an array of shape (runs,) per policy; ``censor`` [s] stands for "never" in
        the means and differences (:func:`tmaplan.evaluation.metrics.censor_time`). Keeps
        the first ``first_runs`` runs' values; ``particles``, ``accuracy`` and ``truth`` are
        the campaign's settings, for the record; ``metrics`` names the two in the paired
        differences (several contacts: ``time_to_accuracy_all``,
        ``worst_final_range_error``)."""
        names = tuple(times_to_accuracy)
        tta = {p: np.asarray(times_to_accuracy[p], float) for p in names}
        fre = {p: np.asarray(final_range_errors[p], float) for p in names}
        stats = {p: {"mean_time_to_accuracy": float(np.where(np.isinf(tta[p]), censor,
                                                               tta[p]).mean()),
                     "reached_fraction": float(np.isfinite(tta[p]).mean()),
                     "final_range_rmse": float(np.sqrt(np.mean(fre[p] ** 2))),
                     "runs": float(tta[p].size)}
                 for p in names}
        diffs = []
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                diffs.append(paired_difference(tta, a, b, metrics[0], censor=censor))
                diffs.append(paired_difference(fre, a, b, metrics[1]))
        first: dict[str, dict[str, list[float | None]]] = {}
        for p in names if first_runs else ():
            first[p] = {"time_to_accuracy": [None if math.isinf(t) else float(t)
                                             for t in tta[p][:first_runs]],
                        "final_range_error": [float(e) for e in fre[p][:first_runs]]}
        runs = len(next(iter(tta.values()))) if names else 0
        return cls(command=command, runs=runs, seed=seed, policies=names, stats=stats,
                   differences=tuple(diffs), first_runs=first, commit=commit,
                   particles=particles, accuracy=accuracy, truth=truth)

    @classmethod
    def from_campaign(cls, result: CampaignResult, *, command: str, commit: str = "",
                      first_runs: int = 0) -> Comparison:
        """From a campaign's result (:func:`tmaplan.experiments.run_campaign`); of several
        contacts, its aggregate values (the time until all are localised, the worst
        contact's final error) under their metric names."""
        s, spec = result.summary, result.spec
        several = len(spec.scenario.contacts) > 1
        return cls.from_values(
            metrics=("time_to_accuracy_all", "worst_final_range_error") if several else
            ("time_to_accuracy", "final_range_error"),
            command=command, seed=spec.seed, commit=commit, first_runs=first_runs,
            particles=spec.n_particles, accuracy=spec.accuracy, truth=spec.truth,
            times_to_accuracy={p: s[p]["time_to_accuracy_runs"] for p in result.policies},
            final_range_errors={p: s[p]["final_range_error_runs"] for p in result.policies},
            censor=censor_time(result.times))

    def to_json(self) -> dict[str, Any]:
        """JSON-able dict (SI units); :meth:`from_json` reads it back."""
        return {"command": self.command, "runs": self.runs, "seed": self.seed,
                "commit": self.commit, "particles": self.particles, "accuracy": self.accuracy,
                "truth": self.truth, "policies": list(self.policies), "stats": self.stats,
                "differences": [dataclasses.asdict(d) for d in self.differences],
                "first_runs": self.first_runs}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Comparison:
        """Inverse of :meth:`to_json`."""
        return cls(command=str(data["command"]), runs=int(data["runs"]),
                   seed=int(data["seed"]), commit=str(data.get("commit", "")),
                   policies=tuple(data["policies"]),
                   stats={p: {k: float(v) for k, v in st.items()}
                          for p, st in data["stats"].items()},
                   differences=tuple(PairedDifference(**d) for d in data["differences"]),
                   first_runs=dict(data.get("first_runs", {})),
                   particles=int(data.get("particles", 3000)),
                   accuracy=float(data.get("accuracy", 0.1)),
                   truth=str(data.get("truth", "prior")))


@dataclasses.dataclass(frozen=True, kw_only=True)
class StoredResult:
    """The demo's stored campaigns (:data:`STORED_FILE`).

    Attributes
    ----------
    problem : str
    campaigns : tuple of Comparison
        Each with its command, runs, seed and commit.
    date : str
        When it was computed (ISO date).
    """

    __repr__ = short_repr

    problem: str
    campaigns: tuple[Comparison, ...]
    date: str = ""

    def comparison_for(self, *policies: str) -> Comparison | None:
        """The campaign with the most runs that flew every one of ``policies``."""
        held = [c for c in self.campaigns if set(policies) <= set(c.policies)]
        return max(held, key=lambda c: c.runs) if held else None

    def merged(self) -> Comparison:
        """One comparison of every stored policy: each policy's statistics and each pair's
        differences from the campaign with the most runs that flew them (their ``n`` and
        ``runs`` say how many)."""
        order = sorted(self.campaigns, key=lambda c: -c.runs)
        policies = tuple(dict.fromkeys(p for c in order for p in c.policies))
        stats = {p: next(c.stats[p] for c in order if p in c.policies) for p in policies}
        diffs = []
        for i, a in enumerate(policies):
            for b in policies[i + 1:]:
                held = self.comparison_for(a, b)
                if held is not None:
                    diffs += [d for d in held.differences if {d.a, d.b} == {a, b}]
        return Comparison(command="; ".join(c.command for c in order),
                          runs=order[0].runs if order else 0,
                          seed=order[0].seed if order else 0, policies=policies,
                          stats=stats, differences=tuple(diffs))

    def label(self) -> str:
        """What it is: ``"Stored result of 2000 and 300 paired runs on 'default' (seed 38;
        commands below)"``."""
        runs = sorted({c.runs for c in self.campaigns}, reverse=True)
        seeds = sorted({c.seed for c in self.campaigns})
        return (f"Stored result of {' and '.join(str(n) for n in runs)} paired runs on "
                f"'{self.problem}' (seed{'s' if len(seeds) > 1 else ''} "
                f"{', '.join(str(x) for x in seeds)}; "
                f"{'commands' if len(self.campaigns) > 1 else 'command'} below)")


def stored_payload(stored: StoredResult) -> dict[str, Any]:
    """The JSON of :data:`STORED_FILE` (``format`` 1)."""
    return {"format": 1, "problem": stored.problem, "date": stored.date,
            "campaigns": [c.to_json() for c in stored.campaigns]}


def load_stored(path: str | Path | None = None) -> StoredResult:
    """The stored result: :data:`STORED_FILE` in the package, or the file ``path``."""
    if path is None:
        text = resources.files("tmaplan").joinpath(STORED_FILE).read_text(encoding="utf-8")
    else:
        text = Path(path).read_text(encoding="utf-8")
    data = json.loads(text)
    return StoredResult(problem=str(data["problem"]), date=str(data.get("date", "")),
                        campaigns=tuple(Comparison.from_json(c) for c in data["campaigns"]))


def difference_of(diffs: Iterable[PairedDifference], a: str, b: str, metric: str
                  ) -> PairedDifference | None:
    """The paired difference ``a − b`` of ``metric`` (a stored ``b − a`` with its sign and
    interval flipped); None if neither is among ``diffs``."""
    for d in diffs:
        if d.metric != metric:
            continue
        if (d.a, d.b) == (a, b):
            return d
        if (d.a, d.b) == (b, a):
            return dataclasses.replace(d, a=a, b=b, mean=-d.mean, ci_low=-d.ci_high,
                                       ci_high=-d.ci_low)
    return None


def _decided(d: PairedDifference) -> bool:
    return math.isfinite(d.ci_low) and math.isfinite(d.ci_high) and d.excludes_zero


def verdict(d: PairedDifference, stored: PairedDifference | None = None) -> str:
    """What a paired difference ``a − b`` decides, in words.

    ``"planned sooner"`` (``"... smaller"`` for the final range error) when the 95 % interval
    excludes zero; ``"not decided at N runs"`` when it holds zero; with ``stored`` (the same
    difference from the stored campaigns) a live verdict is set against it: decided the other
    way round is flagged as chance, decided where the stored runs do not decide is said so.
    Runs censored on both sides (neither policy localised) are counted after the verdict
    (:func:`tmaplan.evaluation.metrics.censored_note`); when every run is, the difference is
    undetermined, whatever the stored runs say.
    """
    note = censored_note(d)
    if d.undetermined:
        return note
    text = _verdict_text(d, stored)
    return f"{text}; {note}" if note else text


def _verdict_text(d: PairedDifference, stored: PairedDifference | None) -> str:
    if d.n < 2 or not (math.isfinite(d.ci_low) and math.isfinite(d.ci_high)):
        return f"no interval with {d.n} run"
    better = _metric(d.metric)[3]
    if not _decided(d):
        text = f"not decided at {d.n} runs"
    else:
        text = f"{d.a if d.mean < 0 else d.b} {better}"
    if stored is None:
        return text
    if not _decided(stored):
        return (text + f"; the stored {stored.n} runs do not decide it" if _decided(d)
                else text)
    if not _decided(d):
        return f"{text} (stored {stored.n} runs: {verdict(stored)})"
    if (stored.mean < 0) != (d.mean < 0):
        return (f"opposite to the stored {stored.n} runs, which decide it: chance at "
                f"{d.n} runs, not a ranking")
    return f"{text}, as the stored {stored.n} runs"


def _interval(d: PairedDifference) -> tuple[str, str]:
    _, unit, u, _ = _metric(d.metric)
    decimals = 2 if u == "min" else 0

    def num(x: float) -> str:  # in display units; a value that rounds to zero shows +0
        return f"{round(x / unit, decimals) + 0.0:+.{decimals}f}"

    if d.undetermined:  # every run censored on both sides: zero by construction
        return "undetermined", "no interval"
    if not (math.isfinite(d.ci_low) and math.isfinite(d.ci_high)):
        return f"{num(d.mean)} {u}", "no interval"
    return f"{num(d.mean)} {u}", f"[{num(d.ci_low)}, {num(d.ci_high)}]"


def _pairs(comparison: Comparison, stored: StoredResult | None,
           keys: Sequence[tuple[str, str, str]]
           ) -> Iterable[tuple[PairedDifference, PairedDifference | None]]:
    """Each key difference of ``comparison`` present, with the same difference from the
    stored campaign with the most runs that flew both policies (None without one)."""
    for a, b, metric in keys:
        d = difference_of(comparison.differences, a, b, metric)
        if d is None:
            continue
        held = stored.comparison_for(a, b) if stored is not None else None
        yield d, (difference_of(held.differences, a, b, metric) if held is not None else None)


def _rows(comparison: Comparison, stored: StoredResult | None,
          keys: Sequence[tuple[str, str, str]]) -> list[tuple[str, str, str, str, str]]:
    """(pair, metric words, mean, interval, verdict) of each key difference present."""
    return [(f"{d.a} − {d.b}", _metric(d.metric)[0], *_interval(d), verdict(d, ref))
            for d, ref in _pairs(comparison, stored, keys)]


def key_json(comparison: Comparison, *, stored: StoredResult | None = None,
             keys: Sequence[tuple[str, str, str]] = KEY_DIFFERENCES) -> list[dict[str, Any]]:
    """The key differences for a JSON payload (SI units): ``a, b, metric, mean, ci_low,
    ci_high, level, n``, ``decided`` (the interval excludes zero) and ``verdict``
    (:func:`verdict`, against ``stored`` if given)."""
    return [{**dataclasses.asdict(d), "decided": _decided(d), "verdict": verdict(d, ref)}
            for d, ref in _pairs(comparison, stored, keys)]


def key_lines(comparison: Comparison, *, stored: StoredResult | None = None,
              keys: Sequence[tuple[str, str, str]] = KEY_DIFFERENCES) -> list[str]:
    """Console lines of the key differences of one comparison, each with its paired 95 %
    interval and verdict (:func:`verdict`; ``stored``: set a live run against it)."""
    rows = _rows(comparison, stored, keys)
    if not rows:
        return []
    w = max(len(r[0]) for r in rows)
    lines = []
    for metric in dict.fromkeys(r[1] for r in rows):
        lines.append(f"  {metric}, a − b, paired 95 % interval:")
        lines += [f"    {p:<{w}}  {m:>10}  {ci:<18}  {v}" for p, mm, m, ci, v in rows
                  if mm == metric]
    return lines


def stats_lines(comparison: Comparison, *, per_policy_runs: bool = False) -> list[str]:
    """Console lines of the per-policy statistics, in the comparison's policy order (not
    ranked): mean time to accuracy, localised fraction, final range RMSE (and the runs behind
    each, ``per_policy_runs``)."""
    w = max(len(p) for p in comparison.policies)
    out = []
    for p in comparison.policies:
        s = comparison.stats[p]
        runs = f" ({s['runs']:.0f} runs)" if per_policy_runs else ""
        out.append(f"    {p:<{w}}  mean time to accuracy {s['mean_time_to_accuracy'] / 60:5.1f} "
                   f"min, localised {s['reached_fraction']:4.0%}, final range RMSE "
                   f"{s['final_range_rmse']:6.0f} m{runs}")
    return out


def key_table_html(comparison: Comparison, *, stored: StoredResult | None = None,
                   keys: Sequence[tuple[str, str, str]] = KEY_DIFFERENCES) -> str:
    """The key differences as an HTML table (pair, metric, mean, paired 95 % interval,
    verdict), the same rows as :func:`key_lines`."""
    rows = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>"
                   for r in _rows(comparison, stored, keys))
    return ("<table><tr><th>a − b</th><th>metric</th><th>mean</th>"
            "<th>paired 95 % interval</th><th>verdict</th></tr>" + rows + "</table>")


_CENSORED = ("runs never localised count as the horizon plus one step; differences are "
             "paired over the same truths and noise")


def _commands(stored: StoredResult) -> list[tuple[str, str]]:
    """(command, provenance) of each stored campaign, most runs first."""
    return [(c.command, f"{c.runs} runs, seed {c.seed}, commit {c.commit or 'unknown'}"
             + (f", {stored.date}" if stored.date else ""))
            for c in sorted(stored.campaigns, key=lambda c: -c.runs)]


def stored_lines(stored: StoredResult) -> list[str]:
    """Console lines of the stored result: its label, the commands that reproduce it, the
    per-policy statistics and the key differences with their verdicts."""
    merged = stored.merged()
    lines = [stored.label() + ":"]
    lines += [f"  $ {cmd}   ({what})" for cmd, what in _commands(stored)]
    lines += stats_lines(merged, per_policy_runs=True)
    return lines + key_lines(merged)


def live_lines(comparison: Comparison, stored: StoredResult | None) -> list[str]:
    """Console lines of this run, labelled illustrative, its key differences set against the
    stored result (:func:`verdict`)."""
    head = (f"This run (illustrative: {comparison.runs} paired runs, seed {comparison.seed}; "
            "its intervals are wider than the stored result's):")
    return [head, *stats_lines(comparison), *key_lines(comparison, stored=stored)]


def stored_html(stored: StoredResult) -> str:
    """The stored result as an HTML section: label, commands, per-policy means, key
    differences with their paired intervals and verdicts."""
    merged = stored.merged()
    cmds = "".join(f"<li><code>{html.escape(c)}</code> ({html.escape(w)})</li>"
                   for c, w in _commands(stored))
    return (f"<h2>{html.escape(stored.label())}</h2>"
            f"<p>Campaigns of the demo's policies sized and seeded before they were run; "
            f"{_CENSORED}. Reproduce with:</p><ul>{cmds}</ul>"
            + _stats_html(merged, per_policy_runs=True)
            + "<h3>Key differences</h3>" + key_table_html(merged))


def live_html(comparison: Comparison, stored: StoredResult | None) -> str:
    """This run's key differences as an HTML section, labelled illustrative and set against
    the stored result."""
    return (f"<h2>This run: illustrative ({comparison.runs} paired runs, seed "
            f"{comparison.seed})</h2><p>The key differences of this report's runs ({_CENSORED})."
            " A difference whose interval holds zero is not decided at this size; the stored "
            "result above has more runs.</p>"
            + key_table_html(comparison, stored=stored))


def _stats_html(comparison: Comparison, *, per_policy_runs: bool) -> str:
    rows = []
    for p in comparison.policies:
        s = comparison.stats[p]
        cells = [p, f"{s['mean_time_to_accuracy'] / 60:.1f}", f"{s['reached_fraction']:.0%}",
                 f"{s['final_range_rmse'] / 1000:.2f}"] + ([f"{s['runs']:.0f}"]
                                                           if per_policy_runs else [])
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    runs = "<th>runs</th>" if per_policy_runs else ""
    return ("<table><tr><th>policy</th><th>mean time to accuracy [min]</th><th>localised</th>"
            f"<th>final range RMSE [km]</th>{runs}</tr>" + "".join(rows) + "</table>")
