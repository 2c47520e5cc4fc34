"""build_tin(method="trust") (issue 45): exact answers on hand-built DEMs, a property test against
the full surface, bad input. "robot" runs the same cases: trust is the robot builder with other
settings (terrain/robot.py, TRUST_SETTINGS)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.terrain import Dem, build_tin, cost_to_go
from tin_swarm_env.terrain import robot as R

METHODS = ("trust", "robot")


def grid_dem(z, cell):
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
def test_cliff_line_is_kept_as_edges(method, budget):
    # flat ground, a 30 m step between columns 7 and 8 of 10 m cells (71 deg): exactly that band is steep
    z = np.zeros((12, 16))
    z[:, 8:] = 30.0
    dem = grid_dem(z, 10.0)
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
    return grid_dem(z, 1.0)


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
    dem = grid_dem(z, 1.0)
    tin = build_tin(dem, method=method, max_slope_deg=20, **kw)
    west, east = np.array([3.0, 10.0]), np.array([[22.0, 10.0], [24.0, 1.0], [13.5, 18.5]])
    full = R.full_surface(dem)
    assert not np.isfinite(cost_to_go(full, west, full.slope_deg <= 20).distance_at(east)).any()
    assert not np.isfinite(cost_to_go(tin, west, tin.slope_deg <= 20).distance_at(east)).any()


@pytest.mark.parametrize("method", METHODS)
def test_hidden_valley_stays_hidden(method):
    # a west-east profile on 10 m cells: plain (0 m), a 1-cell crest at 25 m on column 12, a valley floor
    # at -15 m behind it (columns 15-24), the same for every row
    cols = np.arange(40)
    prof = np.interp(cols, [0, 8, 12, 15, 24, 30, 39], [0.0, 0.0, 25.0, -15.0, -15.0, 0.0, 0.0])
    dem = grid_dem(np.tile(prof, (20, 1)), 10.0)
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
def test_error_bound_reproduces_every_sample(rows, cols, dx, dy, slope, max_error_m, seed):
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
def test_a_budget_gives_that_many_dem_vertices(rows, cols, frac, seed):
    rng = np.random.default_rng(seed)
    dem = grid_dem(np.cumsum(rng.normal(0, 3, (rows, cols)), axis=1), 10.0)
    n = max(4, int(frac * rows * cols))
    tin = build_tin(dem, method="trust", max_vertices=n, max_slope_deg=15)  # Tin() checks the mesh
    assert tin.n_vertices == n
    j = np.rint(tin.vertices[:, 0] / 10.0).astype(int)
    i = np.rint(tin.vertices[:, 1] / 10.0).astype(int)
    assert np.array_equal(tin.vertices[:, 2], dem.z[i, j])
    assert np.isclose(tin.areas.sum(), (rows - 1) * (cols - 1) * 100.0)  # covers the whole grid


def test_trust_needs_max_slope():
    with pytest.raises(ArgumentError, match="max_slope_deg"):
        build_tin(grid_dem(np.zeros((5, 5)), 1.0), method="trust", max_vertices=10)


def test_max_slope_is_refused_for_other_methods():
    with pytest.raises(ArgumentError, match="max_slope_deg applies to method='robot' or 'trust'"):
        build_tin(grid_dem(np.zeros((5, 5)), 1.0), method="greedy", max_vertices=10, max_slope_deg=20)
