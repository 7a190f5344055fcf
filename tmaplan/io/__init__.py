"""Recorded data in and out (docs/recordings.md): bearings, own-ship navigation, the local
frame, plans and the truth of a simulated recording.

Readers return frozen dataclasses of numpy arrays in SI units (seconds, metres, radians;
latitude/longitude in degrees, named ``lat``/``lon``). Faults in a file raise a one-line
:class:`~tmaplan.errors.DataError` naming the file, line and column, or issue a one-line
:class:`DataWarning` saying what was done (:mod:`tmaplan.io.faults`).

Modules: :mod:`~tmaplan.io.bearings` (bearings CSV), :mod:`~tmaplan.io.nav` (own-ship CSV and
the checks shared by the navigation readers), :mod:`~tmaplan.io.nmea` (NMEA 0183, pynmea2),
:mod:`~tmaplan.io.gpx` (GPX, gpxpy), :mod:`~tmaplan.io.navigation` (a navigation file of any of
the three kinds), :mod:`~tmaplan.io.frame` (the azimuthal equidistant
plane, pyproj), :mod:`~tmaplan.io.recording` (bearings and navigation on one clock and plane),
:mod:`~tmaplan.io.plans` (leg table and track), :mod:`~tmaplan.io.truth` (``truth.json``).
"""

from tmaplan.io.bearings import BearingLog, ContactBearings, read_bearings, write_bearings
from tmaplan.io.faults import DataWarning
from tmaplan.io.frame import LocalFrame
from tmaplan.io.gpx import read_gpx, write_gpx
from tmaplan.io.nav import NavTrack, read_nav_csv, write_ownship_csv
from tmaplan.io.navigation import read_nav
from tmaplan.io.nmea import read_nmea, write_nmea
from tmaplan.io.plans import Leg, legs_from_track, read_legs_csv, write_legs_csv, write_track
from tmaplan.io.recording import (
    OwnshipState,
    RecordedContact,
    Recording,
    align,
    ownship_at,
    read_recording,
)
from tmaplan.io.truth import Truth, read_truth, write_truth

__all__ = [
    "BearingLog",
    "ContactBearings",
    "DataWarning",
    "Leg",
    "LocalFrame",
    "NavTrack",
    "OwnshipState",
    "RecordedContact",
    "Recording",
    "Truth",
    "align",
    "legs_from_track",
    "ownship_at",
    "read_bearings",
    "read_gpx",
    "read_legs_csv",
    "read_nav",
    "read_nav_csv",
    "read_nmea",
    "read_recording",
    "read_truth",
    "write_bearings",
    "write_gpx",
    "write_legs_csv",
    "write_nmea",
    "write_ownship_csv",
    "write_track",
    "write_truth",
]
