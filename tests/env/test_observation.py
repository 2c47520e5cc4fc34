"""The parallel observation encoder: bit-identical for any thread count and to its plain loop."""

import numba
import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env import observation as O


def _episode(env, steps, seed=0):
    rng = np.random.default_rng(seed)
    out = [env.reset_arrays(seed=seed)]
    for _ in range(steps):
        obs, rew, term, trunc, reasons = env.step_arrays(rng.uniform(-1, 1, (env.n, 2)))
        out += [obs, rew, term, trunc, reasons]
    return out


@pytest.mark.parametrize("scenario", ["cliff_goal", "hill"])
def test_env_episode_is_bit_identical_for_1_and_2_threads_and_the_plain_encoder(scenario, monkeypatch):
    env = tse.parallel_env(scenario=scenario, n_robots=24)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = _episode(env, 15)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = _episode(env, 15)
    finally:
        numba.set_num_threads(old)
    monkeypatch.setattr(O, "_fill", O._fill.py_func)
    ref = _episode(env, 3)
    for a, b in zip(one, two, strict=True):
        assert a.tobytes() == b.tobytes()
    for a, b in zip(one, ref, strict=False):
        assert a.tobytes() == b.tobytes()
    assert np.any(one[0] != 0)
