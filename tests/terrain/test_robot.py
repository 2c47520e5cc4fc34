"""The robot TIN builder (terrain/robot.py): exact answers on small hand-built DEMs. Method "trust" is
the same builder with TRUST_SETTINGS: the cases at the end run both."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.errors import ArgumentError, DemFormatError
from tin_swarm_env.terrain import Dem, Tin, build_tin, cost_to_go
from tin_swarm_env.terrain import robot as R

CELL = 10.0


def grid_dem(z, cell=CELL):
    z = np.asarray(z, dtype=float)
    return Dem(z, np.arange(z.shape[1]) * cell, np.arange(z.shape[0]) * cell, source="hand-built")


def sample_classes_agree(tin, dem, max_slope_deg):
    """Every full-surface triangle's class equals the TIN's class at its sample point."""
    p = R.sample_points(dem)[:, :2]
    return np.array_equal(tin.slope_at(p) > max_slope_deg, R.full_surface_slope_deg(dem) > max_slope_deg)


def edges_cover_segment(tin, x, y0, y1):
    """The TIN edges lying on the line x = const cover [y0, y1] without a gap."""
    v = tin.vertices
    e = tin.edges
    on = np.isclose(v[e[:, 0], 0], x) & np.isclose(v[e[:, 1], 0], x)
    spans = np.sort(np.sort(v[e[on]][:, :, 1], axis=1), axis=0)
    reach = y0
    for lo, hi in spans[np.argsort(spans[:, 0])]:
        if lo > reach + 1e-9:
            return False
        reach = max(reach, hi)
    return reach >= y1 - 1e-9


# -- the full-resolution surface and the kernels ---------------------------------------------


def test_full_surface_is_every_cell_two_triangles_per_cell():
    dem = grid_dem(np.arange(12.0).reshape(3, 4) ** 2)
    full = R.full_surface(dem)
    assert full.n_vertices == 12 and full.n_triangles == 2 * 2 * 3
    assert np.allclose(np.sort(full.slope_deg), np.sort(R.full_surface_slope_deg(dem)))
    tri = R.full_surface_triangles(dem.shape)
    assert np.allclose(R.full_surface_slope_deg(dem), Tin(full.vertices, tri).slope_deg)


def test_sample_points_lie_inside_their_full_surface_triangle():
    rng = np.random.default_rng(2)
    dem = grid_dem(rng.uniform(0, 30, (6, 8)))
    full = R.full_surface(dem)
    p = R.sample_points(dem)
    assert np.array_equal(full.locate(p[:, :2]), np.arange(full.n_triangles))
    assert np.allclose(full.height_at(p[:, :2]), p[:, 2])


def test_full_surface_slope_of_a_plane():
    z = 0.5 * np.arange(5)[None, :] * CELL * np.ones((4, 1))  # dz/dx = 0.5
    s = R.full_surface_slope_deg(grid_dem(z))
    assert np.allclose(s, np.degrees(np.arctan(0.5)))


def test_raster_samples_matches_point_location():
    rng = np.random.default_rng(0)
    dem = grid_dem(rng.uniform(0, 50, (9, 11)))
    rows, cols = dem.shape
    keep = rng.random(rows * cols) < 0.3
    keep[[0, cols - 1, rows * cols - cols, rows * cols - 1]] = True
    idx = np.flatnonzero(keep)
    tin = Tin.from_points(dem.points()[idx])
    cells = np.arange(rows * cols)
    ni, nj = (cells // cols).astype(float), (cells % cols).astype(float)
    owner = R.raster_samples(ni, nj, idx[tin.triangles], rows, cols)
    assert (owner >= 0).all()
    # every sample lies in (or on the border of) the triangle it was given
    c = R.sample_points(dem)[:, :2]
    p = tin.vertices[tin.triangles[owner], :2]
    for k in range(3):
        a, b = p[:, k], p[:, (k + 1) % 3]
        cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        assert (cross >= -1e-9).all()


def test_score_triangles_matches_numpy_reference():
    rng = np.random.default_rng(1)
    n_s, n_t, n_v = 200, 7, 40
    owner = rng.integers(-1, n_t, n_s)
    gx, gy, c0 = rng.normal(size=n_t), rng.normal(size=n_t), rng.normal(size=n_t)
    steep_t = rng.random(n_t) < 0.5
    sx, sy, sz = rng.normal(size=n_s), rng.normal(size=n_s), rng.normal(size=n_s)
    steep_f = rng.random(n_s) < 0.5
    weight = rng.choice([0.0, 1.0, 3.0], n_s)
    nodes = rng.integers(0, n_v, (n_s, 3))
    vx, vy, vz = rng.normal(size=n_v), rng.normal(size=n_v), rng.normal(size=n_v)
    keep = rng.random(n_v) < 0.3
    best, cell, wrong, err = R.score_triangles(owner, gx, gy, c0, steep_t, sx, sy, sz, steep_f, weight, nodes,
                                             vx, vy, vz, keep, 0.1, 2.0)
    for t in range(n_t):
        s = np.flatnonzero(owner == t)
        dz = np.abs(gx[t] * sx[s] + gy[t] * sy[s] + c0[t] - sz[s])
        bad = (steep_t[t] != steep_f[s]) & (weight[s] > 0)
        assert np.isclose(err[t], dz.max(initial=0.0))
        assert np.isclose(wrong[t], weight[s][bad].sum())
        score = 0.1 * dz / 2.0 + weight[s] * bad
        free = ~keep[nodes[s]].all(axis=1)
        if not free.any():
            assert cell[t] == -1
            continue
        w = s[free][np.argmax(score[free])]
        assert np.isclose(best[t], score[free].max())
        ev = np.abs(gx[t] * vx[nodes[w]] + gy[t] * vy[nodes[w]] + c0[t] - vz[nodes[w]])
        ev[keep[nodes[w]]] = -1
        assert cell[t] == nodes[w][np.argmax(ev)]


def test_crest_score_marks_a_ridge_only():
    z = np.zeros((5, 7))
    z[:, 3] = 10.0
    cs = R.crest_score(z)
    assert np.allclose(cs[1:-1, 3], 10.0)
    assert np.allclose(np.delete(cs, 3, axis=1), 0.0)


# -- what robots use ----------------------------------------------------------------------


def test_cliff_line_is_kept_as_edges():
    # flat ground, a 30 m step between columns 7 and 8 (71 deg): the band is too steep
    z = np.zeros((12, 16))
    z[:, 8:] = 30.0
    dem = grid_dem(z)
    tin = build_tin(dem, method="robot", max_error_m=0.5, max_slope_deg=20)
    assert edges_cover_segment(tin, 7 * CELL, 0.0, 11 * CELL)  # the cliff foot
    assert edges_cover_segment(tin, 8 * CELL, 0.0, 11 * CELL)  # the cliff top
    steep = tin.slope_deg > 20
    assert np.isclose(tin.areas[steep].sum(), CELL * 11 * CELL)  # exactly the band
    assert sample_classes_agree(tin, dem, 20)
    assert tin.n_vertices < dem.z.size // 2


def plateau_dem():
    """Ground at 0, a 20 m plateau (rows 15-24, cols 10-19) with cliff sides, reached only by a
    3-cell-wide ramp (cols 13-16) rising 2 m per row from row 5 to row 14 (11.3 deg)."""
    z = np.zeros((30, 30))
    z[15:25, 10:20] = 20.0
    for i in range(5, 15):
        z[i, 13:17] = 2.0 * (i - 4)
    return grid_dem(z)


def test_plateau_keeps_its_drivable_connection():
    dem = plateau_dem()
    full = R.full_surface(dem)
    tin = build_tin(dem, method="robot", max_error_m=1.0, max_slope_deg=20)
    assert tin.n_vertices < dem.z.size // 2
    assert sample_classes_agree(tin, dem, 20)
    goal = np.array([150.0, 200.0])  # on the plateau
    start = np.array([[145.0, 10.0], [20.0, 20.0]])  # ground, south of the ramp and far west
    d_full = cost_to_go(full, goal, full.slope_deg <= 20).distance_at(start)
    d_tin = cost_to_go(tin, goal, tin.slope_deg <= 20).distance_at(start)
    assert np.isfinite(d_full).all()
    assert np.allclose(d_tin, d_full, rtol=1e-6)


def test_plateau_connection_survives_a_vertex_budget():
    dem = plateau_dem()
    tin = build_tin(dem, method="robot", max_vertices=int(0.25 * dem.z.size), max_slope_deg=20)
    goal = np.array([150.0, 200.0])
    d = cost_to_go(tin, goal, tin.slope_deg <= 20).distance_at(np.array([[145.0, 10.0]]))
    assert np.isfinite(d).all()


def test_hidden_valley_stays_hidden():
    # a west-east profile: plain (0 m), a 1-cell crest at 25 m on column 12, a valley floor at
    # -15 m behind it (columns 15-24), the same for every row
    cols = np.arange(40)
    prof = np.interp(cols, [0, 8, 12, 15, 24, 30, 39], [0.0, 0.0, 25.0, -15.0, -15.0, 0.0, 0.0])
    dem = grid_dem(np.tile(prof, (20, 1)))
    tin = build_tin(dem, method="robot", max_vertices=int(0.1 * dem.z.size), max_slope_deg=20)
    y = np.linspace(20.0, 170.0, 7)
    eye = np.column_stack([np.full_like(y, 20.0), y, np.full_like(y, 2.0)])  # on the plain, 2 m up
    valley = np.column_stack([np.full_like(y, 190.0), y, np.full_like(y, -13.0)])  # floor, 2 m up
    near = np.column_stack([np.full_like(y, 70.0), y, np.full_like(y, 2.0 + np.interp(7.0, cols, prof))])
    full = R.full_surface(dem)
    assert not full.line_of_sight(eye, valley).any()
    assert not tin.line_of_sight(eye, valley).any()
    assert tin.line_of_sight(eye, near).all()  # the test can see what it should


def test_every_vertex_is_a_dem_cell():
    rng = np.random.default_rng(3)
    dem = grid_dem(np.cumsum(rng.normal(0, 3, (25, 30)), axis=1))
    tin = build_tin(dem, method="robot", max_vertices=120, max_slope_deg=15)
    assert tin.n_vertices == 120
    j = np.rint(tin.vertices[:, 0] / CELL).astype(int)
    i = np.rint(tin.vertices[:, 1] / CELL).astype(int)
    assert np.allclose(tin.vertices[:, 0], j * CELL) and np.allclose(tin.vertices[:, 1], i * CELL)
    assert np.array_equal(tin.vertices[:, 2], dem.z[i, j])
    assert np.isclose(tin.areas.sum(), 29 * 24 * CELL * CELL)  # covers the whole grid


# -- bad input -----------------------------------------------------------------------------


def test_robot_needs_max_slope():
    with pytest.raises(ArgumentError, match="max_slope_deg"):
        build_tin(grid_dem(np.zeros((5, 5))), method="robot", max_vertices=10)


@pytest.mark.parametrize("bad", [0.0, 90.0, -5.0, float("nan")])
def test_robot_refuses_bad_slope(bad):
    with pytest.raises(ArgumentError, match="max_slope_deg"):
        build_tin(grid_dem(np.zeros((5, 5))), method="robot", max_vertices=10, max_slope_deg=bad)


def test_max_slope_only_for_robot():
    with pytest.raises(ArgumentError, match="max_slope_deg applies to method='robot'"):
        build_tin(grid_dem(np.zeros((5, 5))), method="greedy", max_vertices=10, max_slope_deg=20)


def test_robot_refuses_nodata():
    z = np.zeros((5, 5))
    z[2, 2] = np.nan
    with pytest.raises(DemFormatError, match="NODATA"):
        build_tin(grid_dem(z), method="robot", max_vertices=10, max_slope_deg=20)


def test_robot_needs_a_stop():
    with pytest.raises(ArgumentError, match="max_vertices, max_error_m"):
        build_tin(grid_dem(np.zeros((5, 5))), method="robot", max_slope_deg=20)


@settings(max_examples=40)
@given(rows=st.integers(3, 9), cols=st.integers(3, 9), dx=st.sampled_from([1.0, 7.5, 30.0]),
       dy=st.sampled_from([1.0, 10.0, 30.0]), slope=st.sampled_from([10.0, 20.0, 35.0]),
       max_error_m=st.sampled_from([0.0, 0.5, 5.0]), seed=st.integers(0, 2**16))
def test_error_bound_reproduces_every_sample(rows, cols, dx, dy, slope, max_error_m, seed):
    """Without a vertex budget the builder stops only when every sample has the full surface's
    class and lies within max_error_m of it (the reference: the full surface at the samples)."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0, 3 * max(dx, dy), (rows, cols)) * rng.integers(0, 2, (rows, cols))
    dem = Dem(z, np.arange(cols) * dx, np.arange(rows) * dy, source="random")
    tin = build_tin(dem, method="robot", max_error_m=max_error_m, max_slope_deg=slope)
    p = R.sample_points(dem)
    assert np.array_equal(tin.slope_at(p[:, :2]) > slope, R.full_surface_slope_deg(dem) > slope)
    assert np.all(np.abs(tin.height_at(p[:, :2]) - p[:, 2]) <= max_error_m + 1e-9)


