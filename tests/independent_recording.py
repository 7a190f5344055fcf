"""An independent recording simulator for ``tmaplan advise`` (issue 41's acceptance check).

It shares no code with tmaplan: numpy and :class:`pyproj.Geod` (WGS84 geodesics) only, and
its own writers of the bearings CSV and of the own ship's navigation as a latitude/longitude
CSV, NMEA 0183 (RMC + GGA, checksums computed here) and GPX 1.1.

* The own ship and every contact move on the ellipsoid: each time step is a geodesic step of
  ``speed·dt`` along the current forward azimuth (a contact: a geodesic, i.e. constant
  velocity on the Earth; the own ship: a geodesic leg, then a turn at a constant rate, then
  another geodesic leg).
* A bearing is the geodesic forward azimuth (true north, clockwise, degrees) from the own
  ship to the contact at the bearing's time, plus Gaussian noise of the stated σ.
* The truth at any time (:meth:`Recording.truth`): geodesic range from the own ship, the
  contact's true course (its forward azimuth) and speed.

Nothing here imports tmaplan: a bug in tmaplan's own writers or frame cannot hide a bug in
its readers or estimators.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from functools import reduce
from pathlib import Path

import numpy as np
from pyproj import Geod

GEOD = Geod(ellps="WGS84")
KNOT = 1852.0 / 3600.0


@dataclasses.dataclass(frozen=True)
class Mover:
    """A track sampled on a fine clock: times [s], lat, lon [deg], course [deg], speed [m/s]."""

    t: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    course: np.ndarray
    speed: float

    def at(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Latitude, longitude and course at times ``t`` (geodesic step from the last sample)."""
        tq = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.t, tq, side="right") - 1, 0, self.t.size - 1)
        lon, lat, back = GEOD.fwd(self.lon[k], self.lat[k], self.course[k],
                                  self.speed * (tq - self.t[k]))
        course = np.where(tq > self.t[k], np.mod(np.asarray(back) + 180.0, 360.0),
                          self.course[k])
        return np.asarray(lat), np.asarray(lon), course


def fly(lat0: float, lon0: float, course0: float, speed: float, duration: float, dt_: float,
        turn: tuple[float, float, float] | None = None) -> Mover:
    """Move along geodesics from (lat0, lon0): ``turn = (start [s], angle [deg], rate [deg/s])``
    turns the course by ``angle`` (signed: + starboard) at ``rate`` from ``start``."""
    n = round(duration / dt_) + 1
    t = dt_ * np.arange(n)
    lat, lon, crs = np.empty(n), np.empty(n), np.empty(n)
    lat[0], lon[0], crs[0] = lat0, lon0, course0
    turned = 0.0
    for k in range(1, n):
        lo, la, back = GEOD.fwd(lon[k - 1], lat[k - 1], crs[k - 1], speed * dt_)
        lat[k], lon[k] = la, lo
        c = (back + 180.0) % 360.0  # the geodesic's forward azimuth here
        if turn is not None and t[k] > turn[0] and abs(turned) < abs(turn[1]):
            step = math.copysign(min(turn[2] * dt_, abs(turn[1]) - abs(turned)), turn[1])
            turned += step
            c = (c + step) % 360.0
        crs[k] = c
    return Mover(t=t, lat=lat, lon=lon, course=crs, speed=speed)


@dataclasses.dataclass(frozen=True)
class Recording:
    """A simulated recording: the own ship, the contacts, and the bearings."""

    start: dt.datetime
    own: Mover
    contacts: dict[str, Mover]
    bearing_times: dict[str, np.ndarray]
    bearings: dict[str, np.ndarray]
    sigma_deg: dict[str, float]
    turn_start: float
    turn_end: float

    def truth(self, name: str, t: float) -> dict[str, float]:
        """Contact ``name`` at ``t`` [s after the start]: geodesic range from the own ship [m],
        true course [deg] and speed [m/s]."""
        la, lo, _ = self.own.at(t)
        cla, clo, ccrs = self.contacts[name].at(t)
        _, _, dist = GEOD.inv(lo, la, clo, cla)
        return {"range": float(dist[0]), "course": float(ccrs[0]),
                "speed": self.contacts[name].speed}


