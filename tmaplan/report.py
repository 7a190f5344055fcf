"""Figures and a self-contained HTML report of a policy comparison."""

from __future__ import annotations

import base64
import html
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.plotting import new_figure, save_figure
from tmaplan.scenario import dump

if TYPE_CHECKING:
    from tmaplan.experiments import CampaignResult

__all__ = ["comparison_figures", "efficiency", "write_report"]


def _bounds(result: CampaignResult) -> dict[str, np.ndarray]:
    """Closed-form PCRB position bound along run 0's track of each policy (if available)."""
    try:
        from tmaplan.bounds.closed_form import closed_form_pcrb
        from tmaplan.models.observer import ObserverTrack
        from tmaplan.models.target import initial_velocity
    except ImportError:  # pragma: no cover - bounds not installed
        return {}
    scenario = result.spec.scenario
    out = {}
    dt = scenario.time.dt
    for name in result.policies:
        ex = result.examples[name]
        pos = np.asarray(ex.observer, float)
        vbar = np.vstack([initial_velocity(scenario.observer)[None],
                          np.diff(pos, axis=0) / dt])
        heading = np.arctan2(vbar[:, 0], vbar[:, 1])
        track = ObserverTrack(times=scenario.times, position=pos, velocity=vbar,
                              mean_velocity=vbar, heading=heading,
                              speed=np.hypot(*vbar.T))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # side-assumption notes: the bound is a guide
                res = closed_form_pcrb(scenario, observer=track,
                                       ping_steps=[int(k) for k in ex.ping_steps])
            out[name] = np.asarray(res.position_std)
        except (ArithmeticError, ValueError, RuntimeError):  # decoration only, never fatal
            continue
    return out


def efficiency(result: CampaignResult) -> dict[str, float]:
    """Final position RMSE over the closed-form PCRB position bound, per policy.

    The bound is evaluated along run 0's own-ship track and pings (the closed form averages over
    the prior, which is where the runs' truths come from). Ratios near 1 mean the filter is
    as good as the bound allows; the LPC bound is optimistic in range for weakly observable
    geometries (README, "Findings"), so large ratios there are expected.
    """
    b = _bounds(result)
    return {name: float(result.summary[name]["rmse_position"][-1] / b[name][-1])
            for name in result.policies if name in b and b[name][-1] > 0}