# -- the data-dependent flips ------------------------------------------------------------------


def _setup(dem, slope, fsw=3.0, fdw=1.0):
    rows, cols = dem.shape
    cells = np.arange(rows * cols)
    ni, nj = (cells // cols).astype(float), (cells % cols).astype(float)
    vx, vy = nj * dem.dx, ni * dem.dy
    sp = R.sample_points(dem)
    steep_f = R.full_surface_slope_deg(dem) > slope
    weight = np.where(steep_f, fdw, fsw)
    tan_s = np.tan(np.radians(slope))
    return (vx, vy, dem.z.ravel(), ni, nj, rows, cols, sp[:, 0] - dem.x[0], sp[:, 1] - dem.y[0], sp[:, 2], steep_f,
            weight, tan_s)


def test_triangle_cost_matches_numpy_reference():
    rng = np.random.default_rng(4)
    dem = grid_dem(rng.uniform(0, 20, (8, 9)))
    args = _setup(dem, 25.0)
    vx, vy, vz, _, _, _, _, sx, sy, sz, steep_f, weight, tan_s = args
    keep = np.flatnonzero(rng.random(dem.z.size) < 0.4)
    keep = np.union1d(keep, [0, 8, 63, 71])
    tin = Tin.from_points(dem.points()[keep])
    for t in range(tin.n_triangles):
        p, q, r = keep[tin.triangles[t]]
        got = R.triangle_cost(p, q, r, *args, 0.7, 2.0)
        a, b, c = np.array([vx[[p, q, r]], vy[[p, q, r]]]).T
        w = [(b[0] - a[0]) * (sy - a[1]) - (b[1] - a[1]) * (sx - a[0]),
             (c[0] - b[0]) * (sy - b[1]) - (c[1] - b[1]) * (sx - b[0]),
             (a[0] - c[0]) * (sy - c[1]) - (a[1] - c[1]) * (sx - c[0])]
        inside = (w[0] >= 0) & (w[1] >= 0) & (w[2] >= 0)
        gx, gy, c0 = tin.planes[t]
        zt = gx * (sx + dem.x[0]) + gy * (sy + dem.y[0]) + c0
        wrong = inside & ((tin.slope_deg[t] > 25.0) != steep_f)
        want = np.sum(0.7 * np.abs(zt - sz)[inside] / 2.0) + np.sum(weight[wrong])
        assert np.isclose(got, want, rtol=1e-9, atol=1e-9)


def test_flip_puts_the_diagonal_where_the_class_is_right():
    # one square: flat but for its NE corner; both full-surface halves (SW-NE diagonal) are 45 deg,
    # the other diagonal leaves a flat (drivable) half
    dem = grid_dem([[0.0, 0.0], [0.0, 10.0]])
    vx, vy, vz, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s = args = _setup(dem, 20.0)
    tris = np.array([[0, 1, 2], [1, 3, 2]], dtype=np.int64)  # SW SE NW, SE NE NW: the NW-SE diagonal
    nbrs = np.array([[1, -1, -1], [-1, 0, -1]], dtype=np.int64)
    n = R.flip_edges(tris, nbrs, *args, 1.0, 1.0, np.cos(np.radians(5.0)), 3)
    assert n == 1
    assert {frozenset(t) for t in tris.tolist()} == {frozenset((0, 1, 3)), frozenset((0, 3, 2))}
    tin = Tin(dem.points(), tris)
    assert sample_classes_agree(tin, dem, 20.0)
    # the neighbours were rewired: each new triangle sees the other across the SW-NE edge
    assert sorted(nbrs[0].tolist()).count(1) == 1 and sorted(nbrs[1].tolist()).count(0) == 1


def test_flips_never_raise_the_cost_and_keep_a_valid_tin():
    rng = np.random.default_rng(5)
    dem = grid_dem(np.cumsum(rng.normal(0, 4, (20, 24)), axis=0))
    args = _setup(dem, 20.0)
    keep = np.union1d(np.flatnonzero(rng.random(dem.z.size) < 0.25), [0, 23, 456, 479])
    tin = Tin.from_points(dem.points()[keep])
    tris = keep[tin.triangles]
    nbrs = tin.neighbors.copy()

    def total(tr):
        return sum(R.triangle_cost(p, q, r, *args, 1.0, 3.0) for p, q, r in tr)

    before = total(tris)
    n = R.flip_edges(tris, nbrs, *args, 1.0, 3.0, np.cos(np.radians(5.0)), 2)
    assert n > 0 and total(tris) < before
    out = Tin(dem.points(), tris)  # validity checks run on construction
    assert np.isclose(out.areas.sum(), tin.areas.sum())
    assert np.array_equal(nbrs, out.neighbors)  # the kernel's rewiring is the adjacency of the result
    assert min_angle_deg(out) >= min(5.0, min_angle_deg(tin)) - 1e-9


def min_angle_deg(tin):
    p = tin.vertices[tin.triangles, :2]
    out = []
    for k in range(3):
        u, w = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        cs = np.sum(u * w, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cs, -1, 1))))
    return float(np.min(out))


