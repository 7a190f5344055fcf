"""The local east/north frame of a recording: an azimuthal equidistant projection.

tmaplan works in a plane (x = East, y = North, metres; docs/conventions.md). A recording's
plane is the azimuthal equidistant projection of the WGS84 ellipsoid (PROJ ``aeqd``, through
pyproj) centred on a reference point, by default the own ship's first fix. ``aeqd`` keeps the
geodesic distance and azimuth from the centre exactly (so ranges and bearings from the
reference are true); away from the centre the plane's distances differ from the geodesic
ones by about ``(d/R)²/6`` relative (R the Earth's radius; 4e-6 at 30 km from the centre,
4e-5 at 100 km), which is far below bearing and range noise at TMA distances.

**Grid north is not true north.** The plane's north (its y axis) is true north only on the
centre's meridian: elsewhere a true azimuth (a bearing or a course as a compass, a GPS or a
sonar gives it, clockwise from true north) and the plane's ("grid") azimuth of the same
direction differ by the meridian convergence, about ``(d/R)·sin(azimuth from the centre)·
tan(latitude)``: 0.1° at 10 km east of the centre at 45°N, 0.5° at 30 km at 60°N, many
times the error of a bearing averaged over a recording. :meth:`LocalFrame.grid_azimuth` and
:meth:`LocalFrame.true_azimuth` convert between the two at any point of the plane, through the
projection's local Jacobian (exact to about 1e-12 rad).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pyproj
from numpy.typing import ArrayLike

from tmaplan.errors import ArgumentError

__all__ = ["LocalFrame"]


_GEOD = pyproj.Geod(ellps="WGS84")


@functools.lru_cache(maxsize=32)
def _transformer(lat0: float, lon0: float) -> pyproj.Transformer:
    """WGS84 (lon, lat) [deg] -> aeqd (east, north) [m] centred on (lat0, lon0)."""
    aeqd = pyproj.CRS.from_proj4(_proj_string(lat0, lon0))
    return pyproj.Transformer.from_crs(pyproj.CRS.from_epsg(4326), aeqd, always_xy=True)


def _proj_string(lat0: float, lon0: float) -> str:
    return f"+proj=aeqd +lat_0={lat0!r} +lon_0={lon0!r} +datum=WGS84 +units=m +no_defs"


@dataclasses.dataclass(frozen=True, kw_only=True)
class LocalFrame:
    """The azimuthal equidistant plane centred on a reference point (WGS84).

    Attributes
    ----------
    lat0 : float
        Latitude of the centre [deg], in [−90, 90].
    lon0 : float
        Longitude of the centre [deg], in [−180, 180].
    """

    lat0: float
    lon0: float

    def __post_init__(self) -> None:
        for name, v, lim in (("lat0", self.lat0, 90.0), ("lon0", self.lon0, 180.0)):
            if not (isinstance(v, int | float) and math.isfinite(v) and abs(v) <= lim):
                raise ArgumentError(name, f"degrees in [-{lim:g}, {lim:g}]", v)
        object.__setattr__(self, "lat0", float(self.lat0))
        object.__setattr__(self, "lon0", float(self.lon0))

    @property
    def projection(self) -> str:
        """The PROJ string of the plane (``+proj=aeqd +lat_0=.. +lon_0=.. +datum=WGS84``)."""
        return _proj_string(self.lat0, self.lon0)

    def to_local(self, lat: ArrayLike, lon: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Latitude/longitude to the plane.

        Parameters
        ----------
        lat, lon : array_like, shape (n,)
            [deg] (WGS84).

        Returns
        -------
        east, north : ndarray, shape (n,)
            [m] from the centre.
        """
        lat_a = np.asarray(lat, float)
        lon_a = np.asarray(lon, float)
        e, n = _transformer(self.lat0, self.lon0).transform(lon_a, lat_a)
        return np.asarray(e, float), np.asarray(n, float)

    def to_latlon(self, east: ArrayLike, north: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The plane to latitude/longitude (the inverse of :meth:`to_local`).

        Parameters
        ----------
        east, north : array_like, shape (n,)
            [m] from the centre.

        Returns
        -------
        lat, lon : ndarray, shape (n,)
            [deg] (WGS84), longitude in [−180, 180].
        """
        e = np.asarray(east, float)
        n = np.asarray(north, float)
        lon, lat = _transformer(self.lat0, self.lon0).transform(e, n, direction="INVERSE")
        return np.asarray(lat, float), np.asarray(lon, float)

    def _jacobian(self, east: ArrayLike, north: ArrayLike) -> np.ndarray:
        """The plane's metres per true east/north metre at points of the plane, shape (n, 2, 2):
        ``J[:, :, 0]`` the plane's image of 1 m true east, ``J[:, :, 1]`` of 1 m true north.

        Central differences along geodesics of ``h`` and ``2h`` (h = 500 m) combined by
        Richardson's extrapolation: truncation error about ``(h/R)⁴``, rounding error (the
        projection's nanometres over a kilometre) about 1e-12.
        """
        e = np.atleast_1d(np.asarray(east, float)).ravel()
        n = np.atleast_1d(np.asarray(north, float)).ravel()
        lat, lon = self.to_latlon(e, n)
        h = 500.0
        cols = []
        for az in (90.0, 0.0):
            diff = []
            for step in (h, 2 * h):
                ends = []
                for sign in (1.0, -1.0):
                    lo, la, _ = _GEOD.fwd(lon, lat, np.full(e.size, az),
                                          np.full(e.size, sign * step))
                    ends.append(np.column_stack(self.to_local(la, lo)))
                diff.append((ends[0] - ends[1]) / (2 * step))
            cols.append((4 * diff[0] - diff[1]) / 3)
        return np.stack(cols, axis=2)

    def grid_azimuth(self, east: ArrayLike, north: ArrayLike, azimuth: ArrayLike
                     ) -> np.ndarray:
        """The plane's azimuth of a direction given by its true azimuth (module doc).

        Parameters
        ----------
        east, north : array_like, shape (n,)
            Points of the plane [m] where the directions start (e.g. the own ship at each
            bearing's time).
        azimuth : array_like, shape (n,)
            True azimuths [rad], clockwise from true north (a geodesic's forward azimuth).

        Returns
        -------
        ndarray, shape (n,)
            The directions' azimuths in the plane [rad], clockwise from the plane's north, in
            (−π, π].
        """
        az = np.atleast_1d(np.asarray(azimuth, float)).ravel()
        J = self._jacobian(east, north)
        d = np.einsum("nij,nj->ni", J, np.column_stack([np.sin(az), np.cos(az)]))
        return np.arctan2(d[:, 0], d[:, 1])

    def true_azimuth(self, east: ArrayLike, north: ArrayLike, azimuth: ArrayLike
                     ) -> np.ndarray:
        """The true azimuth of a direction given by its azimuth in the plane (the inverse of
        :meth:`grid_azimuth`).

        Parameters
        ----------
        east, north : array_like, shape (n,)
            Points of the plane [m].
        azimuth : array_like, shape (n,)
            Azimuths in the plane [rad], clockwise from the plane's north.

        Returns
        -------
        ndarray, shape (n,)
            True azimuths [rad], clockwise from true north, in (−π, π].
        """
        az = np.atleast_1d(np.asarray(azimuth, float)).ravel()
        J = self._jacobian(east, north)
        d = np.linalg.solve(J, np.column_stack([np.sin(az), np.cos(az)])[:, :, None])[:, :, 0]
        return np.arctan2(d[:, 0], d[:, 1])