def simulate(seed: int, *, lat0: float = 50.0, lon0: float = -5.0, leg1: float = 1200.0,
             turn_angle: float = -80.0, turn_rate: float = 0.75, leg2: float = 1500.0,
             own_course: float = 30.0, own_speed: float = 12.0 * KNOT,
             sigma_deg: tuple[float, float] = (1.0, 0.5),
             intervals: tuple[float, float] = (4.0, 6.0),
             start: dt.datetime = dt.datetime(2024, 6, 1, 11, 50, 0, tzinfo=dt.UTC),
             ) -> Recording:
    """Two contacts, the own ship on a leg, a turn, another leg (module doc)."""
    rng = np.random.default_rng(seed)
    duration = leg1 + abs(turn_angle) / turn_rate + leg2
    own = fly(lat0, lon0, own_course, own_speed, duration, 0.5,
              turn=(leg1, turn_angle, turn_rate))
    # the contacts: placed by range and bearing from the own ship's start, a random course
    specs = {"S1": (rng.uniform(60, 110), rng.uniform(9e3, 15e3), rng.uniform(3.0, 7.0)),
             "E7": (rng.uniform(300, 340), rng.uniform(12e3, 20e3), rng.uniform(4.0, 8.0))}
    courses = {name: rng.uniform(0, 360) for name in specs}  # geometry first, then noise
    contacts, btimes, bearings, sig = {}, {}, {}, {}
    for (name, (brg, rng_m, spd)), s, step in zip(specs.items(), sigma_deg, intervals,
                                                   strict=True):
        clo, cla, _ = GEOD.fwd(lon0, lat0, brg, rng_m)
        contacts[name] = fly(cla, clo, courses[name], spd, duration, 5.0)
        # bearings off the navigation's whole seconds, ending before the last fix
        tb = np.arange(0.25 + step, duration - 1.0, step)
        la, lo, _ = own.at(tb)
        cla_, clo_, _ = contacts[name].at(tb)
        az, _, _ = GEOD.inv(lo, la, clo_, cla_)
        bearings[name] = np.mod(np.asarray(az) + s * rng.standard_normal(tb.size), 360.0)
        btimes[name], sig[name] = tb, s
    return Recording(start=start, own=own, contacts=contacts, bearing_times=btimes,
                     bearings=bearings, sigma_deg=sig, turn_start=leg1,
                     turn_end=leg1 + abs(turn_angle) / turn_rate)


# ---- writers (hand-written: no tmaplan code) -------------------------------------------------

PLUS2 = dt.timezone(dt.timedelta(hours=2))


def iso(start: dt.datetime, t: float, zone: dt.timezone = dt.UTC) -> str:
    """ISO 8601 with milliseconds, in ``zone`` (``Z`` for UTC)."""
    s = (start + dt.timedelta(seconds=float(t))).astimezone(zone).isoformat(
        timespec="milliseconds")
    return s.replace("+00:00", "Z")


def write_bearings(rec: Recording, path: Path, *, until: float | None = None,
                   with_sigma: bool = True, mixed_zones: bool = True,
                   duplicates: int = 0, seed: int = 0) -> Path:
    """The bearings CSV (columns ``contact,time,bearing_deg[,sigma_deg]``, rows in time order,
    contacts interleaved); every other row's time in ``+02:00`` when ``mixed_zones``;
    ``duplicates`` rows repeated exactly."""
    rng = np.random.default_rng(seed)
    rows = []
    for name, tb in rec.bearing_times.items():
        for t, b in zip(tb, rec.bearings[name], strict=True):
            if until is None or t <= until:
                rows.append((float(t), name, float(b)))
    rows.sort()
    lines = ["contact,time,bearing_deg" + (",sigma_deg" if with_sigma else "")]
    for i, (t, name, b) in enumerate(rows):
        zone = PLUS2 if mixed_zones and i % 2 else dt.UTC
        line = f"{name},{iso(rec.start, t, zone)},{b!r}"
        lines.append(line + (f",{rec.sigma_deg[name]}" if with_sigma else ""))
    for k in sorted(rng.choice(np.arange(1, len(lines)), size=duplicates, replace=False),
                    reverse=True):
        lines.insert(int(k), lines[int(k)])
    path.write_text("\n".join(lines) + "\n")
    return path