def test_a_budget_filled_before_the_error_bound_builds_as_the_budget_alone():
    # a scenario passes both keys: greedy insertion fills the budget first, the flips then run unguarded
    rng = np.random.default_rng(6)
    dem = grid_dem(np.cumsum(rng.normal(0, 3, (25, 30)), axis=1))
    a = build_tin(dem, method="robot", max_vertices=150, max_slope_deg=15)
    b = build_tin(dem, method="robot", max_vertices=150, max_error_m=0.01, max_slope_deg=15)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.triangles, b.triangles)
    greedy = build_tin(dem, method="greedy", max_vertices=150)
    assert not np.array_equal(np.sort(a.triangles, axis=1), np.sort(greedy.triangles, axis=1))  # flipped


# -- method "trust" (robot.TRUST_SETTINGS) beside "robot" ----------------------------------------


METHODS = ("trust", "robot")


def grid_dem_at(z, cell):
    z = np.asarray(z, dtype=float)
    return Dem(z, np.arange(z.shape[1]) * cell, np.arange(z.shape[0]) * cell, source="hand-built")


def edges_on_line(tin, x):
    """The (y0, y1) spans of the TIN edges lying on the line x = const, sorted."""
    v, e = tin.vertices, tin.edges
    on = np.isclose(v[e[:, 0], 0], x) & np.isclose(v[e[:, 1], 0], x)
    return sorted(tuple(sorted(s)) for s in v[e[on]][:, :, 1])


