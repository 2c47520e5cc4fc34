"""The world state (world/state.py): Reason codes and labels, who is present and active, and copies."""

from __future__ import annotations

import numpy as np

from tin_swarm_env import Reason
from tin_swarm_env.world.state import Entities, WorldState, is_present


def test_reason_codes_and_labels():
    assert [int(r) for r in Reason] == [0, 1, 2, 3, 4]
    assert [r.label for r in Reason][1:] == ["arrived", "fell", "battery", "max_cycles"]
    import tin_swarm_env.world as world
    import tin_swarm_env.world.state as state

    for alias in ("ACTIVE", "DONE", "FELL", "EMPTY", "STATUS_NAMES"):  # robot status is a Reason code, no aliases
        assert not hasattr(world, alias) and not hasattr(state, alias), alias


def test_present_and_active_follow_the_status_codes():
    status = np.array([Reason.NONE, Reason.ARRIVED, Reason.FELL, Reason.BATTERY, Reason.TIMEOUT], np.int8)
    assert is_present(status).tolist() == [True, False, False, True, False]
    s = WorldState(np.zeros((5, 2)), np.zeros(5), np.zeros(5, np.int64), np.zeros(5), np.zeros(5), np.ones(5),
                   status, np.zeros(5, np.int64), Entities.empty(), Entities.empty(), np.random.default_rng(0))
    assert s.n_robots == 5 and s.active.tolist() == [True, False, False, False, False]
    assert s.present.tolist() == is_present(status).tolist()


def test_a_copy_shares_no_array_and_its_generator_draws_the_same_future():
    ent = Entities(np.array([[1.0, 2.0]]), np.array([3]), np.array([0.5]), np.array([True]))
    rng = np.random.default_rng(7)
    rng.uniform(size=3)  # not at the start of its stream
    s = WorldState(np.zeros((2, 2)), np.zeros(2), np.zeros(2, np.int64), np.zeros(2), np.zeros(2), np.ones(2),
                   np.zeros(2, np.int8), np.zeros(2, np.int64), ent, Entities.empty(), rng, step=4)
    c = s.copy()
    assert c.step == 4 and c.rng is not s.rng
    np.testing.assert_array_equal(c.rng.uniform(size=5), s.rng.uniform(size=5))
    c.positions[0, 0] = 9.0
    c.targets.positions[0, 0] = 9.0
    c.battery_j[1] = 0.0
    assert s.positions[0, 0] == 0.0 and s.targets.positions[0, 0] == 1.0 and s.battery_j[1] == 1.0
    assert len(s.targets) == 1 and len(Entities.empty()) == 0
