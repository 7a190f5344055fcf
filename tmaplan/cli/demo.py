"""``tmaplan demo``: the main job on the built-in ``default`` problem.

Placeholder until the planning and comparison verbs exist (issue 7): it simulates ``default``
and writes its geometry figure and a minimal HTML report to ``--out``.
"""

from __future__ import annotations

import argparse
import base64
import html
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.plotting import plot_geometry
from tmaplan.scenario import dump, load_problem
from tmaplan.simulate import simulate

HELP = "run the main job on the built-in 'default' problem and write figures and a report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``demo``."""
    parser.add_argument("--out", default="out", help="output directory (default out/)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Simulate ``default``, write ``geometry.png`` and ``report.html``."""
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scenario = load_problem("default")
    sim = simulate(scenario, np.random.default_rng(args.seed))
    fig_path = out / "geometry.png"
    plot_geometry(sim, fig_path)
    img = base64.b64encode(fig_path.read_bytes()).decode("ascii")
    report = out / "report.html"
    report.write_text(
        "<!doctype html><html><head><meta charset='utf-8'><title>tmaplan demo</title></head>"
        "<body><h1>tmaplan demo: problem <code>default</code></h1>"
        "<p>Placeholder demo: one simulated run of the built-in planning case. Planning, "
        "ping scheduling and the policy comparison are added by later releases.</p>"
        f"<img alt='geometry' src='data:image/png;base64,{img}'>"
        f"<h2>Scenario</h2><pre>{html.escape(dump(scenario))}</pre>"
        f"<p>Reproduce: <code>tmaplan demo --seed {args.seed} --out {html.escape(str(out))}"
        "</code></p></body></html>",
        encoding="utf-8",
    )
    if args.json != "-":
        print(f"wrote {fig_path} and {report}")
    return {"figures": [str(fig_path)], "report": str(report), "seed": args.seed}
