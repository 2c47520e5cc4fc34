"""The uniform bucket grid (world/grid.py): every point within one cell size of a query lies in the
blocks it scans."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tin_swarm_env.world.grid import grid_build, grid_cells


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
