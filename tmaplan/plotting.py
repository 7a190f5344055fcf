"""Figures (matplotlib object API, no global pyplot state; PNG output)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tmaplan.display import objective_label
from tmaplan.geometry import bearing_of
from tmaplan.planning import PingEvaluator
from tmaplan.simulate import Simulation

__all__ = ["new_figure", "plot_bearings", "plot_geometry", "plot_plan", "plot_schedule",
           "save_figure"]


def new_figure(nrows: int = 1, ncols: int = 1, *, size: tuple[float, float] = (7.0, 5.5),
               **kw: Any) -> tuple[Figure, np.ndarray]:
    """A figure with an Agg canvas and a 2-D array of axes."""
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_2d(fig.subplots(nrows, ncols, squeeze=False, **kw))
    return fig, axes


def save_figure(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    """Write a figure as PNG, creating the directory."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def plot_geometry(sim: Simulation, path: str | Path | None = None, *, n_lines: int = 25,
                  unit: float = 1000.0) -> Figure:
    """Tracks of target and observer with bearing lines, in km (x East, y North).

    Parameters
    ----------
    sim : Simulation
    path : str or Path, optional
        Write the figure there as PNG.
    n_lines : int
        Number of bearing lines drawn (evenly spaced over the measurements).
    unit : float
        Metres per plot unit (1000: km).
    """
    fig, axes = new_figure()
    ax = axes[0, 0]
    tgt = sim.target[:, :2] / unit
    obs = sim.observer.position / unit
    ax.plot(tgt[:, 0], tgt[:, 1], "-", color="C3", lw=1.6, label="target")
    ax.plot(obs[:, 0], obs[:, 1], "--", color="C0", lw=1.6, label="observer")
    ax.plot(tgt[0, 0], tgt[0, 1], "o", color="C3", ms=5)
    ax.plot(obs[0, 0], obs[0, 1], "o", color="C0", ms=5)
    rng_max = np.max(np.hypot(*(sim.relative[:, :2].T))) / unit
    for m in sim.measurements:
        if m.kind != "bearing" or len(m.steps) == 0:
            continue
        idx = np.unique(np.linspace(0, len(m.steps) - 1, min(n_lines, len(m.steps))).astype(int))
        for i in idx:
            k = m.steps[i]
            b = m.values[i]
            p0 = obs[k]
            length = np.hypot(*(sim.relative[k, :2])) / unit * 1.15
            if m.relative is not None and getattr(sim.scenario.sensors[m.sensor], "ambiguity",
                                                  "none") == "pi":
                length = rng_max  # both directions are possible: draw the full line
                ax.plot([p0[0] - length * np.sin(b), p0[0] + length * np.sin(b)],
                        [p0[1] - length * np.cos(b), p0[1] + length * np.cos(b)],
                        color="0.6", lw=0.5, alpha=0.6)
            else:
                ax.plot([p0[0], p0[0] + length * np.sin(b)],
                        [p0[1], p0[1] + length * np.cos(b)], color="0.6", lw=0.5, alpha=0.6)
        break
    ax.set_aspect("equal", adjustable="box")
    lab = "km" if unit == 1000.0 else f"{unit:g} m"
    ax.set_xlabel(f"East [{lab}]")
    ax.set_ylabel(f"North [{lab}]")
    ax.set_title(f"{sim.scenario.name}: geometry and bearings")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", framealpha=0.6)
    lo = np.minimum(tgt.min(0), obs.min(0))
    hi = np.maximum(tgt.max(0), obs.max(0))
    pad = 0.1 * (hi - lo).max() + 1e-9
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_bearings(sim: Simulation, path: str | Path) -> Path | None:
    """What an operator watches: the bearings (measured dots, true line) [°] and the true
    bearing rate [°/min] against time [min]; None when the run has no bearing sensor.

    Parameters
    ----------
    sim : Simulation
    path : str or Path
        PNG.
    """

    meas = [m for m in sim.measurements if m.kind == "bearing" and m.steps.size]
    if not meas:
        return None
    fig, ax = new_figure(2, 1, size=(7.0, 5.0), sharex=True)
    t = sim.times / 60.0
    beta = np.unwrap(np.asarray(bearing_of(sim.relative), float))
    shift = 360.0 * np.floor(np.degrees(beta.min()) / 360.0)
    ax[0, 0].plot(t, np.degrees(beta) - shift, "k-", lw=1, label="true")
    for m in meas:
        z = np.degrees(np.asarray(m.values, float)) - shift
        ref = np.degrees(beta[m.steps]) - shift
        z = z + 360.0 * np.round((ref - z) / 360.0)  # on the true curve's branch
        ax[0, 0].plot(m.times / 60.0, z, ".", ms=3, label=f"measured (sensors[{m.sensor}])")
    ax[0, 0].set_ylabel("bearing [°]")
    ax[0, 0].legend(loc="best", fontsize=8)
    rel = sim.relative
    rate = (rel[:, 1] * rel[:, 2] - rel[:, 0] * rel[:, 3]) / np.sum(rel[:, :2] ** 2, axis=1)
    ax[1, 0].plot(t, np.degrees(rate) * 60.0, "k-", lw=1)
    ax[1, 0].axhline(0.0, color="0.6", lw=0.8)
    ax[1, 0].set_ylabel("bearing rate [°/min]")
    ax[1, 0].set_xlabel("time [min]")
    for a in ax[:, 0]:
        a.grid(True, alpha=0.3)
    ax[0, 0].set_title(f"{sim.scenario.name}: bearing and bearing rate")
    return save_figure(fig, path)


