"""Can the plan be solved? The planning inputs checked before a graph is built (issue 38).

Each rule refuses in one line naming the field (:class:`tmaplan.errors.ScenarioError`), in
milliseconds, what the solver used to find after minutes ("no start converged",
``std::bad_alloc``). :class:`tmaplan.planning.HeadingPlanner` and the offline plan from the
prior (:func:`tmaplan.policies.plan_starts.plan_candidates`) check them, and the command
line before any verb that plans (:func:`tmaplan.cli.preflight.preflight`).

Planning horizon (:func:`check_planning_horizon`)
    ``planning.horizon`` (default ``time.horizon``) is a whole number (>= 1) of control
    intervals (``planning.control_interval``, default dt): shorter than one interval there is
    nothing to plan, and a fraction was rounded silently. Longer than ``time.horizon`` it is
    warned (:func:`warn_long_planning_horizon`): the runs fly and score only the plan's
    steps up to the problem's end.
Keep-out range (:func:`check_keep_out`)
    The planner keeps the target *estimate* (the belief mean propagated at constant
    velocity) outside ``planning.keep_out_range`` of the own ship, from t0 on. Refused when
    the range at t0 of the prior's mean (the estimate the plan starts from), the prior's
    median range (more than :data:`KEEP_OUT_REFUSED` = 50 % of its mass would start inside)
    or the contact's true initial range is at most the keep-out range: the first leaves the
    planner no feasible point (every start failed), the other two make the scenario
    contradict itself (most contacts, or its own, begin inside the zone the plan must keep
    out of). Warned when more than :data:`KEEP_OUT_WARNED` = 5 % of the prior's mass lies
    inside (those contacts start inside it).
Memory (:func:`check_plan_memory`)
    The heading OCP's estimated memory at its number of steps
    (:func:`tmaplan.memory.check_steps`) fits in the memory available.
"""

from __future__ import annotations

import multiprocessing
from typing import TYPE_CHECKING, Any

import numpy as np

from tmaplan.display import distance, seconds_text
from tmaplan.errors import InfeasibleError, ScenarioError, is_whole_count, warn_field
from tmaplan.geometry import range_of
from tmaplan.memory import check_steps
from tmaplan.models.prior import true_initial_state
from tmaplan.planning.belief import Belief

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["KEEP_OUT_REFUSED", "KEEP_OUT_WARNED", "check_keep_out", "check_plan_inputs",
           "check_plan_memory",
           "check_planning_horizon", "check_start_keep_out", "keep_out_share",
           "warn_long_planning_horizon"]

KEEP_OUT_REFUSED = 0.5
"""Share of the prior's mass inside the keep-out range from which a plan is refused."""
KEEP_OUT_WARNED = 0.05
"""Share of the prior's mass inside the keep-out range from which a plan is warned."""


def check_planning_horizon(scenario: Scenario) -> None:
    """The scenario's planning horizon (``planning.horizon``, default ``time.horizon``) is a
    whole number (>= 1) of control intervals (``planning.control_interval``, default dt), else
    :class:`ScenarioError`: the planner would round it silently (a 60 min control interval in
    a 45 min problem planned 60 min). Checked when a planner is built from the file's values,
    not at load: only planning reads these fields."""
    pl, g = scenario.planning, scenario.time
    tc = pl.control_interval if pl is not None and pl.control_interval else g.dt
    h = pl.horizon if pl is not None and pl.horizon else None
    ratio = (h if h is not None else g.horizon) / tc
    if is_whole_count(ratio):
        return
    short = ("; it is shorter than one interval: nothing to plan" if ratio < 1 - 1e-9
             else "")
    if h is not None:
        raise ScenarioError("planning.horizon", f"a whole number (>= 1) of control intervals "
                            f"of {tc:g} s (planning.control_interval, default dt){short}", h,
                            source=scenario.name)
    raise ScenarioError("planning.control_interval", "a whole number of intervals in the "
                        f"planning horizon (time.horizon = {g.horizon:g} s; or give "
                        f"planning.horizon){short}", tc, source=scenario.name)


