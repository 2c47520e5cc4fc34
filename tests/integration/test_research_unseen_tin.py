"""research/unseen_tin.py (run by hand, research/unseen_tin.md): its narrowing measure, exact on hand-built
surfaces: a TIN that keeps a flat DEM flat narrows nothing; one with a steep sliver across open ground
narrows exactly the ground near the sliver that the full surface leaves open."""

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.terrain.robot import full_surface


@pytest.fixture
def ut(repo_script):
    return repo_script("research/unseen_tin.py")


def _flat(n=21, cell=1.0):
    c = np.arange(n, dtype=float) * cell
    return tse.terrain.Dem(np.zeros((n, n)), c, c)


def _tin(dem, lift=None):
    """Four corners and the centre; ``lift``: the centre's height (a pyramid, steep on every side)."""
    x0, x1, y0, y1 = dem.x[0], dem.x[-1], dem.y[0], dem.y[-1]
    v = np.array([[x0, y0, 0], [x1, y0, 0], [x1, y1, 0], [x0, y1, 0],
                  [(x0 + x1) / 2, (y0 + y1) / 2, 0.0 if lift is None else lift]], float)
    return tse.terrain.Tin(v, np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]))


def test_a_flat_tin_of_a_flat_dem_narrows_nothing(ut):
    dem = _flat()
    area, share = ut.narrowed(_tin(dem), full_surface(dem), 30.0, dem)
    assert area == 0.0 and share == 0.0


def test_a_steep_tin_over_open_ground_narrows_it(ut):
    dem = _flat()
    full = full_surface(dem)
    area, share = ut.narrowed(_tin(dem, lift=100.0), full, 30.0, dem)  # every triangle steep: all ground shut
    xs = np.arange(dem.x[0], dem.x[-1], ut.RASTER_M)
    open_cells = int(np.sum(ut._clearance(full, xs, xs, 30.0) >= ut.OPEN_M))
    assert open_cells == len(xs) ** 2  # the flat full surface: no steep ground, every raster point open
    assert share == 1.0
    assert area == open_cells * ut.RASTER_M ** 2


def test_a_gentle_tin_narrows_nothing(ut):
    dem = _flat()
    assert ut.narrowed(_tin(dem, lift=1.0), full_surface(dem), 30.0, dem) == (0.0, 0.0)  # ~8 deg: drivable


def test_the_clearance_is_the_distance_to_steep_ground(ut):
    """A 10 m high cliff along x = 10 on a 21 m DEM: the clearance grows by one raster cell per cell away."""
    z = np.zeros((21, 21))
    z[:, 11:] = 10.0
    dem = tse.terrain.Dem(z, np.arange(21.0), np.arange(21.0))
    xs = np.arange(0.0, 20.0, ut.RASTER_M)
    c = ut._clearance(full_surface(dem), xs, np.array([10.0]), 30.0)[0]
    assert c[xs == 10.5][0] == 0.0  # inside the steep squares (x 10..11)
    west = xs < 10.5
    assert np.allclose(c[west], 10.5 - xs[west])  # the distance to the first steep raster point
    assert np.all(c[xs > 11.0] > 0)  # east of the band: flat again
