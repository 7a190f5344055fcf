"""Figures (matplotlib object API, no global pyplot state; PNG output)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from tmaplan.simulate import Simulation

__all__ = ["new_figure", "plot_geometry", "save_figure"]


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