def warn_long_planning_horizon(scenario: Scenario) -> None:
    """Warn (:class:`tmaplan.errors.ScenarioWarning`, one line naming ``planning.horizon``,
    the value given and the value used) when ``planning.horizon`` is longer than the
    problem's ``time.horizon``: the plans are made over ``planning.horizon`` but a run ends
    at ``time.horizon``, so what is flown and scored is the plan clipped to the problem's end
    (``tmaplan plan``'s offline plan refuses it up front). Said by the main process only: a
    campaign's worker processes build the planners of the main process's scenario, which has
    said it."""
    pl, g = scenario.planning, scenario.time
    if pl is None or not pl.horizon or multiprocessing.parent_process() is not None:
        return
    given, end = float(pl.horizon), float(g.horizon)
    if round(given / float(g.dt)) <= scenario.n_steps:
        return
    # attributed to this line (stacklevel 1): said once per process by Python's default
    # filter, however many planners read the file's horizon (a several-contact planner: 1 + N)
    warn_field("planning.horizon", f"{seconds_text(given)} is longer than time.horizon; "
               f"{seconds_text(end)} used: a plan is made over {seconds_text(given)}, but a "
               f"run ends at time.horizon and flies and scores only its first "
               f"{seconds_text(end)} (give planning.horizon <= time.horizon)",
               source=scenario.name, stacklevel=1)


def keep_out_share(belief: Belief, keep_out: float) -> float:
    """Share of ``belief``'s mass within ``keep_out`` [m] of the own ship (its relative
    positions' range below it; the mean alone for a belief without samples: 0 or 1)."""
    if belief.samples is None:
        return float(belief.mean_range() < keep_out)
    inside = range_of(belief.samples[:, :2]) < keep_out
    w = belief.weights if belief.weights is not None else np.full(inside.size, 1 / inside.size)
    return float(np.sum(w[inside]))


def _median_range(belief: Belief) -> float:
    if belief.samples is None:
        return belief.mean_range()
    r = range_of(belief.samples[:, :2])
    order = np.argsort(r)
    w = belief.weights if belief.weights is not None else np.full(r.size, 1 / r.size)
    cum = np.cumsum(w[order])
    return float(r[order][min(int(np.searchsorted(cum, 0.5)), r.size - 1)])


def check_keep_out(scenario: Scenario, *, belief: Belief | None = None,
                   keep_out: float | None = None, field: str = "planning.keep_out_range"
                   ) -> None:
    """Refuse (or warn) a keep-out range that the prior or the truth start inside (module
    notes).

    Parameters
    ----------
    scenario : Scenario
    belief : Belief, optional
        The prior belief at t0 (default :meth:`Belief.from_prior`; nothing is checked for a
        scenario without a prior).
    keep_out : float, optional
        [m]; default ``planning.keep_out_range`` (0: nothing to check).
    field : str
        The name of ``keep_out`` in the messages.

    Raises
    ------
    ScenarioError
        ``field 'planning.keep_out_range': expected less than 12 km, the contact's true
        initial range (...), received '20 km: 75 % of the prior's mass lies inside'``.
    """
    pl = scenario.planning
    R = float(keep_out if keep_out is not None else (pl.keep_out_range if pl else 0.0))
    if R <= 0 or (belief is None and scenario.prior is None):
        return
    b = Belief.from_prior(scenario) if belief is None else belief
    share = keep_out_share(b, R)
    truth = true_initial_state(scenario)[:2] - np.asarray(scenario.observer.position, float)
    limits = (  # (short name, the reason it bounds the keep-out range, range at t0 [m])
        ("the contact's true initial range", "the contact's true initial range",
         float(range_of(truth))),
        ("the prior's mean", "the range of the prior's mean, the target estimate a plan "
         "starts from", b.mean_range()),
        ("the prior's median", f"the prior's median range (more than {KEEP_OUT_REFUSED:.0%} "
         "of its mass would start inside)", _median_range(b)))
    name, why, limit = min(limits, key=lambda x: x[2])
    if R >= limit:
        others = ", ".join(f"{n} at {distance(v)}" for n, _, v in limits if n != name)
        raise ScenarioError(field, f"less than {distance(limit)}, {why} (a plan keeps the "
                            f"estimate outside the keep-out range from t0; {others})",
                            f"{distance(R)}: {share:.0%} of the prior's mass lies inside",
                            source=scenario.name)
    if share > KEEP_OUT_WARNED:
        warn_field(field, f"{share:.0%} of the prior's mass lies within the keep-out range of "
                          "the own ship at t0 (more than "
                          f"{KEEP_OUT_WARNED:.0%}: the contacts drawn there start inside it), "
                          f"received {distance(R)}", source=scenario.name)


