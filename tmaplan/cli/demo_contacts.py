"""``tmaplan demo P`` on a several-contact problem: the three jobs for every contact at once.

1. Plan one own-ship manoeuvre for all the contacts from their priors
   (:class:`tmaplan.planning.contacts.ContactsPlanner`, ``all-contacts-time-to-accuracy``),
   against each contact's own plan and the best single turn for all of them.
2. Schedule the ping budget along the joint plan, one schedule for all the contacts (a ping
   ranges every contact within the range sensor's ``max_range``;
   :func:`tmaplan.planning.schedule_contact_pings`, ``relaxed``, with its certificate).
3. Compare :data:`DEMO_CONTACTS_POLICIES` by paired Monte Carlo runs (one particle filter
   per contact, one own ship), and print the key differences
   (:data:`CONTACTS_KEY_DIFFERENCES`, on the time until every contact is localised) with
   their paired 95 % intervals, labelled
   illustrative: the decided campaigns are in ``docs/results/several-contacts-decided.md``.
   ``receding`` (a joint IPOPT re-plan every ``planning.replan_interval``) is left to
   ``tmaplan compare P --policies receding,...``: it would take the demo's minutes many times.
4. Write the figures and ``<out>/demo/report.html`` (per-contact tables and run 0 of every
   policy, each contact in its own colour).
"""

from __future__ import annotations

import argparse
import html
import sys
import time
from pathlib import Path
from typing import Any

from tmaplan.experiments import CampaignSpec, run_campaign
from tmaplan.headline import Comparison, key_json, key_lines, key_table_html, stats_lines
from tmaplan.models.sensors import default_ping_budget
from tmaplan.planning.contacts import ContactSet
from tmaplan.planning.ping_contacts import schedule_contact_pings
from tmaplan.policies.contacts import joint_baselines, joint_contacts_plan
from tmaplan.scenario import Scenario

__all__ = ["CONTACTS_KEY_DIFFERENCES", "DEMO_CONTACTS_POLICIES", "demo_campaign", "run_several",
           "say"]

#: Policies the demo compares on several contacts (manoeuvre[+ping]).
DEMO_CONTACTS_POLICIES = ("straight", "single-turn", "nearest-contact", "planned",
                          "planned+uniform", "planned+scheduled")

#: The paired differences ``a − b`` it shows, in this order: (a, b, metric).
CONTACTS_KEY_DIFFERENCES: tuple[tuple[str, str, str], ...] = (
    ("planned", "straight", "time_to_accuracy_all"),
    ("planned", "nearest-contact", "time_to_accuracy_all"),
    ("planned", "single-turn", "time_to_accuracy_all"),
    ("planned+uniform", "planned", "time_to_accuracy_all"),
    ("planned+scheduled", "planned+uniform", "time_to_accuracy_all"),
    ("planned+scheduled", "planned+uniform", "worst_final_range_error"),
)

#: Where the campaigns that decide these differences on the built-in problems are recorded,
#: and their least number of paired runs.
DECIDED_RECORD = "docs/results/several-contacts-decided.md"
DECIDED_RUNS = 200


def say(args: argparse.Namespace, msg: str) -> None:
    """Print ``msg`` on the console unless the JSON goes to stdout (``--json -``)."""
    if args.json != "-":
        print(msg, flush=True)


