"""Up-front checks that a verb's computation can be done (issue 38), run by
:func:`tmaplan.cli.preflight.preflight` before any work starts.

* Memory (:func:`check_memory`, first: the verbs' own checks may allocate per step): every
  verb estimates its peak memory from the number of steps (:mod:`tmaplan.memory`): its
  per-step arrays, and the casadi graphs of ``plan``, ``schedule``, ``bound``, ``compare``,
  ``rank-costs`` and ``demo``; what does not fit is refused naming the field or flag that
  sets the steps, before anything is built.
* Planning (:func:`check_feasible`): the verbs that plan (``plan``, the planning policies
  of ``compare`` and ``demo``, ``rank-costs``) check the planning horizon against the
  control interval and the keep-out range against the prior and the truth
  (:mod:`tmaplan.planning.feasibility`).
* Warnings that need the motion model (:func:`tmaplan.models.plausibility.suspicious`):
  the contact on the own ship for every verb; the truth outside its own prior for the verbs
  that read the prior.
"""

from __future__ import annotations

import argparse
from typing import Any

from tmaplan.bounds.closed_form import require_process_noise
from tmaplan.cli.args import DEMO_POLICIES
from tmaplan.display import seconds_text
from tmaplan.memory import check_steps
from tmaplan.models.plausibility import warn_suspicious
from tmaplan.planning.feasibility import check_keep_out, check_planning_horizon

__all__ = ["check_feasible", "check_memory"]

#: Manoeuvres (``compare --policies``) that build the heading OCP (the offline plan, its
#: multi-start evaluating the baselines, and the re-plans on every worker).
_PLANNING = frozenset({"planned", "receding", "receding-multistart", "receding-realtime",
                       "receding-rti", "receding-sqp"})
#: Manoeuvres that evaluate the baseline grids' objective.
_BASELINES = _PLANNING | {"single-turn", "zigzag"}
#: Ping policies that schedule pings (the ping scheduler's graphs).
_SCHEDULING = frozenset({"scheduled", "scheduled-terminal"})


def _policy_names(args: argparse.Namespace) -> tuple[set[str], set[str]]:
    """(manoeuvres, pings) named by ``compare --policies`` or flown by ``demo``."""
    if args.verb == "demo":
        names: Any = DEMO_POLICIES
    else:
        names = [p.strip() for p in args.policies.split(",") if p.strip()]
    parts = [n.split("+") for n in names]
    return {p[0] for p in parts}, {p[1] for p in parts if len(p) > 1}


def _plans(args: argparse.Namespace) -> bool:
    """Whether the verb builds the heading OCP."""
    if args.verb == "plan":
        return True
    if args.verb == "rank-costs":
        return str(getattr(args, "plans", "all")).strip() != "none"
    if args.verb in ("compare", "demo"):
        return bool(_policy_names(args)[0] & _PLANNING)
    return False


def _parts(args: argparse.Namespace) -> list[tuple[str, int]]:
    """The verb's computations held at once, ``(key of tmaplan.memory.MODELS, copies)``."""
    verb = args.verb
    workers = int(getattr(args, "workers", None) or 1)
    copies = workers + 1 if workers > 1 else 1  # the main process's planner and one a worker
    heading = [("heading", copies)] if _plans(args) else []
    out: list[tuple[str, int]] = [("arrays", 1)]
    if verb == "plan":
        out += [("heading", 1), ("baselines", 1)] + (
            [("schedule", 1)] if getattr(args, "pings", 0) else [])
    elif verb == "schedule":
        out.append(("schedule", 1))
    elif verb == "bound":
        out.append(("bound", 1))
    elif verb == "rank-costs":
        out += [*heading, ("baselines", 1)]
    elif verb in ("compare", "demo"):
        manoeuvres, pings = _policy_names(args)
        out += (heading + ([("baselines", 1)] if manoeuvres & _BASELINES else [])
                + ([("schedule", 1)] if pings & _SCHEDULING else []))
    return out


def _plan_steps(args: argparse.Namespace, scenario: Any) -> tuple[int, str, float]:
    """(steps K of the verb's planner, the field or flag that sets them, its value [s])."""
    pl, dt = scenario.planning, float(scenario.time.dt)
    flag = getattr(args, "horizon", None) if args.verb == "plan" else None
    tc = getattr(args, "control_interval", None) if args.verb == "plan" else None
    tc = tc or (pl.control_interval if pl is not None and pl.control_interval else dt)
    m = max(1, round(tc / dt))
    field, h = (("--horizon", flag) if flag is not None else
                ("planning.horizon", pl.horizon) if pl is not None and pl.horizon else
                ("time.horizon", scenario.time.horizon))
    return max(1, round(h / (m * dt))) * m, field, float(h)


def check_memory(args: argparse.Namespace, scenario: Any, *,
                 available: float | None = None) -> None:
    """Refuse a run of ``args.verb`` on ``scenario`` whose estimated peak memory exceeds
    ``available`` bytes (default the machine's, :func:`tmaplan.memory.available_bytes`),
    naming the field or flag that sets the number of steps (module notes)."""
    k, field, value = scenario.n_steps, "time.horizon", float(scenario.time.horizon)
    if _plans(args):
        k_plan, f_plan, v_plan = _plan_steps(args, scenario)
        if k_plan >= k or f_plan == "--horizon":  # the planner's steps set the size
            k, field, value = k_plan, f_plan, v_plan
    check_steps(k, _parts(args), field=field, dt=float(scenario.time.dt),
                received=seconds_text(value), source=scenario.name, available=available)


def _closed_form(args: argparse.Namespace) -> bool:
    """Whether the verb evaluates the closed-form LPC bound (brehard2005): the planners'
    objectives, the baseline grids, the ping scheduler, the ranked cost functionals."""
    if args.verb in ("plan", "schedule", "rank-costs"):
        return True
    if args.verb in ("compare", "demo"):
        manoeuvres, pings = _policy_names(args)
        return bool(manoeuvres & _BASELINES or pings & _SCHEDULING)
    return False


def check_feasible(args: argparse.Namespace, scenario: Any, *, prior_verb: bool = True) -> None:
    """The planning checks and the motion model's warnings of the module notes for
    ``args.verb`` on ``scenario`` (``prior_verb``: the verb reads the prior); a target
    without process noise where the closed-form bound is evaluated (it failed deep inside
    with "Singular matrix")."""
    warn_suspicious(scenario, prior=prior_verb)
    if _closed_form(args):
        require_process_noise(scenario, purpose=f" for tmaplan {args.verb}")
    if not _plans(args):
        return
    if args.verb != "plan" or (args.horizon is None and args.control_interval is None):
        check_planning_horizon(scenario)  # (plan's flags are checked by _check_plan)
    check_keep_out(scenario)
