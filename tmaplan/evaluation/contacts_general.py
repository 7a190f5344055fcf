"""Does the joint plan pay on several-contact geometries it was not tuned on? (issue 40)

The "Done when" of issue 40 asks for the joint plan's advantage "on several-contact geometries
it was not tuned on", not only on ``two-contacts-crossing`` and ``three-contacts-screen``.
This module draws *random several-contact problems*, as :mod:`tmaplan.evaluation.plan_general`
draws one-contact ones:

* :class:`ContactsFamily`: the limits of the random geometry (number of contacts, their
  bearings relative to the own course and their least separation, prior range interval,
  target speed bound), within the two built-in problems' ranges;
* :func:`random_contacts_problem` / :func:`random_contacts_problems`: problems drawn from a
  base several-contact problem by a seeded :class:`numpy.random.Generator`, each a normal,
  validated :class:`tmaplan.scenario.Scenario` (built with :meth:`Scenario.replace`); problem
  ``i`` of seed ``s`` depends only on ``(s, i)``, and the draws never read the base's
  contacts' bearings, ranges or speeds (only their target model and prior shape).

``benchmarks/contacts_general.py`` flies the paired comparison on them
(docs/results/several-contacts-decided.md).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tmaplan.errors import ArgumentError, finite_real, is_integer
from tmaplan.evaluation.plan_general import check_intervals, draw_problems
from tmaplan.scenario import Scenario
from tmaplan.units import DEG, KNOT

__all__ = ["CONTACT_NAMES", "ContactsFamily", "random_contacts_problem",
           "random_contacts_problems"]

#: Names of the drawn contacts, in order (at most this many contacts).
CONTACT_NAMES = ("alpha", "bravo", "charlie", "delta")


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactsFamily:
    """Limits of the random several-contact problems; every interval ``(low, high)`` is
    sampled uniformly, independently per contact.

    The defaults lie within the built-in problems' ranges (``two-contacts-crossing``,
    ``three-contacts-screen``: 2–3 contacts, bearings all round, priors over 5–25 km, speed
    bounds 12–25 kn) without reproducing either: every contact's bearing, range interval and
    speed bound is drawn.

    Attributes
    ----------
    contacts : tuple of int
        Least and largest number of contacts, in [2, 4].
    relative_bearing : tuple of float
        Prior mean bearing of each contact relative to the own ship's initial course [rad],
        in [−π, π].
    min_separation : float
        Least angle between two contacts' prior mean bearings [rad], in [0, π/4] (drawn
        again until it holds: the contacts are told apart by bearing).
    range_min : tuple of float
        Lower end of each prior's range interval [m], > 0.
    range_max : tuple of float
        Upper end of each prior's range interval [m], above ``range_min``'s upper end.
    target_speed_max : tuple of float
        Bound of each prior's target speed [m/s], > 0.
    """

    contacts: tuple[int, int] = (2, 3)
    relative_bearing: tuple[float, float] = (-math.pi, math.pi)
    min_separation: float = 20.0 * DEG
    range_min: tuple[float, float] = (4e3, 8e3)
    range_max: tuple[float, float] = (18e3, 26e3)
    target_speed_max: tuple[float, float] = (10.0 * KNOT, 20.0 * KNOT)

    def __post_init__(self) -> None:
        n = self.contacts
        if not (isinstance(n, tuple) and len(n) == 2 and all(is_integer(v, 2) for v in n)
                and n[0] <= n[1] <= len(CONTACT_NAMES)):
            raise ArgumentError("contacts", f"(low, high) integers with 2 <= low <= high <= "
                                f"{len(CONTACT_NAMES)}", n)
        check_intervals(self, {"relative_bearing": (-math.pi, math.pi, "[-pi, pi] rad"),
                               "range_min": (0.0, math.inf, "> 0 m"),
                               "range_max": (0.0, math.inf, "> 0 m"),
                               "target_speed_max": (0.0, math.inf, "> 0 m/s")})
        if self.range_max[0] <= self.range_min[1]:
            raise ArgumentError("range_max", f"a lower end above range_min's upper end "
                                f"({self.range_min[1]:g} m)", self.range_max)
        if finite_real("min_separation", self.min_separation,
                       "an angle in [0, pi/4] rad", lower=0.0) > math.pi / 4:
            raise ArgumentError("min_separation", "an angle in [0, pi/4] rad",
                                self.min_separation)


def _separated(bearings: list[float], least: float) -> bool:
    return all(abs(math.remainder(a - b, math.tau)) >= least
               for i, a in enumerate(bearings) for b in bearings[i + 1:])


def random_contacts_problem(base: Scenario, rng: np.random.Generator, *,
                            family: ContactsFamily | None = None,
                            name: str | None = None) -> Scenario:
    """One random several-contact problem derived from ``base``.

    The own ship, sensors, time grid and planning settings are the base's. The number of
    contacts is drawn, then per contact its prior mean bearing (relative to the own course;
    all bearings drawn again until no two are closer than ``min_separation``), its prior range
    interval and its speed bound; each prior keeps the shape of the base's first contact
    (bearing std, range distribution, course model, samples), with seed ``i + 1`` for contact
    ``i``, weight 1 and the scenario's required accuracy. The single-run truth (campaigns draw
    truths from the priors) sits at the prior's mean bearing and mid range, at half the speed
    bound, heading for the own ship.

    Parameters
    ----------
    base : Scenario
        A several-contact planning problem with polar speed-course priors (e.g.
        ``load_problem("two-contacts-crossing")``).
    rng : numpy.random.Generator
        Source of the draws.
    family : ContactsFamily, optional
        Limits of the draws (default :class:`ContactsFamily`).
    name : str, optional
        Name of the problem (default: the base's with ``-random``).

    Returns
    -------
    Scenario
        Validated by :meth:`tmaplan.scenario.Scenario.replace`; its ``description`` lists the
        draws.

    Raises
    ------
    ArgumentError
        ``rng`` not a Generator; ``base`` without a ``[planning]`` section or whose first
        contact has no polar speed-course prior.
    """
    if not isinstance(rng, np.random.Generator):
        raise ArgumentError("rng", "a numpy.random.Generator", type(rng).__name__)
    fam = family if family is not None else ContactsFamily()
    template = base.contacts[0]
    prior = template.prior
    if (base.planning is None or prior is None or prior.kind != "polar"
            or prior.velocity_distribution != "speed-course" or prior.speed_max is None
            or base.observer.course is None):
        raise ArgumentError("base", "a planning problem with an initial course and polar "
                            "speed-course priors (e.g. 'two-contacts-crossing')", base.name)
    course = float(base.observer.course)
    n = int(rng.integers(fam.contacts[0], fam.contacts[1] + 1))
    while True:
        rel = [float(rng.uniform(*fam.relative_bearing)) for _ in range(n)]
        if _separated(rel, fam.min_separation):
            break
    x0, y0 = base.observer.position
    contacts, parts = [], []
    for i, r in enumerate(rel):
        r_min = float(rng.uniform(*fam.range_min))
        r_max = float(rng.uniform(*fam.range_max))
        v_max = float(rng.uniform(*fam.target_speed_max))
        bearing = math.remainder(course + r, math.tau)
        p = dataclasses.replace(prior, bearing_mean=bearing, range_min=r_min, range_max=r_max,
                                speed_min=min(prior.speed_min, 0.5 * v_max), speed_max=v_max,
                                course_mode="uniform", course_mean=None, seed=i + 1,
                                centred_on_truth=False)
        r0 = 0.5 * (r_min + r_max)
        target = dataclasses.replace(template.target, position=(x0 + r0 * math.sin(bearing),
                                                                y0 + r0 * math.cos(bearing)),
                                     velocity=None, speed=0.5 * v_max,
                                     course=math.remainder(bearing + math.pi, math.tau))
        contacts.append(dataclasses.replace(template, name=CONTACT_NAMES[i], target=target,
                                            prior=p, weight=1.0, required_accuracy=None))
        parts.append(f"{CONTACT_NAMES[i]} {math.degrees(r):+.0f} deg relative, "
                     f"{r_min / 1e3:.1f}-{r_max / 1e3:.1f} km, <= {v_max / KNOT:.1f} kn")
    desc = f"Random {n}-contact problem from '{base.name}': " + "; ".join(parts)
    return base.replace(name=name or f"{base.name}-random", description=desc,
                        contacts=tuple(contacts))


def random_contacts_problems(base: Scenario, count: int, *, seed: int = 0,
                             family: ContactsFamily | None = None) -> tuple[Scenario, ...]:
    """``count`` random several-contact problems from ``base``
    (:func:`random_contacts_problem`).

    Problem ``i`` is drawn by ``default_rng(SeedSequence(seed, spawn_key=(i,)))``
    and named ``<base>-s<seed>-<i>`` (:func:`tmaplan.evaluation.plan_general.draw_problems`),
    so it depends on ``(seed, i)`` only, not on ``count``.

    Parameters
    ----------
    base : Scenario
    count : int
        Number of problems, >= 1.
    seed : int
        Root seed, >= 0.
    family : ContactsFamily, optional

    Returns
    -------
    tuple of Scenario
    """
    return draw_problems(random_contacts_problem, base, count, seed=seed, family=family)
