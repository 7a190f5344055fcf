"""The navigator's leg table: the exact legs of a plan merged into few steady turns, only as
far as the merged table still flies the plan's track.

A smooth plan's exact table (:func:`tmaplan.io.plans.legs_from_track`) has one leg per
control interval (about 20 one-minute legs of small, slowly changing rates). Consecutive legs
whose turn rates agree within ``rate_tol`` (every leg's rate within ``rate_tol`` of the merged
leg's) become one steady-turn leg whose rate is their duration-weighted mean (so the merged
leg ends on the course the exact legs end on, and its rate never exceeds theirs: a flyable
table stays flyable); a merged leg whose legs all turn slower than ``rate_tol`` is made
straight when that still passes. A merge is kept only when the track the whole table flies
(:func:`legs_track`, at the plan's constant speed from its first position and course) stays
within ``position_tol`` of the plan's track at every step: the table never silently describes
another track. The exact table stays in the exports (CSV, JSON).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from tmaplan.display import short_repr
from tmaplan.errors import ArgumentError
from tmaplan.geometry import wrap_angle
from tmaplan.io.plans import Leg, Turn, legs_table, step_turn_rates
from tmaplan.models.observer import ObserverTrack, turn_rate_track

__all__ = ["MERGE_RATE_TOL", "POSITION_TOL", "NavigatorLegs", "flown_turn_rates", "legs_track",
           "navigator_legs", "track_navigator_legs"]

#: Turn rates closer than this are one steady turn in the navigator's table [rad/s] (0.02 °/s).
MERGE_RATE_TOL = float(np.deg2rad(0.02))
#: The navigator's table flies within this of the plan's track [m].
POSITION_TOL = 50.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class NavigatorLegs:
    """A plan's navigator table and what it was checked against (module doc).

    Attributes
    ----------
    legs : tuple of Leg
        The merged table.
    exact : tuple of Leg
        The exact table it was merged from.
    rate_tolerance : float
        [rad/s].
    position_tolerance : float
        [m].
    max_position_error : float
        Largest distance between the merged table's track and the plan's track over the
        plan's steps [m] (<= ``position_tolerance`` unless the exact table already misses
        it, then ``legs`` is ``exact``).
    """

    __repr__ = short_repr

    legs: tuple[Leg, ...]
    exact: tuple[Leg, ...]
    rate_tolerance: float
    position_tolerance: float
    max_position_error: float

    def text(self) -> str:
        """The table as printed, with the line that states its tolerance."""
        merged = (f"{len(self.exact)} exact legs merged into {len(self.legs)} where their "
                  f"rates agree within {np.rad2deg(self.rate_tolerance):g} °/s"
                  if len(self.legs) < len(self.exact) else
                  f"{len(self.exact)} exact legs (none merged)")
        return (legs_table(self.legs) + f"\n  ({merged}; this table flies within "
                f"{self.max_position_error:.0f} m of the plan's track, tolerance "
                f"{self.position_tolerance:g} m; the exact table is in the CSV/JSON)")

    def to_json(self) -> dict[str, object]:
        """``legs`` (as the exact ``legs``), ``rate_tolerance`` [rad/s],
        ``position_tolerance`` and ``max_position_error`` [m]."""
        return {"legs": [dataclasses.asdict(leg) for leg in self.legs],
                "rate_tolerance": self.rate_tolerance,
                "position_tolerance": self.position_tolerance,
                "max_position_error": self.max_position_error}


def legs_track(legs: Sequence[Leg], position0: ArrayLike, speed: float, dt: float,
               n_steps: int, t0: float = 0.0) -> ObserverTrack:
    """The track a leg table flies at constant speed from ``position0`` on the first leg's
    course (:func:`tmaplan.io.plans.step_turn_rates`, :func:`turn_rate_track`).

    Parameters
    ----------
    legs : sequence of Leg
    position0 : array_like, shape (2,)
        [m].
    speed : float
        [m/s].
    dt : float
        Step [s].
    n_steps : int
        Steps K.
    t0 : float
        Time of the first position [s].

    Returns
    -------
    ObserverTrack
        K + 1 states.
    """
    rates = step_turn_rates(legs, dt, n_steps)
    return turn_rate_track(np.asarray(position0, float), float(legs[0].course), float(speed),
                           rates, float(dt), t0)


def _with_courses(course0: float, parts: Sequence[tuple[float, float, float]]
                  ) -> tuple[Leg, ...]:
    """Legs from (start, signed rate, duration), the courses integrated from ``course0``."""
    out, c = [], float(course0)
    for start, rate, dur in parts:
        turn: Turn = "straight" if rate == 0 else "starboard" if rate > 0 else "port"
        out.append(Leg(start=start, course=float(np.mod(c, 2 * np.pi)), turn=turn,
                       rate=abs(rate), duration=dur))
        c += rate * dur
    return tuple(out)


def navigator_legs(legs: Sequence[Leg], position: ArrayLike, *, speed: float, dt: float,
                   rate_tol: float = MERGE_RATE_TOL, position_tol: float = POSITION_TOL
                   ) -> NavigatorLegs:
    """Merge a plan's exact legs for the navigator, within the stated tolerances (module doc).

    Parameters
    ----------
    legs : sequence of Leg
        The exact table (starts from 0 at the plan's start).
    position : array_like, shape (K + 1, 2)
        The plan's track at steps of ``dt`` from its start [m].
    speed : float
        The plan's constant speed [m/s].
    dt : float
        [s], > 0.
    rate_tol : float
        [rad/s], >= 0.
    position_tol : float
        [m], > 0.

    Returns
    -------
    NavigatorLegs
    """
    P = np.asarray(position, float)
    if not legs or P.ndim != 2 or P.shape[1] != 2 or P.shape[0] < 2 or not dt > 0:
        raise ArgumentError("legs/position", "at least one leg and a track (K + 1, 2), K >= 1, "
                            "dt > 0", f"{len(legs)} legs, track {P.shape}, dt {dt!r}")
    if not (rate_tol >= 0 and position_tol > 0):
        raise ArgumentError("rate_tol/position_tol", "rate_tol >= 0 and position_tol > 0",
                            (rate_tol, position_tol))
    K = P.shape[0] - 1
    c0 = float(legs[0].course)

    def error(parts: Sequence[tuple[float, float, float]]) -> float:
        tr = legs_track(_with_courses(c0, parts), P[0], speed, dt, K)
        return float(np.max(np.hypot(*(tr.position - P).T)))

    exact = [(leg.start, leg.signed_rate, leg.duration) for leg in legs]
    best = error(exact)
    if best > position_tol:  # the exact table already misses: nothing merged
        return NavigatorLegs(legs=tuple(legs), exact=tuple(legs), rate_tolerance=rate_tol,
                             position_tolerance=position_tol, max_position_error=best)
    done: list[tuple[float, float, float]] = []
    members, group = [exact[0]], exact[0]  # the exact legs of the open leg, and that leg
    for j in range(1, len(exact)):
        cand = [*members, exact[j]]
        r = np.array([g[1] for g in cand])
        d = np.array([g[2] for g in cand])
        mean = float(r @ d / d.sum())
        tries = ([0.0] if np.all(np.abs(r) <= rate_tol) else []) + \
            ([mean] if np.all(np.abs(r - mean) <= rate_tol) else [])
        for rate in tries:
            merged = (cand[0][0], rate, float(d.sum()))
            e = error([*done, merged, *exact[j + 1:]])
            if e <= position_tol:
                members, group, best = cand, merged, e
                break
        else:
            done.append(group)
            members, group = [exact[j]], exact[j]
    done.append(group)
    return NavigatorLegs(legs=_with_courses(c0, done), exact=tuple(legs),
                         rate_tolerance=float(rate_tol), position_tolerance=float(position_tol),
                         max_position_error=best)


def track_navigator_legs(legs: Sequence[Leg], track: ObserverTrack) -> NavigatorLegs:
    """:func:`navigator_legs` of a plan's exact ``legs`` and its constant-speed ``track``
    (its step and first speed), at the default tolerances."""
    return navigator_legs(legs, track.position, speed=float(track.speed[0]),
                          dt=float(track.times[1] - track.times[0]))


def flown_turn_rates(position: ArrayLike, heading0: float, dt: float
                     ) -> tuple[np.ndarray, np.ndarray, float]:
    """The turn rates and courses of a track flown at constant speed and a constant turn
    rate over each step (the closed loop's own ship), from its positions alone.

    Over a step of constant rate ω from course ψ_k the chord's direction is ψ_k + ω·dt/2 and
    its length ``v·dt·sinc(ω·dt/2)``, so ``ψ_{k+1} = ψ_k + 2·wrap(chord_k − ψ_k)``.

    Parameters
    ----------
    position : array_like, shape (K + 1, 2)
        [m], steps of ``dt``.
    heading0 : float
        The course at the first position [rad].
    dt : float
        [s], > 0.

    Returns
    -------
    turn_rates : ndarray, shape (K,)
        [rad/s], positive to starboard.
    courses : ndarray, shape (K + 1,)
        [rad], unwrapped from ``heading0``.
    speed : float
        [m/s], the median over the steps.
    """
    P = np.asarray(position, float)
    d = np.diff(P, axis=0)
    chord = np.arctan2(d[:, 0], d[:, 1])  # course: clockwise from North
    psi = np.empty(P.shape[0])
    psi[0] = float(heading0)
    for k in range(d.shape[0]):  # a recursion over the steps (K of them, ~100)
        psi[k + 1] = psi[k] + 2.0 * float(wrap_angle(chord[k] - psi[k]))
    rates = np.diff(psi) / dt
    half = 0.5 * rates * dt
    sinc = np.where(np.abs(half) > 1e-12, np.sin(half) / np.where(half == 0, 1, half), 1.0)
    speed = float(np.median(np.hypot(d[:, 0], d[:, 1]) / (dt * sinc)))
    return rates, psi, speed
