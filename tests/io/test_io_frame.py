"""The local plane (tmaplan.io.frame): properties of the azimuthal equidistant projection,
checked against pyproj's geodesic (Karney) as an independent computation."""

from __future__ import annotations

import numpy as np
import pyproj
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tmaplan.errors import ArgumentError
from tmaplan.io import LocalFrame

GEOD = pyproj.Geod(ellps="WGS84")
centres = st.tuples(st.floats(-80.0, 80.0), st.floats(-180.0, 180.0))
offsets = st.lists(st.tuples(st.floats(0.0, 1e5), st.floats(-np.pi, np.pi)), min_size=1,
                   max_size=20)


def _points(offs):
    r, a = np.array(offs).T
    return r * np.sin(a), r * np.cos(a)


@settings(max_examples=60, deadline=None)
@given(centres, offsets)
def test_local_latlon_round_trip_within_a_millimetre(centre, offs):
    frame = LocalFrame(lat0=centre[0], lon0=centre[1])
    e, n = _points(offs)
    lat, lon = frame.to_latlon(e, n)
    e2, n2 = frame.to_local(lat, lon)
    assert np.max(np.hypot(e2 - e, n2 - n)) < 1e-3
    lat2, lon2 = frame.to_latlon(e2, n2)
    _, _, d = GEOD.inv(lon, lat, lon2, lat2)
    assert np.max(d) < 1e-3


@settings(max_examples=60, deadline=None)
@given(centres, offsets)
@example(centre=(0.0, 1e-9), offs=[(2.0, 1.0)])  # found by CI: 0.09 mm off at 2 m
@example(centre=(0.0, 1e-9), offs=[(2.0, 0.0)])
def test_distance_and_azimuth_from_the_centre_are_the_geodesic_ones(centre, offs):
    frame = LocalFrame(lat0=centre[0], lon0=centre[1])
    e, n = _points(offs)
    lat, lon = frame.to_latlon(e, n)
    az, _, d = GEOD.inv(np.full(lat.size, centre[1]), np.full(lat.size, centre[0]), lon, lat)
    r = np.hypot(e, n)
    # a millimetre plus 1e-6 of the distance: PROJ's aeqd inverse returns the centre itself for
    # points within 1e-10 Earth radii of it (0.64 mm) and is good to ~0.1 mm a few metres out
    assert np.all(np.abs(d - r) < 1e-3 + 1e-6 * r)
    # the plane's bearing from the centre is the geodesic azimuth (where it is defined), to the
    # angle a millimetre across subtends
    far = r > 1.0
    diff = np.angle(np.exp(1j * (np.deg2rad(az[far]) - np.arctan2(e[far], n[far]))))
    assert np.all(np.abs(diff) < 1e-6 + 1e-3 / r[far])


def test_the_centre_is_the_origin_and_north_is_up():
    frame = LocalFrame(lat0=45.0, lon0=-5.0)
    e, n = frame.to_local([45.0, 45.01, 45.0], [-5.0, -5.0, -4.99])
    np.testing.assert_allclose([e[0], n[0]], 0.0, atol=1e-9)
    assert abs(e[1]) < 1e-9 and 1100 < n[1] < 1115  # 0.01° of latitude ≈ 1.11 km north
    assert e[2] > 780 and abs(n[2]) < 1.0            # 0.01° of longitude at 45° ≈ 0.79 km east
    assert "+proj=aeqd" in frame.projection and "+lat_0=45.0" in frame.projection


@pytest.mark.parametrize(("lat", "lon"), [(91.0, 0.0), (0.0, 181.0), (float("nan"), 0.0)])
def test_a_centre_out_of_range_is_refused(lat, lon):
    with pytest.raises(ArgumentError, match=r"lat0|lon0"):
        LocalFrame(lat0=lat, lon0=lon)
