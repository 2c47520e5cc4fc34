"""The random floor of the tables (policies/random.py): uniform body-frame commands from its own
generator, the same draws as ``np.random.default_rng(seed)``, one row per observation."""

from __future__ import annotations

import numpy as np

from tin_swarm_env.policies.random import RandomPolicy


def test_act_batch_draws_uniform_commands_from_its_own_seeded_generator():
    obs = np.zeros((5, 59), np.float32)
    a = RandomPolicy(seed=3).act_batch(obs)
    assert a.shape == (5, 2) and a.dtype == np.float32
    np.testing.assert_array_equal(a, np.random.default_rng(3).uniform(-1, 1, (5, 2)).astype(np.float32))
    pol = RandomPolicy(None, seed=3)
    first, second = pol.act_batch(obs), pol.act_batch(obs)
    assert np.array_equal(first, a) and not np.array_equal(first, second)  # the stream goes on
    big = RandomPolicy(seed=0).act_batch(np.zeros((4000, 3)))
    assert big.min() >= -1 and big.max() <= 1 and big.min() < -0.99 and big.max() > 0.99
    assert abs(float(big.mean())) < 0.05  # mean of 8000 uniforms on [-1, 1]: sd 0.0065


def test_act_maps_agents_to_their_rows_in_dict_order():
    obs = {"robot_2": np.zeros(4), "robot_0": np.ones(4), "robot_1": np.zeros(4)}
    got = RandomPolicy(seed=1).act(obs)
    want = np.random.default_rng(1).uniform(-1, 1, (3, 2)).astype(np.float32)
    assert list(got) == ["robot_2", "robot_0", "robot_1"]
    np.testing.assert_array_equal(np.stack(list(got.values())), want)
    assert RandomPolicy(seed=1).act({}) == {}
