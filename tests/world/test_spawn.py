"""Initial placement (world/spawn.py): positions on traversable ground inside the region, apart by the
separation, per-group allowed triangles, reproducible from the generator; impossible requests named."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError, PlacementError
from tin_swarm_env.terrain import Tin
from tin_swarm_env.world.spawn import spawn_positions

# a 100 m square: triangle 0 below the diagonal (0,0)-(100,100), triangle 1 above it
SQUARE = Tin(np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]], float), [[0, 1, 2], [0, 2, 3]])


def test_positions_avoid_steep_ground_stay_in_the_region_and_keep_apart():
    steep = np.array([False, True])  # only below the diagonal
    p = spawn_positions(SQUARE, steep, 40, np.random.default_rng(0), region=(20, 0, 100, 60), min_separation_m=4.0)
    assert p.shape == (40, 2)
    assert np.all(p[:, 1] <= p[:, 0]) and SQUARE.locate(p).tolist() == [0] * 40
    assert np.all((p >= [20, 0]) & (p <= [100, 60]))
    d = np.hypot(*(p[:, None] - p[None]).transpose(2, 0, 1))
    assert d[np.triu_indices(40, 1)].min() >= 4.0
    again = spawn_positions(SQUARE, steep, 40, np.random.default_rng(0), region=(20, 0, 100, 60), min_separation_m=4.0)
    np.testing.assert_array_equal(p, again)


def test_each_group_stands_on_its_allowed_triangles():
    allowed = np.array([[True, False], [False, True]])  # group 0 below the diagonal, group 1 above
    groups = np.array([0, 1, 1, 0, 1])
    p = spawn_positions(SQUARE, np.zeros(2, bool), 5, np.random.default_rng(3), allowed=allowed, groups=groups)
    assert SQUARE.locate(p).tolist() == groups.tolist()


def test_impossible_or_bad_requests_are_named():
    steep = np.array([False, True])
    with pytest.raises(PlacementError, match=r"could only place \d+ of 30 robots .* separation 40\.0 m"):
        spawn_positions(SQUARE, steep, 30, np.random.default_rng(0), min_separation_m=40.0, max_rounds=5)
    with pytest.raises(PlacementError, match="from which their assigned target can be reached"):
        spawn_positions(SQUARE, steep, 2, np.random.default_rng(0), allowed=[False, True], max_rounds=3)
    with pytest.raises(ArgumentError, match="n must be >= 0"):
        spawn_positions(SQUARE, steep, -1, np.random.default_rng(0))
    with pytest.raises(ArgumentError, match="spawn region .* is empty"):
        spawn_positions(SQUARE, steep, 1, np.random.default_rng(0), region=(50, 0, 50, 10))
    with pytest.raises(ArgumentError, match=r"groups must be 2 integers in 0\.\.0"):
        spawn_positions(SQUARE, steep, 2, np.random.default_rng(0), groups=[0, 1])
    assert spawn_positions(SQUARE, steep, 0, np.random.default_rng(0)).shape == (0, 2)


def test_spawn_positions_with_groups_respect_their_allowed_triangles():
    w = tse.world.World(tse.terrain.build_tin(tse.scenario.terrains.make_dem("ridge", {}), method="delaunay"))
    tin = w.tin
    cx = tin.vertices[tin.triangles, 0].mean(axis=1)
    allowed = np.array([cx < 80, cx > 120])  # (2, T): west for group 0, east for group 1
    groups = np.array([0, 1, 1, 0, 1, 0, 0])
    pos = spawn_positions(tin, w.steep, 7, np.random.default_rng(0), min_separation_m=2.0, allowed=allowed,
                          groups=groups)
    t = tin.locate(pos)
    assert np.all(allowed[groups, t]) and not w.steep[t].any()
    d = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1))
    assert d[np.triu_indices(7, 1)].min() >= 2.0
    # without allowed/groups the draw is the plain one (the same stream gives the same points)
    a = spawn_positions(tin, w.steep, 9, np.random.default_rng(4), min_separation_m=2.0)
    b = spawn_positions(tin, w.steep, 9, np.random.default_rng(4), min_separation_m=2.0,
                        allowed=np.ones(tin.n_triangles, bool))
    np.testing.assert_array_equal(a, b)
    with pytest.raises(PlacementError, match="assigned target can be reached"):
        spawn_positions(tin, w.steep, 3, np.random.default_rng(0), allowed=np.zeros(tin.n_triangles, bool))
