"""What each estimator applies to, and the check that refuses a combination that cannot work.

Every estimator of :data:`tmaplan.estimators.runner.ESTIMATORS` declares an
:class:`Applicability` (:data:`APPLICABILITY`): the measurement kinds it needs and how many,
the target models it is defined for, the bound kinds of the Monte Carlo evaluation that give
it a position *and* a range bound, and whether it fits one deterministic track.
:func:`check_applicable` turns a combination that cannot give a number (an estimator without
its measurements, a bound kind not defined for it, the batch MLE on a target whose process
noise moves it far more than the measurements resolve) into one
:class:`~tmaplan.errors.ArgumentError` line that says why and what would apply. It is called by
:func:`tmaplan.evaluation.tracking.monte_carlo` and by ``tmaplan track`` before any run.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Literal

import numpy as np

from tmaplan.display import timespan
from tmaplan.errors import ArgumentError, ScenarioError, warn_field
from tmaplan.scenario import Scenario, measurement_steps
from tmaplan.scenario.contacts import contact_field
from tmaplan.simulate import simulate

__all__ = ["APPLICABILITY", "MLE_DRIFT_RATIO_MAX", "Applicability", "applicable_estimators",
           "check_applicable", "warn_filter_model"]

MLE_DRIFT_RATIO_MAX = 10.0
"""The batch MLE is refused when the target's process noise moves it by more than this many
times the finest measurement noise over the horizon (its χ² acceptance test would reject every
run)."""

_ALL_MODELS = frozenset({"ncv", "multi-leg", "constant-turn"})
#: The models of the particle filters' NCV dynamics (and of the PCRB they are compared with).
_NCV_MODELS = frozenset({"ncv", "multi-leg"})


@dataclasses.dataclass(frozen=True, kw_only=True)
class Applicability:
    """What an estimator applies to.

    Attributes
    ----------
    what : str
        The estimator in a few words, for messages (e.g. "range-only tracking of sharma2024").
    needs : frozenset of str
        Measurement kinds ("bearing", "range", "frequency") the estimator uses; the scenario
        must measure at least ``min_measurements`` of them over the horizon.
    min_measurements : int
        Fewest measurements of the kinds in ``needs`` [count].
    why_min : str
        Why that many (message text).
    target_models : frozenset of str
        Target models it is defined for ("ncv", "multi-leg", "constant-turn").
    bounds : frozenset of str
        Bound kinds of :func:`~tmaplan.evaluation.tracking.monte_carlo` that give it both a
        position and a range bound: "truth" (PCRB along the runs' truths, ristic2004 ch. 6),
        "crlb" (batch CRLB at the truth). The filters' "prior" (prior-averaged PCRB) is a
        position bound only.
    needs_prior : {"always", "bound", "never"}
        Whether it needs the scenario's ``[prior]``: "always" (it starts from the prior),
        "bound" (only its bound does: the PCRB starts from ``J₀ = P₀⁻¹``), "never".
    deterministic : bool
        Fits one deterministic track (the batch MLE, clavard2013): refused when the target's
        process-noise drift over the horizon, ``sqrt(q T³ / 3)`` [m], exceeds
        :data:`MLE_DRIFT_RATIO_MAX` times the finest measurement noise in metres.
    """

    what: str
    needs: frozenset[str]
    min_measurements: int = 1
    why_min: str = ""
    target_models: frozenset[str] = _ALL_MODELS
    bounds: frozenset[str] = frozenset({"truth"})
    needs_prior: Literal["always", "bound", "never"] = "always"
    deterministic: bool = False


#: The declaration of every named estimator.
APPLICABILITY: dict[str, Applicability] = {
    "pf": Applicability(what="the particle filter of gordon1993",
                        needs=frozenset({"bearing", "range", "frequency"}),
                        target_models=_NCV_MODELS),
    "pf-bearings": Applicability(
        what="the particle filter started from bearings, brehard2004",
        needs=frozenset({"bearing"}), min_measurements=7,
        why_min="its batch initialisation fits a track to the first 2k + 1 bearings, k >= 3",
        needs_prior="bound", target_models=_NCV_MODELS),
    "mle": Applicability(
        what="the batch MLE of clavard2013", needs=frozenset({"bearing"}), min_measurements=5,
        why_min="its grid start and acceptance test are built on bearings, more of them than "
                "the 4 parameters of a constant-velocity track",
        bounds=frozenset({"crlb"}), needs_prior="never", deterministic=True),
    "range-only": Applicability(
        what="range-only tracking of sharma2024", needs=frozenset({"range"}), min_measurements=3,
        why_min="range measurements at every scan"),
}

#: Order in which applicable alternatives are suggested.
_PREFERENCE = ("range-only", "pf", "pf-bearings", "mle")


def _count(scenario: Scenario, kinds: frozenset[str]) -> int:
    """Measurements of ``kinds`` over the horizon; a range sensor's with a ``max_range`` only
    where the noise-free true range is within it (a reading beyond the reach returns nothing,
    :func:`tmaplan.simulate.simulate`)."""
    sensors = [s for s in scenario.sensors if s.kind in kinds]
    r = None
    if any(getattr(s, "max_range", None) is not None for s in sensors):
        rel = simulate(scenario, None).relative
        r = np.hypot(rel[:, 0], rel[:, 1])
    n = 0
    for s in sensors:
        steps = measurement_steps(s, scenario.time)
        reach = getattr(s, "max_range", None)
        n += int(steps.size if reach is None or r is None else np.sum(r[steps] <= reach))
    return n


def _reach_note(scenario: Scenario, kinds: frozenset[str]) -> str:
    """`` within max_range on the true track`` when a counted sensor has a reach."""
    reach = any(getattr(s, "max_range", None) is not None for s in scenario.sensors
                if s.kind in kinds)
    return " within max_range on the true track" if reach else ""


def _resolution(scenario: Scenario) -> tuple[float, str]:
    """Finest measurement noise of the scenario in metres along its truth, and its name."""
    rel = simulate(scenario, None).relative
    r = np.hypot(rel[:, 0], rel[:, 1])
    best = (math.inf, "")
    for sen in scenario.sensors:
        steps = measurement_steps(sen, scenario.time)
        if not steps.size:
            continue
        if sen.kind == "bearing":
            r_min = float(np.min(r[steps]))
            best = min(best, (sen.sigma * r_min, f"bearing noise {np.degrees(sen.sigma):.3g}° "
                              f"at {r_min / 1e3:.3g} km"))
        elif sen.kind == "range":
            best = min(best, (sen.sigma, f"range noise {sen.sigma:g} m"))
    return best


def _reason(name: str, decl: Applicability, scenario: Scenario, bound: Any) -> str | None:
    """Why ``name`` cannot work on ``scenario`` with ``bound``, or None."""
    n = _count(scenario, decl.needs)
    if n < decl.min_measurements:
        kinds = " or ".join(sorted(decl.needs))
        why = f" ({decl.why_min})" if decl.why_min else ""
        return (f"{name} ({decl.what}) needs at least {decl.min_measurements} {kinds} "
                f"measurements{why}, {scenario.name} has {n}{_reach_note(scenario, decl.needs)}")
    if _lacks_prior(decl, scenario, bound):
        return f"{_prior_need(name, decl)}, {scenario.name} has no [prior] table"
    model = scenario.target.model
    if model not in decl.target_models:
        why = (" (its dynamics are nearly constant velocity, as the PCRB's)"
               if decl.target_models == _NCV_MODELS else "")
        return (f"{name} ({decl.what}) is defined for {', '.join(sorted(decl.target_models))}"
                f" targets{why}, {scenario.name}'s is {model}")
    q = float(scenario.target.q)
    if decl.deterministic and model != "constant-turn" and q > 0:
        t = float(scenario.time.horizon)
        drift = math.sqrt(q * t**3 / 3.0)
        res, what = _resolution(scenario)
        if drift > MLE_DRIFT_RATIO_MAX * res:
            return (f"{name} fits one deterministic track (clavard2013), but the target's "
                    f"process noise q = {q:g} m^2/s^3 moves it by {drift:.0f} m (1σ) over the "
                    f"{timespan(t)} horizon, {drift / res:.0f}× the finest measurement ({what}; "
                    f"limit {MLE_DRIFT_RATIO_MAX:g}×): its χ² test would reject every run "
                    f"(NaN RMSE)")
    return None


def _prior_need(name: str, decl: Applicability) -> str:
    """Why estimator ``name`` needs the prior (``decl.needs_prior`` "always" or "bound")."""
    what = ("starts from the prior" if decl.needs_prior == "always" else
            "is compared with the PCRB, which starts from the prior (J₀ = P₀⁻¹)")
    return f"{name} ({decl.what}) {what}"


def _lacks_prior(decl: Applicability, scenario: Scenario, bound: Any) -> bool:
    """Whether the estimator (with ``bound``) needs the prior that ``scenario`` lacks."""
    return scenario.prior is None and (decl.needs_prior == "always" or (
        decl.needs_prior == "bound" and bound is not False))


def applicable_estimators(scenario: Scenario) -> tuple[str, ...]:
    """Names of the estimators that apply to ``scenario`` (with their own bound)."""
    return tuple(n for n in _PREFERENCE
                 if _reason(n, APPLICABILITY[n], scenario, None) is None)


def check_applicable(estimator: Any, scenario: Scenario, *, bound: Any = None,
                     cli: bool = False) -> None:
    """Refuse an estimator / scenario / bound combination that cannot give a number.

    Parameters
    ----------
    estimator : str or Estimator
        A name of :data:`APPLICABILITY` or an estimator with an ``applicability`` attribute
        (others are not checked).
    scenario : Scenario
    bound : {None, True, False, "truth", "prior"}
        The bound asked for (None, True, False, "truth": the estimator's own). "prior" is
        refused for the MLE (compared with the CRLB) and, with ``cli``, for the filters too
        (the prior-averaged PCRB has no range bound; through the API it is a position bound).
    cli : bool
        Name the options as command-line flags (``--estimator``, ``--bound``).

    Raises
    ------
    ArgumentError
        One line: field ``estimator`` (or ``bound``), what would apply, and the reason.
    """
    name = estimator if isinstance(estimator, str) else getattr(estimator, "name", None)
    decl = getattr(estimator, "applicability", None) if not isinstance(estimator, str) \
        else APPLICABILITY.get(estimator)
    if decl is None or name is None:
        return
    opt_e, opt_b = ("--estimator", "--bound") if cli else ("estimator", "bound")
    reason = _reason(name, decl, scenario, bound)
    if reason is not None:
        alts = [a for a in applicable_estimators(scenario) if a != name]
        if not alts and _lacks_prior(decl, scenario, bound):  # the file is at fault
            raise ScenarioError("prior", f"a [prior] table: {_prior_need(name, decl)} "
                                "(and no estimator applies without one)", None,
                                source=scenario.name)
        use = (f"use {opt_e} {' or '.join(alts)}" if alts else
               "no estimator applies to this scenario")
        raise ArgumentError(opt_e, f"an estimator that applies: {reason}; {use}", name,
                            source=scenario.name)
    if bound != "prior" or ("prior" in decl.bounds) or not (cli or "crlb" in decl.bounds):
        return
    own = sorted(decl.bounds)[0]
    if "crlb" in decl.bounds:
        raise ArgumentError(opt_b, f"'truth' (the default) with {opt_e} {name}: {name} is "
                            f"compared with the batch CRLB at the truth, {opt_b} chooses the "
                            "filters' PCRB", bound, source=scenario.name)
    raise ArgumentError(opt_b, f"'{own}' (the default): the prior-averaged PCRB gives a "
                        "position bound only, its range bound would print as NaN; use "
                        f"{opt_b} {own} (the PCRB along each run's truth, ristic2004 ch. 6) or "
                        "`tmaplan bound P --method monte-carlo` for the prior average", bound,
                        source=scenario.name)


def warn_filter_model(scenario: Scenario) -> None:
    """Warn (:class:`tmaplan.errors.ScenarioWarning`, one line per contact naming its
    ``target.model``) for each contact whose true motion the particle filter does not model
    (a constant-turn target: the filter assumes nearly-constant velocity).

    A campaign against the scenario's own truths (``compare --truth scenario``) flies the
    filter there anyway, a legitimate study of its robustness to the mismatch, where
    ``track`` refuses the filter (:func:`check_applicable`); the warning says that the
    results are that study's, not the filter's own case.
    """
    models = APPLICABILITY["pf"].target_models
    several = len(scenario.contacts) > 1
    for i, c in enumerate(scenario.contacts):
        if c.target.model in models:
            continue
        who = f" (contact '{c.name}')" if several else ""
        warn_field(contact_field(scenario, i, "target.model"),
                   f"the particle filter assumes a nearly-constant-velocity target, this "
                   f"contact's truth turns: the runs measure the filter's robustness to the "
                   f"model mismatch{who}, received '{c.target.model}'",
                   source=scenario.name, stacklevel=2)
