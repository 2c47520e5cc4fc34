"""research/vector_mix_floor.py (run by hand): its floors switch off what they name and nothing else, and a
timed run puts the env's sensing back."""

import importlib.util
import sys
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
import tin_swarm_env.env.vector as V

ROOT = Path(__file__).resolve().parents[2]


def _study():
    path = ROOT / "research" / "vector_mix_floor.py"
    spec = importlib.util.spec_from_file_location("research_vector_mix_floor", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("research_vector_mix_floor", mod)
    spec.loader.exec_module(mod)
    return mod


F = _study()


def _stepped(breaks=True, los=True, seed=0):
    env = tse.vector_env("cliff_goal", n_envs=2, n_robots=6, seed=seed)
    env.reset()
    real, patched = F._sense_without(breaks, los)
    V.sense_copies = patched if not (breaks and los) else real
    try:
        obs = env.step(np.zeros((2, 6, 2)))[0]
    finally:
        V.sense_copies = real
    return env, obs


def test_the_no_break_floor_senses_no_break_and_leaves_the_rest():
    full, obs_full = _stepped()
    env, obs = _stepped(breaks=False)
    assert V.sense_copies is F._sense_without(True, True)[0]  # put back
    idx, dist, closest, scan, _ = full._rows
    assert (idx >= 0).any() and (scan < 1).any()  # the real pass sees breaks here
    idx, dist, closest, scan, _ = env._rows
    assert (idx == -1).all() and (scan == 1.0).all()
    lay = env.layout
    assert (obs[..., lay.breaks] == 0).all() and (obs_full[..., lay.breaks] != 0).any()
    for part in (lay.robots, lay.targets):
        np.testing.assert_array_equal(obs[..., part], obs_full[..., part])


def test_the_no_sight_floor_turns_line_of_sight_off_and_breaks_too():
    seen = []
    real = V.sense_copies

    def spy(pack, *a, **k):
        seen.append((isinstance(pack, F._NoBreaks), a[9].sensor.check_los))
        return real(pack, *a, **k)

    env = tse.vector_env("cliff_goal", n_envs=1, n_robots=3, seed=0)
    env.reset()
    V.sense_copies = spy
    try:
        _, patched = F._sense_without(False, False)  # wraps the spy
        V.sense_copies = patched
        env.step(np.zeros((1, 3, 2)))
    finally:
        V.sense_copies = real
    assert seen == [(True, False)]
    assert env.params.sensor.check_los  # the env's own params untouched


def test_a_timed_run_steps_the_env_and_puts_the_sensing_back():
    env = tse.vector_env("cliff_goal", n_envs=2, n_robots=3, seed=0)
    env.reset()
    real = V.sense_copies
    t, resets = F.timed_run(env, 3, np.random.default_rng(0), breaks=False, los=False)
    assert V.sense_copies is real
    assert t > 0 and resets == 0
    assert (env.steps == 4).all()
