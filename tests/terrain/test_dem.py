"""Elevation grids and point clouds (terrain/dem.py): copies, derived sizes, NODATA filling,
cropping, bad grids named, and the geographic scale."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.errors import DemFormatError
from tin_swarm_env.terrain.dem import Dem, PointCloud, geographic_to_metres, metres_per_degree


def test_metres_per_degree_known_values():
    m_lon, m_lat = metres_per_degree(0.0)
    assert m_lon == pytest.approx(111319.5, abs=1.0)
    assert m_lat == pytest.approx(110574.3, abs=1.0)
    m_lon, m_lat = metres_per_degree(45.0)
    assert m_lon == pytest.approx(78846.8, abs=1.0)
    assert m_lat == pytest.approx(111131.8, abs=1.0)


def test_a_dem_owns_read_only_copies_and_derives_its_cell_sizes():
    z = np.array([[1.0, 2.0, 3.0], [4.0, np.nan, 6.0]])
    x, y = [10.0, 12.0, 14.0], [100.0, 105.0]
    dem = Dem(z, x, y, source="hand")
    z[0, 0] = 99.0  # the caller's array changes, the Dem does not
    assert dem.z[0, 0] == 1.0 and not dem.z.flags.writeable and not dem.x.flags.writeable
    assert dem.shape == (2, 3) and dem.dx == 2.0 and dem.dy == 5.0 and dem.n_nodata == 1
    # cell centres row-major, the order of z.ravel(); points leave the NaN cell out
    np.testing.assert_array_equal(dem.cell_centres(), [[10, 100], [12, 100], [14, 100],
                                                       [10, 105], [12, 105], [14, 105]])
    np.testing.assert_array_equal(dem.points(), [[10, 100, 1], [12, 100, 2], [14, 100, 3],
                                                 [10, 105, 4], [14, 105, 6]])
    assert repr(dem) == "Dem('hand', 2x3 cells, dx=2 m, dy=5 m, z 1.0..6.0 m, nodata=1)"


def test_fill_nodata_takes_the_nearest_valid_cell_and_crop_keeps_coordinates():
    z = np.array([[1.0, np.nan, np.nan, 4.0], [5.0, 6.0, 7.0, 8.0], [9.0, 10.0, 11.0, np.nan]])
    dem = Dem(z, [0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0])
    filled = dem.fill_nodata()
    # each NaN cell takes the value of a valid cell one cell away (its nearest; which of two tied
    # ones is the transform's choice, so only the distance is checked)
    assert filled.n_nodata == 0 and np.array_equal(filled.z[~np.isnan(z)], z[~np.isnan(z)])
    for r, c in zip(*np.nonzero(np.isnan(z))):
        src = np.argwhere(z == filled.z[r, c])[0]
        assert np.hypot(*(src - (r, c))) == 1.0
    full = Dem(np.ones((2, 2)), [0.0, 1.0], [0.0, 1.0])
    assert full.fill_nodata() is full
    with pytest.raises(DemFormatError, match="every cell is NODATA"):
        Dem(np.full((2, 2), np.nan), [0.0, 1.0], [0.0, 1.0], source="void").fill_nodata()
    sub = dem.crop(slice(1, 3), slice(0, 2))
    np.testing.assert_array_equal(sub.z, [[5, 6], [9, 10]])
    np.testing.assert_array_equal(sub.x, [0, 1])
    np.testing.assert_array_equal(sub.y, [1, 2])


@pytest.mark.parametrize("z,x,y,msg", [
    (np.ones(4), [0, 1, 2, 3], [0], "elevation must be 2-D"),
    (np.ones((2, 3)), [0, 1], [0, 1], r"elevation shape \(2, 3\) does not match len\(y\)=2, len\(x\)=2"),
    (np.ones((1, 3)), [0, 1, 2], [0], "a DEM needs at least 2x2 cells"),
    (np.ones((2, 2)), [0, np.nan], [0, 1], "x coordinates are not all finite"),
    (np.ones((2, 2)), [0, 1], [1, 0], "y coordinates must be strictly increasing"),
    (np.ones((2, 3)), [0, 1, 3], [0, 1], "x coordinates are not evenly spaced"),
    (np.array([[1.0, np.inf], [1.0, 1.0]]), [0, 1], [0, 1], "elevation has infinite values"),
])
def test_a_bad_grid_is_refused_naming_the_source(z, x, y, msg):
    with pytest.raises(DemFormatError, match="grid.asc: " + msg):
        Dem(z, x, y, source="grid.asc")


def test_a_point_cloud_is_n_by_3_finite_and_read_only():
    pc = PointCloud([[0, 0, 1], [1, 0, 2], [0, 1, 3]], source="pts.xyz")
    assert pc.points.dtype == np.float64 and not pc.points.flags.writeable
    assert repr(pc) == "PointCloud('pts.xyz', 3 points)"
    with pytest.raises(DemFormatError, match=r"pts.xyz: points must have shape \(n, 3\), got \(2, 2\)"):
        PointCloud([[0, 0], [1, 1]], source="pts.xyz")
    with pytest.raises(DemFormatError, match="pts.xyz: points contain NaN"):
        PointCloud([[0, 0, np.nan]], source="pts.xyz")


def test_geographic_to_metres_scales_at_the_mid_latitude_from_the_south_west_centre():
    lon, lat = np.array([10.0, 10.5, 11.0]), np.array([44.0, 46.0])
    x, y, lat0 = geographic_to_metres(lon, lat)
    m_lon, m_lat = metres_per_degree(45.0)
    assert lat0 == 45.0
    np.testing.assert_allclose(x, [0.0, 0.5 * m_lon, m_lon], rtol=1e-15)
    np.testing.assert_allclose(y, [0.0, 2 * m_lat], rtol=1e-15)
