"""The one placement check (world/placement.py): a copy and the triangles of good points; the first bad
point named with its label (not finite, outside the terrain, on a too-steep triangle)."""

from __future__ import annotations

import numpy as np
import pytest

from tin_swarm_env.errors import PlacementError
from tin_swarm_env.terrain import Tin
from tin_swarm_env.world.placement import check_placement

# a 10 m square: triangle 0 below the diagonal (0,0)-(10,10), triangle 1 above it (marked steep)
SQUARE = Tin(np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]], float), [[0, 1, 2], [0, 2, 3]])
STEEP = np.array([False, True])


def test_good_points_come_back_as_a_float_copy_with_their_triangles():
    pts = [[7, 2], [9, 1]]
    p, tri = check_placement(SQUARE, STEEP, pts)
    assert p.dtype == np.float64 and p.tolist() == [[7.0, 2.0], [9.0, 1.0]] and tri.tolist() == [0, 0]
    p[0, 0] = 5.0
    assert pts[0][0] == 7  # a copy
    p, tri = check_placement(SQUARE, STEEP, [])
    assert p.shape == (0, 2) and len(tri) == 0


@pytest.mark.parametrize("pts,msg", [
    ([[7, 2], [np.nan, 1]], r"robot 1 at \[nan, 1\.0\] is not finite"),
    ([[7, 2], [11, 1], [2, 7]],
     r"robot 1 at \[11\.0, 1\.0\] lies outside the terrain \(bounds \(0\.0, 0\.0, 10\.0, 10\.0\)\)"),
    ([[2, 7], [11, 1]], r"robot 1 at \[11\.0, 1\.0\] lies outside"),  # outside is checked before steep
    ([[7, 2], [2, 7]], r"robot 1 at \[2\.0, 7\.0\] lies on a too-steep triangle \(0\.0 deg\)"),
])
def test_the_first_bad_point_is_named(pts, msg):
    with pytest.raises(PlacementError, match=msg):
        check_placement(SQUARE, STEEP, pts, "robot {i}")


def test_the_label_is_the_caller_s():
    with pytest.raises(PlacementError, match=r"^ramp\.toml \[targets\] positions\[0\] at"):
        check_placement(SQUARE, STEEP, [[2, 7]], "ramp.toml [targets] positions[{i}]")
