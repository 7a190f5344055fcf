"""``tmaplan simulate P --seed S [--out DIR] [--json PATH]``: one truth + measurement run."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli._args import add_figure_arguments, add_problem_argument, add_seed_argument
from tmaplan.display import timespan
from tmaplan.plotting import plot_geometry
from tmaplan.scenario import load
from tmaplan.simulate import simulate

HELP = "simulate one truth and measurement run of a problem and plot its geometry"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``simulate``."""
    add_problem_argument(parser)
    add_seed_argument(parser)
    add_figure_arguments(parser)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Simulate, write ``<out>/<problem>_geometry.png`` and return the JSON payload."""
    scenario = load(args.problem)
    sim = simulate(scenario, np.random.default_rng(args.seed))
    payload = sim.to_json()
    payload["seed"] = args.seed
    if args.json != "-":
        counts = ", ".join(f"{m.steps.size} {m.kind} (sensors[{m.sensor}])"
                           for m in sim.measurements)
        r = np.hypot(sim.relative[:, 0], sim.relative[:, 1])
        print(f"{scenario.name}: seed {args.seed}, {scenario.n_steps} steps of "
              f"{scenario.time.dt:g} s over {timespan(scenario.time.horizon)}; range "
              f"{r[0] / 1e3:.2f} km -> {r[-1] / 1e3:.2f} km (min {r.min() / 1e3:.2f} km); "
              f"measurements: {counts or 'none'}")
    if not args.no_figure:
        path = Path(args.out) / f"{scenario.name}_geometry.png"
        plot_geometry(sim, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
