"""``tmaplan track P --estimator pf|pf-bearings|mle|range-only``: Monte Carlo of an estimator
against its bound (PCRB for the filters, CRLB for the MLE), with a figure of RMSE over time."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli.args import (
    MAX_PARTICLES,
    MAX_RUNS,
    add_figure_arguments,
    add_problem_argument,
    add_seed_argument,
    frequency_lines,
    integer,
)
from tmaplan.cli.contacts import scenario_of
from tmaplan.cli.finite import require_finite
from tmaplan.cli.observer_plan import with_observer_plan
from tmaplan.errors import ArgumentError
from tmaplan.estimators.mle import MLEConfig
from tmaplan.estimators.particle_filter import PFConfig
from tmaplan.estimators.range_only import RangeOnlyConfig
from tmaplan.estimators.runner import ESTIMATORS
from tmaplan.evaluation.tracking import monte_carlo
from tmaplan.scenario import Scenario

HELP = "run an estimator over Monte Carlo runs against its bound"

#: Several contacts: each contact's view in turn (:mod:`tmaplan.cli.contacts`).
SEVERAL_CONTACTS = "per-contact"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("rmse_position[-1]", "rmse_range[-1]", "bound_position[-1]", "bound_range[-1]")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``tmaplan track``."""
    add_problem_argument(parser)
    parser.add_argument("--estimator", choices=ESTIMATORS, default="pf",
                        help="pf (prior; default), pf-bearings (brehard2004 init), mle, range-only")
    parser.add_argument("--particles", type=integer(2, MAX_PARTICLES), default=None,
                        help="particles (pf, pf-bearings; default 10000)")
    parser.add_argument("--runs", type=integer(1, MAX_RUNS), default=20,
                        help="Monte Carlo runs (default 20)")
    add_seed_argument(parser, help="root SeedSequence seed (default 0)")
    parser.add_argument("--bound", choices=("truth", "prior"), default="truth",
                        help="filters: PCRB along the runs' truths (B2, default) or "
                             "averaged over prior draws")
    parser.add_argument("--pf-variant", choices=("regularised", "bootstrap", "resample-move"),
                        default=None,
                        help="pf: regularised (default), bootstrap, or resample-move (exact "
                             "MH moves; better on ring-shaped range-only posteriors)")
    parser.add_argument("--range-only-mode", choices=("mixture", "moments", "dirac"),
                        default=None,
                        help="range-only: Gaussian mixture over azimuth sectors (default), or "
                             "sharma2024's single-Gaussian moment / Dirac-mixture recursion")
    parser.add_argument("--frequencies", type=frequency_lines, default=0, metavar="N|all",
                        help="also use the first N frequency lines of the scenario, or all "
                             "(default 0: bearings, and pings if any, only; as `tmaplan crlb`)")
    parser.add_argument("--turn-direction", default="auto",
                        choices=("auto", "either", "clockwise", "anticlockwise"),
                        help="mle, constant-turn source: sense of turn searched (default auto: "
                             "the problem's [estimation] section, else either)")
    parser.add_argument("--observer-plan", default=None, metavar="FILE",
                        help="fly this plan: a `tmaplan plan P --json` file or a legs CSV "
                             "(docs/recordings.md)")
    add_figure_arguments(parser)


def _with_lines(scenario: Scenario, n: int | None) -> Scenario:
    """The scenario with only the first ``n`` lines of its frequency sensors (0: none; None:
    all)."""
    available = max((len(s.f0) for s in scenario.sensors_of("frequency")), default=0)
    if n is None:
        return scenario
    if n < 0 or n > available:
        raise ArgumentError("--frequencies", f"0..{available} (lines of {scenario.name})", n)
    if n == available:
        return scenario
    sensors = tuple(s if s.kind != "frequency" else
                    dataclasses.replace(s, f0=s.f0[:n], sigma=s.sigma[:n])
                    for s in scenario.sensors if s.kind != "frequency" or n > 0)
    return scenario.replace(sensors=sensors)


def _figure(res: Any, path: Path) -> None:
    import matplotlib  # deferred: matplotlib takes ~0.3 s to import; only when drawing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: pyplot sets up its backend; only when drawing

    fig, ax = plt.subplots(figsize=(7, 4))
    t = res.times / 60.0
    ax.semilogy(t, res.rmse_position, label=f"{res.estimator} RMSE ({res.runs} runs)")
    label = {"crlb": "bound (batch CRLB at the truth)",
             "truth": "bound (PCRB along the runs' truths, ristic2004 ch. 6)",
             "prior": "bound (PCRB averaged over the prior)"}.get(res.bound_kind, "bound")
    ax.semilogy(t, res.bound_position, "--", label=label)
    ax.set_xlabel("time [min]")
    ax.set_ylabel("position error [m]")
    with np.errstate(invalid="ignore", divide="ignore"):
        eff = res.rmse_position[-1] / res.bound_position[-1]
    ax.set_title(f"{res.problem}: final RMSE / bound = {eff:.2f}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", framealpha=0.6)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


#: Options that configure one estimator only: flag -> (Namespace name, estimators it applies
#: to). Given with another estimator it would be silently ignored, so it is refused.
_ESTIMATOR_OPTIONS = {"--particles": ("particles", ("pf", "pf-bearings")),
                      "--pf-variant": ("pf_variant", ("pf",)),
                      "--range-only-mode": ("range_only_mode", ("range-only",))}


