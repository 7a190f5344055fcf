"""The tables of the HTML report (:func:`tmaplan.report.write_report`), in display units.

Results per policy (km, kn, °, min), the paired differences (a short summary of the key ones
above the full table, which is collapsible), the small-sample warning, and the parameters of a
baseline manoeuvre in words.
"""

from __future__ import annotations

import html
import math
from typing import Any

import numpy as np

from tmaplan.display import angle, minutes, speed
from tmaplan.evaluation.metrics import PairedDifference, censored_note
from tmaplan.evaluation.replans import NOT_CONVERGED_WARNING, ReplanCounts
from tmaplan.experiments import CampaignResult

__all__ = ["FEW_RUNS", "baseline_parameters", "censored_lines", "differences_html",
           "replan_warning", "results_table", "sample_warning"]

FEW_RUNS = 10
"""Below this many paired runs the report warns that its intervals are wide (t intervals from
fewer than 10 differences) and, with one run, undefined."""

#: metric -> (display label, divisor from SI, unit)
_METRICS: dict[str, tuple[str, float, str]] = {
    "time_to_accuracy": ("time to accuracy", 60.0, "min"),
    "final_range_error": ("final range error", 1000.0, "km"),
    # several contacts (tmaplan.evaluation.contacts_campaign): the aggregate metrics
    "time_to_accuracy_all": ("time until every contact is localised", 60.0, "min"),
    "weighted_time_to_accuracy": ("weighted time to accuracy", 60.0, "min"),
    "worst_final_range_error": ("worst contact's final range error", 1000.0, "km"),
}


def _metric(metric: str) -> tuple[str, float, str]:
    return _METRICS.get(metric, (metric.replace("_", " "), 1.0, ""))


def sample_warning(runs: int, *, ranking: bool = False) -> str:
    """HTML paragraph warning about too few runs ("" from :data:`FEW_RUNS` runs on).

    ``ranking``: the runs are per candidate of a cost ranking (bootstrap intervals of rank
    correlations), not the paired runs of a comparison (t intervals of differences)."""
    if runs >= FEW_RUNS:
        return ""
    if ranking:
        what = ("each candidate's Monte Carlo metrics rest on so few runs that the rank "
                "correlations mostly measure their noise, and the bootstrap intervals are wide")
        treat = "every correlation"
    else:
        what = ("with a single run the confidence intervals of the paired differences are "
                "undefined (no spread to estimate)" if runs < 2 else
                f"with {runs} runs the 95 % intervals rest on {runs - 1} degree(s) of freedom "
                "and are wide")
        treat = "every difference"
    return ("<p class='warning'><strong>Warning: small sample.</strong> "
            f"This report has {runs} Monte Carlo run{'s' if runs != 1 else ''}"
            f"{' per candidate' if ranking else ''}: {what}. Treat {treat} as indicative; use "
            f"at least {FEW_RUNS} runs (30 or more for conclusions).</p>")


def _ci(d: PairedDifference, unit: float, u: str) -> str:
    if d.undetermined:  # every run censored on both sides: a zero-width interval of nothing
        return "undetermined"
    if not (math.isfinite(d.ci_low) and math.isfinite(d.ci_high)):
        return f"undefined ({d.n} run)" if d.n < 2 else "undefined"
    return f"[{d.ci_low / unit:+.3g}, {d.ci_high / unit:+.3g}] {u}"


def _num(x: float, fmt: str) -> str:
    return format(float(x), fmt) if math.isfinite(x) else "undefined"


def _mean(x: float, unit: float, u: str) -> str:
    return f"{x / unit:+.3g} {u}" if math.isfinite(x) else "undefined"


def _verdict(d: PairedDifference) -> str:
    note = censored_note(d)
    if d.undetermined:
        return note
    if not (math.isfinite(d.ci_low) and math.isfinite(d.ci_high)):
        return "undefined"
    text = "yes" if d.excludes_zero else f"no: not decided at {d.n} runs"
    return f"{text}; {note}" if note else text


def _replans(c: ReplanCounts | None) -> str:
    """The results table's re-plan cell: total / not converged / fell back, and the
    infeasible ones if any ("–": none)."""
    if c is None or not c.total:
        return "–"
    bad = f" ({c.infeasible} infeasible)" if c.infeasible else ""
    return (f"{c.total} / {c.not_converged} ({100 * c.not_converged_share:.1f} %) / "
            f"{c.fell_back}{bad}")


