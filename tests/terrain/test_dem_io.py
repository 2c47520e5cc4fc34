"""DEM readers: thesis xyz, ESRI ASCII, npy/npz, samples, and their bad input."""

import numpy as np
import pytest

from tin_swarm_env.errors import DemFormatError, MissingExtraError
from tin_swarm_env.terrain import Dem, PointCloud, build_tin, load_dem, sample_dem
from tin_swarm_env.terrain.dem import metres_per_degree


def write(path, text):
    path.write_text(text)
    return path


def test_xyz_grid_in_any_order_is_a_grid(tmp_path):
    xs, ys = np.arange(4) * 10.0, np.arange(3) * 5.0 + 100
    rows = [(x, y, x + 2 * y) for y in ys for x in xs]
    rng = np.random.default_rng(0)
    rng.shuffle(rows)
    p = write(tmp_path / "g.xyz", "\n".join(f"{x} {y} {z}" for x, y, z in rows) + "\n")
    dem = load_dem(p)
    assert isinstance(dem, Dem)
    assert dem.shape == (3, 4)
    np.testing.assert_array_equal(dem.x, xs)
    np.testing.assert_array_equal(dem.y, ys)
    np.testing.assert_array_equal(dem.z, xs[None, :] + 2 * ys[:, None])
    assert dem.dx == 10.0 and dem.dy == 5.0


def test_xyz_scattered_is_a_point_cloud_and_triangulates(tmp_path):
    p = write(tmp_path / "s.txt", "# scattered\n0 0 1\n10 0 2\n\n0 10 3\n7,7,4\n3 4 5\n")
    cloud = load_dem(p)
    assert isinstance(cloud, PointCloud)
    assert cloud.points.shape == (5, 3)
    tin = build_tin(cloud)
    assert tin.n_vertices == 5
    with pytest.raises(ValueError, match="regular grid"):
        build_tin(cloud, method="vip", max_vertices=4)


def test_xyz_exact_duplicates_dropped_conflicting_duplicates_named(tmp_path):
    p = write(tmp_path / "d.xyz", "0 0 1\n1 0 1\n0 1 1\n1 1 1\n1 1 1\n")
    assert load_dem(p).shape == (2, 2)
    p = write(tmp_path / "c.xyz", "0 0 1\n1 0 1\n0 1 1\n1 1 1\n1 1 2\n")
    with pytest.raises(DemFormatError, match=r"lines 4 and 5"):
        load_dem(p)


def test_xyz_bad_line_names_the_line(tmp_path):
    p = write(tmp_path / "b.xyz", "0 0 1\n1 0 1\n0 1\n")
    with pytest.raises(DemFormatError, match=r"b\.xyz:3: expected 3 numbers"):
        load_dem(p)
    p = write(tmp_path / "n.xyz", "0 0 1\n1 zero 1\n")
    with pytest.raises(DemFormatError, match=r"n\.xyz:2: not a number"):
        load_dem(p)


@pytest.mark.parametrize("text", ["", "\n\n# only a comment\n"])
def test_empty_file_is_an_error(tmp_path, text):
    with pytest.raises(DemFormatError, match="empty"):
        load_dem(write(tmp_path / "e.xyz", text))
    with pytest.raises(DemFormatError, match="empty"):
        load_dem(write(tmp_path / "e.asc", text))


def test_fewer_than_three_points_and_collinear(tmp_path):
    with pytest.raises(DemFormatError, match="at least 3"):
        load_dem(write(tmp_path / "two.xyz", "0 0 0\n5 1 0\n"))
    cloud = load_dem(write(tmp_path / "line.xyz", "0 0 0\n1 1 0\n2 2 1\n5 5 1\n"))
    from tin_swarm_env.errors import TinStructureError

    with pytest.raises(TinStructureError, match="collinear"):
        build_tin(cloud)


ASC = """ncols 3
nrows 2
xllcorner 100
yllcorner 200
cellsize 10
NODATA_value -9999
1 2 3
4 -9999 6
"""


def test_asc_flips_rows_and_masks_nodata(tmp_path):
    dem = load_dem(write(tmp_path / "a.asc", ASC))
    np.testing.assert_array_equal(dem.x, [105, 115, 125])
    np.testing.assert_array_equal(dem.y, [205, 215])
    assert dem.z[1, 0] == 1 and dem.z[0, 0] == 4  # first file row is the north row
    assert np.isnan(dem.z[0, 1]) and dem.n_nodata == 1
    with pytest.raises(DemFormatError, match="NODATA"):
        build_tin(dem, max_vertices=5)
    filled = dem.fill_nodata()
    assert filled.n_nodata == 0 and filled.z[0, 1] in (4.0, 6.0, 2.0)
    tin = build_tin(filled, max_vertices=6)
    assert tin.n_vertices == 6