def _check_estimator_options(args: argparse.Namespace) -> None:
    """Refuse an estimator-specific option given with an estimator it does not configure."""
    for flag, (name, applies) in _ESTIMATOR_OPTIONS.items():
        value = getattr(args, name, None)
        if value is not None and args.estimator not in applies:
            raise ArgumentError(flag, f"only with --estimator {' or '.join(applies)} (it is "
                                      f"ignored by {args.estimator})", value)


def check_arguments(args: argparse.Namespace) -> None:
    """The flags' own rules (no scenario needed): run before any contact's block."""
    if args.runs < 1:
        raise ArgumentError("--runs", ">= 1", args.runs)
    _check_estimator_options(args)
    if getattr(args, "particles", None) is not None and args.particles < 2:
        raise ArgumentError("--particles", ">= 2", args.particles)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Run the Monte Carlo and return the docs/cli.md ``track`` fields."""
    check_arguments(args)
    particles = 10_000 if getattr(args, "particles", None) is None else args.particles
    scenario = _with_lines(scenario_of(args), getattr(args, "frequencies", 0))
    if getattr(args, "observer_plan", None) is not None:
        # a contact's view flies the plan of its problem (`tmaplan plan P`, the own ship's
        # for every contact; the view, "<problem>-<contact>", refused it as another's)
        whole = getattr(args, "problem_scenario", None)
        flown = with_observer_plan(scenario if whole is None else whole, args.observer_plan)
        scenario = scenario.replace(observer=flown.observer)
    quiet = args.json == "-"
    show = not quiet and sys.stderr.isatty()

    def progress(done: int, total: int) -> None:
        if show:
            print(f"\rrun {done}/{total}", end="", file=sys.stderr, flush=True)

    estimator: Any = args.estimator
    mode: Any = getattr(args, "range_only_mode", None) or "mixture"
    if estimator == "range-only" and mode != "mixture":
        estimator = RangeOnlyConfig(dt=scenario.time.dt, q=float(scenario.target.q), mode=mode)
    variant: Any = getattr(args, "pf_variant", None) or "regularised"
    if estimator == "pf" and variant != "regularised":
        estimator = PFConfig(n_particles=particles, dt=scenario.time.dt,
                             q=float(scenario.target.q), variant=variant)
    turn: Any = getattr(args, "turn_direction", "auto")
    if turn != "auto":
        if estimator != "mle":
            raise ArgumentError("--turn-direction", "only with --estimator mle", turn)
        estimator = MLEConfig(turn_direction=turn)
    res = monte_carlo(scenario, estimator, runs=args.runs, seed=args.seed,
                      n_particles=particles, progress=progress,
                      bound=getattr(args, "bound", "truth"))
    if not isinstance(estimator, str):
        res = dataclasses.replace(res, estimator=args.estimator)
    if show:
        print(file=sys.stderr)
    payload = res.to_json()
    if args.estimator == "range-only":
        payload["range_only_mode"] = mode
    if args.estimator == "pf":
        payload["pf_variant"] = variant
    if args.estimator == "mle":
        est = scenario.estimation
        payload["turn_direction"] = (turn if turn != "auto" else
                                     est.turn_direction if est is not None else "either")
    if not args.no_figure:
        suffix = (f"-{mode}" if args.estimator == "range-only" and mode != "mixture"
                  else f"-{variant}" if args.estimator == "pf" and variant != "regularised"
                  else "")
        fig = Path(args.out) / f"track_{scenario.name}_{args.estimator}{suffix}.png"
        _figure(res, fig)
        payload["figure"] = str(fig)
    counts = {s: res.statuses.count(s) for s in dict.fromkeys(res.statuses)}
    n_unobs = counts.get("unobservable", 0)
    limit = (estimator if isinstance(estimator, MLEConfig) else MLEConfig()).max_relative_range_std
    undetermined = f"range not determined: relative range std > {limit:g}"
    require_finite(payload, FINITE, source=scenario.name,
                   why="run statuses: " + ", ".join(f"{n} {s}" for s, n in counts.items())
                   + (f" ({undetermined})" if n_unobs else ""))
    if not quiet:
        runs = f"{res.runs} run{'s' if res.runs != 1 else ''}"
        print(f"{scenario.name}: {args.estimator}, {runs}, {res.seconds:.1f} s")
        print(f"  final position RMSE {res.rmse_position[-1]:.1f} m, bound "
              f"{res.bound_position[-1]:.1f} m, divergence rate {res.divergence_rate:.3f}")
        print(f"  final range RMSE {res.rmse_range[-1]:.1f} m, bound {res.bound_range[-1]:.1f} m")
        if n_unobs:
            print(f"  {n_unobs} of {runs}: {undetermined}; left out of the RMSE")
        if args.estimator == "mle" and scenario.target.model == "constant-turn":
            print(f"  sense of turn searched: {payload['turn_direction']}; "
                  f"{res.ambiguous_runs} run(s) with an indistinguishable alternative "
                  "solution")
        if "figure" in payload:
            print(f"  figure: {payload['figure']}")
    return payload
