"""The Tin (terrain/tin.py): orientation, adjacency, validation, slope/aspect, Delaunay condition;
its batched queries (locate, height_at, sensor tilt, line of sight) against slow, obvious references."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tin_swarm_env.errors import ArgumentError, TinStructureError
from tin_swarm_env.terrain import Dem, Tin, build_tin
from tin_swarm_env.terrain.reference import (
    height_brute,
    line_of_sight_brute,
    line_of_sight_dense,
    locate_brute,
)

SQUARE = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 5], [0, 10, 5]], dtype=float)


def test_orientation_and_neighbors_on_a_square():
    tin = Tin(SQUARE, [[0, 2, 1], [0, 2, 3]])  # first one clockwise
    v, t = tin.vertices, tin.triangles
    for tri in t:
        a, b, c = v[tri, :2]
        assert (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) > 0
    # each triangle has one neighbour, across the diagonal 0-2, opposite its third vertex
    for i in range(2):
        k = int(np.flatnonzero(tin.neighbors[i] >= 0)[0])
        assert tin.neighbors[i, k] == 1 - i
        assert t[i, k] in (1, 3)
    assert (tin.neighbors == -1).sum() == 4
    assert len(tin.edges) == 5


@given(st.integers(0, 10_000), st.integers(3, 60))
def test_neighbor_k_is_across_the_edge_opposite_vertex_k(random_tin, seed, n):
    tin = random_tin(seed, n)
    t, nb = tin.triangles, tin.neighbors
    for i in range(tin.n_triangles):
        for k in range(3):
            j = nb[i, k]
            edge = {t[i, (k + 1) % 3], t[i, (k + 2) % 3]}
            if j < 0:
                continue
            assert edge <= set(t[j])
            assert i in nb[j]
    # boundary edges = convex hull edges
    from scipy.spatial import ConvexHull

    hull = ConvexHull(tin.vertices[:, :2])
    assert (nb == -1).sum() == len(hull.vertices)


def test_non_manifold_and_overlap_are_refused():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    with pytest.raises(TinStructureError, match="non-manifold.*shared by 3"):
        Tin(v, [[0, 1, 2], [0, 2, 4], [0, 3, 2]])
    with pytest.raises(TinStructureError, match="overlap"):
        Tin(v, [[0, 1, 2], [0, 1, 3]])


def test_degenerate_triangles_removed_and_bad_input_named():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    tin = Tin(v, [[0, 1, 2], [0, 1, 3]])  # second is zero-area (collinear)
    assert tin.n_triangles == 1 and tin.n_degenerate_removed == 1 and tin.n_vertices == 3
    with pytest.raises(TinStructureError, match="zero area"):
        Tin(v, [[0, 1, 3]])
    with pytest.raises(TinStructureError, match="out of range"):
        Tin(v, [[0, 1, 9]])
    with pytest.raises(TinStructureError, match="repeats a vertex"):
        Tin(v, [[0, 1, 1]])
    with pytest.raises(TinStructureError, match="NaN"):
        Tin([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(TinStructureError, match="at least 3"):
        Tin.from_points([[0, 0, 0], [1, 1, 1], [1, 1, 2]])
    with pytest.raises(TinStructureError, match="collinear"):
        Tin.from_points([[0, 0, 0], [1, 1, 1], [2, 2, 2], [3, 3, 0]])


def test_duplicate_points_are_triangulated_once():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1], [1, 1, 1]], dtype=float)
    tin = Tin.from_points(pts)
    assert tin.n_vertices == 4 and tin.n_triangles == 2


def plane_tin(gx, gy):
    xy = np.array([[0, 0], [100, 0], [100, 100], [0, 100], [40, 60]], dtype=float)
    z = gx * xy[:, 0] + gy * xy[:, 1] + 7.0
    return Tin.from_points(np.column_stack([xy, z]))


@pytest.mark.parametrize("gx,gy,aspect", [(0, -1, 0), (-1, 0, 90), (0, 1, 180), (1, 0, 270),
                                          (-1, -1, 45), (1, 1, 225)])
def test_aspect_of_planes_facing_the_compass_points(gx, gy, aspect):
    # a plane facing north falls toward +y (dz/dy < 0): aspect 0
    tin = plane_tin(gx, gy)
    np.testing.assert_allclose(tin.aspect_deg, aspect, atol=1e-9)
    np.testing.assert_allclose(tin.slope_deg, math.degrees(math.atan(math.hypot(gx, gy))), atol=1e-9)


@given(st.floats(0.01, 80), st.floats(0, 359.999))
def test_slope_aspect_of_analytic_planes(slope, aspect):
    g = math.tan(math.radians(slope))
    a = math.radians(aspect)
    # downhill direction (sin a, cos a) east/north -> gradient = -g * that
    tin = plane_tin(-g * math.sin(a), -g * math.cos(a))
    np.testing.assert_allclose(tin.slope_deg, slope, atol=1e-7)
    d = (tin.aspect_deg - aspect + 180) % 360 - 180
    np.testing.assert_allclose(d, 0, atol=1e-6)
    assert np.all(tin.normals[:, 2] > 0)
    np.testing.assert_allclose(np.linalg.norm(tin.normals, axis=1), 1)
    # planes: z = a x + b y + c reproduces the vertices
    v = tin.vertices[tin.triangles]
    pz = tin.planes[:, None, 0] * v[..., 0] + tin.planes[:, None, 1] * v[..., 1] + tin.planes[:, None, 2]
    np.testing.assert_allclose(pz, v[..., 2], atol=1e-7)


def test_flat_triangles_have_aspect_minus_one():
    tin = plane_tin(0, 0)
    assert np.all(tin.slope_deg == 0) and np.all(tin.aspect_deg == -1)


def opposite_angle_violations(tin, tol_deg=1e-6):
    """Thesis 2.2's test: for each interior edge, the two angles opposite it sum to <= 180."""
    v = tin.vertices[:, :2]
    bad = 0
    for (p, q), (t0, t1) in zip(tin.edges, tin.edge_triangles):
        if t1 < 0:
            continue
        s = 0.0
        for t in (t0, t1):
            o = [w for w in tin.triangles[t] if w != p and w != q][0]
            u, w = v[p] - v[o], v[q] - v[o]
            s += math.degrees(math.acos(np.clip(u @ w / np.linalg.norm(u) / np.linalg.norm(w), -1, 1)))
        bad += s > 180 + tol_deg
    return bad