def covered(spans, y0, y1):
    reach = y0
    for lo, hi in spans:
        if lo > reach + 1e-9:
            return False
        reach = max(reach, hi)
    return reach >= y1 - 1e-9


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("budget", [None, 0.2])
def test_cliff_line_is_kept_as_edges_by_both_methods(method, budget):
    # flat ground, a 30 m step between columns 7 and 8 of 10 m cells (71 deg): exactly that band is steep
    z = np.zeros((12, 16))
    z[:, 8:] = 30.0
    dem = grid_dem_at(z, 10.0)
    kw = {"max_error_m": 0.5} if budget is None else {"max_vertices": int(budget * z.size)}
    tin = build_tin(dem, method=method, max_slope_deg=20, **kw)
    assert covered(edges_on_line(tin, 70.0), 0.0, 110.0)  # the cliff foot
    assert covered(edges_on_line(tin, 80.0), 0.0, 110.0)  # the cliff top
    steep = tin.slope_deg > 20
    assert np.isclose(tin.areas[steep].sum(), 10.0 * 110.0)


def pass_dem():
    """1 m cells, 24 x 24; a wall 5 m high on rows 11-12 (79 deg sides) with a gap at columns 11-12: a
    flat pass exactly 1 m wide (one robot of radius 0.5 m), the only way from south to north."""
    z = np.zeros((24, 24))
    z[11:13, :] = 5.0
    z[11:13, 11:13] = 0.0
    return grid_dem_at(z, 1.0)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kw", [{"max_error_m": 0.5}, {"max_vertices": 120}])
