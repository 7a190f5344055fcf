"""``tmaplan simulate P --seed S [--out DIR] [--json PATH] [--export DIR [--origin LAT,LON]
[--start TIME]]``: one truth + measurement run, and optionally the run as recorded data."""

from __future__ import annotations

import argparse
import datetime as dt
from pathlib import Path
from typing import Any

import numpy as np

from tmaplan.cli.args import (
    add_figure_arguments,
    add_problem_argument,
    add_seed_argument,
    out_dir,
)
from tmaplan.cli.observer_plan import with_observer_plan
from tmaplan.display import timespan
from tmaplan.errors import ArgumentError
from tmaplan.scenario import load
from tmaplan.simulate import ContactsSimulation, Simulation, simulate, simulate_contacts

HELP = "simulate one truth and measurement run of a problem and plot its geometry"

#: Several contacts: one run of them all (:func:`tmaplan.simulate.simulate_contacts`).
SEVERAL_CONTACTS = "joint"

#: Default ``--origin``: the own ship's start (latitude, longitude) [deg] in the Bay of Biscay.
DEFAULT_ORIGIN = (45.0, -5.0)
#: Default ``--start``: the UTC time of the run's first step.
DEFAULT_START = "2024-06-01T12:00:00Z"


def _origin(text: str) -> tuple[float, float]:
    """Type of ``--origin``: ``LAT,LON`` in degrees."""
    try:
        lat, lon = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be LAT,LON in degrees like '45.0,-5.0', received {text!r}") from None
    if not (np.isfinite(lat) and np.isfinite(lon) and abs(lat) <= 90 and abs(lon) <= 180):
        raise argparse.ArgumentTypeError(
            f"must be a latitude in [-90, 90] and a longitude in [-180, 180], received {text!r}")
    return lat, lon


