"""The advice's figures and its self-contained HTML page (figures embedded as base64 PNG).

* ``advise_picture.png``: the geographic picture in the local plane [km] (x = East,
  y = North): the own ship's track, a sample of bearing lines per contact, each contact's
  ML and particle-filter positions with their 95 % ellipses, and the recommended tracks;
* ``advise_residuals.png``: stacked dots, one row per contact: each bearing's residual
  against the ML solution in standard deviations, over time (the analyst's check that a
  solution fits: dots within ±2 without a trend);
* ``advise_bound.png``: the closed-form PCRB range bound [m] over the next horizon along the
  recommended track and holding course, per contact, with 10 % of its current range.

With several contacts the advice is one (:class:`~tmaplan.advice.joint.JointAdvice`): one
recommended track (black, dotted) and every contact's bound along it in the contact's colour.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.advice.joint import JointAdvice
from tmaplan.advice.recommend import ACCURACY, Advice
from tmaplan.advice.solution import ContactSolution, Estimate
from tmaplan.io.recording import Recording
from tmaplan.plotting import new_figure, save_figure

__all__ = ["advice_figures", "write_advice_page"]

_CAPTIONS = {
    "picture": "Geographic picture (local plane, km): own ship, bearing lines, each contact's "
               "ML (solid) and particle-filter (dashed) position with its 95 % ellipse, and "
               "the recommended track (dotted; with several contacts one track for all, "
               "black) over the next horizon.",
    "residuals": "Stacked dots: bearing residuals against the ML solution, in standard "
                 "deviations, one row per contact.",
    "bound": "Range bound (closed-form PCRB, m) over the next horizon: recommended track "
             "(solid) against holding course (dashed); dotted: 10 % of the contact's range.",
}


def _ellipse(ax: Any, est: Estimate, color: str, style: str) -> None:
    a, b, th = est.ellipse
    if not np.all(np.isfinite([a, b, th])) or a > 1e6:
        return
    s = np.linspace(0.0, 2 * np.pi, 73)
    major = np.array([np.sin(th), np.cos(th)])
    minor = np.array([np.cos(th), -np.sin(th)])
    pts = est.state[:2] + np.outer(a * np.cos(s), major) + np.outer(b * np.sin(s), minor)
    ax.plot(pts[:, 0] / 1e3, pts[:, 1] / 1e3, style, color=color, lw=1)
    ax.plot(est.state[0] / 1e3, est.state[1] / 1e3, "o" if style == "-" else "s",
            color=color, ms=4, mfc="none" if style != "-" else color)


def _bounds(solutions: Sequence[ContactSolution],
            advice: Sequence[Advice | None] | JointAdvice
            ) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, str] | None]:
    """Per contact: (times from now [min], bound along the recommended track, bound holding
    course [m], label), None without advice."""
    if isinstance(advice, JointAdvice):
        t = (advice.track.times - advice.track.times[0]) / 60.0
        return [(t, advice.range_bounds[s.name], advice.hold_range_bounds[s.name],
                 f"{s.name}: {advice.recommendation} (all contacts)") for s in solutions]
    return [None if a is None else ((a.track.times - a.track.times[0]) / 60.0, a.range_bound,
                                    a.hold_range_bound, f"{s.name}: {a.recommendation}")
            for s, a in zip(solutions, advice, strict=True)]


def advice_figures(recording: Recording, solutions: Sequence[ContactSolution],
                   advice: Sequence[Advice | None] | JointAdvice,
                   out_dir: str | Path) -> dict[str, Path]:
    """Write the three figures (module doc) into ``out_dir``; name -> path. ``advice``: one
    per contact (None: no advice), or the joint advice of several contacts."""
    out = Path(out_dir)
    colors = [f"C{i % 10}" for i in range(len(solutions))]
    joint = advice if isinstance(advice, JointAdvice) else None
    per: Sequence[Advice | None] = [None] * len(solutions) if joint is not None \
        else advice  # type: ignore[assignment]
    nav = recording.nav
    fig, ax = new_figure(size=(7.0, 6.0))
    a = ax[0, 0]
    assert nav.east is not None and nav.north is not None
    a.plot(nav.east / 1e3, nav.north / 1e3, "k-", lw=1.5, label="own ship")
    if joint is not None:
        a.plot(joint.track.position[:, 0] / 1e3, joint.track.position[:, 1] / 1e3, "k:", lw=2,
               label=f"recommended for all contacts ({joint.recommendation})")
    for sol, adv, col in zip(solutions, per, colors, strict=True):
        c = recording.contact(sol.name)
        # the filter's range (its prior bounds it); the ML range of an unobservable contact
        # can be anything (1e10 km seen): not the length of the bearing lines
        r = sol.pf.range if np.isfinite(sol.pf.range) else sol.mle.range
        r = float(np.clip(r, 1000.0, 100_000.0)) if np.isfinite(r) else 10_000.0
        idx = np.unique(np.linspace(0, c.times.size - 1, 20).astype(int))
        p = c.ownship.position[idx]
        g = sol.problem.bearing[idx]  # the plane's azimuths (grid north)
        end = p + 1.3 * r * np.column_stack([np.sin(g), np.cos(g)])
        for p0, p1 in zip(p, end, strict=True):
            a.plot([p0[0] / 1e3, p1[0] / 1e3], [p0[1] / 1e3, p1[1] / 1e3], "-", color=col,
                   lw=0.4, alpha=0.5)
        _ellipse(a, sol.mle, col, "-")
        _ellipse(a, sol.pf, col, "--")
        a.plot([], [], "-", color=col, label=f"{sol.name}: {sol.verdict.split(':')[0]}")
        if adv is not None:
            a.plot(adv.track.position[:, 0] / 1e3, adv.track.position[:, 1] / 1e3, ":",
                   color=col, lw=2)
    a.set_xlabel("east [km]")
    a.set_ylabel("north [km]")
    a.set_aspect("equal", adjustable="datalim")
    a.grid(True, alpha=0.3)
    a.legend(loc="best", fontsize=8, framealpha=0.6)
    paths = {"picture": save_figure(fig, out / "advise_picture.png")}

    n = len(solutions)
    fig, ax = new_figure(n, 1, size=(7.0, 1.2 + 1.3 * n), sharex=True)
    for i, (sol, col) in enumerate(zip(solutions, colors, strict=True)):
        a = ax[i, 0]
        sig = np.concatenate([np.full(m.steps.size, float(m.sigma))
                              for m in sol.problem.measurements])
        order = np.argsort(np.concatenate([m.steps for m in sol.problem.measurements]),
                           kind="stable")
        z = sol.residuals / sig[order]
        a.plot(sol.residual_times / 60.0, z, ".", color=col, ms=3)
        a.axhspan(-2, 2, color="0.9", zorder=0)
        a.axhline(0.0, color="0.5", lw=0.8)
        a.set_ylabel(f"{sol.name}\n[σ]", fontsize=8)
        a.set_ylim(-5, 5)
    ax[-1, 0].set_xlabel("time since the first fix [min]")
    paths["residuals"] = save_figure(fig, out / "advise_residuals.png")

    fig, ax = new_figure(size=(7.0, 4.0))
    a = ax[0, 0]
    for sol, bound, col in zip(solutions, _bounds(solutions, advice), colors, strict=True):
        if bound is None:
            continue
        t, rb, hold, label = bound
        a.semilogy(t, rb, "-", color=col, label=label)
        a.semilogy(t, hold, "--", color=col)
        r = sol.pf.range if np.isfinite(sol.pf.range) else sol.mle.range
        if np.isfinite(r):
            a.axhline(ACCURACY * r, color=col, lw=0.8, ls=":")
    a.plot([], [], "k--", label="holding course")
    a.plot([], [], "k:", lw=0.8, label=f"{ACCURACY:.0%} of the range")
    a.set_xlabel("time from now [min]")
    a.set_ylabel("range bound [m]")
    a.grid(True, which="both", alpha=0.3)
    a.legend(loc="best", fontsize=8)
    paths["bound"] = save_figure(fig, out / "advise_bound.png")
    return paths


def write_advice_page(out_dir: str | Path, *, title: str, command: str, summary_html: str,
                      figures: dict[str, Path]) -> Path:
    """Write ``advise.html`` (figures embedded) into ``out_dir`` and return its path.

    Parameters
    ----------
    out_dir : str or Path
    title : str
    command : str
        The command that reproduces the page.
    summary_html : str
        The solution and advice tables (escaped HTML).
    figures : dict of str to Path
    """
    imgs = []
    for name, p in figures.items():
        b64 = base64.b64encode(Path(p).read_bytes()).decode("ascii")
        imgs.append(f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,"
                    f"{b64}'><figcaption>{html.escape(_CAPTIONS.get(name, name))}"
                    "</figcaption></figure>")
    doc = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}}
table{{border-collapse:collapse;margin:.5em 0}}td,th{{border:1px solid #ccc;padding:3px 8px;
text-align:right}}.warning{{background:#fff4e0;border-left:4px solid #e69500;padding:.5em 1em}}
img{{max-width:100%}}</style></head>
<body>
<h1>{html.escape(title)}</h1>
<p>Reproduce: <code>{html.escape(command)}</code></p>
{summary_html}
<h2>Figures</h2>
{''.join(imgs)}
</body></html>
"""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "advise.html"
    path.write_text(doc, encoding="utf-8")
    return path