def _fixes(rec: Recording, step: float, gap: tuple[float, float] | None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(0.0, rec.own.t[-1] + 1e-9, step)
    if gap is not None:
        t = t[(t < gap[0]) | (t > gap[1])]
    lat, lon, crs = rec.own.at(t)
    return t, lat, lon, crs


def write_ownship_csv(rec: Recording, path: Path, *, step: float = 1.0,
                      gap: tuple[float, float] | None = None, mixed_zones: bool = False) -> Path:
    """``time,lat_deg,lon_deg`` every ``step`` seconds (``gap``: no fixes in that span)."""
    t, lat, lon, _ = _fixes(rec, step, gap)
    lines = ["time,lat_deg,lon_deg"]
    for i, (ti, la, lo) in enumerate(zip(t, lat, lon, strict=True)):
        zone = PLUS2 if mixed_zones and i % 3 == 1 else dt.UTC
        lines.append(f"{iso(rec.start, ti, zone)},{la:.8f},{lo:.8f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def nmea_checksum(body: str) -> str:
    """The XOR of the characters between ``$`` and ``*``, two hex digits."""
    return f"{reduce(lambda a, c: a ^ ord(c), body, 0):02X}"


def _ddmm(value: float, lat: bool) -> tuple[str, str]:
    hemi = ("N" if value >= 0 else "S") if lat else ("E" if value >= 0 else "W")
    a = abs(value)
    deg = int(a)
    minutes = (a - deg) * 60.0
    if round(minutes, 4) >= 60.0:
        deg, minutes = deg + 1, 0.0
    return f"{deg:0{2 if lat else 3}d}{minutes:07.4f}", hemi


def write_ownship_nmea(rec: Recording, path: Path, *, step: float = 1.0,
                       gap: tuple[float, float] | None = None, bad_checksums: int = 0,
                       seed: int = 0) -> Path:
    """``$GPRMC`` + ``$GPGGA`` every ``step`` seconds (minutes to 1e-4, a receiver's usual
    resolution); ``bad_checksums`` sentences given a wrong checksum."""
    t, lat, lon, crs = _fixes(rec, step, gap)
    out = []
    for ti, la, lo, c in zip(t, lat, lon, crs, strict=True):
        when = rec.start + dt.timedelta(seconds=float(ti))
        hms = when.strftime("%H%M%S") + f".{when.microsecond // 10000:02d}"
        (lat_s, ns), (lon_s, ew) = _ddmm(la, True), _ddmm(lo, False)
        rmc = (f"GPRMC,{hms},A,{lat_s},{ns},{lon_s},{ew},{rec.own.speed / KNOT:.2f},"
               f"{c:.1f},{when:%d%m%y},,,A")
        gga = f"GPGGA,{hms},{lat_s},{ns},{lon_s},{ew},1,09,0.9,12.0,M,48.0,M,,"
        out += [f"${rmc}*{nmea_checksum(rmc)}", f"${gga}*{nmea_checksum(gga)}"]
    if bad_checksums:
        rng = np.random.default_rng(seed)
        for k in rng.choice(np.arange(2, len(out) - 2), size=bad_checksums, replace=False):
            s = out[int(k)]
            good = s[-2:]
            out[int(k)] = s[:-2] + ("00" if good != "00" else "FF")
    path.write_text("\r\n".join(out) + "\r\n")
    return path


def write_ownship_gpx(rec: Recording, path: Path, *, step: float = 1.0,
                      gap: tuple[float, float] | None = None) -> Path:
    """One GPX 1.1 track; a ``gap`` splits it into two segments."""
    t, lat, lon, _ = _fixes(rec, step, gap)
    segs = [[]]  # type: list[list[str]]
    for i, (ti, la, lo) in enumerate(zip(t, lat, lon, strict=True)):
        if i and gap is not None and t[i - 1] < gap[0] < ti:
            segs.append([])
        segs[-1].append(f'      <trkpt lat="{la:.8f}" lon="{lo:.8f}"><ele>0.0</ele>'
                        f"<time>{iso(rec.start, ti)}</time></trkpt>")
    body = "\n".join("    <trkseg>\n" + "\n".join(s) + "\n    </trkseg>" for s in segs)
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n'
                    '<gpx version="1.1" creator="independent-simulator" '
                    'xmlns="http://www.topografix.com/GPX/1/1">\n'
                    "  <metadata><name>own ship</name></metadata>\n"
                    f"  <trk><name>own ship</name>\n{body}\n  </trk>\n</gpx>\n")
    return path