def parse_start(text: str) -> dt.datetime:
    """Type of ``--start``: an ISO 8601 time with a zone."""
    from tmaplan.io.times import parse_utc  # deferred: tmaplan.io loads pyproj, pynmea2, gpxpy

    t = parse_utc(text)
    if t is None:
        raise argparse.ArgumentTypeError(
            f"must be an ISO 8601 time with a zone like '{DEFAULT_START}', received {text!r}")
    return t


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``simulate``."""
    add_problem_argument(parser)
    add_seed_argument(parser)
    add_figure_arguments(parser)
    parser.add_argument(
        "--export", type=out_dir, default=None, metavar="DIR",
        help="write the run as recorded data to DIR: bearings.csv (the bearing sensors'), "
             "ownship.csv, ownship.nmea, ownship.gpx and truth.json (docs/recordings.md)")
    parser.add_argument(
        "--origin", type=_origin, default=None, metavar="LAT,LON",
        help="with --export: the own ship's start position in degrees (default "
             f"{DEFAULT_ORIGIN[0]:g},{DEFAULT_ORIGIN[1]:g}); the exported plane is the "
             "scenario's shifted so that the own ship starts at its origin; a southern "
             "latitude with '=': --origin=-33.5,151.5")
    parser.add_argument(
        "--observer-plan", default=None, metavar="FILE",
        help="fly this plan: a `tmaplan plan P --json` file or a legs CSV (docs/recordings.md)")
    parser.add_argument(
        "--start", type=parse_start, default=None, metavar="TIME",
        help=f"with --export: UTC time of the run's first step (default {DEFAULT_START})")


def export(sim: Simulation | ContactsSimulation, directory: str | Path, *,
           origin: tuple[float, float],
           start: dt.datetime, seed: int | None = None) -> dict[str, str]:
    """Write a simulated run as recorded data (docs/recordings.md).

    The exported plane is the scenario's translated so that the own ship starts at (0, 0),
    the azimuthal equidistant plane centred on ``origin``: the plane the readers build
    (centred on the first fix), so reading the files back gives the simulation's positions
    less the own ship's start. Times are ``start`` plus the scenario's time since its first
    step. The bearings are the bearing sensors' (with their ``sigma_deg``) of every contact,
    turned from the plane's azimuths into true bearings at the own ship's position
    (:meth:`tmaplan.io.frame.LocalFrame.true_azimuth`, which the readers undo),
    each row naming its contact (one contact: ``"contact"``); ``truth.json`` holds every
    contact's track.

    Parameters
    ----------
    sim : Simulation or ContactsSimulation
    directory : str or Path
    origin : (float, float)
        The own ship's start (latitude, longitude) [deg].
    start : datetime.datetime
        Aware UTC time of the first step.
    seed : int, optional
        Recorded in ``truth.json``.

    Returns
    -------
    dict of str to str
        File role (``bearings``, ``ownship_csv``, ``ownship_nmea``, ``ownship_gpx``,
        ``truth``) to path.

    Raises
    ------
    ArgumentError
        (``--export``) The run has no bearing, or the directory cannot be written.
    """
    from tmaplan.io import (  # deferred: pyproj, pynmea2, gpxpy only when exporting
        LocalFrame,
        write_bearings,
        write_gpx,
        write_nmea,
        write_ownship_csv,
        write_truth,
    )

    scenario = sim.scenario
    # one contact's run, or each contact's (several contacts: one row per contact and step)
    runs = (sim.runs if isinstance(sim, ContactsSimulation)
            else {scenario.contacts[0].name: sim})
    bearings = [(name, m) for name, run in runs.items() for m in run.measurements
                if m.kind == "bearing" and m.steps.size]
    if not bearings:
        raise ArgumentError("--export", "a problem whose run has bearings (bearings.csv holds "
                            "the bearing sensors' measurements)", "no bearing",
                            source=scenario.name)
    d = Path(directory)
    t0 = float(sim.times[0])
    t = sim.times - t0
    obs = sim.observer
    p0 = obs.position[0]
    frame = LocalFrame(lat0=origin[0], lon0=origin[1])
    local = obs.position - p0
    lat, lon = frame.to_latlon(local[:, 0], local[:, 1])
    bt = np.concatenate([m.times for _, m in bearings]) - t0
    order = np.argsort(bt, kind="stable")
    # the simulation's bearings are the plane's azimuths; a recording's are true
    own = np.concatenate([local[m.steps] for _, m in bearings])
    values = frame.true_azimuth(own[:, 0], own[:, 1],
                                np.concatenate([m.values for _, m in bearings]))[order]
    sigma = np.concatenate([np.full(m.steps.size, float(m.sigma)) for _, m in bearings])[order]
    names = np.concatenate([np.full(m.steps.size, name, dtype=object) for name, m in bearings])
    contact: str | list[str] = (next(iter(runs)) if len(runs) == 1
                                else [str(n) for n in names[order]])
    try:  # the writers make the directory
        files = {
            "bearings": write_bearings(d / "bearings.csv", bt[order], values, sigma=sigma,
                                       contact=contact, start=start),
            "ownship_csv": write_ownship_csv(d / "ownship.csv", t, lat, lon, start=start),
            "ownship_nmea": write_nmea(d / "ownship.nmea", t, lat, lon, start=start,
                                       course=obs.heading, speed=obs.speed),
            "ownship_gpx": write_gpx(d / "ownship.gpx", t, lat, lon, start=start,
                                     name=f"{scenario.name} own ship"),
            "truth": write_truth(
                d / "truth.json", times=t, start=start, frame=frame,
                contacts={name: run.target - np.r_[p0, 0.0, 0.0] for name, run in runs.items()},
                ownship=local,
                extra={"problem": scenario.name, "seed": seed,
                       "scenario_offset": [float(p0[0]), float(p0[1])], "scenario_t0": t0}),
        }
    except OSError as exc:
        raise ArgumentError("--export", "a directory where files can be written",
                            f"{str(d)!r} ({exc.strerror or exc})", source=scenario.name
                            ) from None
    return {k: str(v) for k, v in files.items()}


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Simulate, write ``<out>/<problem>_geometry.png`` (and the ``--export`` files) and return
    the JSON payload."""
    scenario = load(args.problem)
    if args.export is None:
        for flag in ("origin", "start"):
            if getattr(args, flag, None) is not None:
                raise ArgumentError(f"--{flag}", "given only with --export", "no --export",
                                    source=scenario.name)
    if getattr(args, "observer_plan", None) is not None:
        scenario = with_observer_plan(scenario, args.observer_plan)
    if len(scenario.contacts) > 1:
        return _run_several(args, scenario)
    sim = simulate(scenario, np.random.default_rng(args.seed))
    payload = sim.to_json()
    payload["seed"] = args.seed
    if args.json != "-":
        print(_summary(scenario.name, sim, args.seed))
    if args.export is not None:
        files = export(sim, args.export, origin=args.origin or DEFAULT_ORIGIN,
                       start=args.start or parse_start(DEFAULT_START), seed=args.seed)
        payload["export"] = files
        if args.json != "-":
            print(f"wrote {', '.join(files.values())}")
    if not args.no_figure:
        from tmaplan.plotting import plot_bearings, plot_geometry  # deferred: matplotlib

        path = Path(args.out) / f"{scenario.name}_geometry.png"
        plot_geometry(sim, path)
        payload["figure"] = str(path)
        bearings = plot_bearings(sim, Path(args.out) / f"{scenario.name}_bearings.png")
        if bearings is not None:
            payload["bearings_figure"] = str(bearings)
        if args.json != "-":
            print(f"wrote {path}" + (f", {bearings}" if bearings is not None else ""))
    return payload


