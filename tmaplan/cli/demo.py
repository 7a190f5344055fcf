"""``tmaplan demo [P]``: the main job on the built-in ``default`` problem (or on a
several-contact problem P: :mod:`tmaplan.cli.demo_contacts`).

1. Plan a manoeuvre offline from the prior (heading OCP, :data:`CLOSED_LOOP_OBJECTIVE`)
   and compare it with the baselines (straight, best single turn, best zig-zag).
2. Schedule the ping budget along the planned track (closed-form PCRB, ``relaxed``).
3. Compare ``straight``, ``single-turn``, ``zigzag``, ``planned`` and ``receding`` (converged
   re-plans by the condensed SQP on the compiled objective), without and with pings (scheduled and
   uniformly spaced), by paired Monte Carlo runs of the closed loop (particle filter,
   re-planning).
4. Print, and put first in the report, the **stored result**: campaigns of the same policies
   sized to decide the differences that matter (:mod:`tmaplan.headline`, package data written
   by ``benchmarks/demo_stored.py``), then this run's results, labelled illustrative: every
   key difference with its paired 95 % interval, "not decided at N runs" where the interval
   holds zero (40 runs cannot decide ``planned`` against the best single turn: about a
   thousand can).
5. Write the figures and a self-contained ``report.html`` to ``<out>/demo/``
   (:data:`REPORT_DIR`; ``tmaplan compare P`` writes to ``<out>/P_compare/``, so neither
   overwrites the other's report). The runs are stored in ``<out>/campaign-<key>/``, shared
   with ``compare`` and reloaded by a second demo.
"""

from __future__ import annotations

import argparse
import html
import time
from pathlib import Path
from typing import Any

from tmaplan.cli.args import (
    DEMO_POLICIES,
    MAX_RUNS,
    MAX_WORKERS,
    add_figure_arguments,
    add_particles_argument,
    add_seed_argument,
    integer,
)
from tmaplan.cli.demo_contacts import demo_campaign, run_several, say
from tmaplan.errors import ArgumentError, PlanningError
from tmaplan.experiments import run_campaign
from tmaplan.headline import (
    Comparison,
    StoredResult,
    key_json,
    live_html,
    live_lines,
    load_stored,
    stored_html,
    stored_lines,
    stored_payload,
)
from tmaplan.models.sensors import default_ping_budget
from tmaplan.parallel import closing_pool, process_pool
from tmaplan.planning import Belief, HeadingPlanner, evaluate_baselines, schedule_pings
from tmaplan.policies import CLOSED_LOOP_OBJECTIVE
from tmaplan.policies.manoeuvres import offline_plan
from tmaplan.policies.receding import prefetch_receding_model
from tmaplan.report_tables import baseline_parameters
from tmaplan.scenario import load, load_problem

HELP = ("run the main job on the built-in 'default' problem (or a several-contact problem): "
        "plan, schedule, compare, report")

#: Several contacts: one plan, one ping schedule and one campaign for all of them
#: (:mod:`tmaplan.cli.demo_contacts`).
SEVERAL_CONTACTS = "joint"

#: Results that must be numbers (:mod:`tmaplan.cli.finite`).
FINITE = ("policies.*.rmse_position[-1]", "policies.*.final_range_rmse")

#: The problem the demo works on.
PROBLEM = "default"

#: Subdirectory of ``--out`` that holds the demo's report and figures.
REPORT_DIR = "demo"