def check_plan_memory(scenario: Scenario, n_steps: int, *,
                      horizon: float | None = None, horizon_field: str = "horizon",
                      copies: int = 1,
                      extra: tuple[tuple[str, int], ...] = (),
                      available: float | None = None) -> None:
    """Refuse a heading OCP of ``n_steps`` steps that would not fit in memory
    (:func:`tmaplan.memory.check_steps`), naming what set the steps: ``horizon`` (an
    argument, ``horizon_field``) if given, else ``planning.horizon`` or ``time.horizon``.

    Parameters
    ----------
    scenario : Scenario
    n_steps : int
        Steps of the plan (K).
    horizon : float, optional
        [s] the horizon given as an argument, named ``horizon_field`` (``"--horizon"`` on
        the command line).
    horizon_field : str
        The name of ``horizon`` in the message.
    copies : int
        Planners built at once (worker processes).
    extra : tuple of (str, int)
        Further computations held at the same time (``(key of tmaplan.memory.MODELS,
        copies)``, e.g. the baselines' objective).
    available : float, optional
        Bytes available (default :func:`tmaplan.memory.available_bytes`).

    Raises
    ------
    ScenarioError or ArgumentError
        If the estimate exceeds the memory available.
    """
    pl = scenario.planning
    if horizon is not None:
        field, value = horizon_field, float(horizon)
    elif pl is not None and pl.horizon:
        field, value = "planning.horizon", float(pl.horizon)
    else:
        field, value = "time.horizon", float(scenario.time.horizon)
    check_steps(n_steps, (("heading", copies), *extra), field=field, dt=scenario.time.dt,
                received=seconds_text(value), source=scenario.name, available=available)


def check_plan_inputs(scenario: Scenario, n_steps: int, *, horizon: float | None = None,
                      **memory: Any) -> None:
    """A heading planner's inputs, checked before its graph is built: without ``horizon``
    (the file's ``planning.horizon`` read), a planning horizon past ``time.horizon`` warned
    (:func:`warn_long_planning_horizon`); then its memory (:func:`check_plan_memory`, with
    ``horizon`` and the further arguments ``memory``).

    Warns
    -----
    ScenarioWarning
        A ``planning.horizon`` longer than ``time.horizon``.

    Raises
    ------
    ScenarioError or ArgumentError
        If the estimated memory exceeds the memory available.
    """
    if horizon is None:
        warn_long_planning_horizon(scenario)
    check_plan_memory(scenario, n_steps, horizon=horizon, **memory)


def check_start_keep_out(belief: Belief, *, keep_out: float, u_max: float,
                         speed_choice: bool, times: np.ndarray) -> None:
    """Refuse a plan's start no plan can satisfy, before any solve
    (:meth:`tmaplan.planning.heading.HeadingPlanner.check_start`).

    Parameters
    ----------
    belief : Belief
        Relative state at the plan's start (its mean is the target estimate).
    keep_out : float
        Keep-out range [m] (0: none).
    u_max : float
        Turn-rate limit [rad/s].
    speed_choice : bool
        Whether the plan may change speed.
    times : ndarray, shape (K + 1,)
        Plan times relative to its start [s].

    Raises
    ------
    InfeasibleError
        The target estimate already inside the keep-out range, or no turn possible
        (``u_max = 0``, fixed speed) and the straight course passing inside it.
    """
    if keep_out <= 0:
        return
    r0 = belief.mean_range()
    if r0 < keep_out:
        raise InfeasibleError(f"keep_out_range {keep_out:.0f} m: the target estimate "
                              f"is already inside it (range {r0:.0f} m)")
    if u_max == 0.0 and not speed_choice:
        rel = belief.mean[:2] + np.asarray(times)[:, None] * belief.mean[2:]
        closest = float(np.min(np.hypot(rel[:, 0], rel[:, 1])))
        if closest < keep_out:
            raise InfeasibleError(
                f"infeasible: turn_rate_max = 0 (no turn possible) and the straight course "
                f"comes within {closest:.0f} m of the target estimate, inside keep_out_range "
                f"{keep_out:.0f} m")