def test_asc_errors(tmp_path):
    with pytest.raises(DemFormatError, match="found 5"):
        load_dem(write(tmp_path / "short.asc", ASC.replace("4 -9999 6", "4 6")))
    with pytest.raises(DemFormatError, match=r":3: unknown ESRI ASCII header key 'xllwrong'"):
        load_dem(write(tmp_path / "k.asc", ASC.replace("xllcorner", "xllwrong")))
    with pytest.raises(DemFormatError, match="cellsize"):
        load_dem(write(tmp_path / "c.asc", ASC.replace("cellsize 10\n", "")))


def test_asc_data_may_start_with_nan_and_an_infinite_value_is_named_by_line(tmp_path):
    dem = load_dem(write(tmp_path / "n.asc", ASC.replace("1 2 3", "nan 2 3")))  # a data row, not a header key
    assert np.isnan(dem.z[1, 0]) and dem.z[1, 1] == 2 and dem.n_nodata == 2
    with pytest.raises(DemFormatError, match=r"i\.asc:8: an infinite elevation 'inf'"):
        load_dem(write(tmp_path / "i.asc", ASC.replace("4 -9999 6", "4 inf 6")))
    with pytest.raises(DemFormatError, match=r"c\.asc:7: not a number: '1,5'"):  # data, if not a number
        load_dem(write(tmp_path / "c.asc", ASC.replace("1 2 3", "1,5 2 3")))


