"""Each recorded contact's solution: the batch ML estimate with its CRLB and the particle
filter's posterior at the last bearing, an observability verdict and Ekelund's range.

Both estimates come from :func:`tmaplan.estimators.run` on the contact's
:class:`~tmaplan.advice.problem.ContactProblem`, exactly as ``tmaplan track`` runs its
estimators on a simulated run ("mle": :class:`~tmaplan.estimators.runner.MLEEstimator`, its
covariance the delta-method CRLB at the estimate; "pf": the regularised particle filter from
the prior). **Seed rule**: contact i of n draws the filter's generator from
``numpy.random.SeedSequence(seed).spawn(n)[i]`` (:func:`contact_rng`), so an advice is
reproducible from its seed.

**Observability** (nardone1981, lecadre1997 §III): bearings from an own ship that has not
manoeuvred (straight at constant speed) never determine the range of a constant-velocity
contact; the verdict is then "unobservable: no own-ship manoeuvre yet", whatever numbers the
estimators return. With a manoeuvre (:func:`tmaplan.advice.ekelund.manoeuvres`) the contact is
observable when the batch estimate is accepted (clavard2013's test).

**Uncertainty**: standard deviations by the delta method from each estimate's 4×4 covariance
of ``[east, north, v_east, v_north]``; the 95 % ellipse of the position has semi-axes
``sqrt(χ²₂(0.95)·λ)`` (λ the covariance's eigenvalues), the 95 % intervals of range, course and
speed are ±1.96 standard deviations.
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import Any

import numpy as np

from tmaplan.advice.ekelund import EkelundRange, ekelund_range, manoeuvres
from tmaplan.advice.problem import ContactProblem
from tmaplan.display import short_repr
from tmaplan.errors import TmaplanError
from tmaplan.estimators.runner import Track, run
from tmaplan.geometry import wrap_angle
from tmaplan.io.frame import LocalFrame

__all__ = ["CHI2_95", "Z_95", "ContactSolution", "Estimate", "SolutionWarning", "contact_rng",
           "cross_check", "estimate_at", "solve_contact"]

#: χ² quantile of 2 degrees of freedom at 95 % (the position ellipse).
CHI2_95 = 5.991464547107979
#: Two-sided 95 % normal quantile (the intervals of range, course and speed).
Z_95 = 1.959963984540054


@dataclasses.dataclass(frozen=True, kw_only=True)
class Estimate:
    """One estimator's solution of a contact at one time (x = East, y = North).

    Attributes
    ----------
    estimator : str
        "mle" or "pf".
    status : str
        The estimator's status ("ok", "recovered", "rejected", "unobservable", "failed").
    time : float
        [s] since the recording's origin.
    state : ndarray, shape (4,)
        The contact's ``[east, north, v_east, v_north]`` [m, m/s].
    covariance : ndarray, shape (4, 4)
        Of ``state`` (MLE: the CRLB at the estimate; PF: the posterior's).
    range, bearing, course, speed : float
        From the own ship [m, rad]; the contact's course [rad] and speed [m/s]. With a
        frame, bearing and course are true (clockwise from true north, as a recording's
        bearings; :meth:`tmaplan.io.frame.LocalFrame.true_azimuth`), else the plane's.
    std : dict of str to float
        ``range``, ``bearing``, ``course``, ``speed``, ``east``, ``north`` [m, rad, m/s].
    ellipse : tuple of float
        95 % position ellipse: semi-major, semi-minor axis [m], bearing of the major axis
        [rad] in [0, π).
    lat, lon : float or None
        [deg] with a geographic frame.
    """

    __repr__ = short_repr

    estimator: str
    status: str
    time: float
    state: np.ndarray
    covariance: np.ndarray
    range: float
    bearing: float
    course: float
    speed: float
    std: dict[str, float]
    ellipse: tuple[float, float, float]
    lat: float | None
    lon: float | None

    def interval(self, name: str) -> tuple[float, float]:
        """The 95 % interval of ``range``, ``course`` or ``speed`` (course: not wrapped)."""
        v, s = float(getattr(self, name)), self.std[name]
        return v - Z_95 * s, v + Z_95 * s

    def to_json(self) -> dict[str, Any]:
        """The docs/cli.md ``advise`` fields of one estimate (SI units)."""
        return {"estimator": self.estimator, "status": self.status, "time": self.time,
                "range": self.range, "bearing": self.bearing, "course": self.course,
                "speed": self.speed,
                "position": {"east": float(self.state[0]), "north": float(self.state[1]),
                             "lat": self.lat, "lon": self.lon},
                "std": dict(self.std),
                "ellipse": {"semi_major": self.ellipse[0], "semi_minor": self.ellipse[1],
                            "orientation": self.ellipse[2], "probability": 0.95}}


def estimate_at(estimator: str, status: str, time: float, state: np.ndarray,
                covariance: np.ndarray, ownship: np.ndarray,
                frame: LocalFrame | None) -> Estimate:
    """An :class:`Estimate` from a state and its covariance (module doc).

    Parameters
    ----------
    estimator, status : str
    time : float
        [s].
    state : ndarray, shape (4,)
        The contact's absolute ``[east, north, v_east, v_north]``.
    covariance : ndarray, shape (4, 4)
    ownship : ndarray, shape (2,)
        The own ship's position [m] at ``time``.
    frame : LocalFrame or None
        Gives latitude/longitude, and the true bearing and course (else the plane's).

    Returns
    -------
    Estimate
    """
    S = np.asarray(state, float)
    P = np.asarray(covariance, float)
    rel = S[:2] - np.asarray(ownship, float)
    r = float(np.hypot(*rel))
    b = float(np.arctan2(rel[0], rel[1]))
    v = S[2:]
    s = float(np.hypot(*v))
    c = float(np.mod(np.arctan2(v[0], v[1]), 2 * np.pi))
    u = rel / max(r, 1e-9)
    g_b = np.array([u[1], -u[0]]) / max(r, 1e-9)
    w = v / max(s, 1e-9)
    g_c = np.array([w[1], -w[0]]) / max(s, 1e-9)
    Pp, Pv = P[:2, :2], P[2:, 2:]

    def sd(g: np.ndarray, M: np.ndarray) -> float:
        val = float(g @ M @ g)
        return float(np.sqrt(val)) if np.isfinite(val) and val >= 0 else float("nan")

    std = {"range": sd(u, Pp), "bearing": sd(g_b, Pp), "course": sd(g_c, Pv),
           "speed": sd(w, Pv), "east": sd(np.array([1.0, 0.0]), Pp),
           "north": sd(np.array([0.0, 1.0]), Pp)}
    if np.isfinite(Pp).all():
        lam, vec = np.linalg.eigh(0.5 * (Pp + Pp.T))
        lam = np.clip(lam, 0.0, None)
        major = vec[:, 1]
        ellipse = (float(np.sqrt(CHI2_95 * lam[1])), float(np.sqrt(CHI2_95 * lam[0])),
                   float(np.mod(np.arctan2(major[0], major[1]), np.pi)))
    else:
        ellipse = (float("nan"),) * 3
    lat = lon = None
    if frame is not None:
        la, lo = frame.to_latlon(S[0], S[1])
        lat, lon = float(np.asarray(la)), float(np.asarray(lo))
        if np.isfinite(S).all():  # true bearing at the own ship, true course at the contact
            own = np.asarray(ownship, float)
            b = float(frame.true_azimuth(own[0], own[1], b)[0])
            c = float(np.mod(frame.true_azimuth(S[0], S[1], c)[0], 2 * np.pi))
    return Estimate(estimator=estimator, status=status, time=float(time), state=S,
                    covariance=P, range=r, bearing=float(np.mod(b, 2 * np.pi)), course=c,
                    speed=s, std=std, ellipse=ellipse, lat=lat, lon=lon)


@dataclasses.dataclass(frozen=True, kw_only=True)
class ContactSolution:
    """A recorded contact's solution (module doc).

    Attributes
    ----------
    name : str
    problem : ContactProblem
    mle, pf : Estimate
        At the last bearing's step.
    mle_track, pf_track : Track or None
        The estimators' whole runs (None when one failed with an error).
    manoeuvred : bool
        The own ship manoeuvred during the contact's bearings.
    observable : bool
    verdict : str
        One line.
    ekelund : EkelundRange or None
        At the own ship's last manoeuvre; None without one.
    residuals : ndarray, shape (n,)
        Bearing residuals of the ML solution at the bearings, wrapped [rad].
    residual_times : ndarray, shape (n,)
        [s].
    cross_check : str
        Empty, or why the two solutions should not be trusted (:func:`cross_check`).
    """

    __repr__ = short_repr

    name: str
    problem: ContactProblem
    mle: Estimate
    pf: Estimate
    mle_track: Track | None
    pf_track: Track | None
    manoeuvred: bool
    observable: bool
    verdict: str
    ekelund: EkelundRange | None
    residuals: np.ndarray
    residual_times: np.ndarray
    cross_check: str = ""


class SolutionWarning(UserWarning):
    """A contact's solutions disagree, or the batch solution lies outside the prior."""


def cross_check(problem: ContactProblem, mle: Estimate, pf: Estimate, *,
                start_range: float | None = None) -> str:
    """Why a contact's two solutions should not be trusted, or "".

    The batch ML solution outside the prior's range interval at the prior's time (the grid's
    first step) or above its maximum speed (the filter cannot follow it there: the prior is
    wrong), or the two ranges more than 3 standard deviations of their difference apart.

    Parameters
    ----------
    problem : ContactProblem
    mle, pf : Estimate
    start_range : float, optional
        The batch solution's range [m] at the grid's first step, where the prior holds
        (default ``mle.range``). A contact inside the prior's interval at the start may be
        outside it at the end (issue 41: an own ship running 75 km away from its contacts
        was told its prior was wrong).

    Returns
    -------
    str
        One line.
    """
    if mle.status != "ok" or pf.status not in ("ok", "recovered") \
            or not np.isfinite([mle.range, pf.range]).all():
        return ""
    p = problem.scenario.prior
    assert p is not None
    hi = p.range_max if p.range_max is not None else np.inf
    r0 = mle.range if start_range is None or not np.isfinite(start_range) else start_range
    if not p.range_min <= r0 <= hi:
        return (f"the batch solution's range {r0 / 1e3:.2f} km at the start lies outside "
                "the prior's "
                f"{p.range_min / 1e3:g}-{hi / 1e3:g} km: the particle filter cannot follow it; "
                "widen --range-min/--range-max")
    if p.speed_max is not None and mle.speed > p.speed_max:
        return (f"the batch solution's speed {mle.speed:.1f} m/s is above the prior's "
                f"maximum {p.speed_max:.1f} m/s; raise --speed-max")
    spread = float(np.hypot(mle.std["range"], pf.std["range"]))
    if abs(mle.range - pf.range) > 3.0 * spread:
        return (f"the particle filter's range {pf.range / 1e3:.2f} km and the batch "
                f"solution's {mle.range / 1e3:.2f} km differ by more than 3 standard "
                "deviations: check the prior (--range-min, --range-max, --speed-max)")
    return ""


def contact_rng(seed: int, index: int, count: int) -> np.random.Generator:
    """The filter's generator of contact ``index`` of ``count`` (the seed rule, module doc)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(count)[index])


def _last(track: Track | None, name: str, problem: ContactProblem, error: str,
          frame: LocalFrame | None) -> Estimate:
    obs = problem.observer
    k = obs.times.size - 1
    if track is None:
        nan4 = np.full(4, np.nan)
        return estimate_at(name, f"failed: {error}", float(obs.times[k]), nan4,
                           np.full((4, 4), np.nan), obs.position[k], frame)
    state = track.estimates[k] + obs.state[k]
    return estimate_at(name, track.status, float(obs.times[k]), state, track.covariances[k],
                       obs.position[k], frame)


def _run(name: str, problem: ContactProblem, rng: np.random.Generator | None,
         particles: int) -> tuple[Track | None, str]:
    try:
        return run(name, problem.scenario, problem.measurements, observer=problem.observer,  # type: ignore[arg-type]
                   rng=rng, n_particles=particles), ""
    except (TmaplanError, np.linalg.LinAlgError) as exc:
        return None, str(exc)


def solve_contact(problem: ContactProblem, *, rng: np.random.Generator,
                  frame: LocalFrame | None = None, particles: int = 10_000,
                  ) -> ContactSolution:
    """Solve one contact (module doc).

    Parameters
    ----------
    problem : ContactProblem
    rng : numpy.random.Generator
        The particle filter's (:func:`contact_rng`).
    frame : LocalFrame, optional
        Gives latitude/longitude.
    particles : int
        Of the particle filter.

    Returns
    -------
    ContactSolution
    """
    mle_tr, mle_err = _run("mle", problem, None, particles)
    pf_tr, pf_err = _run("pf", problem, rng, particles)
    mle_est = _last(mle_tr, "mle", problem, mle_err, frame)
    pf_est = _last(pf_tr, "pf", problem, pf_err, frame)
    obs = problem.observer
    steps = np.concatenate([m.steps for m in problem.measurements])
    order = np.argsort(steps, kind="stable")
    steps = steps[order]
    z = np.concatenate([m.values for m in problem.measurements])[order]
    # the manoeuvre test and Ekelund's range on the bearings as recorded
    manoeuvred = bool(manoeuvres(problem.times, problem.velocity).any())
    ek = ekelund_range(problem.times, problem.bearing, problem.sigma,
                       problem.velocity) if manoeuvred else None
    if mle_tr is not None:
        rel = mle_tr.estimates[steps]
        residuals = np.asarray(wrap_angle(z - np.arctan2(rel[:, 0], rel[:, 1])))
    else:
        residuals = np.full(z.size, np.nan)
    rsd = mle_est.std["range"] / mle_est.range if mle_est.range > 0 else np.nan
    if not manoeuvred:
        observable = False
        verdict = ("unobservable: no own-ship manoeuvre yet (straight at constant speed, the "
                   "bearings fix the line of sight but not the range); manoeuvre to range it")
    elif mle_tr is None or mle_est.status not in ("ok",):
        observable = False
        verdict = (f"not solved: the own ship has manoeuvred but the batch estimate is "
                   f"{mle_est.status} ({mle_tr.message if mle_tr else mle_err})")
    else:
        observable = bool(np.isfinite(rsd))
        verdict = (f"observable: range {mle_est.range / 1e3:.2f} km ± {Z_95 * rsd:.0%} (95 %)"
                   if observable else "unobservable: the range's bound is not finite")
    r0 = None  # the batch solution's range where the prior holds: its first finite step
    if mle_tr is not None and np.isfinite(mle_tr.estimates).all(axis=1).any():
        k0 = int(np.argmax(np.isfinite(mle_tr.estimates).all(axis=1)))
        r0 = float(np.hypot(*mle_tr.estimates[k0, :2]))
    check = cross_check(problem, mle_est, pf_est, start_range=r0) if observable else ""
    if check:
        warnings.warn(f"contact '{problem.name}': {check}", SolutionWarning, stacklevel=2)
    return ContactSolution(name=problem.name, problem=problem, mle=mle_est, pf=pf_est,
                           mle_track=mle_tr, pf_track=pf_tr, manoeuvred=manoeuvred,
                           observable=observable, verdict=verdict, ekelund=ek,
                           cross_check=check,
                           residuals=residuals, residual_times=obs.times[steps])
