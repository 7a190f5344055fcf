"""``tmaplan bound``: posterior CRB over time (Monte Carlo, or closed form in LPC).

The default is the Monte Carlo Cartesian PCRB **conditioned on the problem's true track**
(``--method monte-carlo --over truth``, :func:`tmaplan.bounds.truth_bound.
truth_conditioned_pcrb`): the PCRB along realisations of the true target track with the
prior's covariance as ``P_0``, the bound the Ristic benchmark prescribes (ristic2004, ch. 6)
and the one a filter run on that truth can approach (``tmaplan track`` compares with it). It
responds to the sensor as a bound should (``default``: 3.6 km at a bearing σ of 1°, 4.7 km at
90°) and costs 0.1–4 s on the built-in problems (docs/findings.md). ``--over prior`` is the
Bayesian PCRB averaged over the prior (brehard2005; :func:`tmaplan.bounds.pcrb.
monte_carlo_pcrb`): it averages the *information* over geometries drawn from the prior and is
far more optimistic while the geometry is weakly observable (``ristic-bot-moderate`` at 960 s:
≈ 40 m against ≈ 840 m conditioned on the truth). ``--method closed-form`` is the closed-form
PCRB in log-polar coordinates (brehard2005 §4, corrected), milliseconds, prior-averaged by
construction like every LPC bound (``--over prior`` only): its ln r information comes mostly
from the coordinate change and the prior, not from the bearings, so its range bound barely
responds to the sensor (``default``: 474 m at σ = 1°, 475 m at 90°); the console says so in a
``caveat:`` line. The console's first line, the JSON's ``bound`` (with ``method``,
``coords``, ``over``) and the figure's title name the bound computed.
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.bounds.closed_form import closed_form_pcrb
from tmaplan.bounds.inputs import range_reach_terms
from tmaplan.bounds.pcrb import monte_carlo_pcrb
from tmaplan.bounds.truth_bound import truth_conditioned_pcrb
from tmaplan.cli.args import (
    MAX_SAMPLES,
    add_figure_arguments,
    add_problem_argument,
    add_seed_argument,
    duration,
    integer,
    step_list,
)
from tmaplan.cli.contacts import scenario_of
from tmaplan.display import timespan
from tmaplan.errors import ArgumentError, ScenarioError
from tmaplan.geometry import range_of
from tmaplan.scenario import RangeSensor, Scenario, measurement_steps
from tmaplan.simulate import simulate

HELP = ("posterior Cramér-Rao bound over time (default: Monte Carlo, conditioned on the "
        "true track; or the closed form in LPC)")

#: Several contacts: each contact's view in turn (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "per-contact"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("range_std[-1]", "position_std[-1]")

_LPC_LABELS = ("β [rad]", "ln r [-]", "β̇ [rad/s]", "ṙ/r [1/s]")
_CART_LABELS = ("r_x [m]", "r_y [m]", "v_x [m/s]", "v_y [m/s]")
# console: (name, display unit, factor from SI) per component
_LPC_CONSOLE = (("β", "°", np.degrees(1.0)), ("ln r", "", 1.0), ("β̇", "°/s", np.degrees(1.0)),
                ("ṙ/r", "1/s", 1.0))
_CART_CONSOLE = (("r_x", "m", 1.0), ("r_y", "m", 1.0), ("v_x", "m/s", 1.0),
                 ("v_y", "m/s", 1.0))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``tmaplan bound``."""
    add_problem_argument(parser)
    parser.add_argument("--method", choices=("closed-form", "monte-carlo"),
                        default="monte-carlo",
                        help="default monte-carlo: with the default --coords cartesian and "
                             "--over truth, the bound a filter on the problem's true track can "
                             "approach (ristic2004 ch. 6; 0.1-4 s on the built-in problems); "
                             "closed-form: brehard2005's closed form in LPC (milliseconds; its "
                             "range bound barely responds to the bearing noise, "
                             "docs/findings.md)")
    parser.add_argument("--coords", choices=("lpc", "cartesian"), default=None,
                        help="coordinates (closed form: lpc only; default lpc for the closed "
                             "form, cartesian for Monte Carlo)")
    parser.add_argument("--over", choices=("truth", "prior"), default=None,
                        help="Monte Carlo, Cartesian: condition the PCRB on the problem's "
                             "true track (default; ristic2004 ch. 6, the bound a filter can "
                             "approach) or average it over the prior (brehard2005); the closed "
                             "form and LPC are prior-averaged only")
    parser.add_argument("--samples", type=integer(2, MAX_SAMPLES), default=None,
                        help="Monte Carlo samples (default 1000, as brehard2005 §6; with "
                             "--over truth: realisations of the true track's process noise; "
                             "with --method closed-form only for the overlaid Monte Carlo "
                             "bound of the figure)")
    pings = parser.add_mutually_exclusive_group()
    pings.add_argument("--ping-every", type=duration(), metavar="T",
                       help="a range ping at the first step at or after each multiple of T "
                            "(seconds or with a unit: '80 s')")
    pings.add_argument("--ping-steps", type=step_list, metavar="K,K,..",
                       help="range pings at these steps, each once")
    add_seed_argument(parser, help="Monte Carlo seed (default 0)")
    add_figure_arguments(parser)
    parser.add_argument("--no-overlay", action="store_true",
                        help="do not overlay the other method on the LPC figure (Cartesian: "
                             "the other --over)")