def test_a_pass_one_robot_wide_stays_open(method, kw):
    dem = pass_dem()
    tin = build_tin(dem, method=method, max_slope_deg=20, **kw)
    assert tin.n_vertices < dem.z.size // 2
    full = R.full_surface(dem)
    goal, start = np.array([11.5, 20.0]), np.array([[11.5, 3.0], [2.0, 2.0]])
    d_full = cost_to_go(full, goal, full.slope_deg <= 20).distance_at(start)
    d_tin = cost_to_go(tin, goal, tin.slope_deg <= 20).distance_at(start)
    assert np.isfinite(d_full).all()
    assert np.allclose(d_tin, d_full, rtol=1e-9)  # through the pass, straight where the full surface is
    # the pass is 1 m wide on both: the wall's steep triangles stop at x = 11 and x = 12
    for t in (full, tin):
        steep = t.slope_deg > 20
        c = t.vertices[t.triangles[steep], :2].mean(axis=1)
        assert not np.any((c[:, 0] > 11.0) & (c[:, 0] < 12.0))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("kw", [{"max_error_m": 0.5}, {"max_vertices": 60}, {"max_vertices": 30}, {"max_vertices": 10}])
def test_a_steep_ridge_is_never_bridged(method, kw):
    # 1 m cells, 20 x 26; a ridge one cell wide, 3 m high (72 deg flanks), along column 12 from edge to edge
    z = np.zeros((20, 26))
    z[:, 12] = 3.0
    dem = grid_dem_at(z, 1.0)
    tin = build_tin(dem, method=method, max_slope_deg=20, **kw)
    west, east = np.array([3.0, 10.0]), np.array([[22.0, 10.0], [24.0, 1.0], [13.5, 18.5]])
    full = R.full_surface(dem)
    assert not np.isfinite(cost_to_go(full, west, full.slope_deg <= 20).distance_at(east)).any()
    assert not np.isfinite(cost_to_go(tin, west, tin.slope_deg <= 20).distance_at(east)).any()


