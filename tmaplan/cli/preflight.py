"""Up-front checks of the arguments that need the scenario, before any verb starts work
(:func:`preflight`, run by :func:`tmaplan.cli.main`): each bad value is refused in one line
naming its flag or the scenario's field; the limits themselves are in :mod:`tmaplan.cli.args`.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tmaplan.cli.args import MAX_PLAN_STEPS, PLAN_STARTS, repeated
from tmaplan.cli.feasible import check_feasible, check_memory
from tmaplan.cli.paths import check_outputs
from tmaplan.cli.schedule import check_options, check_spacing, read_observer_plan
from tmaplan.display import seconds_text
from tmaplan.errors import (
    ArgumentError,
    PlanningError,
    ScenarioError,
    is_whole_count,
    whole_steps_text,
)
from tmaplan.estimators.applicability import check_applicable
from tmaplan.planning.joint import JOINT_OBJECTIVES
from tmaplan.planning.multi_objectives import CONTACTS_OBJECTIVE_NAMES
from tmaplan.planning.objectives import OBJECTIVE_NAMES
from tmaplan.policies.combine import MANOEUVRES, PINGS
from tmaplan.policies.parse import check_policy
from tmaplan.scenario.contacts import contact_field
from tmaplan.simulate import check_truth_source

__all__ = ["preflight"]


def _flag_error(flag: str, constraint: str, received: Any, scenario: Any) -> ArgumentError:
    return ArgumentError(flag, constraint, received, source=scenario.name)


def _scenario_error(field: str, constraint: str, received: Any, scenario: Any) -> ScenarioError:
    return ScenarioError(field, constraint, received, source=scenario.name)


def _check_starts(args: argparse.Namespace, scenario: Any) -> None:
    """``plan --starts`` only where the planner's built-in initial guesses are solved: the
    bang-bang transcription, or the first heading solve of a joint plan (``--pings``); the
    direct plan without pings is multi-started from the manoeuvres it must beat
    (:func:`tmaplan.policies.plan_starts.plan_from_prior`), whatever ``--starts``."""
    starts = getattr(args, "starts", None)
    if starts is None:
        return
    tr = getattr(args, "transcription", "direct")
    if tr == "direct" and getattr(args, "pings", 0) == 0:
        raise _flag_error("--starts", "only with --transcription bang-bang (at most "
                          f"{PLAN_STARTS['bang-bang']}) or --pings K (at most "
                          f"{PLAN_STARTS['direct']} with the direct transcription): the direct "
                          "plan without pings starts from straight, the tactics, the best "
                          "single turns and 4 fixed guesses, whatever --starts", starts,
                          scenario)
    if starts > PLAN_STARTS[tr]:
        raise _flag_error("--starts", f"at most {PLAN_STARTS[tr]} with --transcription {tr} "
                          "(the planner's built-in initial guesses)", starts, scenario)


def _check_plan(args: argparse.Namespace, scenario: Any) -> None:
    if getattr(args, "objective", None) in CONTACTS_OBJECTIVE_NAMES:  # (several: plan's own)
        raise _flag_error("--objective", f"with one contact one of {', '.join(OBJECTIVE_NAMES)}"
                          f" ({', '.join(CONTACTS_OBJECTIVE_NAMES)} plan for several "
                          "contacts, [[contacts]] in the scenario file)", args.objective,
                          scenario)
    _check_starts(args, scenario)
    dt = float(scenario.time.dt)
    pl = scenario.planning
    tc = args.control_interval if getattr(args, "control_interval", None) is not None else (
        pl.control_interval if pl is not None and pl.control_interval else dt)
    if getattr(args, "control_interval", None) is not None:
        m = tc / dt
        if not is_whole_count(m):
            raise _flag_error("--control-interval", whole_steps_text(dt), seconds_text(tc),
                              scenario)
    joint, stride = getattr(args, "joint", None), getattr(args, "ping_stride", None)
    if getattr(args, "pings", 0) == 0 and (joint is not None or stride is not None):
        flag = "--joint" if joint is not None else "--ping-stride"
        raise _flag_error(flag, "only with --pings K (K >= 1): a heading-only plan has no "
                          "pings", joint if joint is not None else stride, scenario)
    if joint == "alternating" and stride is not None:
        raise _flag_error("--ping-stride", "only with --joint ocp (the alternating blocks "
                          "search every step)", stride, scenario)
    if getattr(args, "pings", 0) > 0:
        objective = args.objective or (pl.objective if pl is not None else "range-bound")
        if objective not in JOINT_OBJECTIVES:
            given = "" if args.objective else " (the problem's planning.objective)"
            raise _flag_error("--objective", f"with --pings, one of {', '.join(JOINT_OBJECTIVES)}",
                              f"{objective}{given}", scenario)
        if args.pings > scenario.n_steps:
            raise _flag_error("--pings", f"at most the {scenario.n_steps} steps of the horizon",
                              args.pings, scenario)
    if args.horizon is None:
        h = pl.horizon if pl is not None and pl.horizon else float(scenario.time.horizon)
        if round(h / dt) > scenario.n_steps:  # a receding horizon may; an offline plan not
            raise _scenario_error(
                "planning.horizon", "at most the problem's horizon of "
                f"{seconds_text(float(scenario.time.horizon))} for an offline plan (or give "
                "--horizon)", seconds_text(h), scenario)
        if getattr(args, "control_interval", None) is not None:  # else rounded silently
            n = h / tc
            if not is_whole_count(n):
                raise _flag_error("--control-interval", "a whole number (>= 1) of intervals in "
                                  f"the planning horizon of {seconds_text(h)} (or give "
                                  "--horizon)", seconds_text(tc), scenario)
        return
    k = round(args.horizon / dt)
    if k > MAX_PLAN_STEPS:
        raise _flag_error("--horizon", f"at most {MAX_PLAN_STEPS} steps of dt = {dt:g} s "
                          f"({seconds_text(MAX_PLAN_STEPS * dt)}, documented limit)",
                          f"{seconds_text(args.horizon)} = {k} steps", scenario)
    h = float(scenario.time.horizon)
    if k > scenario.n_steps:  # a plan past the problem's end: beyond its measurements
        raise _flag_error("--horizon", f"at most the problem's horizon of {seconds_text(h)}",
                          seconds_text(args.horizon), scenario)
    n = args.horizon / tc
    if not is_whole_count(n):
        raise _flag_error("--horizon", f"a whole number (>= 1) of control intervals of "
                          f"{seconds_text(tc)}", seconds_text(args.horizon), scenario)


def _check_bound(args: argparse.Namespace, scenario: Any) -> None:
    if scenario.prior is None:
        raise _scenario_error("prior", "a [prior] table: the PCRB starts from the prior "
                              "information (J₀ = P₀⁻¹); add one or use `tmaplan crlb "
                              f"{scenario.name}` for the batch CRLB of a deterministic track",
                              None, scenario)
    if args.ping_every is not None and args.ping_every < scenario.time.dt:
        raise _flag_error("--ping-every", f">= dt = {scenario.time.dt:g} s",
                          seconds_text(args.ping_every), scenario)
    if args.ping_steps is not None and max(args.ping_steps) > scenario.n_steps:
        raise _flag_error("--ping-steps", f"steps within 0..{scenario.n_steps}",
                          max(args.ping_steps), scenario)


def _check_frequencies(args: argparse.Namespace, scenario: Any) -> None:
    available = max((len(s.f0) for s in scenario.sensors_of("frequency")), default=0)
    if (getattr(args, "frequencies", 0) or 0) > available:
        raise _flag_error("--frequencies", f"0..{available} (lines of {scenario.name})",
                          args.frequencies, scenario)


def _check_schedule(args: argparse.Namespace, scenario: Any) -> None:
    if args.budget is not None and args.budget > scenario.n_steps:
        raise _flag_error("--budget", f"at most the {scenario.n_steps} steps of the horizon",
                          args.budget, scenario)
    check_options(args, scenario)
    track = None
    if args.observer_plan is not None:
        track = read_observer_plan(args.observer_plan, scenario)
    check_spacing(args, scenario, track)


def _check_track(args: argparse.Namespace, scenario: Any) -> None:
    # the flags' own constraints first, then whether the estimator applies at all
    turn = getattr(args, "turn_direction", "auto")
    if turn != "auto" and args.estimator != "mle":
        raise _flag_error("--turn-direction", "only with --estimator mle", turn, scenario)
    model = scenario.target.model
    if turn in ("clockwise", "anticlockwise") and model != "constant-turn":
        raise _flag_error("--turn-direction", "'auto' or 'either' unless the target model is "
                          f"'constant-turn' ({scenario.name}'s is '{model}')", turn, scenario)
    _check_frequencies(args, scenario)
    check_applicable(args.estimator, scenario, bound=args.bound, cli=True)


def _check_compare(args: argparse.Namespace, scenario: Any) -> None:
    names = [p.strip() for p in args.policies.split(",") if p.strip()]
    if not names:
        raise _flag_error("--policies", "one or more distinct MANOEUVRE[+PING], comma-separated",
                          args.policies, scenario)
    twice = repeated(names)
    if twice is not None:
        raise _flag_error("--policies", f"one or more distinct MANOEUVRE[+PING], each once "
                          f"({twice} is repeated)", args.policies, scenario)
    for name in names:
        try:
            check_policy(name, scenario)
        except ArgumentError as exc:  # the policy's rule, on the flag that named it
            raise _flag_error("--policies", exc.expected, exc.received, scenario) from None
        except PlanningError:  # an unknown name
            raise _flag_error("--policies", f"names MANOEUVRE[+PING] with MANOEUVRE in "
                              f"{', '.join(sorted(MANOEUVRES))} and PING in "
                              f"{', '.join(sorted(PINGS))}", name, scenario) from None
    if scenario.prior is None:
        raise _scenario_error("prior", "a [prior] table: every policy is flown against the "
                              "particle filter, which starts from the prior (and --truth prior "
                              "draws the truths from it); add one (see the example of "
                              "docs/scenario-files.md)",
                              None, scenario)
    check_truth_source(scenario, getattr(args, "truth", "prior") == "prior")
    turning = [p.strip() for p in args.policies.split(",")
               if p.strip() and p.strip().split("+")[0] != "straight"]
    if turning and scenario.observer.turn_rate_max is None:
        raise _scenario_error("observer.turn_rate_max", "a turn-rate limit of the own ship "
                              "(e.g. turn_rate_max = \"0.5 deg/s\" in [observer]) for the "
                              f"turning policies {', '.join(turning)}, or --policies "
                              "straight[+PING] only", None, scenario)


def _check_rank_costs(args: argparse.Namespace, scenario: Any) -> None:
    # with several contacts this runs on every contact's view before the first ranking: a
    # contact without a prior is refused before hours of runs on the contacts before it
    if scenario.prior is None:
        raise _scenario_error("prior", "a [prior] table: every candidate is flown against "
                              "the particle filter, which starts from the prior, and the "
                              "truths are drawn from it", None, scenario)
    check_truth_source(scenario, True)


#: Verbs whose results depend on the prior (the others do not read it).
_PRIOR_VERBS = frozenset({"bound", "track", "plan", "schedule", "compare", "demo"})


def _truth_note(verb: str, scenario: Any, whose: tuple[Any, int] | None = None) -> None:
    # ``whose``: (the several-contact scenario, the index of the contact ``scenario`` is the
    # view of), to name the contact's table and the contact as its errors do
    if verb not in _PRIOR_VERBS:
        return
    p = scenario.prior
    fields = p.truth_fields if p is not None else ()
    if fields:
        names = [f"prior.{f}" if whose is None else contact_field(*whose, f"prior.{f}")
                 for f in fields]
        tail = "" if whose is None else f" (contact '{whose[0].contacts[whose[1]].name}')"
        print(f"tmaplan {verb}: warning: {scenario.name}: the prior is centred on the target's "
              f"true initial state ({', '.join(names)} from the truth){tail}",
              file=sys.stderr)


def preflight(args: argparse.Namespace, scenario: Any) -> None:
    """Checks of the arguments that need the scenario, before any work starts.

    Raises :class:`tmaplan.errors.ArgumentError` naming the flag for: ``plan --horizon`` /
    ``--control-interval`` not whole (``--control-interval`` alone: in the problem's planning
    horizon) or over :data:`tmaplan.cli.args.MAX_PLAN_STEPS`, ``plan --horizon`` past the
    problem's ``time.horizon`` (the plan's track would leave the problem's grid, which
    ``schedule --observer-plan`` refuses), ``plan --pings`` with an objective that has no joint
    form or more pings than steps; ``schedule --budget`` over the number of steps; ``crlb`` /
    ``track --frequencies`` over the problem's lines; ``compare --policies`` empty or repeated;
    ``bound --ping-every`` below dt or ``--ping-steps`` beyond the horizon; ``schedule
    --observer-plan`` not a plan of this problem on its grid; ``compare`` turning policies
    without ``observer.turn_rate_max``; ``track`` estimator/bound combinations that cannot give
    a number (``--bound prior`` (no range bound; with ``mle``: not used), ``range-only`` without
    ranges, ``mle`` on a target whose process noise drifts more than
    :data:`tmaplan.estimators.applicability.MLE_DRIFT_RATIO_MAX` times the finest measurement
    noise over the horizon, the drift being the NCV position std ``sqrt(q T³/3)``). Then prints
    a one-line warning on stderr when the scenario's prior takes values from the truth
    (``prior.centred_on_truth`` or ``course_mode = "true"``): every run of a verb that uses the
    prior says so. Output paths first (:func:`tmaplan.cli.paths.check_outputs`): ``--json PATH``
    naming an input of the verb (the problem file, ``--observer-plan``) or an existing file that
    is not a JSON document is refused (the output would overwrite it), as is a ``--json`` or
    ``--out`` where no file can be created.
    """
    check_outputs(args, scenario.name)
    check_memory(args, scenario)  # first: the verbs' checks below may allocate per step
    check = {"plan": _check_plan, "bound": _check_bound, "track": _check_track,
             "schedule": _check_schedule, "compare": _check_compare,
             "rank-costs": _check_rank_costs,
             "crlb": _check_frequencies}.get(args.verb)
    if check is not None:
        check(args, scenario)
    check_feasible(args, scenario, prior_verb=args.verb in _PRIOR_VERBS)
    _truth_note(args.verb, scenario, getattr(args, "contact_of", None))