def replan_warning(result: CampaignResult) -> str:
    """HTML paragraph naming the policies with more than
    :data:`~tmaplan.evaluation.replans.NOT_CONVERGED_WARNING` of their re-plans not
    converged ("" if none), as the campaign's :class:`~tmaplan.evaluation.replans.ReplanWarning`."""

    over = [(n, c) for n in result.policies if (c := result.summary[n].get("replans"))
            is not None and c.not_converged_share > NOT_CONVERGED_WARNING]
    if not over:
        return ""
    items = "; ".join(f"{html.escape(n)}: {c.not_converged} of {c.total} "
                      f"({100 * c.not_converged_share:.1f} %)" for n, c in over)
    return ("<p class='warning'><strong>Warning: re-plans not converged.</strong> "
            f"More than {100 * NOT_CONVERGED_WARNING:g} % of the re-plans did not converge "
            f"({items}); the own ship kept its previous plan there, so these results say "
            "less about the policy's re-planning.</p>")


def results_table(result: CampaignResult, eff: dict[str, dict[str, float]]) -> str:
    """The per-policy results table (HTML) in display units."""
    rows = []
    for name in result.policies:
        s = result.summary[name]
        e = eff[name]
        cells = (html.escape(name), minutes(s["time_to_accuracy"]),
                 f"{s['reached_fraction']:.0%}", _num(s["final_range_rmse"] / 1000, ".2f"),
                 _num(s["rmse_position"][-1] / 1000, ".2f"),
                 _num(np.degrees(s["rmse_course"][-1]), ".0f"),
                 speed(s["rmse_speed"][-1]).removesuffix(" kn"),
                 f"{_num(e['final_position'], '.2g')} / {_num(e['final_range'], '.2g')}",
                 _num(e["mean_range"], ".2g"), f"{s['divergence_rate']:.0%}",
                 f"{s['pings_used']:.1f}", f"{s['replan_seconds']:.2f}",
                 _replans(s.get("replans")), f"{s.get('recoveries', 0.0):.2f}")
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
    return ("<table><tr><th>policy</th><th>median time to accuracy</th><th>localised</th>"
            "<th>final range RMSE [km]</th><th>final position RMSE [km]</th>"
            "<th>final course RMSE [°]</th><th>final speed RMSE [kn]</th>"
            "<th>RMSE / PCRB final (position / range)</th>"
            "<th>range RMSE / PCRB, mean over time</th><th>diverged</th><th>pings</th>"
            "<th>re-plan [s]</th><th>re-plans: total / not converged / fell back</th>"
            "<th>recoveries / run</th></tr>" + "".join(rows)
            + "</table>")


def _relative_means(diffs: list[PairedDifference], policies: tuple[str, ...]
                    ) -> dict[str, float]:
    """Mean of the metric per policy relative to the first policy (from the pairs)."""
    ref = policies[0]
    rel = {ref: 0.0}
    for d in diffs:
        if d.b == ref:
            rel[d.a] = d.mean
        elif d.a == ref:
            rel[d.b] = -d.mean
    return rel


def _pair(diffs: list[PairedDifference], a: str, b: str) -> tuple[PairedDifference, float]:
    """The difference a − b (sign +1) or b − a (sign −1)."""
    for d in diffs:
        if (d.a, d.b) == (a, b):
            return d, 1.0
        if (d.a, d.b) == (b, a):
            return d, -1.0
    raise KeyError((a, b))


def _summary_line(diffs: list[PairedDifference], policies: tuple[str, ...], metric: str,
                  ) -> str:
    label, unit, u = _metric(metric)
    if all(d.undetermined for d in diffs):  # nobody localised: no ranking, not a tie
        return (f"<li><strong>{label}</strong>: undetermined: no policy localised in any of "
                f"the {min(d.n for d in diffs)} paired runs.</li>")
    rel = {p: m for p, m in _relative_means(diffs, policies).items() if math.isfinite(m)}
    if len(rel) < 2:
        return f"<li><strong>{label}</strong>: no summary (undefined means).</li>"
    order = sorted(rel, key=lambda p: rel[p])
    best = order[0]
    items = []
    for other in order[1:]:
        d, sign = _pair(diffs, best, other)
        lo, hi = sorted((sign * d.ci_low, sign * d.ci_high))
        ci = (f"[{lo / unit:+.3g}, {hi / unit:+.3g}] {u}"
              if math.isfinite(lo) and math.isfinite(hi) else "interval undefined")
        sig = ("" if not (math.isfinite(lo) and math.isfinite(hi)) else
               ", decided" if d.excludes_zero else f", not decided at {d.n} runs")
        note = censored_note(d)
        if d.undetermined:
            items.append(f"{html.escape(other)} {note}")
            continue
        items.append(f"{html.escape(other)} {_mean(sign * d.mean, unit, u)} ({ci}{sig}"
                     + (f"; {note})" if note else ")"))
    n_sig = sum(_pair(diffs, best, o)[0].excludes_zero for o in order[1:])
    n_runs = min(d.n for d in diffs)
    verdict = (f"better than {n_sig} of the {len(order) - 1} other policies at 95 %"
               if n_runs >= 2 else "no confidence interval with a single run")
    head = f"<li><strong>{label}</strong>: {_lowest(diffs, best, order[1], n_runs)}, {verdict}. "
    shown = items[:1] + ([items[-1]] if len(items) > 1 else [])
    names = ["runner-up", "last"][:len(shown)]
    rest = "; ".join(f"{n}: {html.escape(best)} − {i}" for n, i in zip(names, shown))
    missing = [html.escape(p) for p in policies if p not in rel]
    left = f" Mean undefined for {', '.join(missing)}." if missing else ""
    return head + rest + "." + left + "</li>"


