"""``tmaplan advise BEARINGS --ownship NAV [--budget K] [--horizon T] [--platform FILE] ...``:
recorded bearings and own-ship navigation in, each contact's solution and the advice out
(docs/recordings.md, docs/cli.md).

Per contact: the batch ML solution with its CRLB and the particle filter's posterior
(:mod:`tmaplan.advice.solution`), an observability verdict, Ekelund's range where the own ship
has manoeuvred, and the advice (:mod:`tmaplan.advice.recommend`): the recommended manoeuvre
over ``--horizon`` with its leg table against holding course, and ``--budget`` ping times with
the certificate. Writes the figures, ``advise.html``, and per contact ``<contact>_legs.csv``
(the exact leg table), ``<contact>_navigator_legs.csv`` (the merged one,
:mod:`tmaplan.models.leg_table`), ``<contact>_track.gpx`` and ``<contact>_track.csv`` into
``--out``.

Several contacts: one solution per contact and ONE advice for all of them at once
(:func:`tmaplan.advice.joint.advise_contacts`: the several-contact planner's manoeuvre against
holding course, one shared ping schedule); its files are ``all-contacts_*``.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import html
import math
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.advice.joint import JointAdvice, advise_contacts
from tmaplan.advice.problem import Platform, contact_problem, read_platform
from tmaplan.advice.recommend import ACCURACY, advise_contact
from tmaplan.advice.solution import contact_rng, solve_contact
from tmaplan.cli.args import (
    add_figure_arguments,
    add_seed_argument,
    command_line,
    duration,
    integer,
)
from tmaplan.errors import ArgumentError, DataError, UnitError
from tmaplan.io import read_recording
from tmaplan.io.faults import warn
from tmaplan.io.plans import legs_json, write_plan
from tmaplan.models.leg_table import NavigatorLegs, track_navigator_legs
from tmaplan.units import to_si

HELP = ("recorded bearings + own-ship navigation: each contact's solution with its uncertainty, "
        "observability, and the recommended manoeuvre and pings")

#: Default ``--horizon`` [s].
HORIZON = 1200.0
#: The stem of the joint advice's files and its key under ``exports``.
JOINT = "all-contacts"


def _quantity(dimension: str) -> Any:
    """Type of a flag with a unit (``"40 km"``, ``"25 kn"``, ``"0.5 deg/s"``), > 0 (>= 0 for
    a length that may be 0: the keep-out)."""
    def parse(text: str) -> float:
        try:
            value = to_si(text, dimension, "value")
        except UnitError as exc:
            raise argparse.ArgumentTypeError(str(exc).split(": ", 1)[-1]) from None
        if value < 0:
            raise argparse.ArgumentTypeError(f"expected a value >= 0, received {text!r}")
        return value
    parse.__name__ = dimension
    return parse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``tmaplan advise``."""
    parser.add_argument("bearings", metavar="BEARINGS",
                        help="bearings CSV: time,bearing_deg[,sigma_deg][,contact]")
    parser.add_argument("--ownship", required=True, metavar="NAV",
                        help="own-ship navigation: CSV (time,lat_deg,lon_deg), NMEA 0183 or GPX")
    parser.add_argument("--budget", type=integer(0, 50), default=0, metavar="K",
                        help="active pings to schedule over the horizon (default 0)")
    parser.add_argument("--horizon", type=duration(), default=None, metavar="T",
                        help="advice horizon, seconds or with a unit (default 20 min; whole "
                             "minutes)")
    parser.add_argument("--platform", default=None, metavar="FILE",
                        help="TOML with range_min, range_max, speed_max, turn_rate_max, "
                             "keep_out_range, ... (docs/recordings.md); flags override it")
    parser.add_argument("--range-min", type=_quantity("length"), default=None, metavar="R",
                        help="contact's least range of the prior (default 1 km)")
    parser.add_argument("--range-max", type=_quantity("length"), default=None, metavar="R",
                        help="contact's greatest range of the prior (default 40 km)")
    parser.add_argument("--speed-max", type=_quantity("speed"), default=None, metavar="S",
                        help="contact's greatest speed (default 25 kn)")
    parser.add_argument("--turn-rate-max", type=_quantity("angular_rate"), default=None,
                        metavar="W", help="own ship's turn-rate limit (default 0.5 deg/s)")
    parser.add_argument("--keep-out", type=_quantity("length"), default=None, metavar="R",
                        help="own ship's closest range to a contact's estimate (default 2 km)")
    parser.add_argument("--sigma-deg", type=float, default=None, metavar="DEG",
                        help="bearing standard deviation where the file has none (default 1)")
    parser.add_argument("--no-advice", action="store_true",
                        help="solutions only (no planning)")
    add_seed_argument(parser, help="seed of the particle filters (contact i of n: child i of "
                                   "SeedSequence(S).spawn(n); default 0)")
    add_figure_arguments(parser)


