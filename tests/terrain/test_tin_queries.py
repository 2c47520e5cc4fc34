"""Batched queries against slow, obvious references: locate, height_at, sensor tilt,
line of sight; and the compiled kernels against their uncompiled selves."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tin_swarm_env.terrain import Tin
from tin_swarm_env.terrain import _kernels as K
from tin_swarm_env.terrain.reference import (
    height_brute,
    line_of_sight_brute,
    line_of_sight_dense,
    locate_brute,
)


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


def random_rays(tin, rng, n, height=(0.0, 30.0)):
    x0, y0, x1, y1 = tin.bounds
    a = rng.uniform([x0, y0], [x1, y1], (n, 2))
    b = rng.uniform([x0, y0], [x1, y1], (n, 2))
    ha = tin.height_at(a) + rng.uniform(*height, n)
    hb = tin.height_at(b) + rng.uniform(*height, n)
    return np.column_stack([a, ha]), np.column_stack([b, hb])


@given(st.integers(0, 10_000))
def test_line_of_sight_matches_exact_brute_force_and_is_symmetric(random_tin, seed):
    tin = random_tin(seed, 40, zscale=80)
    rng = np.random.default_rng(seed)
    a, b = random_rays(tin, rng, 150)
    got = tin.line_of_sight(a, b)
    np.testing.assert_array_equal(got, line_of_sight_brute(tin, a, b))
    np.testing.assert_array_equal(got, tin.line_of_sight(b, a))
    assert 0 < got.sum() < len(got) or len(got) < 20  # both outcomes occur


@given(st.integers(0, 10_000))
def test_line_of_sight_matches_dense_sampling_outside_a_band(random_tin, seed):
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


def test_compiled_kernels_equal_their_plain_python_versions(random_tin):
    tin = random_tin(7, 40, zscale=80)
    rng = np.random.default_rng(0)
    xy = rng.uniform(-50, 1050, (200, 2))
    px, py = np.ascontiguousarray(xy[:, 0]), np.ascontiguousarray(xy[:, 1])
    hints = rng.integers(0, tin.n_triangles, 200)
    args = (tin._vx, tin._vy, tin.triangles, tin.neighbors, px, py, hints, tin.n_triangles + 3, tin._tol[0])
    np.testing.assert_array_equal(K.walk_locate(*args), K.walk_locate.py_func(*args))
    bk = tin._bucket
    args = (tin._vx, tin._vy, tin.triangles, bk["start"], bk["tris"], bk["x0"], bk["y0"], bk["inv_cs"],
            bk["nx"], bk["ny"], px, py, tin._tol[0])
    np.testing.assert_array_equal(K.bucket_locate(*args), K.bucket_locate.py_func(*args))
    a, b = random_rays(tin, rng, 200)
    start = tin.locate(a[:, :2])
    args = (tin._vx, tin._vy, tin._vz, tin.triangles, tin.neighbors, tin._grad, a, b, start,
            tin.n_triangles + 3, tin._tol[1])
    np.testing.assert_array_equal(K.los_walk(*args), K.los_walk.py_func(*args))
    za, zb = tin.height_at(a[:, :2]), tin.height_at(b[:, :2])
    border = tin.edge_triangles[:, 1] < 0
    args = (tin._vx, tin._vy, tin._vz, tin.edges, border, a, b, za, zb, tin._tol[1], 1e-9)
    brute = K.los_brute(*args)
    np.testing.assert_array_equal(brute, K.los_brute.py_func(*args))
    np.testing.assert_array_equal(brute.astype(bool), tin.line_of_sight(a, b))


def test_queries_on_jacksboro_agree_with_references(jacksboro):
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


def test_the_walk_itself_finds_points_on_shared_and_border_edges():
    """The walk's tolerance: a point on an edge is inside both triangles, so the walk stops in the
    first one it tries (it never steps across an edge the point lies on, which would leave the TIN
    at a border edge or give up going back and forth); only then is no fallback needed."""
    tin = Tin(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]], float), [[0, 1, 2], [0, 2, 3]])
    pts = np.array([[5.0, 5.0], [5.0, 0.0], [10.0, 5.0], [0.0, 5.0], [5.0, 10.0], [2.0, 1.0]])
    want = [[0, 1], [0], [0], [1], [1], [0]]
    vx, vy = tin.xy_columns
    for hint in (0, 1):
        got = K.walk_locate(vx, vy, tin.triangles, tin.neighbors, pts[:, 0], pts[:, 1],
                            np.full(len(pts), hint, np.int64), tin.n_triangles + 3, tin.tolerances[0])
        assert all(int(g) in w for g, w in zip(got, want)), (hint, got)
        assert got[0] == hint  # on the shared diagonal: stays where it started
