"""Does the plan pay in general? Random planning problems and the issue-13 criteria on them.

The "Done when" of issue 13 is re-checked "on geometries you do not see": a plan that beats
the baselines on three built-in problems may have been made to. This module draws *random
planning problems* from a base problem and checks the same criteria on each:

* :class:`ProblemFamily`: the limits of the random geometry (contact bearing relative to the
  own course, prior range interval, target speed bound, own speed, bearing noise, horizon);
* :func:`random_problem` / :func:`random_problems`: problems drawn from a base scenario by a
  seeded :class:`numpy.random.Generator`, each a normal, validated
  :class:`tmaplan.scenario.Scenario` (built with :meth:`Scenario.replace`, no second format);
  problem ``i`` of seed ``s`` depends only on ``(s, i)``;
* :func:`general_check`: per problem, the Monte Carlo tuned turn on seeds of its own, the
  paired campaign :func:`tmaplan.experiments.plan_campaign` and the differences
  ``planned − X`` (:func:`tmaplan.experiments.planned_differences`);
* :func:`criteria`: which of the issue's inequalities those differences meet.

``benchmarks/planning_general.py`` prints the table docs/results/unseen-problems.md records.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.errors import ArgumentError, as_real, finite_real, is_integer
from tmaplan.evaluation.metrics import PairedDifference
from tmaplan.evaluation.plan_check import plan_campaign, planned_differences, tune_single_turn
from tmaplan.evaluation.seeding import run_seeds
from tmaplan.scenario import Scenario
from tmaplan.units import DEG, KNOT

__all__ = ["CRITERIA", "ProblemFamily", "criteria", "general_check", "random_problem",
           "random_problems"]

_MINUTE = 60.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class ProblemFamily:
    """Limits of the random planning problems; every field is a ``(low, high)`` interval
    sampled uniformly (the horizon on a grid of ``horizon_step``).

    Attributes
    ----------
    relative_bearing : tuple of float
        Prior mean of the contact bearing relative to the own ship's initial course [rad],
        in [−π, π] (0: dead ahead, ±π: dead astern).
    range_min : tuple of float
        Lower end of the prior's range interval [m], > 0.
    range_ratio : tuple of float
        Upper end over lower end of the prior's range interval, > 1.
    target_speed_max : tuple of float
        Bound of the prior's target speed [m/s], > 0.
    own_speed : tuple of float
        Own-ship speed [m/s] (constant), > 0.
    bearing_sigma : tuple of float
        Bearing noise std [rad], in (0, 0.2].
    horizon : tuple of float
        Scenario and planning horizon [s]; drawn on multiples of ``horizon_step``.
    horizon_step : float
        Grid of the horizon [s], > 0 (a multiple of the base's dt, control and re-plan
        intervals).
    """

    relative_bearing: tuple[float, float] = (-math.pi, math.pi)
    range_min: tuple[float, float] = (3e3, 12e3)
    range_ratio: tuple[float, float] = (2.0, 5.0)
    target_speed_max: tuple[float, float] = (6.0 * KNOT, 18.0 * KNOT)
    own_speed: tuple[float, float] = (4.0 * KNOT, 10.0 * KNOT)
    bearing_sigma: tuple[float, float] = (0.5 * DEG, 2.0 * DEG)
    horizon: tuple[float, float] = (30.0 * _MINUTE, 50.0 * _MINUTE)
    horizon_step: float = 5.0 * _MINUTE

    def __post_init__(self) -> None:
        check_intervals(self, {"relative_bearing": (-math.pi, math.pi, "[-pi, pi] rad"),
                               "range_min": (0.0, math.inf, "> 0 m"),
                               "range_ratio": (1.0, math.inf, "> 1"),
                               "target_speed_max": (0.0, math.inf, "> 0 m/s"),
                               "own_speed": (0.0, math.inf, "> 0 m/s"),
                               "bearing_sigma": (0.0, 0.2, "(0, 0.2] rad"),
                               "horizon": (0.0, math.inf, "> 0 s")})
        finite_real("horizon_step", self.horizon_step, "> 0 s", lower=0.0, strict=True)
        if math.floor(self.horizon[1] / self.horizon_step + 1e-9) < math.ceil(
                self.horizon[0] / self.horizon_step - 1e-9):
            raise ArgumentError("horizon", f"an interval holding a multiple of horizon_step "
                                f"= {self.horizon_step:g} s", self.horizon)


def _check_base(base: Scenario) -> None:
    p = base.prior
    if p is None or p.kind != "polar" or p.range_distribution == "normal" \
            or p.velocity_distribution != "speed-course" or p.speed_max is None:
        raise ArgumentError("base", "a planning problem with a polar prior, a uniform or "
                            "log-uniform range and a speed-course velocity prior "
                            "(e.g. 'default')", base.name)
    if base.planning is None or not base.sensors_of("bearing"):
        raise ArgumentError("base", "a planning problem with a [planning] section and a "
                            "bearing sensor", base.name)


def _course(base: Scenario) -> float:
    o = base.observer
    if o.course is not None:
        return float(o.course)
    if o.velocity is not None:
        return float(math.atan2(o.velocity[0], o.velocity[1]))
    raise ArgumentError("base", "an observer with an initial course or velocity", base.name)


def random_problem(base: Scenario, rng: np.random.Generator, *,
                   family: ProblemFamily | None = None, name: str | None = None) -> Scenario:
    """One random planning problem derived from ``base``.

    The own ship keeps the base's position, course and turn-rate limit at a constant drawn
    speed; the prior keeps its bearing std, range distribution and course model, with a drawn
    bearing mean (relative to the own course), range interval and speed bound (its lower
    speed bound clipped to half the drawn bound); the bearing sensors get the drawn noise; the
    scenario and planning horizons are the drawn horizon. The single-run truth (campaigns draw
    truths from the prior) sits at the prior's mean bearing and mid range, at the middle of
    the prior's speed interval, on the prior's course (``given``) or heading for the own ship.

    Parameters
    ----------
    base : Scenario
        A planning problem with a polar prior (e.g. ``load_problem("default")``).
    rng : numpy.random.Generator
        Source of the draws.
    family : ProblemFamily, optional
        Limits of the draws (default :class:`ProblemFamily`).
    name : str, optional
        Name of the problem (default: the base's with ``-random``).

    Returns
    -------
    Scenario
        Validated by :meth:`tmaplan.scenario.Scenario.replace`; its ``description`` lists the
        draws.
    """
    if not isinstance(rng, np.random.Generator):
        raise ArgumentError("rng", "a numpy.random.Generator", type(rng).__name__)
    fam = family if family is not None else ProblemFamily()
    _check_base(base)
    course = _course(base)
    rel = float(rng.uniform(*fam.relative_bearing))
    r_min = float(rng.uniform(*fam.range_min))
    r_max = r_min * float(rng.uniform(*fam.range_ratio))
    v_max = float(rng.uniform(*fam.target_speed_max))
    own = float(rng.uniform(*fam.own_speed))
    sigma = float(rng.uniform(*fam.bearing_sigma))
    k_lo = math.ceil(fam.horizon[0] / fam.horizon_step - 1e-9)
    k_hi = math.floor(fam.horizon[1] / fam.horizon_step + 1e-9)
    horizon = fam.horizon_step * int(rng.integers(k_lo, k_hi + 1))

    bearing = math.remainder(course + rel, 2.0 * math.pi)
    prior, planning = base.prior, base.planning
    if prior is None or planning is None:  # refused by _check_base; narrows the types
        raise ArgumentError("base", "a planning problem with a prior", base.name)
    new_prior = dataclasses.replace(prior, bearing_mean=bearing, range_min=r_min,
                                    range_max=r_max, speed_max=v_max,
                                    speed_min=min(prior.speed_min, 0.5 * v_max))
    # the bearing mean is given now: the truth opt-in stays only for a mean still omitted
    new_prior = dataclasses.replace(new_prior, centred_on_truth=prior.centred_on_truth
                                    and bool(new_prior.truth_means))
    r0 = 0.5 * (r_min + r_max)
    x0, y0 = base.observer.position
    t_course = (float(prior.course_mean) if prior.course_mode == "given"
                and prior.course_mean is not None else math.remainder(bearing + math.pi,
                                                                      2.0 * math.pi))
    target = dataclasses.replace(base.target, position=(x0 + r0 * math.sin(bearing),
                                                        y0 + r0 * math.cos(bearing)),
                                 velocity=None, course=t_course,
                                 speed=0.5 * (new_prior.speed_min + v_max))
    observer = dataclasses.replace(base.observer, velocity=None, course=course, speed=own,
                                   speed_min=own, speed_max=own)
    sensors = tuple(dataclasses.replace(s, sigma=sigma) if s.kind == "bearing" else s
                    for s in base.sensors)
    desc = (f"Random planning problem from '{base.name}': contact {math.degrees(rel):+.0f} deg "
            f"relative, {r_min / 1e3:.1f}-{r_max / 1e3:.1f} km, target <= {v_max / KNOT:.1f} "
            f"kn, own ship {own / KNOT:.1f} kn, bearing sigma {math.degrees(sigma):.2f} deg, "
            f"{horizon / _MINUTE:.0f} min")
    return base.replace(name=name or f"{base.name}-random", description=desc,
                        time=dataclasses.replace(base.time, horizon=horizon),
                        target=target, observer=observer, sensors=sensors, prior=new_prior,
                        planning=dataclasses.replace(planning, horizon=horizon))


def random_problems(base: Scenario, count: int, *, seed: int = 0,
                    family: ProblemFamily | None = None) -> tuple[Scenario, ...]:
    """``count`` random planning problems from ``base`` (:func:`random_problem`).

    Problem ``i`` is drawn by ``default_rng(SeedSequence(seed, spawn_key=(i,)))`` (the seed of
    run ``i``, :func:`tmaplan.evaluation.seeding.run_seed`) and named
    ``<base>-s<seed>-<i>``, so it depends on ``(seed, i)`` only, not on ``count``.

    Parameters
    ----------
    base : Scenario
    count : int
        Number of problems, >= 1.
    seed : int
        Root seed, >= 0.
    family : ProblemFamily, optional

    Returns
    -------
    tuple of Scenario
    """
    return draw_problems(random_problem, base, count, seed=seed, family=family)


def draw_problems(draw: Callable[..., Scenario], base: Scenario, count: int, *, seed: int,
                  family: Any) -> tuple[Scenario, ...]:
    """``count`` problems ``draw(base, rng, family=family, name=...)``, problem ``i`` drawn by
    ``default_rng(SeedSequence(seed, spawn_key=(i,)))`` and named ``<base>-s<seed>-<i>``
    (the rule of :func:`random_problems`), ``count`` and ``seed`` checked first.

    Raises
    ------
    ArgumentError
        ``count`` not an integer >= 1, ``seed`` not an integer >= 0.
    """
    if not is_integer(count, 1):
        raise ArgumentError("count", "an integer >= 1", count)
    if not is_integer(seed, 0):
        raise ArgumentError("seed", "an integer >= 0", seed)
    return tuple(draw(base, np.random.default_rng(s), family=family,
                      name=f"{base.name}-s{seed}-{i}")
                 for i, s in enumerate(run_seeds(seed, int(count))))


def check_intervals(family: Any, limits: Mapping[str, tuple[float, float, str]]) -> None:
    """Check a problem family's ``(low, high)`` fields: ``limits`` maps a field name to
    ``(lo, hi, text)``; each field must be a pair of finite reals with ``low <= high``,
    ``lo < low`` (``lo <= low`` for ``relative_bearing``, a closed interval) and
    ``high <= hi``.

    Raises
    ------
    ArgumentError
        Naming the first field that is not such a pair (``text`` its expected values).
    """
    for name, (lo, hi, text) in limits.items():
        v = getattr(family, name)
        closed = name == "relative_bearing"
        ok = (isinstance(v, tuple) and len(v) == 2
              and all(math.isfinite(as_real(x)) for x in v)
              and v[0] <= v[1] and (lo <= v[0] if closed else lo < v[0]) and v[1] <= hi)
        if not ok:
            raise ArgumentError(name, f"(low, high) with low <= high, each {text}", v)


#: The issue's inequalities: name -> (baseline X, bound on the paired interval of
#: ``planned − X`` [s], which end). ``receding`` is the other way round: ``receding −
#: planned`` below zero is ``planned − receding`` above zero.
CRITERIA: Mapping[str, tuple[str, float, str]] = {
    "sooner than straight": ("straight", 0.0, "high"),
    "sooner than the cost's single turn": ("single-turn", 0.0, "high"),
    "sooner than leg-turn-leg": ("leg-turn-leg", 0.0, "high"),
    "sooner than lead-lag": ("lead-lag", 0.0, "high"),
    "no worse than the tuned turn (+1 min)": ("tuned-turn", 60.0, "high"),
    "receding beats planned": ("receding", 0.0, "low"),
}


def criteria(differences: Mapping[str, PairedDifference]) -> dict[str, bool]:
    """Which criteria of :data:`CRITERIA` the differences ``planned − X`` meet.

    A criterion whose baseline was not flown is left out. ``high``: the upper end of the
    paired interval is below the bound; ``low``: the lower end is above it.
    """
    out = {}
    for name, (x, bound, end) in CRITERIA.items():
        if x in differences:
            d = differences[x]
            out[name] = bool(d.ci_high < bound) if end == "high" else bool(d.ci_low > bound)
    return out


def general_check(problem: Scenario, *, runs: int = 60, seed: int = 0, tune_runs: int = 8,
                  tune_seed: int = 1000, n_particles: int = 3000, receding: bool = False,
                  workers: int = 1, out_dir: str | Path | None = None,
                  ) -> dict[str, PairedDifference]:
    """The differences ``planned − X`` of the mean time to accuracy on one problem [s].

    Tunes a single turn by Monte Carlo on ``tune_seed``
    (:func:`tmaplan.experiments.tune_single_turn`), then flies the paired campaign
    :func:`tmaplan.experiments.plan_campaign` on ``seed`` (``receding`` too if asked).

    Parameters
    ----------
    problem : Scenario
    runs, seed : int
        Paired evaluation runs and their root seed.
    tune_runs, tune_seed : int
        Runs per grid point of the tuning and their root seed (keep it apart from ``seed``);
        ``tune_runs=0``: no tuned turn (no ``tuned-turn`` entry).
    n_particles, receding, workers, out_dir :
        As for :func:`tmaplan.experiments.plan_campaign` (resumable with ``out_dir``).

    Returns
    -------
    dict
        Baseline name -> :class:`tmaplan.evaluation.metrics.PairedDifference` of
        ``planned − X`` (:func:`criteria` reads it).
    """
    # all checked before the tuning campaign, which takes minutes
    for field, value, least in (("runs", runs, 1), ("seed", seed, 0), ("tune_seed", tune_seed, 0)):
        if not is_integer(value, least):
            raise ArgumentError(field, f"an integer >= {least}", value)
    if tune_seed == seed:
        raise ArgumentError("tune_seed", f"a seed other than the evaluation's ({seed})",
                            tune_seed)
    if not is_integer(tune_runs, 0):
        raise ArgumentError("tune_runs", "an integer >= 0 (0: no tuned turn)", tune_runs)
    tuned = None
    if tune_runs > 0:
        tuned, _ = tune_single_turn(problem, runs=tune_runs, seed=tune_seed,
                                    n_particles=n_particles, workers=workers, out_dir=out_dir)
    camp = plan_campaign(problem, runs=runs, seed=seed, n_particles=n_particles, tuned=tuned,
                         receding=receding, workers=workers, out_dir=out_dir)
    return planned_differences(camp)
