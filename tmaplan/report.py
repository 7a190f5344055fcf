"""Figures and a self-contained HTML report of a policy comparison."""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from tmaplan.display import scenario_text
from tmaplan.evaluation.contacts_campaign import accuracy_text
from tmaplan.experiments import CampaignResult
from tmaplan.plotting import new_figure, save_figure
from tmaplan.report_tables import (
    differences_html,
    replan_warning,
    results_table,
    sample_warning,
)
from tmaplan.scenario import to_dict

__all__ = ["BOUND_NAME", "comparison_figures", "efficiency", "line_style", "outside_legend",
           "rmse_figure", "write_report"]


#: What the dotted curves of the RMSE figure are (figure title, report caption).
BOUND_NAME = ("truth-conditioned PCRB over the runs' truths, own-ship tracks and pings "
              "(ristic2004, ch. 6)")


def efficiency(result: CampaignResult) -> dict[str, dict[str, float]]:
    """The filter's RMSE over the bound it can approach, per policy.

    The bound is the truth-conditioned PCRB along every run's own truth, own-ship track and
    pings, covariance averaged over the runs (``summary[name]["bound_position"]`` /
    ``["bound_range"]``, :func:`tmaplan.bounds.truth_bound.closed_loop_truth_bounds`,
    ristic2004, ch. 6): the quantity an RMSE over the same runs is compared with. (The
    prior-averaged PCRB is far more optimistic while the geometry is weakly observable; the
    closed-form LPC bound more so in range, docs/findings.md.) A ratio of 1 is an efficient
    filter. With truths drawn from the prior the run average of truth-conditioned bounds is
    not a strict lower bound (the Bayesian one is the prior-averaged PCRB, smaller): a filter
    can go below it while the geometry is weakly observable (``tmaplan compare default
    --policies straight,single-turn,planned,planned+uniform --runs 30``: final range ratios
    1.06, 1.13, 0.98, 1.04; ``planned`` 0.56–0.92, mean 0.73, between 8 and 20 min).

    Returns
    -------
    dict
        Policy -> ``final_position``, ``final_range`` (RMSE / bound at the last step) and
        ``mean_range`` (range RMSE / bound averaged over the horizon); NaN where the bound is
        not available.
    """
    out: dict[str, dict[str, float]] = {}
    for name in result.policies:
        s = result.summary[name]
        bp = np.asarray(s.get("bound_position", np.full(len(result.times), np.nan)), float)
        br = np.asarray(s.get("bound_range", np.full(len(result.times), np.nan)), float)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.asarray(s["rmse_range"], float) / br
            out[name] = {
                "final_position": float(s["rmse_position"][-1] / bp[-1]),
                "final_range": float(ratio[-1]),
                "mean_range": float(np.mean(ratio)) if np.all(np.isfinite(ratio))
                else float("nan")}
    return out


#: Line styles cycled over the policies, so that overlapping curves stay distinguishable (never
#: dotted: dotted curves are the bounds).
_STYLES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (8, 2, 2, 2)))


def line_style(i: int) -> dict[str, Any]:
    """Colour, dash, width and z-order of the ``i``-th policy's curve.

    Later policies are drawn thinner and on top of earlier ones with their own dash pattern, so
    a curve that coincides with another (``planned`` and ``planned+scheduled`` share the
    own-ship track until the first ping) stays visible around it.
    """
    return {"color": f"C{i % 10}", "ls": _STYLES[i % len(_STYLES)],
            "lw": max(1.0, 3.2 - 0.45 * i), "zorder": 2 + i}