@given(st.integers(0, 10_000), st.integers(3, 80))
def test_scattered_triangulation_is_delaunay(random_tin, seed, n):
    assert opposite_angle_violations(random_tin(seed, n)) == 0


@given(st.integers(0, 10_000))
def test_vip_triangulation_is_delaunay(seed):
    rng = np.random.default_rng(seed)
    z = rng.normal(0, 20, (12, 15)).cumsum(axis=0)
    dem = Dem(z, 30.0 * np.arange(15), 25.0 * np.arange(12))
    tin = build_tin(dem, method="vip", max_vertices=int(rng.integers(4, 150)))
    assert opposite_angle_violations(tin) == 0


def test_vip_triangulation_is_delaunay_on_jacksboro(jacksboro):
    tin = build_tin(jacksboro.crop(slice(0, 120), slice(0, 120)), max_vertices=1500)
    assert opposite_angle_violations(tin) == 0


def test_equality_ignores_order():
    t1 = Tin(SQUARE, [[0, 1, 2], [0, 2, 3]])
    t2 = Tin(SQUARE[[2, 3, 0, 1]], [[2, 3, 0], [2, 0, 1]])
    assert t1 == t2
    t3 = Tin(SQUARE, [[0, 1, 3], [1, 2, 3]])
    assert t1 != t3