def run_several(args: argparse.Namespace, scenario: Scenario, out: Path, rep: Path,
                pool: Any, t0: float) -> dict[str, Any]:
    """The demo's three jobs on ``scenario`` (several contacts); the payload of ``demo``.

    Parameters
    ----------
    args : argparse.Namespace
        ``demo``'s options (``runs``, ``seed``, ``particles``, ``workers``, ``json``, ``out``).
    scenario : Scenario
        Two or more contacts.
    out, rep : Path
        The runs' directory and the report's (``<out>/demo``).
    pool : executor or None
        The demo's worker pool.
    t0 : float
        ``time.perf_counter()`` at the start.

    Returns
    -------
    dict
        ``compare``'s JSON for the campaign, plus ``plan``, ``schedule``,
        ``key_differences`` (SI units), ``report`` and ``seconds``.
    """
    from tmaplan.report import efficiency, write_report  # deferred: matplotlib
    from tmaplan.report_contacts import (  # deferred: matplotlib
        contacts_figure,
        contacts_html,
        schedule_figure,
    )

    cs = ContactSet.from_scenario(scenario)
    say(args, f"[1/3] planning one manoeuvre for the {len(cs)} contacts from their priors "
               "(all-contacts-time-to-accuracy) ...")
    res = joint_contacts_plan(scenario)
    plan = res.plan
    # the best baselines on the joint objective, evaluated once: the campaign's single-turn
    # flies the same turn (joint_baselines is cached per scenario)
    best = joint_baselines(scenario)
    say(args, f"      objective {plan.objective / 60:.1f} min (straight "
               f"{best['straight'].objective / 60:.1f}, best single turn "
               f"{best['single-turn'].objective / 60:.1f}); {plan.status}, "
               f"{res.seconds:.1f} s")
    for n in cs.names:
        own = res.alone_times.get(n)
        say(args, f"      {n:<16} expected time to accuracy {res.expected_times[n] / 60:.1f} "
                   "min on the joint plan" + ("" if own is None else
                                              f", {own / 60:.1f} min on its own plan"))

    budget = default_ping_budget(scenario)
    say(args, f"[2/3] scheduling {budget} pings for all the contacts along the joint plan ...")
    shared = schedule_contact_pings(cs, budget=budget, method="relaxed",
                                    observer=plan.observer)
    sched = shared.schedule
    schedule_figure(shared, plan.observer.times, rep / "schedule.png",
                    title=f"{scenario.name}: {budget} pings shared by {len(cs)} contacts")
    pings = ", ".join(f"{t / 60:.1f}" for t in sched.times) or "none"
    say(args, f"      pings at {pings} min: the contacts' mean range bound "
               f"{sched.objective:.0f} m (uniform {sched.uniform_objective:.0f} m, none "
               f"{sched.no_ping_objective:.0f} m; {sched.status}, gap {100 * sched.gap:.2f} %)")

    result, cmd = demo_campaign(args, scenario, DEMO_CONTACTS_POLICIES, out, pool,
                                per=" per contact")
    live = Comparison.from_campaign(result, command=cmd)
    extra = (contacts_html(result) + _live_html(live)
             + _plan_html(res, best, sched, cs.names))
    report = write_report(result, rep, command=cmd,
                          title=f"tmaplan demo: problem '{scenario.name}'", extra_html=extra,
                          figures={"contacts": contacts_figure(result, rep),
                                   "ping schedule": rep / "schedule.png"})
    for line in ["", f"This run (illustrative: {live.runs} paired runs, seed {live.seed}; "
                 "time until every contact is within its required accuracy; the decided "
                 f"campaigns, {DECIDED_RUNS}+ paired runs each: {DECIDED_RECORD}):",
                 *stats_lines(live), *key_lines(live, keys=CONTACTS_KEY_DIFFERENCES), ""]:
        say(args, line)
    seconds = time.perf_counter() - t0
    say(args, f"wrote {report} ({seconds:.0f} s)")
    payload = result.to_json()
    for name, e in efficiency(result).items():
        payload["policies"][name]["efficiency"] = e
    payload["key_differences"] = key_json(live, keys=CONTACTS_KEY_DIFFERENCES)
    payload.update(report=str(report), seconds=seconds,
                   plan={"objective": plan.objective, "status": plan.status,
                         "baselines": {k: b.objective for k, b in best.items()},
                         "times": plan.times, "turn_rate": plan.turn_rate,
                         "contacts": {n: {"expected_time_to_accuracy": res.expected_times[n],
                                          "alone_expected_time_to_accuracy":
                                              res.alone_times.get(n)} for n in cs.names}},
                   schedule={"ping_times": sched.times, "objective": sched.objective,
                             "uniform_objective": sched.uniform_objective,
                             "no_ping_objective": sched.no_ping_objective,
                             "lower_bound": sched.lower_bound, "gap": sched.gap,
                             "status": sched.status,
                             "contacts": {n: {"objective": shared.objectives[n],
                                              "pings_in_reach": shared.pings_in_reach[n]}
                                          for n in cs.names}})
    return payload


def demo_campaign(args: argparse.Namespace, scenario: Scenario, policies: tuple[str, ...],
                  out: Path, pool: Any, per: str = "") -> tuple[Any, str]:
    """The demo's campaign of ``policies`` on ``scenario`` (step 3 of ``demo``, one contact or
    several; ``per``: after "particles" in its console line) and the command that reproduces
    it.

    Returns
    -------
    tuple
        The :class:`tmaplan.experiments.CampaignResult` and the command (str).
    """
    say(args, f"[3/3] comparing {len(policies)} policies over {args.runs} paired runs "
               f"({args.particles} particles{per}, {args.workers} workers) ...")
    spec = CampaignSpec(scenario=scenario, policies=policies, runs=args.runs,
                        seed=args.seed, n_particles=args.particles)
    result = run_campaign(spec, out_dir=out, workers=args.workers, pool=pool,
                          progress=args.json != "-" and sys.stderr.isatty())
    problem = "" if args.problem is None else f" {args.problem}"
    cmd = (f"tmaplan demo{problem} --runs {args.runs} --particles {args.particles} "
           f"--seed {args.seed} --workers {args.workers} --out {args.out}")
    return result, cmd


def _live_html(live: Comparison) -> str:
    return (f"<h2>This run: illustrative ({live.runs} paired runs, seed {live.seed})</h2>"
            "<p>Key differences over the contacts, each with its paired 95 % interval; one "
            "whose interval holds zero is not decided at this size (the decided campaigns: "
            f"{DECIDED_RECORD}).</p>"
            + key_table_html(live, keys=CONTACTS_KEY_DIFFERENCES))


def _plan_html(res: Any, best: dict[str, Any], sched: Any, names: tuple[str, ...]) -> str:
    rows = "".join(
        f"<tr><td>{html.escape(n)}</td><td>{res.expected_times[n] / 60:.1f}</td><td>"
        + ("–" if res.alone_times.get(n) is None else f"{res.alone_times[n] / 60:.1f}")
        + "</td></tr>" for n in names)
    pings = ", ".join(f"{t / 60:.1f}" for t in sched.times) or "none"
    return (
        "<h2>Joint plan from the priors</h2>"
        "<p>Objective <code>all-contacts-time-to-accuracy</code> (minimised): "
        f"{res.plan.objective / 60:.1f} min ({html.escape(res.plan.status)}); straight "
        f"{best['straight'].objective / 60:.1f} min, best single turn "
        f"{best['single-turn'].objective / 60:.1f} min.</p>"
        "<table><tr><th>contact</th><th>expected time to accuracy on the joint plan [min]"
        "</th><th>on its own plan [min]</th></tr>" + rows + "</table>"
        "<h2>Ping schedule along the joint plan, shared by the contacts</h2>"
        f"<p>Pings at {pings} min ({html.escape(sched.method)}, {html.escape(sched.status)},"
        f" gap {100 * sched.gap:.2f} %): the contacts' mean closed-form range bound "
        f"{sched.objective:.0f} m, against {sched.uniform_objective:.0f} m for uniformly "
        f"spaced pings and {sched.no_ping_objective:.0f} m without pings.</p>")
