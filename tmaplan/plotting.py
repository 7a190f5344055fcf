"""Figures (matplotlib object API, no global pyplot state; PNG output)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from tmaplan.simulate import Simulation

__all__ = ["new_figure", "plot_geometry", "plot_plan", "plot_schedule", "save_figure"]


def new_figure(nrows: int = 1, ncols: int = 1, *, size: tuple[float, float] = (7.0, 5.5),
               **kw: object) -> tuple[Figure, np.ndarray]:
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
            if m.relative is not None and sim.scenario.sensors[m.sensor].ambiguity == "pi":
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
    ax.legend(loc="best")
    lo = np.minimum(tgt.min(0), obs.min(0))
    hi = np.maximum(tgt.max(0), obs.max(0))
    pad = 0.1 * (hi - lo).max() + 1e-9
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    if path is not None:
        save_figure(fig, path)
    return fig


def plot_plan(plan: Any, base: dict[str, Any], belief: Any, path: str | Path) -> Figure:
    """Planned track over the prior cloud with the best baselines, and the closed-form range
    bound over time (plan vs baselines).

    Parameters
    ----------
    plan : tmaplan.planning.HeadingPlan
    base : dict
        :func:`tmaplan.planning.baselines.evaluate_baselines` output.
    belief : tmaplan.planning.Belief
    path : path
        PNG file.
    """
    fig, axes = new_figure(1, 2, size=(12.0, 5.5))
    ax, bx = axes[0, 0], axes[0, 1]
    p0 = plan.observer.position[0]
    if belief.samples is not None:
        cloud = p0 + belief.samples[:2000, :2]
        ax.plot(cloud[:, 0] / 1e3, cloud[:, 1] / 1e3, ".", ms=1, color="0.7",
                label="prior (target at t0)")
    t_h = (plan.observer.times - plan.observer.times[0]) / 60.0
    for i, (name, lst) in enumerate(base.items()):
        b = lst[0]
        ax.plot(b.track.position[:, 0] / 1e3, b.track.position[:, 1] / 1e3, "--",
                color=f"C{i + 1}", lw=1, label=f"best {name}")
        bx.plot(t_h, b.range_bound, "--", color=f"C{i + 1}", label=f"best {name}")
    ax.plot(plan.observer.position[:, 0] / 1e3, plan.observer.position[:, 1] / 1e3, "-",
            color="C0", lw=2, label="plan")
    ax.set_xlabel("East [km]")
    ax.set_ylabel("North [km]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.legend(fontsize=8)
    ax.set_title("planned track over the prior")
    bx.plot(t_h, plan.range_bound, "-", color="C0", lw=2, label="plan")
    bx.set_yscale("log")
    bx.set_xlabel("time [min]")
    bx.set_ylabel("closed-form PCRB range bound [m]")
    bx.legend(fontsize=8)
    bx.set_title("range bound over time")
    save_figure(fig, path)
    return fig


def plot_schedule(scenario: Any, obs: Any, belief: Any, res: Any, path: str | Path) -> Figure:
    """Bound over time with the scheduled pings, against no pings and uniform pings.

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
    from tmaplan.planning import PingEvaluator

    ev = PingEvaluator(scenario, obs, belief, res.objective_name)
    curves = ev.per_step(ev.schedules([[], res.uniform_steps.tolist()]))
    fig, axes = new_figure(1, 1, size=(8.0, 5.0))
    ax = axes[0, 0]
    t = (obs.times - obs.times[0]) / 60.0
    ax.plot(t, curves[0], "--", color="0.5", label=f"no pings ({res.no_ping_objective:.3g} m)")
    ax.plot(t, curves[1], ":", color="C1", label=f"uniform ({res.uniform_objective:.3g} m)")
    ax.plot(t, res.bound, "-", color="C0", lw=2,
            label=f"{res.method} ({res.objective:.3g} m)")
    for tp in res.times:
        ax.axvline((tp - obs.times[0]) / 60.0, color="C3", lw=0.8, alpha=0.6)
    ax.set_yscale("log")
    ax.set_xlabel("time [min] (red lines: ping times)")
    ax.set_ylabel("position bound [m]" if "position" in res.objective_name
                  else "range bound [m]")
    gap = (f"certified gap {100 * res.gap:.2f} %" if np.isfinite(res.gap)
           else "no certificate")
    ax.set_title(f"{scenario.name}: {res.budget} pings, {res.objective_name}, "
                 f"{res.status} ({gap})")
    ax.legend(fontsize=8)
    save_figure(fig, path)
    return fig
