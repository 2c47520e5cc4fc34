"""scenarios/canyon_left.toml and canyon_right.toml (the held-out canyons of the learned-policy
evaluation) are exactly tests/helpers/canyons.py's eastward variants: same TIN, same observations."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("side", ["left", "right"])
def test_canyon_files_match_the_test_terrains(canyon_config, side):
    a = tse.parallel_env(scenario=canyon_config(side, "east"))
    b = tse.parallel_env(scenario=str(ROOT / "scenarios" / f"canyon_{side}.toml"))
    assert a.max_cycles == b.max_cycles == 1500 and a.n == b.n == 20
    np.testing.assert_array_equal(a.tin.vertices, b.tin.vertices)
    np.testing.assert_array_equal(a.tin.triangles, b.tin.triangles)
    np.testing.assert_array_equal(a.reset_arrays(seed=3), b.reset_arrays(seed=3))
