"""A CLI policy name parsed: ``manoeuvre[+ping]`` (:data:`tmaplan.policies.combine.MANOEUVRES`,
:data:`~tmaplan.policies.combine.PINGS`), or for several contacts the names of
:mod:`tmaplan.policies.contacts`.

Above both :mod:`~tmaplan.policies.combine` and :mod:`~tmaplan.policies.contacts`: a
several-contact policy is built from the single-contact ones, so the dispatch on the number
of contacts sits here and the imports run one way.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from tmaplan.errors import ArgumentError, PlanningError
from tmaplan.models.sensors import default_ping_budget
from tmaplan.policies.combine import MANOEUVRES, PINGS, Combined
from tmaplan.policies.contacts import check_contacts_policy, parse_contacts_policy
from tmaplan.policies.pings import NoPing
from tmaplan.simulate import ping_sensors

if TYPE_CHECKING:
    from tmaplan.scenario import Scenario

__all__ = ["check_policy", "parse_policy"]


def check_policy(spec: str, scenario: Scenario) -> tuple[str, str | None]:
    """The manoeuvre and ping names of a CLI policy name ``manoeuvre[+ping]``, checked against
    the scenario before anything is computed: the one check behind :func:`parse_policy` and
    ``tmaplan compare``'s up-front check of ``--policies``.

    Raises
    ------
    PlanningError
        For an unknown name (the message lists the valid ones).
    ArgumentError
        ``policy``: a ping policy (any but ``no-ping``) on a problem that cannot ping in the
        closed loop: without an active range sensor (:func:`tmaplan.simulate.ping_sensors`),
        or with no pings to spend (``planning.ping_budget`` 0 or no ``[planning]`` table:
        the CLI's ping policies spend the scenario's budget). The same refusal for every
        ping policy: a uniform or adaptive policy would silently never ping.
    """
    if len(scenario.contacts) > 1:  # several contacts: their own policies

        man, ping, _ = check_contacts_policy(spec, scenario)
        return man, ping
    if not isinstance(spec, str):  # (None.strip() was an AttributeError)
        raise PlanningError(f"unknown policy {spec!r}: expected a name MANOEUVRE[+PING]")
    parts = spec.strip().split("+")
    if len(parts) > 2 or parts[0] not in MANOEUVRES or (len(parts) == 2
                                                        and parts[1] not in PINGS):
        raise PlanningError(f"unknown policy {spec!r}: expected MANOEUVRE[+PING] with MANOEUVRE "
                            f"in {sorted(MANOEUVRES)} and PING in {sorted(PINGS)}")
    ping = parts[1] if len(parts) == 2 else None
    if ping in (None, "no-ping"):
        return parts[0], ping
    if not ping_sensors(scenario):
        raise ArgumentError("policy", "no ping policy (+PING): there is no range sensor to "
                            "ping with (add a [[sensors]] kind = 'range' with active = true, "
                            f"or fly {parts[0]} without +{ping})", spec, source=scenario.name)
    pl = scenario.planning
    if default_ping_budget(scenario) == 0:
        raise ArgumentError("policy", "no ping policy (+PING): the problem has no pings to "
                            "spend (planning.ping_budget is "
                            f"{'0' if pl is not None else 'not set: no [planning] table'}; "
                            f"or fly {parts[0]} without +{ping})", spec, source=scenario.name)
    return parts[0], ping


def parse_policy(spec: str, scenario: Scenario) -> Combined:
    """Policy from a CLI name: ``manoeuvre[+ping]``, e.g. ``receding+scheduled``.

    Manoeuvres (:data:`MANOEUVRES`): straight, single-turn and zigzag (the best of the
    baseline grids of :mod:`tmaplan.planning.baselines` for :data:`CLOSED_LOOP_OBJECTIVE`),
    planned, receding (every re-plan solved to IPOPT's tolerance by a condensed
    quasi-Newton SQP, warm-started from the previous plan; also receding-sqp),
    receding-ipopt (an IPOPT solve at every re-plan: the default before issue 42),
    receding-realtime (real-time iteration, a full IPOPT re-solve when the optimum moved
    far: the default before that), receding-rti (real-time-iteration
    steps only: no full re-solve when the optimum moves far; a rejected step still falls
    back to IPOPT), receding-multistart (IPOPT re-plans from five starts), leg-turn-leg,
    lead-lag. Several contacts: :mod:`tmaplan.policies.contacts` (``planned`` the joint plan,
    ``nearest-contact``, ``heaviest-contact``, ``alternate``, ``single-turn``, ``straight``).
    Pings (:data:`PINGS`): no-ping, uniform,
    scheduled (offline schedule minimising the mean range bound over the horizon),
    scheduled-terminal (minimising the terminal range bound), adaptive.

    Raises
    ------
    PlanningError
        For an unknown name (the message lists the valid ones).
    ArgumentError
        A ping policy on a problem without a range sensor (:func:`check_policy`).
    """
    if len(scenario.contacts) > 1:  # several contacts: tmaplan.policies.contacts

        return parse_contacts_policy(spec, scenario)
    manoeuvre, ping = check_policy(spec, scenario)
    return Combined(manoeuvre=MANOEUVRES[manoeuvre](scenario),
                    ping=PINGS[ping]() if ping is not None else NoPing())