def _summary(name: str, sim: Simulation, seed: int) -> str:
    """The console line of one contact's run."""
    sc = sim.scenario
    counts = ", ".join(f"{m.steps.size} {m.kind} (sensors[{m.sensor}])"
                       for m in sim.measurements)
    r = np.hypot(sim.relative[:, 0], sim.relative[:, 1])
    return (f"{name}: seed {seed}, {sc.n_steps} steps of {sc.time.dt:g} s over "
            f"{timespan(sc.time.horizon)}; range {r[0] / 1e3:.2f} km -> {r[-1] / 1e3:.2f} km "
            f"(min {r.min() / 1e3:.2f} km); measurements: {counts or 'none'}")


def _run_several(args: argparse.Namespace, scenario: Any) -> dict[str, Any]:
    """``simulate`` of a several-contact scenario: one run of every contact
    (:class:`ContactsSimulation`), a console line, a geometry figure and a bearings figure
    per contact (``<out>/<problem>-<contact>_geometry.png``, ``_bearings.png``, as one
    contact's); ``--export`` writes every contact's bearings, each row naming its contact."""
    sim: ContactsSimulation = simulate_contacts(scenario, np.random.default_rng(args.seed))
    payload = sim.to_json()
    payload["seed"] = args.seed
    if args.export is not None:
        payload["export"] = export(sim, args.export, origin=args.origin or DEFAULT_ORIGIN,
                                   start=args.start or parse_start(DEFAULT_START), seed=args.seed)
        if args.json != "-":
            print(f"wrote {', '.join(payload['export'].values())}")
    for name, run in sim.runs.items():
        if args.json != "-":
            print(_summary(f"{scenario.name} contact {name}", run, args.seed))
        if not args.no_figure:
            from tmaplan.plotting import plot_bearings, plot_geometry  # deferred: matplotlib

            path = Path(args.out) / f"{scenario.name}-{name}_geometry.png"
            plot_geometry(run, path)
            payload["contacts"][name]["figure"] = str(path)
            bearings = plot_bearings(run, Path(args.out) / f"{scenario.name}-{name}_bearings.png")
            if bearings is not None:
                payload["contacts"][name]["bearings_figure"] = str(bearings)
            if args.json != "-":
                print(f"wrote {path}" + (f", {bearings}" if bearings is not None else ""))
    return payload
