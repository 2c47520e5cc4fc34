"""The uniform bucket grid (world/grid.py): every point within one cell size of a query lies in the
blocks it scans."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.world.grid import SENSE_REACH, grid_block, grid_build, grid_cells, sense_cell


@settings(max_examples=30)
@given(st.integers(0, 10_000), st.integers(0, 200), st.floats(0.5, 300))
def test_grid_blocks_hold_every_point_within_the_cell_size(seed, n, cell):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-500, 500, (n, 2)) * rng.uniform(0.01, 1)
    use = rng.random(n) < 0.8
    x0, y0, inv, nx, ny, start, items, gx, gy = grid_build(xy[:, 0].copy(), xy[:, 1].copy(), use, cell)
    assert sorted(items.tolist()) == np.flatnonzero(use).tolist()
    assert nx * ny <= 4 * use.sum() + 64 and 1 / inv >= cell * (1 - 1e-12)
    for c in range(nx * ny):  # index order inside a cell; coordinates carried along
        assert list(items[start[c]:start[c + 1]]) == sorted(items[start[c]:start[c + 1]])
    np.testing.assert_array_equal(gx, xy[items, 0])
    for q in rng.uniform(-600, 600, (20, 2)):
        lo_x, hi_x, lo_y, hi_y = grid_cells(x0, y0, inv, nx, ny, q[0], q[1])
        got = {int(items[m]) for cy in range(lo_y, hi_y + 1) for cx in range(lo_x, hi_x + 1)
               for m in range(start[cy * nx + cx], start[cy * nx + cx + 1])}
        near = np.flatnonzero(use & (np.hypot(*(xy - q).T) <= cell))
        assert set(near.tolist()) <= got


@settings(max_examples=30)
@given(st.integers(0, 10_000), st.integers(0, 200), st.floats(0.5, 300), st.integers(1, 3))
def test_a_reach_r_block_holds_every_point_within_r_cell_sides(seed, n, cell, reach):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-500, 500, (n, 2)) * rng.uniform(0.01, 1)
    use = np.ones(n, dtype=bool)
    x0, y0, inv, nx, ny, start, items, gx, gy = grid_build(xy[:, 0].copy(), xy[:, 1].copy(), use, cell)
    for q in np.concatenate([rng.uniform(-600, 600, (20, 2)), xy[:5] + 1e-9]):
        lo_x, hi_x, lo_y, hi_y = grid_block(x0, y0, inv, nx, ny, q[0], q[1], reach)
        got = {int(items[m]) for cy in range(lo_y, hi_y + 1) for cx in range(lo_x, hi_x + 1)
               for m in range(start[cy * nx + cx], start[cy * nx + cx + 1])}
        near = np.flatnonzero(np.hypot(*(xy - q).T) <= reach * cell)
        assert set(near.tolist()) <= got
    if reach == 1:  # grid_cells is the reach-1 block
        for q in rng.uniform(-600, 600, (5, 2)):
            assert grid_block(x0, y0, inv, nx, ny, q[0], q[1], 1) == grid_cells(x0, y0, inv, nx, ny, q[0], q[1])


@settings(max_examples=30)
@given(st.integers(0, 10_000), st.floats(1, 300))
def test_a_sensing_grid_holds_points_exactly_at_the_range(seed, range_m):
    """Points placed at exactly range_m (along the axes and the diagonals) from a query lie in
    its SENSE_REACH block of a grid built with sense_cell(range_m)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1000, 1000, 2)
    ang = np.concatenate([np.arange(8) * np.pi / 4, rng.uniform(0, 2 * np.pi, 40)])
    pts = q + range_m * np.column_stack([np.cos(ang), np.sin(ang)])
    pts = np.concatenate([pts, rng.uniform(-1500, 1500, (100, 2))])
    use = np.ones(len(pts), dtype=bool)
    x0, y0, inv, nx, ny, start, items, gx, gy = grid_build(pts[:, 0].copy(), pts[:, 1].copy(), use,
                                                           sense_cell(range_m))
    lo_x, hi_x, lo_y, hi_y = grid_block(x0, y0, inv, nx, ny, q[0], q[1], SENSE_REACH)
    got = {int(items[m]) for cy in range(lo_y, hi_y + 1) for cx in range(lo_x, hi_x + 1)
           for m in range(start[cy * nx + cx], start[cy * nx + cx + 1])}
    d = np.sqrt((pts[:, 0] - q[0]) ** 2 + (pts[:, 1] - q[1]) ** 2)
    assert set(np.flatnonzero(d <= range_m * (1 + 1e-12)).tolist()) <= got
