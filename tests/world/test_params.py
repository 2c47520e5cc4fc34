"""World parameters (world/params.py): each dataclass checks its values and names the bad one."""

from __future__ import annotations

import pytest

from tin_swarm_env.world import (
    SensorParams,
)


def test_max_candidates_must_be_a_positive_integer():
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ValueError, match="max_candidates"):
            SensorParams(max_candidates=bad)
