"""The world state (world/state.py): Reason codes and labels."""

from __future__ import annotations

from tin_swarm_env import Reason


def test_reason_codes_and_labels():
    assert [int(r) for r in Reason] == [0, 1, 2, 3, 4]
    assert [r.label for r in Reason][1:] == ["arrived", "fell", "battery", "max_cycles"]
    import tin_swarm_env.world as world
    import tin_swarm_env.world.state as state

    for alias in ("ACTIVE", "DONE", "FELL", "EMPTY", "STATUS_NAMES"):  # robot status is a Reason code, no aliases
        assert not hasattr(world, alias) and not hasattr(state, alias), alias