def outside_legend(ax: Any, ncol: int = 2, **kw: Any) -> None:
    """Legend below the axes (never over the data)."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=ncol, fontsize=7,
              frameon=False, **kw)


def rmse_figure(result: CampaignResult) -> Figure:
    """Position and range RMSE per policy (solid) with the truth-conditioned PCRB over the
    same runs (dotted, :data:`BOUND_NAME`) and the efficiency of :func:`efficiency` in the
    legends."""
    t_min = result.times / 60.0
    eff = efficiency(result)
    n = len(result.policies)
    fig, axes = new_figure(1, 2, size=(12.0, 5.2 + 0.18 * ((n + 1) // 2)))
    for i, name in enumerate(result.policies):
        s = result.summary[name]
        st = line_style(i)
        c = st["color"]
        e = eff[name]
        axes[0, 0].semilogy(t_min, s["rmse_position"], **st,
                            label=f"{name} (RMSE/PCRB final {e['final_position']:.2g})")
        axes[0, 1].semilogy(t_min, s["rmse_range"], **st,
                            label=f"{name} (final {e['final_range']:.2g}, mean "
                                  f"{e['mean_range']:.2g})")
        for ax, key in ((axes[0, 0], "bound_position"), (axes[0, 1], "bound_range")):
            if key in s and np.any(np.isfinite(s[key])):
                ax.semilogy(t_min, s[key], color=c, ls=":", lw=1.2, zorder=st["zorder"])
    axes[0, 0].set_title("position RMSE (solid) and PCRB (dotted)")
    axes[0, 1].set_title("range RMSE (solid) and PCRB (dotted)")
    fig.suptitle(f"dotted: {BOUND_NAME}; legend: filter efficiency RMSE/PCRB", fontsize=9)
    for ax in axes[0]:
        ax.set_xlabel("time [min]")
        ax.set_ylabel("[m]")
        ax.grid(True, which="both", alpha=0.3)
        outside_legend(ax, ncol=1 if n < 4 else 2)
    return fig


def comparison_figures(result: CampaignResult, out_dir: str | Path) -> dict[str, Path]:
    """Write the comparison figures (PNG) and return their paths by name.

    Figures: ``rmse`` (position and range RMSE over time per policy, dotted: the
    truth-conditioned PCRB over the runs, :data:`BOUND_NAME`, with the efficiency RMSE/PCRB of
    :func:`efficiency` in the legend), ``tracks`` (run 0's own-ship tracks, target and
    pings), ``time_to_accuracy`` (fraction of runs localised by time t).
    """
    out = Path(out_dir)
    paths: dict[str, Path] = {"rmse": save_figure(rmse_figure(result), out / "rmse.png")}

    fig, axes = new_figure(size=(9.0, 6.0))
    ax = axes[0, 0]
    first = result.examples[result.policies[0]]
    tgt = np.asarray(first.target) / 1000
    ax.plot(tgt[:, 0], tgt[:, 1], color="k", lw=2, label="target (run 0)")
    ax.plot(tgt[0, 0], tgt[0, 1], "ko")
    for i, name in enumerate(result.policies):
        ex = result.examples[name]
        obs = np.asarray(ex.observer) / 1000
        st = line_style(i)
        ax.plot(obs[:, 0], obs[:, 1], **st, label=name)
        pk = np.asarray(ex.ping_steps, int)
        if pk.size:
            ax.plot(obs[pk, 0], obs[pk, 1], "*", color=st["color"], ms=9,
                    zorder=st["zorder"] + 20)
    ax.plot(0, 0, "o", color="0.3")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("East [km]")
    ax.set_ylabel("North [km]")
    ax.set_title("example tracks (run 0; stars: pings)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    paths["tracks"] = save_figure(fig, out / "tracks.png")

    fig, axes = new_figure(size=(9.0, 4.6))
    ax = axes[0, 0]
    grid = result.times - result.times[0]
    for i, name in enumerate(result.policies):
        t = result.summary[name]["time_to_accuracy_runs"]
        frac = [(t <= g).mean() for g in grid]
        ax.step(grid / 60, frac, where="post", **line_style(i), label=name)
    ax.set_xlabel("time since t0 [min]")
    ax.set_ylabel("fraction of runs localised")
    ax.set_title(f"time to range accuracy "
                 f"({accuracy_text(result.spec.scenario, result.spec.accuracy)} of range, "
                 "for good)")
    ax.set_ylim(-0.03, 1.03)  # curves at 0 and 1 stay visible
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
    paths["time_to_accuracy"] = save_figure(fig, out / "time_to_accuracy.png")
    return paths


_CAPTIONS = {"rmse": (f"Position and range RMSE over the runs (solid) and, dotted, the "
                     f"{BOUND_NAME}: the bound the filter can approach. Legend: the "
                     "filter's efficiency, RMSE / PCRB at the last step (range: also the mean "
                     "over the horizon); 1 is efficient.")}


def write_report(result: CampaignResult, out_dir: str | Path, *, command: str,
                 title: str | None = None, extra_html: str = "",
                 figures: dict[str, Path] | None = None) -> Path:
    """Write ``report.html`` (figures embedded as base64 PNG) and return its path.

    Parameters
    ----------
    result : CampaignResult
    out_dir : path
    command : str
        The exact command that reproduces the report.
    title : str, optional
    extra_html : str
        Extra sections (already escaped HTML), e.g. the plan and schedule of the demo.
    figures : dict, optional
        Additional figures (name -> PNG path) to embed before the comparison figures.
    """
    out = Path(out_dir)
    figs = dict(figures or {})
    figs.update(comparison_figures(result, out))
    eff = efficiency(result)
    imgs = []
    for name, p in figs.items():
        b64 = base64.b64encode(Path(p).read_bytes()).decode("ascii")
        cap = _CAPTIONS.get(name, name)
        imgs.append(f"<figure><img alt='{html.escape(name)}' "
                    f"src='data:image/png;base64,{b64}'><figcaption>{html.escape(cap)}"
                    "</figcaption></figure>")
    spec = result.spec
    doc = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title or 'tmaplan report')}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}
.warning{{background:#fff4e0;border-left:4px solid #e69500;padding:.5em 1em}}
img{{max-width:100%}}pre{{background:#f6f6f6;padding:1em;overflow-x:auto}}</style>
<script>window.addEventListener("load",function(){{var im=document.images,n=0;
for(var i=0;i<im.length;i++){{if(im[i].complete&&im[i].naturalWidth>0)n++;}}
document.body.setAttribute("data-images-loaded",n);
document.body.setAttribute("data-images-total",im.length);}});</script></head>
<body>
<h1>{html.escape(title or 'tmaplan policy comparison')}</h1>
<p>{spec.runs} Monte Carlo run{'s' if spec.runs != 1 else ''}, seed {spec.seed},
{spec.n_particles} particles; truths drawn
from the {'prior' if spec.truth == 'prior' else 'scenario'}; the same truth and noise for
every policy in a run (paired comparison). Localised = relative range error below
{accuracy_text(spec.scenario, spec.accuracy)} and staying there. Wall time {result.seconds:.0f} s
({len(result.computed_runs)} runs computed now, {len(result.loaded_runs)} loaded from disk).</p>
<p>Reproduce: <code>{html.escape(command)}</code></p>
{sample_warning(spec.runs)}
{extra_html}
<h2>Results</h2>
{replan_warning(result)}
{results_table(result, eff)}
<h2>Paired differences</h2>
{differences_html(result)}
<h2>Figures</h2>
{''.join(imgs)}
<h2>Scenario</h2>
<p>The scenario file of this report, in display units (a valid scenario file).</p>
<pre>{html.escape(scenario_text(to_dict(spec.scenario)))}</pre>
</body></html>
"""
    path = out / "report.html"
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(doc, encoding="utf-8")
    return path


def report_payload(result: CampaignResult) -> dict[str, Any]:
    """Alias of ``result.to_json()`` (kept for symmetry with the CLI)."""
    return result.to_json()
