"""Up-front checks that a verb's computation can be done (issue 38), run by
:func:`tmaplan.cli._args.preflight` before any work starts.

* Memory: the verbs that build large casadi graphs (``plan``, ``schedule``, ``bound``,
  ``compare``, ``rank-costs``, ``demo``) estimate their peak memory from the number of
  steps (:mod:`tmaplan.memory`) and refuse, naming the field or flag that sets the steps,
  what does not fit: nothing is built first.
* Planning: the verbs that plan (``plan``, the planning policies of ``compare`` and
  ``demo``, ``rank-costs``) check the planning horizon against the control interval and the
  keep-out range against the prior and the truth (:mod:`tmaplan.planning.feasibility`).
* Warnings that need the motion model (:func:`tmaplan.models.plausibility.suspicious`):
  the contact on the own ship for every verb; the truth outside its own prior for the verbs
  that read the prior.
"""

from __future__ import annotations

import argparse
from typing import Any

from tmaplan.display import seconds_text
from tmaplan.memory import check_steps

__all__ = ["check_feasible"]

#: Manoeuvres (``compare --policies``) that build the heading OCP (the offline plan, its
#: multi-start evaluating the baselines, and the re-plans on every worker).
_PLANNING = frozenset({"planned", "receding", "receding-multistart", "receding-realtime",
                       "receding-rti"})
#: Manoeuvres that evaluate the baseline grids' objective.
_BASELINES = _PLANNING | {"single-turn", "zigzag"}
#: Ping policies that schedule pings (the ping scheduler's graphs).
_SCHEDULING = frozenset({"scheduled", "scheduled-terminal"})


def _policy_names(args: argparse.Namespace) -> tuple[set[str], set[str]]:
    """(manoeuvres, pings) named by ``compare --policies`` or flown by ``demo``."""
    if args.verb == "demo":
        from tmaplan.cli.demo import DEMO_POLICIES

        names: Any = DEMO_POLICIES
    else:
        names = [p.strip() for p in args.policies.split(",") if p.strip()]
    parts = [n.split("+") for n in names]
    return {p[0] for p in parts}, {p[1] for p in parts if len(p) > 1}


def _plan_steps(args: argparse.Namespace, scenario: Any) -> tuple[int, int, float | None]:
    """(steps K, steps per control interval, ``--horizon`` or None) of the verb's planner."""
    pl, dt = scenario.planning, float(scenario.time.dt)
    flag = getattr(args, "horizon", None) if args.verb == "plan" else None
    tc = getattr(args, "control_interval", None) if args.verb == "plan" else None
    tc = tc or (pl.control_interval if pl is not None and pl.control_interval else dt)
    h = flag or (pl.horizon if pl is not None and pl.horizon else scenario.time.horizon)
    m = max(1, round(tc / dt))
    return max(1, round(h / (m * dt))) * m, m, flag


def _parts(args: argparse.Namespace) -> tuple[bool, list[tuple[str, int]]]:
    """(whether the verb plans, its computations ``(key of tmaplan.memory.MODELS,
    copies)``)."""
    verb = args.verb
    workers = int(getattr(args, "workers", None) or 1)
    copies = workers + 1 if workers > 1 else 1  # the main process's planner and one a worker
    if verb == "plan":
        return True, [("heading", 1), ("baselines", 1)] + (
            [("schedule", 1)] if getattr(args, "pings", 0) else [])
    if verb == "schedule":
        return False, [("schedule", 1)]
    if verb == "bound":
        return False, [("bound", 1)]
    if verb == "rank-costs":
        plans = getattr(args, "plans", "all").strip() != "none"
        return plans, ([("heading", copies)] if plans else []) + [("baselines", 1)]
    if verb in ("compare", "demo"):
        manoeuvres, pings = _policy_names(args)
        plans = bool(manoeuvres & _PLANNING)
        return plans, (([("heading", copies)] if plans else [])
                       + ([("baselines", 1)] if manoeuvres & _BASELINES else [])
                       + ([("schedule", 1)] if pings & _SCHEDULING else []))
    return False, []


def check_feasible(args: argparse.Namespace, scenario: Any, *, prior_verb: bool = True,
                   available: float | None = None) -> None:
    """The module's checks for ``args.verb`` on ``scenario`` (``prior_verb``: the verb reads
    the prior; ``available``: bytes of memory, default the machine's)."""
    from tmaplan.models.plausibility import warn_suspicious

    warn_suspicious(scenario, prior=prior_verb)
    plans, parts = _parts(args)
    if plans:
        from tmaplan.planning.feasibility import check_keep_out, check_planning_horizon

        if args.verb != "plan" or (args.horizon is None and args.control_interval is None):
            check_planning_horizon(scenario)  # (plan's flags are checked by _check_plan)
    if not parts:
        return
    k_plan, m, flag = _plan_steps(args, scenario)
    k = scenario.n_steps
    if plans and (k_plan >= k or flag is not None):  # the planner's steps set the size
        pl = scenario.planning
        field, value = (("--horizon", flag) if flag is not None else
                        ("planning.horizon", pl.horizon) if pl is not None and pl.horizon
                        else ("time.horizon", scenario.time.horizon))
        k = k_plan
    else:
        field, value = "time.horizon", scenario.time.horizon
    check_steps(k, parts, field=field, dt=float(scenario.time.dt),
                received=seconds_text(float(value)), source=scenario.name,
                available=available, steps_per_interval=m)
    if plans:
        check_keep_out(scenario)
