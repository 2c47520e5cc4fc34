"""How well a TIN fits its DEM (terrain/metrics.py): the vertical error cell by cell on a hand-built case."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tin_swarm_env.terrain import Dem, Tin
from tin_swarm_env.terrain.metrics import ErrorStats, vertical_error


def test_vertical_error_is_tin_minus_dem_per_cell_nan_outside_and_on_nodata():
    # the plane z = x + 2 y; the TIN covers x, y in [0, 2], the DEM one more column (x = 3)
    x, y = np.arange(4.0), np.arange(3.0)
    z = x[None, :] + 2 * y[:, None]
    z[1, 1] += 0.5  # a bump the TIN does not carry: error -0.5 there
    z[0, 0] = np.nan  # no data: not compared
    tin = Tin.from_points(np.array([[0, 0, 0], [2, 0, 2], [2, 2, 6], [0, 2, 4]], float))
    stats, err = vertical_error(tin, Dem(z, x, y))
    assert err.shape == (3, 4)
    want = np.zeros((3, 4))
    want[1, 1] = -0.5
    want[0, 0] = np.nan
    want[:, 3] = np.nan  # outside the TIN
    np.testing.assert_allclose(err, want, atol=1e-12)
    assert stats.n_cells == 8 and stats.n_outside == 3
    assert stats.max_m == pytest.approx(0.5, abs=1e-12)
    assert stats.rms_m == pytest.approx(math.sqrt(0.25 / 8), abs=1e-12)


def test_a_tin_covering_no_cell_has_nan_statistics():
    dem = Dem(np.zeros((2, 2)), [100.0, 101.0], [100.0, 101.0])
    tin = Tin.from_points(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float))
    stats, err = vertical_error(tin, dem)
    assert np.isnan(err).all() and stats.n_cells == 0 and stats.n_outside == 4
    assert math.isnan(stats.max_m) and math.isnan(stats.rms_m)
    assert isinstance(stats, ErrorStats)
