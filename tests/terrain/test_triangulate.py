"""Delaunay of points with very different x and y spacings (a DEM's cell aspect ratio): every builder's
mesh passes its own validity check up to :data:`~tin_swarm_env.terrain.build.MAX_CELL_ASPECT`, and a DEM
beyond it is refused before any work, naming the file and the cell size."""

from __future__ import annotations

import re

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import DemFormatError
from tin_swarm_env.terrain import Dem
from tin_swarm_env.terrain.build import MAX_CELL_ASPECT

METHODS = [("vip", {"max_vertices": 60}), ("greedy", {"max_error_m": 0.5}), ("greedy", {"max_vertices": 50}),
           ("delaunay", {})]


@pytest.mark.parametrize("nx, ny", [(20, 20), (50, 8)])
@pytest.mark.parametrize("dx, dy", [(1.0, 1e6), (1e6, 1.0), (1e-3, 1e3), (30.0, 3e7)])
def test_extreme_cell_aspect_ratios_give_valid_tins(nx, ny, dx, dy):
    z = np.random.default_rng(nx + ny).normal(size=(ny, nx)) * 5
    dem = Dem(z=z, x=100 * dx + np.arange(nx) * dx, y=np.arange(ny) * dy, source="stretched")
    for method, kw in METHODS:
        tin = tse.terrain.build_tin(dem, method=method, **kw)  # Tin() runs the validity check
        assert tin.n_triangles >= 2
        assert np.all(tin.areas > 0)
        if method == "delaunay":  # every cell split in two: the planimetric area is the DEM's
            assert tin.n_triangles == 2 * (nx - 1) * (ny - 1)
            assert tin.areas.sum() == pytest.approx((nx - 1) * dx * (ny - 1) * dy, rel=1e-9)


@pytest.mark.parametrize("dx, dy", [(1.0, 1e9), (1e9, 1.0)])
def test_beyond_the_limit_the_dem_is_refused_up_front(dx, dy):
    dem = Dem(z=np.zeros((5, 5)), x=np.arange(5) * dx, y=np.arange(5) * dy, source="far.asc")
    for method, kw in METHODS:
        with pytest.raises(DemFormatError, match=r"far\.asc: cells of .* \(aspect ratio 1e\+09\); at most "
                                                 + re.escape(f"{MAX_CELL_ASPECT:g}")):
            tse.terrain.build_tin(dem, method=method, **kw)