def _platform(args: argparse.Namespace) -> Any:

    base = read_platform(args.platform) if args.platform else Platform()
    flags = {"range_min": args.range_min, "range_max": args.range_max,
             "speed_max": args.speed_max, "turn_rate_max": args.turn_rate_max,
             "keep_out_range": args.keep_out}
    given = {k: v for k, v in flags.items() if v is not None}
    p = dataclasses.replace(base, **given)
    checks = (("--range-min", p.range_min > 0, "> 0 m", p.range_min),
              ("--range-max", p.range_max > p.range_min,
               f"> the range minimum {p.range_min:g} m", p.range_max),
              ("--speed-max", p.speed_max > 0, "> 0 m/s", p.speed_max),
              ("--turn-rate-max", p.turn_rate_max > 0, "> 0 rad/s", p.turn_rate_max))
    for flag, ok, expected, value in checks:
        if not ok:
            raise ArgumentError(flag, expected, value)
    return p



def _alone(t: float, unit: str = " min") -> str:
    """A contact's expected time on its own plan [s] in minutes, or ``"not planned"`` when
    that plan failed or was never solved (NaN: the joint planner refused the start)."""
    return f"{t / 60:.1f}{unit}" if math.isfinite(t) else "not planned"

def _navigator(adv: Any) -> NavigatorLegs:
    """The navigator's (merged) table of an advice's plan."""
    return track_navigator_legs(adv.legs, adv.track)


def _plan_json(adv: Any, rec: Any, pings: Any) -> dict[str, Any]:
    """The keys of one recommended plan (the one-contact advice and the joint one)."""
    tr = adv.track
    lat = lon = None
    if rec.frame is not None:
        lat, lon = rec.frame.to_latlon(tr.position[:, 0], tr.position[:, 1])
    p = pings
    return {"recommendation": adv.recommendation, "note": adv.note,
            "start": float(tr.times[0]), "start_time": rec.time_text(float(tr.times[0])),
            "legs": legs_json(adv.legs), "navigator_legs": _navigator(adv).to_json(),
            "track": {"times": tr.times, "lat": lat, "lon": lon, "east": tr.position[:, 0],
                      "north": tr.position[:, 1]},
            "expected_time_to_accuracy": adv.expected_time_to_accuracy,
            "hold_course_time_to_accuracy": adv.hold_course_time_to_accuracy,
            "plan_time_to_accuracy": adv.plan_time_to_accuracy,
            "ping_times": [] if p is None else p.times,
            "lower_bound": None if p is None else p.lower_bound,
            "gap": None if p is None else p.gap,
            "ping_status": None if p is None else p.status,
            "ping_objective": None if p is None else p.objective,
            "solver": adv.solver}


def _advice_json(adv: Any, rec: Any) -> dict[str, Any]:
    out = {"contact": adv.name, **_plan_json(adv, rec, adv.pings),
           "range_bound": adv.range_bound, "hold_range_bound": adv.hold_range_bound}
    return out


