"""Figure and HTML report of ``tmaplan rank-costs`` (cost functionals against Monte Carlo)."""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from tmaplan.display import objective_label
from tmaplan.evaluation.cost_ranking import CostRankingResult
from tmaplan.plotting import new_figure, save_figure
from tmaplan.report_tables import sample_warning

__all__ = ["candidate_label", "cost_label", "plot_cost_ranking", "write_ranking_report"]

_MARKERS = {"straight": "s", "single-turn": "o", "zigzag": "^", "tactic": "D", "planned": "*"}


def _ci(ci: tuple[float, float]) -> str:
    return "–" if not np.all(np.isfinite(ci)) else f"[{ci[0]:+.2f}, {ci[1]:+.2f}]"


def candidate_label(name: str) -> str:
    """A candidate's name in display units: ``"single-turn:+60deg@900s"`` ->
    ``"single-turn +60° at 15 min"``, ``"zigzag:+30deg,leg600s"`` -> ``"zigzag +30°, legs
    of 10 min"`` (other names unchanged)."""
    def mins(m: re.Match[str]) -> str:
        return f"{float(m.group(1)) / 60:.3g} min"

    out = re.sub(r"^(single-turn|zigzag):", r"\1 ", name)
    out = re.sub(r"([+-]?\d+(?:\.\d+)?)deg", r"\1°", out)
    out = re.sub(r"@(\d+(?:\.\d+)?)s$", lambda m: f" at {mins(m)}", out)
    return re.sub(r",leg(\d+(?:\.\d+)?)s$", lambda m: f", legs of {mins(m)}", out)


def cost_label(name: str) -> str:
    """A cost functional's name with its unit: :func:`tmaplan.plotting.objective_label` for
    the planning objectives, [m] for the Monte Carlo range bounds of
    :func:`tmaplan.evaluation.cost_ranking.cost_functionals`."""
    if name.endswith(("pcrb-cartesian-range", "expected-crlb-range")):
        return f"{name} [m]"
    return objective_label(name)


def _num(x: float) -> str:
    return "–" if not np.isfinite(x) else f"{x:+.2f}"


def plot_cost_ranking(result: CostRankingResult, path: str | Path) -> Figure:
    """One panel per cost: the cost of each candidate (x, with its unit: :func:`cost_label`)
    against its Monte Carlo mean time to accuracy [min], marker by family, titled with the
    cost's Spearman ρ.

    Parameters
    ----------
    result : CostRankingResult
    path : path
        PNG file.
    """
    costs = result.costs
    ncols = min(4, len(costs))
    nrows = int(np.ceil(len(costs) / ncols))
    fig, axes = new_figure(nrows, ncols, size=(3.6 * ncols, 3.0 * nrows))
    y = result.time_to_accuracy / 60.0
    fam = np.array(result.families)
    for i, ax in enumerate(axes.flat):
        if i >= len(costs):
            ax.set_visible(False)
            continue
        c = costs[i]
        for f, mk in _MARKERS.items():
            sel = fam == f
            if np.any(sel):
                ax.plot(c.values[sel], y[sel], mk, ms=6 if f == "planned" else 4,
                        label=f, alpha=0.8)
        ax.set_title(f"{c.name}\nρ = {_num(c.spearman)} {_ci(c.spearman_ci)}", fontsize=8)
        ax.tick_params(labelsize=7)
        if i % ncols == 0:
            ax.set_ylabel("MC mean time to accuracy [min]", fontsize=7)
        ax.set_xlabel(f"{cost_label(c.name)}, minimised", fontsize=7)
    axes.flat[0].legend(fontsize=6, loc="best", framealpha=0.6)
    fig.suptitle(f"{result.problem}: cost functionals against closed-loop Monte Carlo "
                 f"({len(result.candidates)} candidates, {result.campaign.spec.runs} runs)",
                 fontsize=10)
    save_figure(fig, path)
    return fig


def write_ranking_report(result: CostRankingResult, out_dir: str | Path, *, command: str,
                         figure: Path | None = None) -> Path:
    """Write ``<out>/<problem>_rank-costs.html``: the ρ/τ table, the candidates' metrics and
    the figure (rankings of other problems into the same directory are kept).

    Returns
    -------
    Path
        The report file.
    """
    spec = result.campaign.spec
    rows = "".join(
        f"<tr><td style='text-align:left'>{html.escape(c.name)}"
        f"{' (default)' if c.name == result.default_objective else ''}</td>"
        f"<td>{_num(c.spearman)}</td><td>{_ci(c.spearman_ci)}</td><td>{_num(c.kendall)}</td>"
        f"<td>{_num(c.spearman_rmse)}</td><td>{_ci(c.spearman_rmse_ci)}</td></tr>"
        for c in result.costs)
    order = np.argsort(result.time_to_accuracy, kind="stable")
    cands = "".join(
        f"<tr><td style='text-align:left'>{html.escape(candidate_label(result.candidates[i]))}"
        "</td>"
        f"<td>{result.families[i]}</td><td>{result.time_to_accuracy[i] / 60:.1f}</td>"
        f"<td>{result.final_range_rmse[i] / 1000:.2f}</td></tr>" for i in order)
    img = ""
    if figure is not None:
        b64 = base64.b64encode(Path(figure).read_bytes()).decode("ascii")
        img = f"<figure><img alt='costs against Monte Carlo' src='data:image/png;base64,{b64}'>" \
              "</figure>"
    skipped = "".join(f"<li>{html.escape(k)}: {html.escape(v)}</li>"
                      for k, v in result.skipped.items())
    problem = html.escape(result.problem)
    doc = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>tmaplan rank-costs: {problem}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}
.warning{{background:#fff4e0;border-left:4px solid #e69500;padding:.5em 1em}}
img{{max-width:100%}}</style></head><body>
<h1>Cost functionals against closed-loop Monte Carlo: {html.escape(result.problem)}</h1>
<p>{len(result.candidates)} candidate manoeuvres flown in closed loop, {spec.runs} paired runs
(truths from the prior, common random numbers), {spec.n_particles} particles, seed
{spec.seed}. Time to accuracy: relative range error below {100 * spec.accuracy:.3g}% and staying
there, mean over runs, censored at {result.censor / 60:.2f} min. Every cost and metric is
minimised, so ρ near +1 means the cost ranks the manoeuvres as the filter does. Intervals:
bootstrap percentile 95 % (runs and candidates resampled). Default objective of
<code>tmaplan plan</code>: <code>{html.escape(result.default_objective)}</code>; of the
closed-loop policies: <code>{html.escape(result.closed_loop_objective)}</code>.</p>
<p>Reproduce: <code>{html.escape(command)}</code></p>
{sample_warning(spec.runs, ranking=True)}
<h2>Rank correlations</h2>
<table><tr><th>cost</th><th>Spearman ρ (time to accuracy)</th><th>95 % CI</th>
<th>Kendall τ</th><th>Spearman ρ (final range RMSE)</th><th>95 % CI</th></tr>{rows}</table>
<h2>Figure</h2>{img}
<h2>Candidates (best first)</h2>
<table><tr><th>candidate</th><th>family</th><th>mean time to accuracy [min]</th>
<th>final range RMSE [km]</th></tr>{cands}</table>
<h2>Left out</h2><ul>{skipped}</ul>
</body></html>
"""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{result.problem}_rank-costs.html"
    path.write_text(doc, encoding="utf-8")
    return path
