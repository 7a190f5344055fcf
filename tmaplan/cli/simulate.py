"""``tmaplan simulate P --seed S [--out DIR] [--json PATH]``: one truth + measurement run."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.plotting import plot_geometry
from tmaplan.scenario import load
from tmaplan.simulate import simulate

HELP = "simulate one truth and measurement run of a problem and plot its geometry"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``simulate``."""
    parser.add_argument("problem", help="built-in problem name or path to a .toml file")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument("--out", default="out", help="directory for the figure (default out/)")
    parser.add_argument("--no-plot", action="store_true", help="do not write the figure")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Simulate, write ``<out>/<problem>_geometry.png`` and return the JSON payload."""
    scenario = load(args.problem)
    sim = simulate(scenario, np.random.default_rng(args.seed))
    payload = sim.to_json()
    payload["seed"] = args.seed
    if not args.no_plot:
        path = Path(args.out) / f"{scenario.name}_geometry.png"
        plot_geometry(sim, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