def plot_plan(plan: Any, base: dict[str, Any], belief: Any, path: str | Path, *,
              objective: str | None = None) -> Figure:
    """Planned track over the prior cloud with the best baselines, and the functional that was
    optimised for the plan and every baseline.

    The right panel shows, for the plan and each baseline family, the value of the objective
    the planner minimised (``plan.objective``, ``Baseline.objective``: the same functional
    evaluated by :class:`tmaplan.planning.ObjectiveEvaluator`): a bar for the plan and for the
    best of each family, a dot for every candidate of the family's grid. Its title names the
    functional with its units (:func:`objective_label`).

    Parameters
    ----------
    plan : tmaplan.planning.HeadingPlan
    base : dict
        :func:`tmaplan.planning.baselines.evaluate_baselines` output on the planner's
        objective (name -> list of Baseline, best first).
    belief : tmaplan.planning.Belief
    path : path
        PNG file.
    objective : str, optional
        Name of the optimised objective (``HeadingPlanner.objective.name``); default
        "objective".
    """
    label = objective_label(objective or "objective")
    fig, axes = new_figure(1, 2, size=(13.0, 5.5))
    ax, bx = axes[0, 0], axes[0, 1]
    p0 = plan.observer.position[0]
    if belief.samples is not None:
        cloud = p0 + belief.samples[:2000, :2]
        ax.plot(cloud[:, 0] / 1e3, cloud[:, 1] / 1e3, ".", ms=1, color="0.7",
                label="prior (target at t0)")
    names = ["plan", *base]
    best = [float(plan.objective)] + [float(lst[0].objective) for lst in base.values()]
    for i, (name, lst) in enumerate(base.items()):
        b = lst[0]
        ax.plot(b.track.position[:, 0] / 1e3, b.track.position[:, 1] / 1e3, "--",
                color=f"C{i + 1}", lw=1, label=f"best {name}")
        vals = [float(c.objective) for c in lst]
        bx.plot(vals, np.full(len(vals), i + 1.0), "o", ms=3, color=f"C{i + 1}", alpha=0.5,
                label=f"every {name} of the grid" if len(vals) > 1 else None)
    ax.plot(plan.observer.position[:, 0] / 1e3, plan.observer.position[:, 1] / 1e3, "-",
            color="C0", lw=2, label="plan")
    ax.set_xlabel("East [km]")
    ax.set_ylabel("North [km]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8, loc="best", framealpha=0.6)
    ax.set_title("planned track over the prior")
    y = np.arange(len(names), dtype=float)
    bars = bx.barh(y, best, height=0.5, color=[f"C{i}" for i in range(len(names))], alpha=0.8)
    for rect, v in zip(bars, best):
        bx.annotate(f"{v:.4g}", (rect.get_width(), rect.get_y() + rect.get_height() / 2),
                    xytext=(3, 0), textcoords="offset points", va="center", fontsize=8)
    bx.set_yticks(y, ["plan", *(f"best {n}" for n in base)])
    bx.invert_yaxis()
    bx.set_xlabel(label)
    bx.set_title(f"optimised functional (smaller is better):\n{label}", fontsize=10)
    bx.grid(True, axis="x", alpha=0.3)
    if any(len(lst) > 1 for lst in base.values()):
        bx.legend(fontsize=7, loc="best", framealpha=0.6)
    save_figure(fig, path)
    return fig


def plot_schedule(scenario: Any, obs: Any, belief: Any, res: Any, path: str | Path) -> Figure:
    """Bound over time with the scheduled pings, against no pings and uniform pings, all on
    the functional the schedule optimised (``res.objective_name``, named with its units in
    the title; a mean objective drawn as a horizontal line, a terminal one as a dot).

    Parameters
    ----------
    scenario : Scenario
    obs : ObserverTrack
        The track the schedule was computed along.
    belief : tmaplan.planning.Belief
    res : tmaplan.planning.PingSchedule
    path : path
        PNG file.
    """
    ev = PingEvaluator(scenario, obs, belief, res.objective_name)
    curves = ev.per_step(ev.schedules([[], res.uniform_steps.tolist()]))
    fig, axes = new_figure(1, 1, size=(8.0, 5.0))
    ax = axes[0, 0]
    t = obs.times / 60.0  # the scenario clock, as the console's and the JSON's ping times
    name = res.objective_name
    label = objective_label(name)
    mean = name.startswith("mean-")
    rows = (("no pings", curves[0], res.no_ping_objective, "--", "0.5"),
            ("uniform", curves[1], res.uniform_objective, ":", "C1"),
            (res.method, res.bound, res.objective, "-", "C0"))
    for lab, curve, value, ls, color in rows:
        ax.plot(t, curve, ls, color=color, lw=2 if ls == "-" else 1.2,
                label=f"{lab}: {name} = {value:.4g} m")
        if mean:  # the functional itself: the mean of the curve over the horizon
            ax.axhline(value, color=color, ls=ls, lw=0.8, alpha=0.7)
        else:  # terminal: the value at the last step
            ax.plot(t[-1], value, "o", color=color, ms=6)
    for tp in res.times:
        ax.axvline(tp / 60.0, color="C3", lw=0.8, alpha=0.6)
    ax.set_yscale("log")
    ax.set_xlabel("time [min] (red lines: ping times)")
    what = "position" if "position" in name else "range"
    ax.set_ylabel(f"closed-form PCRB {what} bound per step [m]")
    gap = (f"certified gap {100 * res.gap:.2f} %" if np.isfinite(res.gap)
           else "no certificate")
    ax.set_title(f"{scenario.name}: {res.budget} pings, {res.status} ({gap})\noptimised: "
                 f"{label} ({'mean over the horizon: thin lines' if mean else 'last step: dots'})",
                 fontsize=10)
    ax.legend(fontsize=8, loc="best", framealpha=0.6)
    save_figure(fig, path)
    return fig
