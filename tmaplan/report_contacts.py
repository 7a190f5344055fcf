"""The several-contact tables and figures: comparison report, joint plan, shared pings.

Role: issue 40's report (DESIGN.md §6). For a campaign on several contacts
(:mod:`tmaplan.evaluation.contacts_campaign`), ``tmaplan compare`` adds to the report
(:func:`tmaplan.report.write_report`) an aggregate table (time until every contact is
localised, weighted mean time, worst final range error) and a per-contact table, and a figure
of run 0 in which every contact has its own colour and label; :func:`console_lines` gives the
same tables on the console. :func:`plan_figure` draws ``tmaplan plan``'s joint plan against
each contact's own plan, :func:`schedule_figure` ``tmaplan schedule``'s shared pings; every
contact has the colour :func:`contact_colour` of its index in all of them.
"""

from __future__ import annotations

import dataclasses
import html
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.experiments import CampaignResult
from tmaplan.models.target import target_track
from tmaplan.plotting import new_figure, save_figure

__all__ = ["console_lines", "contact_colour", "contacts_figure", "contacts_html",
           "plan_figure", "schedule_figure"]


def contact_colour(i: int) -> str:
    """The colour of the contact of index ``i`` in every several-contact figure (``C0`` is
    left to the own ship's plan)."""
    return f"C{(i + 1) % 10}"


def _minutes(t: float) -> str:
    return "never" if not np.isfinite(t) else f"{t / 60:.1f} min"


def _rows(result: CampaignResult) -> list[tuple[str, list[str], list[tuple[str, list[str]]]]]:
    """Per policy: its aggregate cells and its per-contact rows (name, cells)."""
    out = []
    for name in result.policies:
        s = result.summary[name]
        agg = [_minutes(s["time_to_accuracy_all"]), f"{s['reached_fraction']:.0%}",
               _minutes(s["weighted_time_to_accuracy"]), f"{s['worst_final_range_error']:.0f} m"]
        per = [(c, [f"{100 * v['required_accuracy']:.3g}%", _minutes(v["time_to_accuracy"]),
                    f"{v['reached_fraction']:.0%}",
                    f"{v['final_range_rmse']:.0f} m", f"{v['divergence_rate']:.0%}"])
               for c, v in s["contacts"].items()]
        out.append((name, agg, per))
    return out


#: Column heads of the aggregate and per-contact tables.
AGGREGATE_HEAD = ("all localised (median)", "runs all localised", "weighted mean time",
                  "worst final range error (mean)")
CONTACT_HEAD = ("required accuracy", "time to accuracy (median)", "localised",
                "final range RMSE", "diverged")


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
        lines += [f"  {c:<26} time to {cells[0]:>4} accuracy {cells[1]:>9}  localised "
                  f"{cells[2]:>4}  final range RMSE {cells[3]}" for c, cells in per]
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
            col = contact_colour(i)
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