def _lowest(diffs: list[PairedDifference], best: str, runner_up: str, n_runs: int) -> str:
    """Who has the lowest mean, said as a ranking only when the paired interval against the
    runner-up excludes zero ("not decided at N runs" otherwise, issue 38)."""
    name = f"<strong>{html.escape(best)}</strong>"
    if n_runs >= 2 and _pair(diffs, best, runner_up)[0].excludes_zero:
        return f"lowest mean with {name}"
    return (f"lowest mean not decided at {n_runs} runs ({name} and "
            f"{html.escape(runner_up)} within the interval)")


def censored_lines(result: CampaignResult) -> list[str]:
    """Console lines of the paired differences with runs censored on both sides (neither
    policy localised; :func:`tmaplan.evaluation.metrics.censored_note`), one per difference:
    ``"straight − single-turn, time to accuracy: undetermined: neither policy localised in
    any of the 4 paired runs"``; none when no run is."""
    return [f"{d.a} − {d.b}, {_metric(d.metric)[0]}: {note}" for d in result.differences
            if (note := censored_note(d))]


def differences_html(result: CampaignResult) -> str:
    """Summary of the key paired differences, then the full table in ``<details>``."""
    diffs = list(result.differences)
    if not diffs:
        return "<p>One policy only: no paired differences.</p>"
    metrics = list(dict.fromkeys(d.metric for d in diffs))
    summary = "".join(_summary_line([d for d in diffs if d.metric == m], result.policies, m)
                      for m in metrics)
    rows = []
    for d in diffs:
        label, unit, u = _metric(d.metric)
        rows.append(f"<tr><td>{html.escape(d.a)} − {html.escape(d.b)}</td><td>{label}</td>"
                    f"<td>{'undetermined' if d.undetermined else _mean(d.mean, unit, u)}</td>"
                    f"<td>{_ci(d, unit, u)}</td>"
                    f"<td>{_verdict(d)}</td></tr>")
    return (f"<h3>Summary</h3><ul>{summary}</ul>"
            "<p>Negative differences favour the first policy named (lower is better). "
            "Time to accuracy is censored at the horizon plus one time step for runs that never "
            "get there; a run where neither policy gets there is censored on both sides and "
            "decides nothing (a pair censored on both sides in every run is undetermined).</p>"
            f"<details><summary>All {len(diffs)} paired differences (95 % confidence "
            "intervals)</summary><table><tr><th>pair</th><th>metric</th><th>mean</th>"
            "<th>95 % CI</th><th>decided (excludes 0)</th></tr>" + "".join(rows) +
            "</table></details>")


def baseline_parameters(params: dict[str, Any]) -> str:
    """A baseline manoeuvre's parameters in words: ``"turn +60° at 15.0 min"``, ``"first turn
    +120°, legs of 7.5 min"`` (zig-zag)."""
    if not params:
        return "no turn"
    parts = []
    if "angle" in params:
        first = "first turn" if "leg_duration" in params else "turn"
        parts.append(f"{first} {angle(float(params['angle']), signed=True)}")
    if "time" in params:
        parts.append(f"at {minutes(float(params['time']))}")
    text = " ".join(parts)
    if "leg_duration" in params:
        text += f"{', ' if text else ''}legs of {minutes(float(params['leg_duration']))}"
    other = [f"{k} = {float(v):.4g}" for k, v in params.items()
             if k not in ("angle", "time", "leg_duration")]
    return ", ".join([t for t in (text, *other) if t])