def test_greedy_delaunay_option_is_delaunay_on_jacksboro(jacksboro):
    """Greedy's own triangles fail thesis 2.2's test; delaunay=True re-triangulates the same vertices."""
    from tin_swarm_env.terrain import vertical_error

    g = build_tin(jacksboro, method="greedy", max_vertices=5000)
    d = build_tin(jacksboro, method="greedy", max_vertices=5000, delaunay=True)
    assert opposite_angle_violations(g) > 0
    assert opposite_angle_violations(d) == 0
    np.testing.assert_array_equal(np.unique(g.vertices, axis=0), np.unique(d.vertices, axis=0))
    ed = vertical_error(d, jacksboro)[0]
    assert ed.n_outside == 0 and np.isfinite(ed.max_m) and ed.rms_m > 0.0


def test_delaunay_option_applies_to_greedy_only(jacksboro):
    with pytest.raises(ArgumentError, match="greedy"):
        build_tin(jacksboro.crop(slice(0, 20), slice(0, 20)), method="vip", max_vertices=50, delaunay=True)


def test_index_nbytes_counts_the_point_location_grid_apart_from_nbytes():
    small = Tin.from_points(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 1]], dtype=float))
    xy = np.random.default_rng(0).uniform(0, 100, (2000, 2))
    big = Tin.from_points(np.column_stack([xy, np.zeros(len(xy))]))
    assert isinstance(small.index_nbytes, int) and 0 < small.index_nbytes < big.index_nbytes
    # by count: 3 float64 per vertex; per triangle 3 int64 corners, 3 int64 neighbours, 3 float64
    # plane coefficients, 3 float64 normal, slope, aspect, area and the 2 float64 gradient: 17 * 8 bytes
    for t in (small, big):
        assert t.nbytes == 24 * t.n_vertices + 136 * t.n_triangles


# -- queries against slow, obvious references (terrain/reference.py) ------------------------------


def contains(tin, t, p, tol=1e-9):
    a, b, c = tin.vertices[tin.triangles[t], :2]

    def o(u, v):
        return (v[0] - u[0]) * (p[1] - u[1]) - (v[1] - u[1]) * (p[0] - u[0])

    return o(a, b) >= -tol and o(b, c) >= -tol and o(c, a) >= -tol


@given(st.integers(0, 10_000), st.integers(3, 50))
def test_locate_matches_brute_force(random_tin, seed, n):
    tin = random_tin(seed, n)
    rng = np.random.default_rng(seed + 1)
    xy = rng.uniform(-100, 1100, (300, 2))  # some outside
    xy[:20] = tin.vertices[rng.integers(0, tin.n_vertices, 20), :2]  # exactly on vertices
    e = tin.edges[rng.integers(0, len(tin.edges), 20)]
    xy[20:40] = 0.5 * (tin.vertices[e[:, 0], :2] + tin.vertices[e[:, 1], :2])  # on edges
    got = tin.locate(xy)
    ref = locate_brute(tin, xy)
    np.testing.assert_array_equal(got < 0, ref < 0)
    for i in np.flatnonzero(got >= 0):
        assert contains(tin, got[i], xy[i])
    # walking from any hint gives a containing triangle too
    hints = rng.integers(0, tin.n_triangles, len(xy))
    walked = tin.locate(xy, hint=hints)
    np.testing.assert_array_equal(walked < 0, ref < 0)
    for i in np.flatnonzero(walked >= 0):
        assert contains(tin, walked[i], xy[i])


def test_locate_on_a_non_convex_tin_falls_back_to_the_bucket_grid():
    # an L-shaped TIN: walking from the far arm toward the notch reaches the border
    v = np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0], [0, 1, 0]], float)
    tin = Tin(v, [[0, 1, 2], [0, 2, 3], [0, 3, 6], [6, 3, 4], [6, 4, 5]])
    pts = np.array([[1.5, 0.5], [0.5, 1.5], [1.5, 1.5], [-1, 0]])
    start = tin.locate(pts[[1, 0, 0, 0]])
    got = tin.locate(pts, hint=start)
    ref = locate_brute(tin, pts)
    np.testing.assert_array_equal(got, ref)
    assert got[2] == -1 and got[3] == -1