@pytest.mark.parametrize("method", METHODS)
def test_hidden_valley_stays_hidden_for_both_methods(method):
    # a west-east profile on 10 m cells: plain (0 m), a 1-cell crest at 25 m on column 12, a valley floor
    # at -15 m behind it (columns 15-24), the same for every row
    cols = np.arange(40)
    prof = np.interp(cols, [0, 8, 12, 15, 24, 30, 39], [0.0, 0.0, 25.0, -15.0, -15.0, 0.0, 0.0])
    dem = grid_dem_at(np.tile(prof, (20, 1)), 10.0)
    tin = build_tin(dem, method=method, max_vertices=int(0.1 * dem.z.size), max_slope_deg=20)
    y = np.linspace(20.0, 170.0, 7)
    eye = np.column_stack([np.full_like(y, 20.0), y, np.full_like(y, 2.0)])  # on the plain, 2 m up
    valley = np.column_stack([np.full_like(y, 190.0), y, np.full_like(y, -13.0)])  # floor, 2 m up
    near = np.column_stack([np.full_like(y, 70.0), y, np.full_like(y, 2.0 + np.interp(7.0, cols, prof))])
    assert not R.full_surface(dem).line_of_sight(eye, valley).any()
    assert not tin.line_of_sight(eye, valley).any()
    assert tin.line_of_sight(eye, near).all()  # the test can see what it should


