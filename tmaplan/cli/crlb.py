"""``tmaplan crlb P [--frequencies N|all]``: CRLB of the batch estimate (docs/cli.md).

``--frequencies`` defaults to 0 (bearings, and pings if any), as ``tmaplan track``, so that
the bound ``track --estimator mle`` reports is this one; ``--frequencies all`` is the default
of the library's :func:`tmaplan.bounds.crlb.crlb` (every frequency line of the problem).

JSON (SI units): ``parameters`` (final-time parametrisation Z_N: target position at t_N, then
the remaining motion parameters and the tones), ``std`` (CRLB std of each, same order),
``final_range_std`` [m], ``final_range_rsd`` (σ_R/R), plus ``values``, ``units``,
``final_time``, ``final_range``, ``condition_number``, ``frequencies``, ``n_measurements``,
``observability`` (verdict) and ``notes``; ``figure`` when one is written (the truth's
geometry with the CRLB 2σ ellipse of the target position at t_N, ``<out>/crlb_<problem>.png``).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.bounds.crlb import CRLBResult, crlb
from tmaplan.bounds.observability import observability
from tmaplan.cli.args import add_figure_arguments, add_problem_argument, frequency_lines
from tmaplan.cli.contacts import scenario_of
from tmaplan.display import timespan
from tmaplan.scenario import Scenario
from tmaplan.simulate import simulate

HELP = "CRLB of the batch (deterministic-track) estimate"

#: Several contacts: each contact's view in turn (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "per-contact"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("final_range_std",)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``P`` (problem name or .toml path), ``--frequencies N|all``, ``--out``,
    ``--no-figure``."""
    add_problem_argument(parser)
    parser.add_argument("--frequencies", type=frequency_lines, default=0, metavar="N|all",
                        help="also use the first N frequency lines of the scenario, or all "
                             "(default 0: bearings, and pings if any, only, as `tmaplan "
                             "track`; the library's crlb() uses all lines by default)")
    add_figure_arguments(parser)


def _figure(scenario: Scenario, res: CRLBResult, path: Path) -> None:
    """Truth geometry (km) with the 2σ CRLB ellipse of the target position at t_N."""
    import matplotlib  # deferred: matplotlib takes ~0.8 s to import; only when drawing
    from matplotlib.patches import Ellipse  # deferred: as matplotlib

    from tmaplan.plotting import plot_geometry  # deferred: matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: pyplot sets up its backend; only when drawing

    fig = plot_geometry(simulate(scenario, None))
    ax = fig.axes[0]
    w, v = np.linalg.eigh(np.asarray(res.final_covariance, float)[:2, :2])
    angle = float(np.degrees(np.arctan2(v[1, 1], v[0, 1])))
    half = 2.0 * np.sqrt(np.maximum(w, 0.0)) / 1e3
    ax.add_patch(Ellipse(tuple(np.asarray(res.final_position, float) / 1e3), 2 * half[1],
                         2 * half[0], angle=angle, fill=False, color="k", lw=1.4,
                         label=f"CRLB 2σ at t_N = {timespan(res.final_time)}"))
    ax.legend(loc="best", fontsize=8, framealpha=0.6)
    ax.set_title(f"{scenario.name}: batch CRLB, range std {res.final_range_std / 1e3:.3g} km")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _display(name: str, unit: str, value: float) -> tuple[float, str]:
    if unit == "m":
        return value / 1e3, "km"
    if unit == "rad":
        return float(np.degrees(value)), "deg"
    if unit == "rad/s":
        return float(np.degrees(value)), "deg/s"
    return value, unit


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the CRLB, print a table (unless ``--json -``) and return the JSON payload."""
    scenario = scenario_of(args)
    res = crlb(scenario, frequencies=args.frequencies)
    n_tones = sum(1 for p in res.parameters if p.startswith("f0["))
    units = res.units
    try:
        verdict = observability(scenario, frequencies=n_tones).verdict
    except Exception as exc:  # the verdict is informative only; the CRLB succeeded
        verdict = f"observability test not available: {exc}"
    payload = {
        "problem": scenario.name,
        "model": res.model,
        "frequencies": n_tones,
        "parameters": list(res.final_parameters),
        "units": list(units),
        "values": res.final_values,
        "std": res.final_std,
        "final_time": res.final_time,
        "final_range": res.final_range,
        "final_range_std": res.final_range_std,
        "final_range_rsd": res.final_range_rsd,
        "condition_number": res.condition_number,
        "n_measurements": res.n_measurements,
        "observability": verdict,
        "notes": list(res.notes),
    }
    if args.json != "-":
        print(f"{scenario.name}: batch CRLB, model {res.model}, {n_tones} frequency line(s), "
              f"t_N = {timespan(res.final_time)}")
        print(f"{'parameter':<10} {'value':>12} {'std':>12}  unit")
        for name, unit, v, s in zip(res.final_parameters, units, res.final_values,
                                    res.final_std):
            dv, du = _display(name, unit, float(v))
            ds, _ = _display(name, unit, float(s))
            print(f"{name:<10} {dv:>12.4g} {ds:>12.4g}  {du}")
        print(f"final range {res.final_range / 1e3:.3f} km, std {res.final_range_std / 1e3:.3f} "
              f"km, RSD {100 * res.final_range_rsd:.2f} %  (scaled FIM condition "
              f"{res.condition_number:.3g})")
        print(verdict)
        for note in res.notes:
            print(f"note: {note}")
    if not args.no_figure:
        path = Path(args.out) / f"crlb_{scenario.name}.png"
        _figure(scenario, res, path)
        payload["figure"] = str(path)
        if args.json != "-":
            print(f"wrote {path}")
    return payload