@given(st.integers(0, 10_000))
def test_height_exact_at_vertices_and_linear_along_edges(random_tin, seed):
    tin = random_tin(seed, 25, zscale=300)
    np.testing.assert_allclose(tin.height_at(tin.vertices[:, :2]), tin.vertices[:, 2], atol=1e-9)
    rng = np.random.default_rng(seed)
    e = tin.edges
    s = rng.uniform(0, 1, len(e))
    p, q = tin.vertices[e[:, 0]], tin.vertices[e[:, 1]]
    pts = p + s[:, None] * (q - p)
    np.testing.assert_allclose(tin.height_at(pts[:, :2]), pts[:, 2], atol=1e-8)
    xy = rng.uniform(0, 1000, (200, 2))
    np.testing.assert_allclose(tin.height_at(xy), height_brute(tin, xy), atol=1e-8)


def test_height_outside_names_the_point(random_tin):
    tin = random_tin(0)
    with pytest.raises(ValueError, match=r"point 1 at \[2000.0, 5.0\] lies outside"):
        tin.height_at([[5.0, 5.0], [2000.0, 5.0]])
    with pytest.raises(ValueError, match="not finite"):
        tin.locate([[np.nan, 1.0]])
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        tin.locate(np.zeros((3, 3)))


def test_sensor_tilt_thesis_formula():
    # a plane rising to the north at 30 deg: downhill faces south, aspect 180
    g = math.tan(math.radians(30))
    xy = np.array([[0, 0], [100, 0], [100, 100], [0, 100]], float)
    tin = Tin.from_points(np.column_stack([xy, g * xy[:, 1]]))
    assert np.allclose(tin.aspect_deg, 180)
    p = np.array([[50.0, 50.0]] * 4)
    # headings (math convention): east, north, west, south
    tilt = tin.sensor_tilt(p, np.array([0, 0.5, 1.0, 1.5]) * math.pi)
    # facing up/down the slope: 0; facing across: +-slope; east-facing has downhill (south) on
    # its right -> negative
    np.testing.assert_allclose(np.degrees(tilt), [-30, 0, 30, 0], atol=1e-9)
    # general value: asin(sin(slope) sin(heading_compass - aspect))
    h = 0.3
    expect = math.asin(math.sin(math.radians(30)) * math.sin(math.pi / 2 - h - math.pi))
    assert tin.sensor_tilt(p[:1], h)[0] == pytest.approx(expect)


@given(st.integers(0, 10_000))
def test_line_of_sight_matches_exact_brute_force_and_is_symmetric(random_rays, random_tin, seed):
    tin = random_tin(seed, 40, zscale=80)
    rng = np.random.default_rng(seed)
    a, b = random_rays(tin, rng, 150)
    got = tin.line_of_sight(a, b)
    np.testing.assert_array_equal(got, line_of_sight_brute(tin, a, b))
    np.testing.assert_array_equal(got, tin.line_of_sight(b, a))
    assert 0 < got.sum() < len(got) or len(got) < 20  # both outcomes occur


@given(st.integers(0, 10_000))
def test_line_of_sight_matches_dense_sampling_outside_a_band(random_rays, random_tin, seed):
    tin = random_tin(seed, 30, zscale=80)
    rng = np.random.default_rng(seed)
    a, b = random_rays(tin, rng, 60)
    clearance = line_of_sight_dense(tin, a, b, n_samples=3000)
    got = tin.line_of_sight(a, b)
    sure = np.abs(clearance) > 0.5  # m: sampling can miss a peak by less than this
    np.testing.assert_array_equal(got[sure], clearance[sure] >= 0)