@settings(max_examples=30, deadline=None)
@given(rows=st.integers(3, 9), cols=st.integers(3, 9), dx=st.sampled_from([1.0, 7.5, 30.0]),
       dy=st.sampled_from([1.0, 10.0, 30.0]), slope=st.sampled_from([10.0, 20.0, 35.0]),
       max_error_m=st.sampled_from([0.0, 0.5, 5.0]), seed=st.integers(0, 2**16))
def test_trust_error_bound_reproduces_every_sample(rows, cols, dx, dy, slope, max_error_m, seed):
    """With max_error_m and no budget, trust stops only when every full-surface triangle's sample has
    its class and lies within max_error_m (the reference: the full surface at its samples)."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0, 3 * max(dx, dy), (rows, cols)) * rng.integers(0, 2, (rows, cols))
    dem = Dem(z, np.arange(cols) * dx, np.arange(rows) * dy, source="random")
    tin = build_tin(dem, method="trust", max_error_m=max_error_m, max_slope_deg=slope)
    p = R.sample_points(dem)
    assert np.array_equal(tin.slope_at(p[:, :2]) > slope, R.full_surface_slope_deg(dem) > slope)
    assert np.all(np.abs(tin.height_at(p[:, :2]) - p[:, 2]) <= max_error_m + 1e-9)


@settings(max_examples=25, deadline=None)
@given(rows=st.integers(4, 14), cols=st.integers(4, 14), frac=st.floats(0.05, 1.0), seed=st.integers(0, 2**16))
def test_trust_budget_gives_that_many_dem_vertices(rows, cols, frac, seed):
    rng = np.random.default_rng(seed)
    dem = grid_dem_at(np.cumsum(rng.normal(0, 3, (rows, cols)), axis=1), 10.0)
    n = max(4, int(frac * rows * cols))
    tin = build_tin(dem, method="trust", max_vertices=n, max_slope_deg=15)  # Tin() checks the mesh
    assert tin.n_vertices == n
    j = np.rint(tin.vertices[:, 0] / 10.0).astype(int)
    i = np.rint(tin.vertices[:, 1] / 10.0).astype(int)
    assert np.array_equal(tin.vertices[:, 2], dem.z[i, j])
    assert np.isclose(tin.areas.sum(), (rows - 1) * (cols - 1) * 100.0)  # covers the whole grid


def test_trust_needs_max_slope_and_a_stop_and_says_trust():
    with pytest.raises(ArgumentError, match=r"max_slope_deg must be a number in \(0, 90\) for method='trust'"):
        build_tin(grid_dem_at(np.zeros((5, 5)), 1.0), method="trust", max_vertices=10)
    with pytest.raises(ArgumentError, match="method='trust' needs max_vertices, max_error_m or both"):
        build_tin(grid_dem_at(np.zeros((5, 5)), 1.0), method="trust", max_slope_deg=20)


def test_max_slope_is_refused_for_other_methods():
    with pytest.raises(ArgumentError, match="max_slope_deg applies to method='robot' or 'trust'"):
        build_tin(grid_dem_at(np.zeros((5, 5)), 1.0), method="greedy", max_vertices=10, max_slope_deg=20)