def test_npy_and_npz(tmp_path):
    z = np.arange(12.0).reshape(3, 4)
    np.save(tmp_path / "z.npy", z)
    dem = load_dem(tmp_path / "z.npy")
    np.testing.assert_array_equal(dem.z, z)
    assert dem.dx == 1.0
    np.savez(tmp_path / "z.npz", elevation=z, dx=2.0, dy=3.0)
    dem = load_dem(tmp_path / "z.npz")
    assert (dem.dx, dem.dy) == (2.0, 3.0)
    np.savez(tmp_path / "bad.npz", other=z)
    with pytest.raises(DemFormatError, match="no elevation array"):
        load_dem(tmp_path / "bad.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(DemFormatError, match=r"junk\.npz: not an \.npz archive \(a zip of \.npy arrays"):
        load_dem(tmp_path / "junk.npz")
    (tmp_path / "zipjunk.npz").write_bytes(b"PK\x05\x06" + b"\0" * 18)  # an empty zip: no elevation in it
    with pytest.raises(DemFormatError, match="no elevation array"):
        load_dem(tmp_path / "zipjunk.npz")


def test_a_small_cell_size_alone_is_metres_and_small_coordinates_are_degrees(tmp_path):
    """No coordinates, only dx/dy: metres, however small (5 mm cells stay 5 mm); the same spacing as
    x/y coordinate vectors (or named longitude/latitude) inside degrees' range: degrees."""
    z = np.zeros((5, 6))
    np.savez(tmp_path / "mm.npz", z=z, dx=0.005)
    dem = load_dem(tmp_path / "mm.npz")
    assert (dem.dx, dem.dy) == (0.005, 0.005)
    np.savez(tmp_path / "deg.npz", z=z, x=10.0 + 0.005 * np.arange(6), y=45.0 + 0.005 * np.arange(5))
    m_lon, m_lat = metres_per_degree(45.01)
    dem = load_dem(tmp_path / "deg.npz")
    assert dem.dx == pytest.approx(0.005 * m_lon) and dem.dy == pytest.approx(0.005 * m_lat)


@pytest.mark.parametrize("keys, match", [
    ({"x": np.arange(6.0) * 5}, "'x' given without the other axis"),
    ({"longitude": np.arange(6.0)}, "'longitude' given without the other axis"),
    ({"lat": np.arange(5.0)}, "'lat' given without the other axis"),
    ({"dy": 2.0}, "'dy' given without 'dx'"),
    ({"x": np.arange(6.0), "y": np.arange(5.0), "dx": 2.0}, r"both coordinates \('x', 'y'\) and a cell size \(dx\)"),
    ({"longitude": np.arange(6.0), "latitude": np.arange(5.0) + 100}, r"latitudes \('latitude'\) must lie within"),
    ({"longitude": np.arange(6.0), "latitude": np.arange(5.0) + 88}, "must lie within -90..90 degrees, got 88..92"),
])
def test_coordinates_that_leave_the_scale_to_a_guess_are_refused_by_name(tmp_path, keys, match):
    np.savez(tmp_path / "d.npz", z=np.zeros((5, 6)), **keys)
    with pytest.raises(DemFormatError, match=match) as e:
        load_dem(tmp_path / "d.npz")
    assert "d.npz" in str(e.value)


def test_unknown_suffix_and_missing_file(tmp_path):
    with pytest.raises(DemFormatError, match="unknown DEM suffix"):
        load_dem(write(tmp_path / "x.dem", "1"))
    with pytest.raises(DemFormatError, match="no such DEM file"):
        load_dem(tmp_path / "missing.xyz")


def test_geotiff_without_rasterio_names_the_extra(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_rasterio(name, *a, **k):
        if name == "rasterio" or name.startswith("rasterio."):
            raise ImportError("No module named 'rasterio'")
        return real_import(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_rasterio)
    monkeypatch.delitem(__import__("sys").modules, "rasterio", raising=False)
    with pytest.raises(MissingExtraError, match=r"tin_swarm_env\[geo\]"):
        load_dem(write(tmp_path / "t.tif", "x"))


def test_jacksboro_sample_in_metres(jacksboro):
    dem = jacksboro
    assert dem.shape == (344, 403)
    assert np.nanmin(dem.z) == 236 and np.nanmax(dem.z) == 1076
    m_lon, m_lat = metres_per_degree(0.5 * (36.44625 + 36.73291666666667))
    assert dem.dx == pytest.approx(m_lon * 3 / 3600, rel=1e-9)
    assert dem.dy == pytest.approx(m_lat * 3 / 3600, rel=1e-9)
    assert 74 < dem.dx < 75 and 92 < dem.dy < 93
    assert dem.x[0] == 0 and dem.y[0] == 0


def test_topobathy_sample():
    dem = sample_dem("topobathy")
    assert dem.shape == (91, 120)
    assert np.nanmin(dem.z) < 0 < np.nanmax(dem.z)
    # 2 arc-minutes of longitude at 49 N; rows about 1.3 arc-minutes apart (Mercator-square cells)
    assert 2400 < dem.dx < 2480 and 2400 < dem.dy < 2480
    with pytest.raises(ValueError, match="unknown sample"):
        sample_dem("everest")


def test_geotiff_projected_and_geographic(tmp_path):
    rasterio = pytest.importorskip("rasterio", reason="the geo extra")
    from rasterio.transform import from_origin

    z = np.arange(12, dtype="float32").reshape(3, 4)
    z[1, 2] = -9999
    p = tmp_path / "utm.tif"
    with rasterio.open(p, "w", driver="GTiff", height=3, width=4, count=1, dtype="float32", crs="EPSG:32616",
                       transform=from_origin(1000, 2000, 10, 10), nodata=-9999) as dst:
        dst.write(z, 1)
    dem = load_dem(p)
    np.testing.assert_array_equal(dem.x, [1005, 1015, 1025, 1035])
    np.testing.assert_array_equal(dem.y, [1975, 1985, 1995])
    np.testing.assert_array_equal(dem.z[0], [8, 9, 10, 11])  # the file's last (southern) row
    assert np.isnan(dem.z[1, 2]) and dem.n_nodata == 1
    g = tmp_path / "wgs84.tif"
    with rasterio.open(g, "w", driver="GTiff", height=3, width=4, count=1, dtype="float32", crs="EPSG:4326",
                       transform=from_origin(-84.4, 36.7, 0.001, 0.001)) as dst:
        dst.write(np.ones((3, 4), "float32"), 1)
    dem = load_dem(g)
    m_lon, m_lat = metres_per_degree(36.7 - 0.0015)
    assert dem.dx == pytest.approx(0.001 * m_lon, rel=1e-6) and dem.dy == pytest.approx(0.001 * m_lat, rel=1e-6)


@pytest.mark.parametrize("dtype,nodata", [("int16", -32768), ("int16", None), ("uint16", 65535), ("uint16", 0),
                                          ("uint16", None), ("int32", -2147483648), ("int32", -9999),
                                          ("int32", None), ("float32", None)])
def test_integer_geotiffs_with_and_without_nodata(tmp_path, dtype, nodata):
    """SRTM-style rasters: integers cast to float64 before NODATA cells become NaN."""
    rasterio = pytest.importorskip("rasterio", reason="the geo extra")
    from rasterio.transform import from_origin

    z = (np.arange(12).reshape(3, 4) * 7 + 100).astype(dtype)
    if nodata is not None:
        z[1, 2] = nodata
    p = tmp_path / f"srtm_{dtype}.tif"
    kw = {} if nodata is None else {"nodata": nodata}
    with rasterio.open(p, "w", driver="GTiff", height=3, width=4, count=1, dtype=dtype, crs="EPSG:32616",
                       transform=from_origin(1000, 2000, 30, 30), **kw) as dst:
        dst.write(z, 1)
    dem = load_dem(p)
    assert dem.z.dtype == np.float64
    expect = z[::-1].astype(np.float64)
    if nodata is not None:
        expect[1, 2] = np.nan  # file row 1 is our row 1 of 3 (flipped)
        assert dem.n_nodata == 1
    else:
        assert dem.n_nodata == 0
    np.testing.assert_array_equal(dem.z, expect)
    tin = build_tin(dem.fill_nodata(), method="delaunay")
    assert np.all(np.isfinite(tin.slope_deg))


def test_unreadable_geotiff_is_a_dem_error(tmp_path):
    pytest.importorskip("rasterio", reason="the geo extra")
    with pytest.raises(DemFormatError, match=r"junk\.tif: not a readable GeoTIFF"):
        load_dem(write(tmp_path / "junk.tif", "II*\x00 not really a tiff"))


@pytest.mark.parametrize("key,value", [("ncols", "3.7"), ("ncols", "-3"), ("ncols", "0"), ("nrows", "2.5"),
                                       ("nrows", "nan"), ("nrows", "inf"), ("ncols", "1e400")])
def test_asc_counts_must_be_positive_whole_numbers(tmp_path, key, value):
    line = {"ncols": 1, "nrows": 2}[key]
    text = ASC.replace(f"{key} {3 if key == 'ncols' else 2}\n", f"{key} {value}\n")
    assert text != ASC
    with pytest.raises(DemFormatError, match=rf"bad\.asc:{line}: header {key} must be a positive whole number"):
        load_dem(write(tmp_path / "bad.asc", text))


def test_asc_repeated_header_key_names_both_lines(tmp_path):
    with pytest.raises(DemFormatError, match=r"rep\.asc:2: header key NCOLS repeats line 1"):
        load_dem(write(tmp_path / "rep.asc", ASC.replace("nrows 2\n", "NCOLS 3\nnrows 2\n")))


@pytest.mark.parametrize("big", [1e300, -1e35, 3.5e38])
def test_elevations_beyond_float32_are_refused_by_greedy_naming_the_dem(tmp_path, big):
    z = np.arange(16.0).reshape(4, 4)
    z[2, 1] = big
    np.save(tmp_path / "huge.npy", z)
    dem = load_dem(tmp_path / "huge.npy")
    with pytest.raises(DemFormatError, match=r"huge\.npy: elevation .* at row 2, col 1 .*float32"):
        build_tin(dem, method="greedy", max_error_m=1)


def test_elevations_that_would_overflow_the_planes_are_refused_by_every_method(tmp_path):
    from tin_swarm_env.errors import TinStructureError

    z = np.arange(16.0).reshape(4, 4)
    z[2, 1] = 1e300
    np.save(tmp_path / "huge.npy", z)
    dem = load_dem(tmp_path / "huge.npy")
    for kw in ({"method": "delaunay"}, {"method": "vip", "max_vertices": 16}):
        with pytest.raises(TinStructureError, match=r"huge\.npy.*coordinate beyond 1e\+15 m"):
            build_tin(dem, **kw)


def test_build_tin_and_sample_dem_name_a_wrong_argument():
    from tin_swarm_env.errors import ArgumentError

    with pytest.raises(ArgumentError, match=r"dem: build_tin needs a Dem or PointCloud, got list"):
        build_tin([[0, 0, 0]], method="delaunay")
    with pytest.raises(ArgumentError, match=r"name: unknown sample DEM 'nowhere'"):
        sample_dem("nowhere")
