"""The numpy reference of the observation (env/reference.py) on a hand-built scene with every value
worked out by hand; the compiled observation is compared against it in tests/env/test_tin_swarm.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tin_swarm_env.env.observation import SLOT_FIELDS, ObsLayout
from tin_swarm_env.env.reference import build_observations_reference
from tin_swarm_env.world import World


def slots(lay, obs, part):
    """``(n, K, fields)`` view of one part of the observation, fields in SLOT_FIELDS order."""
    return obs[:, lay.part_slice(part)].reshape(len(obs), lay.count(part), len(SLOT_FIELDS[part]))


def test_a_hand_built_scene_observed_field_by_field(world_params):
    # flat ground, range 50 m, all round sight; robot 0 at (100, 100) faces north, robot 1 20 m
    # north of it faces east; the one target 30 m east of robot 0, assigned to robot 0 only
    w = World(None, world_params(sensor={"range_m": 50, "fov_deg": 360}))
    s = w.reset(0, [[100, 100], [100, 120]], headings=[math.pi / 2, 0.0], targets=[[130, 100]])
    lay = ObsLayout(k_robots=1, k_targets=1, k_breaks=1, k_assets=0)
    live = np.array([True, True])
    obs = build_observations_reference(w, s, w.sense(s), np.array([0, -1]), live, lay)
    assert obs.dtype == np.float32 and obs.shape == (2, lay.size)
    own = lay.own
    assert obs[0, own["battery"]].tolist() == [1.0] and obs[0, own["speed"]].tolist() == [0.0]
    assert obs[0, own["tilt"]].tolist() == obs[0, own["slope"]].tolist() == [0.0]
    assert obs[0, own["uphill"]].tolist() == [0.0, 0.0]  # flat: no uphill direction
    # the target 30 m to robot 0's right: body frame (0, -30); distance 30 / (30 + 50)
    assert obs[0, own["target_valid"]].tolist() == [1.0]
    np.testing.assert_allclose(obs[0, own["target_dir"]], [0.0, -1.0], atol=1e-7)
    assert obs[0, own["target_dist"]][0] == pytest.approx(30 / 80)
    assert obs[0, own["target_dz"]].tolist() == [0.0]
    assert obs[1, own["target_valid"]].tolist() == obs[1, own["target_dist"]].tolist() == [0.0]
    # robot slots (valid, x, y, d), x and y in the body frame over the range: robot 0 sees robot 1
    # straight ahead, robot 1 sees robot 0 on its right
    np.testing.assert_allclose(slots(lay, obs, "robots")[:, 0], [[1, 0.4, 0, 0.4], [1, 0, -0.4, 0.4]], atol=1e-7)
    d1 = math.hypot(30, 20) / 50
    np.testing.assert_allclose(slots(lay, obs, "targets")[:, 0], [[1, 0, -0.6, 0.6], [1, 0.6, -0.4, d1]],
                               atol=1e-7)
    assert not slots(lay, obs, "breaks").any()  # no break on flat ground
    # a robot that is not live observes nothing
    dead = build_observations_reference(w, s, w.sense(s), np.array([0, -1]), np.array([True, False]), lay)
    np.testing.assert_array_equal(dead[0], obs[0])
    assert not dead[1].any()


def test_values_are_clipped_to_the_unit_interval(world_params):
    w = World(None, world_params(sensor={"range_m": 50, "fov_deg": 360}))
    s = w.reset(0, [[100, 100]], headings=[0.0])
    s.speeds[:] = 3 * w.params.robot.max_speed_mps  # faster than the top speed: clipped to 1
    obs = build_observations_reference(w, s, w.sense(s), np.array([-1]), np.array([True]), ObsLayout())
    assert obs[0, ObsLayout().own["speed"]].tolist() == [1.0] and np.abs(obs).max() <= 1.0
