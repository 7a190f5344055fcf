"""The several-contact parts of a comparison report: the per-contact table and figure.

Role: issue 40's report (DESIGN.md §6). For a campaign on several contacts
(:mod:`tmaplan.evaluation.contacts_campaign`), ``tmaplan compare`` adds to the report
(:func:`tmaplan.report.write_report`) an aggregate table (time until every contact is
localised, weighted mean time, worst final range error) and a per-contact table, and a figure
of run 0 in which every contact has its own colour and label; :func:`console_lines` gives the
same tables on the console.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from tmaplan.experiments import CampaignResult
from tmaplan.plotting import new_figure, save_figure

__all__ = ["console_lines", "contacts_figure", "contacts_html"]


def _minutes(t: float) -> str:
    return "never" if not np.isfinite(t) else f"{t / 60:.1f} min"


def _rows(result: CampaignResult) -> list[tuple[str, list[str], list[tuple[str, list[str]]]]]:
    """Per policy: its aggregate cells and its per-contact rows (name, cells)."""
    out = []
    for name in result.policies:
        s = result.summary[name]
        agg = [_minutes(s["time_to_accuracy_all"]), f"{s['reached_fraction']:.0%}",
               _minutes(s["weighted_time_to_accuracy"]), f"{s['worst_final_range_error']:.0f} m"]
        per = [(c, [_minutes(v["time_to_accuracy"]), f"{v['reached_fraction']:.0%}",
                    f"{v['final_range_rmse']:.0f} m", f"{v['divergence_rate']:.0%}"])
               for c, v in s["contacts"].items()]
        out.append((name, agg, per))
    return out


#: Column heads of the aggregate and per-contact tables.
AGGREGATE_HEAD = ("all localised (median)", "runs all localised", "weighted mean time",
                  "worst final range error (mean)")
CONTACT_HEAD = ("time to accuracy (median)", "localised", "final range RMSE", "diverged")


def contacts_html(result: CampaignResult) -> str:
    """The aggregate and per-contact tables (HTML) of a several-contact campaign."""
    def row(cells: list[str]) -> str:
        return "<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>"

    rows = _rows(result)
    agg = "".join(row([n, *a]) for n, a, _ in rows)
    per = "".join(row([n, c, *cells]) for n, _, p in rows for c, cells in p)
    head_a = "".join(f"<th>{h}</th>" for h in ("policy", *AGGREGATE_HEAD))
    head_c = "".join(f"<th>{h}</th>" for h in ("policy", "contact", *CONTACT_HEAD))
    return (f"<h2>Several contacts</h2><p>Aggregate over the contacts (a run's time until all "
            f"are localised is the latest of the contacts' times; means censor a run never "
            f"localised at the horizon + dt):</p><table><tr>{head_a}</tr>{agg}</table>"
            f"<h3>Per contact</h3><table><tr>{head_c}</tr>{per}</table>")


def console_lines(result: CampaignResult) -> list[str]:
    """The same tables as plain text lines."""
    lines = []
    for name, agg, per in _rows(result):
        lines.append(f"{name:<28} all localised {agg[0]:>9} ({agg[1]} of runs)  weighted "
                     f"mean {agg[2]:>9}  worst final range error {agg[3]}")
        lines += [f"  {c:<26} time to accuracy {cells[0]:>9}  localised {cells[1]:>4}  "
                  f"final range RMSE {cells[2]}" for c, cells in per]
    return lines


def contacts_figure(result: CampaignResult, out_dir: str | Path) -> Path:
    """Run 0 of every policy: the own-ship track, and each contact's true (solid) and
    estimated (dotted) track in its own colour, labelled by name. Written to
    ``<out_dir>/contacts.png``."""
    n = len(result.policies)
    fig, axes = new_figure(1, n, size=(4.6 * n, 5.0))
    for j, name in enumerate(result.policies):
        ax = axes[0, j]
        s = result.summary[name]
        own = result.examples[name].observer / 1e3
        ax.plot(own[:, 0], own[:, 1], color="k", lw=2, label="own ship")
        for i, (c, v) in enumerate(s["contacts"].items()):
            ex = v["example"]
            col = f"C{(i + 1) % 10}"
            tr, est = ex.target / 1e3, ex.estimate / 1e3
            ax.plot(tr[:, 0], tr[:, 1], color=col, lw=1.8, label=f"{c} (truth)")
            ax.plot(est[:, 0], est[:, 1], color=col, ls=":", lw=1.2, label=f"{c} (estimate)")
            ax.annotate(c, tr[0], color=col, fontsize=9)
        ax.set_title(name)
        ax.set_xlabel("east [km]")
        ax.set_ylabel("north [km]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    return save_figure(fig, Path(out_dir) / "contacts.png")