def ping_steps_from_args(scenario: Scenario, every: float | None,
                         steps: str | list[int] | None) -> list[int] | None:
    """Ping steps from ``--ping-every`` / ``--ping-steps`` (None: the scenario's own)."""
    if every is None and steps is None:
        return None
    ranges = [s for s in scenario.sensors if isinstance(s, RangeSensor)]
    if not ranges:
        raise ScenarioError("sensors", "a range sensor (kind = 'range') to ping with",
                            "no range sensor", source=scenario.name)
    if every is not None:
        if not every > 0:
            raise ArgumentError("--ping-every", "> 0 s", every)
        sensor = dataclasses.replace(ranges[0], steps=(), period=float(every), every=None)
        return measurement_steps(sensor, scenario.time).tolist()
    if isinstance(steps, list):
        return [int(x) for x in steps]
    try:
        return [int(x) for x in str(steps).split(",") if x.strip()]
    except ValueError as exc:
        raise ArgumentError("--ping-steps", "comma-separated integers", steps) from exc


def resolve_over(method: str, coords: str, over: str | None) -> str:
    """``--over`` for a method and coordinates: default ``truth`` for the Monte Carlo Cartesian
    bound, ``prior`` otherwise; ``truth`` where only the prior average exists is an error."""
    if over is None:
        return "truth" if method == "monte-carlo" and coords == "cartesian" else "prior"
    if over == "truth" and (method != "monte-carlo" or coords != "cartesian"):
        raise ArgumentError("--over", "'prior' with --method closed-form or --coords lpc (the "
                            "truth-conditioned PCRB, ristic2004 ch. 6, is the Monte Carlo "
                            "Cartesian one)", over)
    return over


_COORDS_TEXT = {"lpc": "log-polar coordinates (LPC)", "cartesian": "Cartesian coordinates"}


def bound_label(method: str, coords: str, over: str, samples: int = 0) -> str:
    """What a bound is, in words: method, coordinates, what it is averaged over, source.

    Parameters
    ----------
    method : {"closed-form", "monte-carlo"}
    coords : {"lpc", "cartesian"}
    over : {"truth", "prior"}
    samples : int
        Monte Carlo samples (0: not said).

    Returns
    -------
    str
        E.g. ``"Monte Carlo PCRB in Cartesian coordinates, conditioned on the true track
        (ristic2004 ch. 6; 1000 samples)"``.
    """
    if method == "closed-form":
        what, source = "closed-form PCRB", "brehard2005 §4, corrected"
    else:
        what = "Monte Carlo PCRB"
        source = "ristic2004 ch. 6" if over == "truth" else "brehard2005"
    given = ("conditioned on the true track" if over == "truth"
             else "averaged over the prior")
    n = f"; {samples} samples" if method == "monte-carlo" and samples else ""
    return f"{what} in {_COORDS_TEXT[coords]}, {given} ({source}{n})"


def bound_caveat(coords: str, over: str) -> str | None:
    """One line on what a bound that is not the default does not tell (None for the default,
    the Monte Carlo Cartesian bound conditioned on the true track).

    LPC bounds (closed form, or Monte Carlo in LPC, which agrees with it within 3 %): the
    ln r information comes mostly from the coordinate change and the prior (brehard2005
    eq. 43's constant), so the range bound barely responds to the bearing noise
    (docs/findings.md); Cartesian over the prior: the information averaged over very different
    geometries is far more optimistic than the bound for the problem's own track.
    """
    if coords == "lpc":
        return ("its ln r information comes mostly from the coordinate change and the prior "
                "(brehard2005 eq. 43), hardly from the bearings: the range bound barely "
                "responds to the bearing noise and can lie far below what a filter reaches "
                "(docs/findings.md); the bound a filter can approach is --method monte-carlo "
                "--over truth (the default)")
    if over == "prior":
        return ("averaged over geometries drawn from the prior, it is far more optimistic "
                "than the bound for the problem's true track while the geometry is weakly "
                "observable; the bound a filter can approach is --over truth (the default)")
    return None


def _compute(scenario: Scenario, method: str, coords: str, samples: int, seed: int,
             pings: list[int] | None, over: str = "prior") -> Any:
    if method == "closed-form":
        if coords != "lpc":
            raise ArgumentError("--coords", "lpc for the closed form (docs/cli.md)", coords)
        return closed_form_pcrb(scenario, ping_steps=pings)
    if over == "truth":
        return truth_conditioned_pcrb(scenario, samples=samples,
                                      rng=np.random.default_rng(seed), ping_steps=pings)
    return monte_carlo_pcrb(scenario, samples=samples, rng=np.random.default_rng(seed),
                            coords=coords, ping_steps=pings)  # type: ignore[arg-type]