def _joint_json(adv: JointAdvice, rec: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """The top-level ``advice`` of several contacts (docs/recordings.md) and each contact's
    ``advice``."""
    p = adv.pings
    top = {"contacts": list(adv.names), "objective": adv.objective,
           **_plan_json(adv, rec, None if p is None else p.schedule)}
    each = {}
    for n in adv.names:
        d: dict[str, Any] = {**adv.contacts[n], "range_bound": adv.range_bounds[n],
                             "hold_range_bound": adv.hold_range_bounds[n]}
        if p is not None:
            d.update({"ping_objective": p.objectives[n],
                      "no_ping_objective": p.no_ping_objectives[n],
                      "pings_in_reach": p.pings_in_reach[n]})
        each[n] = d
    return top, each


def solution_of(sol: Any) -> Any:
    """The contact's reported solution: the particle filter's posterior (it models the
    contact's process noise, so its intervals hold the current course and speed; the batch
    CRLB is a constant-velocity contact's), the ML solution when the filter failed."""
    return sol.pf if sol.pf_track is not None and sol.pf.status in ("ok", "recovered") \
        else sol.mle


def _contact_json(sol: Any) -> dict[str, Any]:
    use = solution_of(sol)
    out = use.to_json()
    out.pop("estimator")
    ek = sol.ekelund
    out.update({"solution": use.estimator, "observable": sol.observable,
                "manoeuvred": sol.manoeuvred, "verdict": sol.verdict,
                "ekelund_range": None if ek is None else ek.range,
                "ekelund": None if ek is None else {"time": ek.time, "range": ek.range,
                                                    "std": ek.std, "rates": list(ek.rates)},
                "cross_check": sol.cross_check or None,
                "mle": sol.mle.to_json(), "pf": sol.pf.to_json(),
                "bearings": int(sol.residuals.size),
                "residual_rms": float(np.sqrt(np.nanmean(sol.residuals ** 2)))
                if sol.residuals.size else None})
    return out


def _print(rec: Any, solutions: Sequence[Any], advice: Sequence[Any]) -> None:

    names = {"pf": "particle filter", "mle": "batch ML (CRLB)"}
    for sol in solutions:
        print(f"contact {sol.name}: {sol.verdict}")
        for e in (sol.pf, sol.mle):
            if e.estimator == "mle" and not sol.manoeuvred:
                print(f"  {names['mle']}: no range without an own-ship manoeuvre (its "
                      "numbers are in the JSON)")
                continue
            print(f"  {names[e.estimator]} at {rec.time_text(e.time)}: range "
                  f"{e.range / 1e3:.2f} ± {e.std['range'] / 1e3:.2f} km, bearing "
                  f"{math.degrees(e.bearing):.1f}°, course {math.degrees(e.course):.0f} ± "
                  f"{math.degrees(e.std['course']):.0f}°, speed {e.speed / 0.514444:.1f} ± "
                  f"{e.std['speed'] / 0.514444:.1f} kn"
                  + (f", {e.lat:.5f} {e.lon:.5f}" if e.lat is not None else "")
                  + ("" if e.status == "ok" else f" [{e.status}]"))
        if sol.ekelund is not None and math.isfinite(sol.ekelund.range):
            print(f"  Ekelund range at {rec.time_text(sol.ekelund.time)}: "
                  f"{sol.ekelund.range / 1e3:.2f} ± {sol.ekelund.std / 1e3:.2f} km")
    for title, _stem, adv, pings in _plans(advice):
        print(f"advice for {title}: {adv.note}")
        if isinstance(adv, JointAdvice):
            for n, c in adv.contacts.items():
                print(f"  {n}: expected time to {ACCURACY:.0%} range accuracy "
                      f"{c['expected_time_to_accuracy'] / 60:.1f} min (holding course "
                      f"{c['hold_course_time_to_accuracy'] / 60:.1f} min; its own plan alone "
                      f"{_alone(c['alone_expected_time_to_accuracy'])})")
        print(_navigator(adv).text())
        if pings is not None:
            times = ", ".join(rec.time_text(float(t)) for t in pings.times)
            print(f"  pings: {times or 'none'} (lower bound {pings.lower_bound:.1f} m, "
                  f"objective {pings.objective:.1f} m, gap {pings.gap:.2%}, {pings.status})")
            if isinstance(adv, JointAdvice) and adv.pings is not None:
                reach = ", ".join(f"{n} {k}" for n, k in adv.pings.pings_in_reach.items())
                print(f"  pings in reach of each contact: {reach}")


def _plans(advice: Any) -> list[tuple[str, str, Any, Any]]:
    """Each recommended plan as (title, file stem, advice, ping schedule or None): one per
    contact (one contact), or the joint one (several contacts)."""
    if isinstance(advice, JointAdvice):
        return [(f"all {len(advice.names)} contacts ({', '.join(advice.names)})", JOINT,
                 advice, None if advice.pings is None else advice.pings.schedule)]
    return [(adv.name, "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in adv.name),
             adv, adv.pings) for adv in advice if adv is not None]


def _tables(rec: Any, solutions: Sequence[Any], advice: Sequence[Any]) -> str:
    rows = []
    for sol in solutions:
        for e in (sol.mle, sol.pf):
            rows.append(f"<tr><td>{html.escape(sol.name)}</td><td>{e.estimator}</td>"
                        f"<td>{e.range / 1e3:.2f} ± {e.std['range'] / 1e3:.2f}</td>"
                        f"<td>{math.degrees(e.bearing):.1f}</td>"
                        f"<td>{math.degrees(e.course):.0f} ± "
                        f"{math.degrees(e.std['course']):.0f}</td>"
                        f"<td>{e.speed / 0.514444:.1f} ± {e.std['speed'] / 0.514444:.1f}</td>"
                        f"<td>{html.escape(e.status)}</td></tr>")
    verdicts = "".join(f"<li><b>{html.escape(s.name)}</b>: {html.escape(s.verdict)}</li>"
                       for s in solutions)
    parts = [f"<h2>Solutions at {html.escape(rec.time_text(solutions[0].mle.time))}</h2>",
             f"<ul>{verdicts}</ul>",
             "<table><tr><th>contact</th><th>estimator</th><th>range [km]</th>"
             "<th>bearing [°]</th><th>course [°]</th><th>speed [kn]</th><th>status</th></tr>"
             + "".join(rows) + "</table>"]
    for title, _stem, adv, pings in _plans(advice):
        nav = _navigator(adv)
        legs = "".join(f"<tr><td>{leg.start / 60:.1f}</td><td>"
                       f"{math.degrees(leg.course) % 360:.1f}</td><td>{leg.turn}</td><td>"
                       f"{math.degrees(leg.rate):.3f}</td><td>{leg.duration / 60:.1f}</td></tr>"
                       for leg in nav.legs)
        extra = ""
        if isinstance(adv, JointAdvice):
            extra = "<table><tr><th>contact</th><th>expected time to accuracy [min]</th>" \
                "<th>holding course [min]</th><th>its own plan alone [min]</th>" + \
                "".join(f"<tr><td>{html.escape(n)}</td>"
                        f"<td>{c['expected_time_to_accuracy'] / 60:.1f}</td>"
                        f"<td>{c['hold_course_time_to_accuracy'] / 60:.1f}</td>"
                        f"<td>{_alone(c['alone_expected_time_to_accuracy'], '')}</td></tr>"
                        for n, c in adv.contacts.items()) + "</table>"
        if pings is not None:
            times = ", ".join(rec.time_text(float(t)) for t in pings.times) or "none"
            extra += (f"<p>Pings: {html.escape(times)} (lower bound {pings.lower_bound:.1f} "
                      f"m, objective {pings.objective:.1f} m, gap {pings.gap:.2%}, "
                      f"{html.escape(pings.status)})</p>")
        parts.append(f"<h2>Advice for {html.escape(title)}</h2><p>{html.escape(adv.note)}"
                     f"</p>{extra}<table><tr><th>start [min]</th><th>course [°]</th>"
                     "<th>turn</th><th>rate [°/s]</th><th>duration [min]</th></tr>"
                     f"{legs}</table><p>{html.escape(nav.text().splitlines()[-1].strip())}"
                     "</p>")
    return "\n".join(parts)


def _exports(out: Path, rec: Any, advice: Any) -> dict[str, dict[str, str]]:
    """Each plan's leg tables and track files (:func:`tmaplan.io.plans.write_plan`), by
    contact (one contact) or under :data:`JOINT`."""
    files: dict[str, dict[str, str]] = {}
    for _title, stem, adv, _pings in _plans(advice):
        t0 = float(adv.track.times[0])
        start = None if rec.start is None else rec.start + dt.timedelta(seconds=t0)
        key = JOINT if isinstance(adv, JointAdvice) else adv.name
        files[key] = write_plan(out, stem, adv.legs, adv.track.times - t0,
                                adv.track.position[:, 0], adv.track.position[:, 1],
                                start=start, frame=rec.frame,
                                navigator=_navigator(adv).legs)
    return files


#: Fewest bearings at different times of a contact that is solved (4 unknowns).
MIN_BEARINGS = 5


def _enough_bearings(rec: Any) -> Any:
    """The recording without its contacts of fewer than :data:`MIN_BEARINGS` bearing times
    (left out, warned); none left: an error."""

    few = {c.name: int(np.unique(c.times).size) for c in rec.contacts
           if np.unique(c.times).size < MIN_BEARINGS}
    if not few:
        return rec
    text = ", ".join(f"'{k}' ({v})" for k, v in few.items())
    if len(few) == len(rec.contacts):
        raise DataError(rec.bearings_source, f"expected a contact with at least {MIN_BEARINGS} "
                        f"bearings at different times (4 unknowns), received {text}",
                        field="contact")
    warn(f"{rec.bearings_source}: contact{'s' if len(few) > 1 else ''} with fewer than "
         f"{MIN_BEARINGS} bearings at different times left out: {text}")
    return dataclasses.replace(rec, contacts=tuple(c for c in rec.contacts
                                                   if c.name not in few))


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Read, solve, advise; return the docs/cli.md ``advise`` fields."""

    if args.sigma_deg is not None and not 0 < args.sigma_deg < 180:
        raise ArgumentError("--sigma-deg", "a standard deviation in (0, 180) degrees",
                            args.sigma_deg)
    platform = _platform(args)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rec = _enough_bearings(read_recording(args.bearings, args.ownship,
                                              sigma_deg=args.sigma_deg))
        n = len(rec.contacts)
        solutions = []
        for i, c in enumerate(rec.contacts):
            cp = contact_problem(rec, c, platform)
            solutions.append(solve_contact(cp, rng=contact_rng(args.seed, i, n),
                                           frame=rec.frame, particles=platform.particles))
    texts = []
    for w in caught:
        texts.append(str(w.message))
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    horizon = HORIZON if args.horizon is None else args.horizon
    advice: Any = [None] * len(solutions)
    if args.no_advice:
        pass
    elif len(solutions) > 1:
        advice = advise_contacts(solutions, platform, horizon=horizon, budget=args.budget)
    else:
        advice = [advise_contact(s, platform, horizon=horizon, budget=args.budget)
                  for s in solutions]
    quiet = args.json == "-"
    if not quiet:
        _print(rec, solutions, advice)
    payload: dict[str, Any] = {
        "bearings": args.bearings, "ownship": args.ownship, "seed": args.seed,
        "contacts": {s.name: _contact_json(s) for s in solutions},
        "reference": {"time": rec.time_text(0.0),
                      "lat": None if rec.frame is None else rec.frame.lat0,
                      "lon": None if rec.frame is None else rec.frame.lon0,
                      "projection": None if rec.frame is None else rec.frame.projection},
        "platform": dataclasses.asdict(platform), "warnings": texts}
    if isinstance(advice, JointAdvice):
        payload["advice"], each = _joint_json(advice, rec)
        for name, a in each.items():
            payload["contacts"][name]["advice"] = a
    elif not args.no_advice:
        a = _advice_json(advice[0], rec)
        payload["contacts"][advice[0].name]["advice"] = a
        payload["advice"] = a
    out = Path(args.out)
    if not args.no_advice:
        payload["exports"] = _exports(out, rec, advice)
    if not args.no_figure:
        from tmaplan.advice.report import advice_figures, write_advice_page  # deferred: matplotlib

        figs = advice_figures(rec, solutions, advice, out)
        page = write_advice_page(out, title=f"tmaplan advice: {Path(args.bearings).name}",
                                 command=command_line("advise", f"tmaplan advise "
                                                      f"{args.bearings} --ownship "
                                                      f"{args.ownship}"),
                                 summary_html=_tables(rec, solutions, advice), figures=figs)
        payload["figures"] = {k: str(v) for k, v in figs.items()}
        payload["report"] = str(page)
        if not quiet:
            print(f"wrote {page}")
    return payload