def plan_figure(views: Sequence[Any], names: Sequence[str], plans: Mapping[str, Any],
                bounds: Mapping[str, Mapping[str, np.ndarray]], path: str | Path,
                *, title: str = "", ping_times: np.ndarray | None = None,
                bound_label: str = "closed-form PCRB range bound [m]") -> Path:
    """A plan for several contacts against each contact's own plan.

    Left: the own-ship track of each plan (the joint plan solid black, contact c's own plan
    dashed in c's colour) and each contact's true track over the plan (its view's
    ``target``, noise-free) in its colour, labelled. Right: each contact's closed-form range
    bound [m] over time on the joint plan (solid) and on each contact's own plan (dashed:
    c's own plan; dotted: another contact's), log scale.

    Parameters
    ----------
    views : sequence of Scenario
        Each contact's one-contact view (its ``target``: the true track drawn).
    names : sequence of str
        The contacts' names, in the order of ``views``.
    plans : mapping of str to HeadingPlan
        ``"joint"`` and ``"alone:<name>"`` (those present) -> plan.
    bounds : mapping of str to mapping of str to ndarray
        Same keys as ``plans`` -> contact name -> range bound per step (K+1,) [m].
    path : path
        PNG file.
    title : str
        Figure title.
    ping_times : ndarray, optional
        Times of the joint plan's pings [s] (the scenario clock): vertical lines on the
        right, squares on the joint track.
    bound_label : str
        The right axis' label (what ``bounds`` hold).
    """
    fig, axes = new_figure(1, 2, size=(13.0, 5.5))
    ax, bx = axes[0, 0], axes[0, 1]
    colour = {n: contact_colour(i) for i, n in enumerate(names)}
    for label, plan in plans.items():
        own = plan.observer
        mine = label.removeprefix("alone:")
        style = ({"color": "k", "lw": 2.2, "ls": "-"} if label == "joint" else
                 {"color": colour.get(mine, "0.5"), "lw": 1.2, "ls": "--"})
        ax.plot(own.position[:, 0] / 1e3, own.position[:, 1] / 1e3,
                label="joint plan" if label == "joint" else f"{mine}'s own plan", **style)
        t = (own.times - own.times[0]) / 60.0
        on = "the joint plan" if label == "joint" else f"{mine}'s plan"
        for n in names:
            curve = bounds[label][n]
            ls = "-" if label == "joint" else "--" if mine == n else ":"
            bx.plot(t[: len(curve)], curve, ls=ls, color=colour[n],
                    lw=2.0 if label == "joint" else 1.1, label=f"{n} on {on}")
    joint = plans.get("joint", next(iter(plans.values())))
    if ping_times is not None and len(ping_times):
        obs = joint.observer
        at = np.searchsorted(obs.times, np.asarray(ping_times, float) - 1e-6)
        at = np.clip(at, 0, obs.times.size - 1)
        ax.plot(obs.position[at, 0] / 1e3, obs.position[at, 1] / 1e3, "ks", ms=5,
                label="pings")
        for t in (np.asarray(ping_times, float) - obs.times[0]) / 60.0:
            bx.axvline(t, color="0.4", lw=0.8, ls="--")
    for v, n in zip(views, names, strict=True):
        grid = dataclasses.replace(v.time, horizon=float(joint.observer.times[-1] - v.time.t0))
        tr = target_track(v.target, grid, None)[:, :2] / 1e3
        ax.plot(tr[:, 0], tr[:, 1], color=colour[n], lw=1.6, alpha=0.8, label=f"{n} (truth)")
        ax.plot(*tr[0], "o", color=colour[n], ms=4)
        ax.annotate(n, tuple(tr[0]), color=colour[n], fontsize=9)
    ax.set_xlabel("East [km]")
    ax.set_ylabel("North [km]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best", framealpha=0.6)
    ax.set_title("own-ship plans and the contacts' true tracks")
    bx.set_yscale("log")
    bx.set_xlabel("time [min]")
    bx.set_ylabel(bound_label)
    bx.grid(True, alpha=0.3)
    bx.legend(fontsize=7, loc="best", framealpha=0.6)
    bx.set_title("each contact's range bound: joint plan (solid), own plans (dashed/dotted)",
                 fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    return save_figure(fig, path)


def schedule_figure(res: Any, times: np.ndarray, path: str | Path, *, title: str = "",
                    ) -> Path:
    """Shared pings: each contact's range bound [m] over time with the schedule (solid, its
    colour), the steps where a ping reaches it (dots on the curve) and the ping times
    (vertical lines).

    Parameters
    ----------
    res : tmaplan.planning.ping_contacts.ContactsPingSchedule
    times : ndarray, shape (K+1,)
        The track's times [s] (the scenario clock).
    path : path
        PNG file.
    title : str
        Axes title.
    """
    fig, axes = new_figure(1, 1, size=(8.0, 5.0))
    ax = axes[0, 0]
    t = np.asarray(times, float) / 60.0
    for i, n in enumerate(res.names):
        b = np.asarray(res.bounds[n], float)
        ax.plot(t, b, color=contact_colour(i), lw=1.8,
                label=f"{n}: {res.objectives[n]:.4g} m (no pings {res.no_ping_objectives[n]:.4g}"
                      f" m; {res.pings_in_reach[n]} ping(s) in reach)")
        hit = np.intersect1d(np.asarray(res.schedule.steps, int), np.flatnonzero(res.reach[n]))
        ax.plot(t[hit], b[hit], "o", color=contact_colour(i), ms=5)
    for tp in res.schedule.times:
        ax.axvline(tp / 60.0, color="k", lw=0.8, alpha=0.5)
    ax.set_yscale("log")
    ax.set_xlabel("time [min] (lines: ping times; dots: a ping that reaches the contact)")
    ax.set_ylabel("closed-form PCRB range bound per step [m]")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best", framealpha=0.6)
    if title:
        ax.set_title(title, fontsize=10)
    return save_figure(fig, path)
