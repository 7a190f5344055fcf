"""The local east/north frame of a recording: an azimuthal equidistant projection.

tmaplan works in a plane (x = East, y = North, metres; docs/conventions.md). A recording's
plane is the azimuthal equidistant projection of the WGS84 ellipsoid (PROJ ``aeqd``, through
pyproj) centred on a reference point, by default the own ship's first fix. ``aeqd`` keeps the
geodesic distance and azimuth from the centre exactly (so ranges and bearings from the
reference are true); away from the centre the plane's distances differ from the geodesic
ones by about ``(d/R)²/6`` relative (R the Earth's radius; 4e-6 at 30 km from the centre,
4e-5 at 100 km), which is far below bearing and range noise at TMA distances.
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
