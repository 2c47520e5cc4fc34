"""research/trust_limits.py (run by hand, research/trust_limits_notes.md): exact on hand-built DEMs,
its class islands, boundary corners, boundary chains, Douglas-Peucker and quarter areas."""

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.terrain.robot import full_surface_slope_deg


@pytest.fixture
def tl(repo_script):
    return repo_script("research/trust_limits.py")


def _dem(z):
    z = np.asarray(z, float)
    return tse.terrain.Dem(z, np.arange(z.shape[1], dtype=float), np.arange(z.shape[0], dtype=float))


def _step():
    """6 x 6 cells, flat but for a 10 m cliff between columns 2 and 3: one column of steep squares."""
    z = np.zeros((6, 6))
    z[:, 3:] = 10.0
    return _dem(z)


def test_a_cliff_band_is_three_islands_with_straight_boundaries(tl):
    dem = _step()
    steep = full_surface_slope_deg(dem) > 20.0
    assert steep.reshape(5, 5, 2)[:, 2].all() and steep.sum() == 10  # the squares of columns 2-3, both halves
    n, lab = tl.islands(dem.shape, steep)
    assert n == 3  # drivable west, the steep band, drivable east
    corners, nodes = tl.corner_nodes(dem, steep)
    assert nodes == 12 and corners == 4  # two straight lines, 6 nodes each; only their ends are corners
    chains = tl.boundary_chains(dem, steep)
    assert sorted(len(c) for c in chains) == [6, 6]
    for c in chains:
        cols = {v % 6 for v in c}
        assert cols in ({2}, {3})
        p = np.column_stack([np.array(c) % 6, np.array(c) // 6]).astype(float)
        assert tl.douglas_peucker(p, 0.1) == [0, 5]  # a straight chain keeps its ends only


def test_quarters_are_firm_on_the_cliff_and_on_the_flat(tl):
    dem = _step()
    full, other = tl.quarter_classes(dem, 20.0)
    assert full.shape == (25, 4) and (full == other).all()
    assert full.reshape(5, 5, 4)[:, 2].all() and full.sum() == 20


def test_a_corner_raised_square_is_firm_on_two_quarters(tl):
    # NE raised 1 m on 1 m cells: full surface 45 deg in both triangles; other diagonal 0 deg (SW, SE, NW)
    # and 54.7 deg (SE, NE, NW), which hold the S, W and the E, N quarters
    dem = _dem([[0.0, 0.0], [0.0, 1.0]])
    full, other = tl.quarter_classes(dem, 40.0)
    assert full.tolist() == [[True, True, True, True]] and other.tolist() == [[False, True, True, False]]
    full, other = tl.quarter_classes(dem, 50.0)
    assert not full.any() and other.tolist() == [[False, True, True, False]]