def _pings_in_reach_text(scenario: Scenario, pings: list[int] | None,
                        ping_steps: np.ndarray) -> str:
    """`` (M within max_range on the true track)`` for the console's ping count when a range
    sensor has a ``max_range`` (the truth-conditioned bound counts a ping only where the true
    range is within it, :func:`tmaplan.bounds.truth_bound.truth_conditioned_pcrb`); "" without
    a reach. The noise-free true track: the realisations of its process noise may differ."""
    terms = range_reach_terms(scenario, pings)
    if not terms or not len(ping_steps):
        return ""
    r = range_of(simulate(scenario, None).relative)
    out = {int(k) for R, w in terms for k in ping_steps if w[k] > 0 and r[k] > R}
    return f" ({len(ping_steps) - len(out)} within max_range on the true track)"


def _figure(results: list[Any], path: Path, title: str) -> None:
    import matplotlib  # deferred: matplotlib takes ~0.3 s to import; only when drawing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: pyplot sets up its backend; only when drawing

    coords = results[0].coords
    labels = _LPC_LABELS if coords == "lpc" else _CART_LABELS
    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex=True)
    styles = {("closed-form", "prior"): dict(ls="--", color="C0"),
              ("monte-carlo", "prior"): dict(ls="-", color="C1"),
              ("monte-carlo", "truth"): dict(ls="-", color="C3")}
    for res in results:
        st = styles[(res.method, res.over)]
        lab = (f"{res.method}, over the {res.over}" if res.coords == "cartesian"
               else res.method)
        for i in range(4):
            ax = axes.flat[i]
            ax.semilogy(res.times, res.std[:, i], label=lab, **st)
            ax.set_ylabel(f"std {labels[i]}")
        axes.flat[4].plot(res.times, res.range_std, label=lab, **st)
        axes.flat[5].plot(res.times, res.position_std, label=lab, **st)
    axes.flat[4].set_ylabel("range bound [m]")
    axes.flat[5].set_ylabel("position bound [m]")
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    axes.flat[0].legend(loc="best", framealpha=0.6)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _samples(samples: int | None, method: str, overlay: bool) -> int:
    """``--samples`` (default 1000); refused where no Monte Carlo bound is computed (the
    closed form without the figure's overlay), which would silently ignore it."""
    if samples is None:
        return 1000
    if method == "closed-form" and not overlay:
        raise ArgumentError("--samples", "no --samples with --method closed-form unless its "
                            "figure overlays the Monte Carlo bound (no --no-figure or "
                            "--no-overlay); the closed form draws no samples", samples)
    if samples < 2:
        raise ArgumentError("--samples", ">= 2", samples)
    return int(samples)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Compute the bound, write the figure, return the docs/cli.md JSON fields."""
    scenario = scenario_of(args)
    coords = args.coords or ("lpc" if args.method == "closed-form" else "cartesian")
    overlay = not args.no_figure and not args.no_overlay
    samples = _samples(args.samples, args.method, overlay)
    over = resolve_over(args.method, coords, getattr(args, "over", None))
    pings = ping_steps_from_args(scenario, args.ping_every, args.ping_steps)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = _compute(scenario, args.method, coords, samples, args.seed, pings, over)
        results = [res]
        if overlay and coords == "lpc":
            other = "monte-carlo" if args.method == "closed-form" else "closed-form"
            results.append(_compute(scenario, other, coords, samples, args.seed, pings))
        elif overlay:  # Cartesian: the other average
            results.append(_compute(scenario, args.method, coords, samples, args.seed,
                                    pings, "prior" if over == "truth" else "truth"))
    quiet = args.json == "-"
    notes = sorted({str(w.message) for w in caught})
    payload = res.to_json()
    payload["warnings"] = notes
    payload["problem"] = scenario.name
    label = bound_label(args.method, coords, over, res.samples)
    caveat = bound_caveat(coords, over)
    payload["bound"] = label
    payload["caveat"] = caveat
    if not args.no_figure:
        suffix = "_truth" if over == "truth" else ""
        fig_path = Path(args.out) / f"bound_{scenario.name}_{args.method}_{coords}{suffix}.png"
        _figure(results, fig_path, f"{scenario.name}: {label}")
        payload["figure"] = str(fig_path)
    if not quiet:
        k = len(res.times) - 1
        reach = _pings_in_reach_text(scenario, pings, res.ping_steps) if over == "truth" else ""
        print(f"{scenario.name}: {label}, {k} steps over "
              f"{timespan(res.times[-1] - res.times[0])}, {len(res.ping_steps)} pings{reach}, "
              f"computed in {res.seconds:.3f} s")
        if caveat is not None:
            print(f"  caveat: {caveat}")
        comps = _LPC_CONSOLE if coords == "lpc" else _CART_CONSOLE
        print("  final std: " + ", ".join(
            f"{name} {v * f:.4g}{'' if unit in ('', '°') else ' '}{unit}"
            for (name, unit, f), v in zip(comps, res.std[-1])))
        print(f"  final range bound {res.range_std[-1]:.1f} m, "
              f"position bound {res.position_std[-1]:.1f} m")
        for n in notes:
            print(f"  warning: {n}")
        if "figure" in payload:
            print(f"  figure: {payload['figure']}")
    return payload
