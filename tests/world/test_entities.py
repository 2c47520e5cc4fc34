"""Targets and assets (world/entities.py): placement, a random walk step worked out by hand, static
entities that never draw from the generator, and a walk that never leaves traversable ground."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tin_swarm_env.errors import PlacementError
from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import World
from tin_swarm_env.world.entities import make_entities, move_entities

# a 100 m square: triangle 0 below the diagonal (0,0)-(100,100), triangle 1 above it
SQUARE = Tin(np.array([[0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]], float), [[0, 1, 2], [0, 2, 3]])


def _state(rng):
    return rng.bit_generator.state["state"]["state"]


def test_make_entities_places_them_and_draws_headings_only_for_mobile_ones():
    rng = np.random.default_rng(5)
    before = _state(rng)
    e = make_entities(SQUARE, np.zeros(2, bool), [[70, 20], [20, 70]], False, rng, "target")
    assert _state(rng) == before and e.headings.tolist() == [0.0, 0.0] and e.tri_idx.tolist() == [0, 1]
    e = make_entities(SQUARE, np.zeros(2, bool), [[70, 20], [20, 70]], [True, False], rng, "asset")
    assert e.mobile.tolist() == [True, False]
    want = np.random.default_rng(5).uniform(-math.pi, math.pi, 2)
    np.testing.assert_array_equal(e.headings, want)
    with pytest.raises(PlacementError, match=r"target 1 at \[20\.0, 70\.0\] lies on a too-steep triangle"):
        make_entities(SQUARE, np.array([False, True]), [[70, 20], [20, 70]], False, rng, "target")


def test_one_random_walk_step_by_hand_and_a_turn_back_at_steep_ground():
    steep = np.array([False, True])
    rng = np.random.default_rng(1)
    e = make_entities(SQUARE, steep, [[60, 20], [90, 89.5], [30, 5]], [True, True, False], rng, "target")
    e.headings[:] = [0.0, math.pi / 2, 1.0]  # 0 east (stays below the diagonal), 1 north (toward the steep side)
    turn = np.random.default_rng(9).normal(0.0, 0.1, 2)  # one draw per mobile entity, in order
    out = move_entities(SQUARE, steep, e, 2.0, 0.1, 0.5, np.random.default_rng(9))
    h0, h1 = turn[0], math.pi / 2 + turn[1]
    np.testing.assert_allclose(out.positions[0], [60 + math.cos(h0), 20 + math.sin(h0)], rtol=1e-14)
    # entity 1 at (90, 89.5), 1 m north, would cross the diagonal into the steep triangle: it stays and turns round
    np.testing.assert_array_equal(out.positions[1], [90, 89.5])
    assert out.headings[1] == pytest.approx(h1 + math.pi - 2 * math.pi)
    np.testing.assert_array_equal(out.positions[2], [30, 5])  # static
    assert out.headings[2] == 1.0 and e.positions[0].tolist() == [60, 20]  # the input is not changed
    assert move_entities(SQUARE, steep, e, 0.0, 0.1, 0.5, rng) is e  # speed 0: nothing to do


def test_static_entities_never_draw_from_the_generator():
    e = make_entities(SQUARE, np.zeros(2, bool), [[70, 20]], False, np.random.default_rng(0), "asset")
    rng = np.random.default_rng(2)
    before = _state(rng)
    assert move_entities(SQUARE, np.zeros(2, bool), e, 3.0, 0.5, 1.0, rng) is e and _state(rng) == before


def test_mobile_entities_stay_on_traversable_ground(world_params, cliff_tin):
    w = World(cliff_tin(width=5.0), world_params(entity_speed_mps=3.0, entity_turn_sd_deg=60))
    s = w.reset(0, [[50, 50]], targets=[[150, 50], [20, 20]], targets_mobile=[True, False])
    for _ in range(300):
        s, _ = w.step(s, [[0.0, 0.0]])
        assert not w.steep[s.targets.tri_idx].any()
        np.testing.assert_array_equal(s.targets.positions[1], [20, 20])
    assert s.targets.positions[0, 0] > 105  # stayed below the cliff