#: Policies compared by the demo (manoeuvre[+ping]): :data:`tmaplan.cli.args.DEMO_POLICIES`.
#: The re-planning is ``receding`` (issue 42: its converged SQP re-plans take about 45 ms
#: where IPOPT's took 0.2–1 s, so the demo flies the policy the documentation recommends).


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``demo``."""
    parser.add_argument("problem", nargs="?", default=None,
                        help=f"'{PROBLEM}' (the default: its stored decisive campaigns are "
                             "printed first) or a several-contact problem, built-in name or "
                             "path to a .toml file")
    add_figure_arguments(parser, report=True)
    add_seed_argument(parser, help="root seed (default 0)")
    parser.add_argument("--runs", type=integer(1, MAX_RUNS), default=40,
                        help="Monte Carlo runs per policy (default 40 paired runs: "
                             "illustrative, most differences are not decided at that size; "
                             "the demo prints first the stored result of 2000 and 300 runs "
                             "that decides them)")
    add_particles_argument(parser)
    parser.add_argument("--workers", type=integer(1, MAX_WORKERS), default=2,
                        help="worker processes (default 2)")


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Plan, schedule, compare and write ``<out>/demo/report.html``."""
    t0 = time.perf_counter()
    for name, value, low in (("--runs", args.runs, 1), ("--particles", args.particles, 2),
                             ("--workers", args.workers, 1)):
        if value < low:
            raise PlanningError(f"{name}: expected >= {low}, received {value}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    # one pool of workers for the whole demo, importing while the main process starts: the
    # offline plan's multi-start and the campaign run on it (campaigns imports plan_starts)
    pool = (process_pool(args.workers, warm_up=(run_campaign.__module__,))
            if args.workers > 1 else None)
    with closing_pool(pool):  # (stopped at once by an interrupt)
        return _run(args, out, pool, t0)


def _run(args: argparse.Namespace, out: Path, pool: Any, t0: float) -> dict[str, Any]:
    from tmaplan.plotting import plot_plan, plot_schedule  # deferred: matplotlib
    from tmaplan.report import efficiency, write_report  # deferred: matplotlib

    scenario = load_problem(PROBLEM) if args.problem is None else load(args.problem)
    rep = out / REPORT_DIR  # the report and its figures; the runs stay in `out`
    if len(scenario.contacts) > 1:
        rep.mkdir(parents=True, exist_ok=True)
        return run_several(args, scenario, out, rep, pool, t0)
    if scenario != load_problem(PROBLEM):
        raise ArgumentError("problem", f"'{PROBLEM}' (its stored decisive campaigns come "
                            "first) or a problem with several contacts; compare the policies "
                            f"on a one-contact problem with `tmaplan compare P --policies "
                            f"{','.join(DEMO_POLICIES)}`", args.problem, source=scenario.name)
    belief = Belief.from_prior(scenario)
    rep.mkdir(parents=True, exist_ok=True)

    say(args, f"[1/3] planning a manoeuvre from the prior ({CLOSED_LOOP_OBJECTIVE}) ...")
    planner = HeadingPlanner(scenario, objective=CLOSED_LOOP_OBJECTIVE)
    # the same solve as planner.solve(belief), cached: the campaign's `planned` and
    # `receding` policies' real-time model reuse it instead of solving again
    plan = offline_plan(scenario, CLOSED_LOOP_OBJECTIVE, workers=args.workers, pool=pool)
    base = evaluate_baselines(scenario, planner.objective, evaluator=planner.evaluator(belief))
    plan_fig = plot_plan(plan, base, belief, rep / "plan.png",
                         objective=planner.objective.name)
    del plan_fig
    best = {k: v[0] for k, v in base.items()}
    say(args, f"      objective {plan.objective:.4g} (straight {best['straight'].objective:.4g}"
               f", best single turn {best['single-turn'].objective:.4g}, best zig-zag "
               f"{best['zigzag'].objective:.4g}); {plan.status}, {plan.seconds:.1f} s")

    if pool is not None:  # receding's Hessian model (its SQP) on a worker while we schedule
        prefetch_receding_model(scenario, CLOSED_LOOP_OBJECTIVE, pool)
    budget = default_ping_budget(scenario)
    say(args, f"[2/3] scheduling {budget} pings along the planned track ...")
    sched = schedule_pings(scenario, budget=budget, method="relaxed", observer=plan.observer,
                           belief=belief)
    plot_schedule(scenario, plan.observer, belief, sched, rep / "schedule.png")
    say(args, f"      pings at {', '.join(f'{t / 60:.1f}' for t in sched.times)} min: mean "
               f"range bound {sched.objective:.0f} m (uniform {sched.uniform_objective:.0f} m,"
               f" none {sched.no_ping_objective:.0f} m)")

    result, cmd = demo_campaign(args, scenario, DEMO_POLICIES, out, pool)
    stored = load_stored()
    live = Comparison.from_campaign(result, command=cmd)
    extra = stored_html(stored) + live_html(live, stored) + _extra_html(plan, best, sched)
    report = write_report(result, rep, command=cmd, title="tmaplan demo: problem 'default'",
                          extra_html=extra,
                          figures={"planned manoeuvre": rep / "plan.png",
                                   "ping schedule": rep / "schedule.png"})
    for line in _headline(stored, live):
        say(args, line)
    _say_replans(args, result)
    seconds = time.perf_counter() - t0
    say(args, f"wrote {report} ({seconds:.0f} s)")
    payload = result.to_json()
    payload["stored"] = stored_payload(stored)
    payload["key_differences"] = key_json(live, stored=stored)
    for name, e in efficiency(result).items():
        payload["policies"][name]["efficiency"] = e
    payload.update(report=str(report), seconds=seconds,
                   plan={"objective": plan.objective, "status": plan.status,
                         "baselines": {k: b.objective for k, b in best.items()},
                         "times": plan.times, "turn_rate": plan.turn_rate},
                   schedule={"ping_times": sched.times, "objective": sched.objective,
                             "uniform_objective": sched.uniform_objective,
                             "no_ping_objective": sched.no_ping_objective})
    return payload


def _headline(stored: StoredResult, live: Comparison) -> list[str]:
    """The console's results: the stored decisive campaigns first, then this run, labelled
    illustrative; every difference with its paired 95 % interval (:mod:`tmaplan.headline`)."""
    return ["", *stored_lines(stored), "", *live_lines(live, stored), ""]


def _say_replans(args: argparse.Namespace, result: Any) -> None:
    """One line per re-planning policy: its re-plans, not converged, fell back
    (:mod:`tmaplan.evaluation.replans`)."""
    for name in result.policies:
        if (counts := result.summary[name]["replans"]).total:
            say(args, f"    {name:<28} {counts.text()}")


def _extra_html(plan: Any, best: dict[str, Any], sched: Any) -> str:
    rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{b.objective:.4g}</td>"
                   f"<td>{html.escape(baseline_parameters(b.params))}</td></tr>"
                   for k, b in best.items())
    pings = ", ".join(f"{t / 60:.1f}" for t in sched.times)
    return (
        "<h2>Offline plan from the prior</h2>"
        f"<p>Objective <code>{CLOSED_LOOP_OBJECTIVE}</code> (minimised): plan "
        f"{plan.objective:.4g} ({html.escape(plan.status)}, {plan.seconds:.1f} s).</p>"
        "<table><tr><th>best baseline</th><th>objective</th><th>parameters</th></tr>"
        f"{rows}</table>"
        "<h2>Ping schedule along the plan</h2>"
        f"<p>Pings at {pings} min ({html.escape(sched.method)}, "
        f"{html.escape(sched.status)}): mean closed-form range bound {sched.objective:.0f} m, "
        f"against {sched.uniform_objective:.0f} m for uniformly spaced pings and "
        f"{sched.no_ping_objective:.0f} m without pings.</p>")