def comparison_figures(result: CampaignResult, out_dir: str | Path) -> dict[str, Path]:
    """Write the comparison figures (PNG) and return their paths by name.

    Figures: ``rmse`` (position and range RMSE over time per policy, with the closed-form
    PCRB position bound along run 0's track), ``tracks`` (run 0's own-ship tracks, target and
    pings), ``time_to_accuracy`` (fraction of runs localised by time t).
    """
    out = Path(out_dir)
    t_min = result.times / 60.0
    paths: dict[str, Path] = {}
    bounds = _bounds(result)

    fig, axes = new_figure(1, 2, size=(12.0, 4.6))
    for i, name in enumerate(result.policies):
        s = result.summary[name]
        c = f"C{i % 10}"
        axes[0, 0].semilogy(t_min, s["rmse_position"], color=c, label=name)
        if name in bounds:
            axes[0, 0].semilogy(t_min, bounds[name], color=c, ls=":", lw=1)
        axes[0, 1].semilogy(t_min, s["rmse_range"], color=c, label=name)
    axes[0, 0].set_title("position RMSE (dotted: closed-form PCRB, run 0's track)")
    axes[0, 1].set_title("range RMSE")
    for ax in axes[0]:
        ax.set_xlabel("time [min]")
        ax.set_ylabel("[m]")
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 1].legend(fontsize=8)
    paths["rmse"] = save_figure(fig, out / "rmse.png")

    fig, axes = new_figure(size=(7.0, 6.0))
    ax = axes[0, 0]
    first = result.examples[result.policies[0]]
    tgt = np.asarray(first.target) / 1000
    ax.plot(tgt[:, 0], tgt[:, 1], color="k", lw=2, label="target (run 0)")
    ax.plot(tgt[0, 0], tgt[0, 1], "ko")
    for i, name in enumerate(result.policies):
        ex = result.examples[name]
        obs = np.asarray(ex.observer) / 1000
        ax.plot(obs[:, 0], obs[:, 1], color=f"C{i % 10}", label=name)
        pk = np.asarray(ex.ping_steps, int)
        if pk.size:
            ax.plot(obs[pk, 0], obs[pk, 1], "*", color=f"C{i % 10}", ms=9)
    ax.plot(0, 0, "o", color="0.3")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("East [km]")
    ax.set_ylabel("North [km]")
    ax.set_title("example tracks (run 0; stars: pings)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    paths["tracks"] = save_figure(fig, out / "tracks.png")

    fig, axes = new_figure(size=(7.0, 4.6))
    ax = axes[0, 0]
    grid = result.times - result.times[0]
    for i, name in enumerate(result.policies):
        t = result.summary[name]["time_to_accuracy_runs"]
        frac = [(t <= g).mean() for g in grid]
        ax.step(grid / 60, frac, where="post", color=f"C{i % 10}", label=name)
    ax.set_xlabel("time [min]")
    ax.set_ylabel("fraction of runs localised")
    ax.set_title(f"time to range accuracy ({result.spec.accuracy:.0%} of range, for good)")
    ax.set_ylim(0, 1.02)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    paths["time_to_accuracy"] = save_figure(fig, out / "time_to_accuracy.png")
    return paths


def _fmt_time(x: float) -> str:
    return "never" if not np.isfinite(x) else f"{x / 60:.1f} min"


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
    rows = []
    eff = efficiency(result)
    for name in result.policies:
        s = result.summary[name]
        rows.append(
            "<tr>" + "".join(f"<td>{v}</td>" for v in (
                html.escape(name), _fmt_time(s["time_to_accuracy"]),
                f"{s['reached_fraction']:.0%}", f"{s['final_range_rmse']:.0f}",
                f"{s['rmse_position'][-1]:.0f}",
                f"{np.degrees(s['rmse_course'][-1]):.0f}", f"{s['rmse_speed'][-1]:.2f}",
                f"{eff[name]:.1f}" if name in eff else "–",
                f"{s['divergence_rate']:.0%}",
                f"{s['pings_used']:.1f}", f"{s['replan_seconds']:.2f}")) + "</tr>")
    drows = []
    for d in result.differences:
        unit = 60.0 if d.metric == "time_to_accuracy" else 1.0
        u = "min" if d.metric == "time_to_accuracy" else "m"
        drows.append(
            f"<tr><td>{html.escape(d.a)} − {html.escape(d.b)}</td><td>{d.metric}</td>"
            f"<td>{d.mean / unit:+.2f} {u}</td>"
            f"<td>[{d.ci_low / unit:+.2f}, {d.ci_high / unit:+.2f}] {u}</td>"
            f"<td>{'yes' if d.excludes_zero else 'no'}</td></tr>")
    imgs = []
    for name, p in figs.items():
        b64 = base64.b64encode(Path(p).read_bytes()).decode("ascii")
        imgs.append(f"<figure><img alt='{html.escape(name)}' "
                    f"src='data:image/png;base64,{b64}'><figcaption>{html.escape(name)}"
                    "</figcaption></figure>")
    spec = result.spec
    doc = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title or 'tmaplan report')}</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}}
table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right}}
img{{max-width:100%}}pre{{background:#f6f6f6;padding:1em;overflow-x:auto}}</style>
<script>window.addEventListener("load",function(){{var im=document.images,n=0;
for(var i=0;i<im.length;i++){{if(im[i].complete&&im[i].naturalWidth>0)n++;}}
document.body.setAttribute("data-images-loaded",n);
document.body.setAttribute("data-images-total",im.length);}});</script></head>
<body>
<h1>{html.escape(title or 'tmaplan policy comparison')}</h1>
<p>{spec.runs} Monte Carlo runs, seed {spec.seed}, {spec.n_particles} particles; truths drawn
from the {'prior' if spec.truth == 'prior' else 'scenario'}; the same truth and noise for
every policy in a run (paired comparison). Localised = relative range error below
{spec.accuracy:.0%} and staying there. Wall time {result.seconds:.0f} s
({len(result.computed_runs)} runs computed now, {len(result.loaded_runs)} loaded from disk).</p>
<p>Reproduce: <code>{html.escape(command)}</code></p>
{extra_html}
<h2>Results</h2>
<table><tr><th>policy</th><th>median time to accuracy</th><th>localised</th>
<th>final range RMSE [m]</th><th>final position RMSE [m]</th><th>final course RMSE [°]</th>
<th>final speed RMSE [m/s]</th><th>RMSE / PCRB (final)</th><th>diverged</th>
<th>pings</th><th>re-plan [s]</th></tr>
{''.join(rows)}</table>
<h2>Paired differences (95 % confidence intervals)</h2>
<p>Time to accuracy is censored at the horizon for runs that never get there.</p>
<table><tr><th>pair</th><th>metric</th><th>mean</th><th>95 % CI</th><th>excludes 0</th></tr>
{''.join(drows)}</table>
<h2>Figures</h2>
{''.join(imgs)}
<h2>Scenario</h2>
<pre>{html.escape(dump(spec.scenario))}</pre>
</body></html>
"""
    path = out / "report.html"
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(doc, encoding="utf-8")
    return path


def report_payload(result: CampaignResult) -> dict[str, Any]:
    """Alias of ``result.to_json()`` (kept for symmetry with the CLI)."""
    return result.to_json()
