"""Targets and assets (world/entities.py): placement and movement of mobile and fixed entities."""

from __future__ import annotations

import numpy as np

from tin_swarm_env.world import (
    World,
)


def test_mobile_entities_stay_on_traversable_ground(world_params, cliff_tin):
    w = World(cliff_tin(width=5.0), world_params(entity_speed_mps=3.0, entity_turn_sd_deg=60))
    s = w.reset(0, [[50, 50]], targets=[[150, 50], [20, 20]], targets_mobile=[True, False])
    for _ in range(300):
        s, _ = w.step(s, [[0.0, 0.0]])
        assert not w.steep[s.targets.tri_idx].any()
        np.testing.assert_array_equal(s.targets.positions[1], [20, 20])
    assert s.targets.positions[0, 0] > 105  # stayed below the cliff