def ridge_tin(ridge_z):
    # a 2 x 1 km strip with a north-south ridge at x = 1000 m
    xy = np.array([[0, 0], [0, 1000], [1000, 0], [1000, 1000], [2000, 0], [2000, 1000]], float)
    z = np.array([0, 0, ridge_z, ridge_z, 0, 0], float)
    return Tin.from_points(np.column_stack([xy, z]))


def test_ridge_blocks_and_removing_it_restores_sight():
    a = np.array([[200.0, 500.0, 2.0]])
    b = np.array([[1800.0, 500.0, 2.0]])
    assert not ridge_tin(50.0).line_of_sight(a, b)[0]
    assert ridge_tin(0.0).line_of_sight(a, b)[0]
    assert ridge_tin(1.9).line_of_sight(a, b)[0]  # lower than the sensors
    # grazing: the sight line touches the ridge top exactly -> visible
    assert ridge_tin(2.0).line_of_sight(a, b)[0]


def test_line_of_sight_end_points_below_ground_or_outside():
    tin = ridge_tin(0.0)
    a = np.array([[200.0, 500.0, -1.0], [200.0, 500.0, 1.0], [200.0, 500.0, 1.0]])
    b = np.array([[300.0, 500.0, 1.0], [3000.0, 500.0, 1.0], [200.0, 500.0, 1.0]])
    np.testing.assert_array_equal(tin.line_of_sight(a, b), [False, False, True])


def test_line_of_sight_through_vertices_uses_a_consistent_rule():
    # rays along grid lines pass exactly through vertices and along edges
    xs, ys = np.meshgrid(np.arange(5) * 10.0, np.arange(5) * 10.0)
    z = np.zeros_like(xs)
    z[2, 2] = 5.0
    tin = Tin.from_points(np.column_stack([xs.ravel(), ys.ravel(), z.ravel()]))
    a = np.array([[0, 20, 1.0], [20, 0, 1.0], [0, 0, 1.0], [0, 10, 1.0], [0, 20, 6.0]])
    b = np.array([[40, 20, 1.0], [20, 40, 1.0], [40, 40, 1.0], [40, 10, 1.0], [40, 20, 6.0]])
    np.testing.assert_array_equal(tin.line_of_sight(a, b), [False, False, False, True, True])
    np.testing.assert_array_equal(tin.line_of_sight(b, a), [False, False, False, True, True])


def test_queries_on_jacksboro_agree_with_references(random_rays, jacksboro):
    from tin_swarm_env.terrain import build_tin

    tin = build_tin(jacksboro, method="greedy", max_vertices=3000)
    rng = np.random.default_rng(1)
    x0, y0, x1, y1 = tin.bounds
    xy = rng.uniform([x0, y0], [x1, y1], (500, 2))
    t = tin.locate(xy)
    assert np.all(t >= 0)
    assert all(contains(tin, ti, p, tol=1e-3) for ti, p in zip(t, xy))
    a, b = random_rays(tin, rng, 300, height=(2.0, 2.0))
    np.testing.assert_array_equal(tin.line_of_sight(a, b), line_of_sight_brute(tin, a, b))


def test_slope_and_aspect_at_points_follow_their_triangles(random_tin):
    tin = random_tin(3, 20, zscale=200)
    rng = np.random.default_rng(3)
    xy = rng.uniform(0, 1000, (100, 2))
    t = locate_brute(tin, xy)
    np.testing.assert_array_equal(tin.slope_at(xy), tin.slope_deg[tin.locate(xy)])
    # on shared edges either side may be reported; away from edges it is the brute-force one
    inside = np.array([contains(tin, ti, p, tol=-1e-3) for ti, p in zip(t, xy)])
    np.testing.assert_array_equal(tin.aspect_at(xy)[inside], tin.aspect_deg[t[inside]])
    np.testing.assert_array_equal(tin.slope_at(xy)[inside], tin.slope_deg[t[inside]])
