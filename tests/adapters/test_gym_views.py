"""Gymnasium views of the swarm: env checkers on every scenario, bit-for-bit agreement with the
parallel env, episode ends and reasons, seeding, vector envs and wrappers, SB3 PPO."""

import functools
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from tin_swarm_env.adapters.gym_views import (
    CENTRAL_ID,
    SINGLE_ID,
    TinSwarmCentralEnv,
    TinSwarmSingleEnv,
    reason_labels,
    register_gymnasium,
)
from tin_swarm_env.env import TinSwarmEnv
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.scenario import list_scenarios
from tin_swarm_env.world.state import Reason

register_gymnasium()

FALL_START = {"robot_positions": [[217.0, 120.0], [30.0, 120.0]], "headings": [0.0, 0.0]}  # ramp: robot 0 at the cliff
EAST = np.array([1.0, 0.0])
SB3_2D_OBS = "unconventional shape"  # SB3's advice for the (n, d) central observation; not an error


def small(scenario):
    return {"scenario": scenario, "n_robots": 3, "max_cycles": 12}


def fixed_actions(n_steps, shape, seed=0):
    return np.random.default_rng(seed).uniform(-1, 1, (n_steps, *shape)).astype(np.float32)


# -- registration, checkers --------------------------------------------------------------------------
def test_register_is_idempotent_with_entry_point_strings_and_no_time_limit():
    register_gymnasium()
    register_gymnasium()
    for env_id, cls in ((SINGLE_ID, "TinSwarmSingleEnv"), (CENTRAL_ID, "TinSwarmCentralEnv")):
        spec = gymnasium.spec(env_id)
        assert spec.entry_point == f"tin_swarm_env.adapters.gym_views:{cls}"
        assert spec.max_episode_steps is None
    env = gymnasium.make(SINGLE_ID, scenario="flat", n_robots=2, max_cycles=7)
    assert isinstance(env.unwrapped, TinSwarmSingleEnv)
    assert not any(type(w).__name__ == "TimeLimit" for w in _wrappers(env))
    env.reset(seed=0)
    steps, trunc = 0, False
    while not trunc:
        _, _, term, trunc, info = env.step(np.zeros(2, np.float32))
        steps += 1
        assert not term
    assert steps == 7 and info["reason"] == "max_cycles"  # max_cycles is the one time limit


def _wrappers(env):
    while isinstance(env, gymnasium.Wrapper):
        yield env
        env = env.env


@pytest.mark.parametrize("env_id", [SINGLE_ID, CENTRAL_ID])
@pytest.mark.parametrize("scenario", sorted(list_scenarios()))
def test_gymnasium_and_sb3_env_checkers_pass_on_every_scenario(scenario, env_id):
    sb3_check_env = pytest.importorskip("stable_baselines3.common.env_checker", reason="the train extra").check_env
    env = gymnasium.make(env_id, render_mode="rgb_array", **small(scenario))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=False)  # also makes it with every render mode
        sb3_check_env(env.unwrapped, skip_render_check=False)
    # render_mode="human" on this headless machine warns that no window will open (intended)
    messages = [str(w.message) for w in caught if SB3_2D_OBS not in str(w.message)
                and "there is no display" not in str(w.message)]
    assert messages == []  # the passive checker's findings (out-of-space obs, dtypes...) are warnings
    frame = env.unwrapped.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    env.close()


def test_reason_labels_map_codes_and_truncation():
    labels = reason_labels([0, 1, 2, 3, 0], [False, False, False, False, True])
    assert labels.tolist() == ["", "arrived", "fell", "battery", "max_cycles"]
    # the lookup table against the enum, one code at a time (every Reason, 2-D input flattened)
    codes = np.array([[int(r) for r in Reason]] * 2)
    want = [Reason(int(c)).label for c in codes.ravel()]
    assert reason_labels(codes, np.zeros(codes.size, bool)).tolist() == want
    assert reason_labels(codes, np.ones(codes.size, bool)).tolist() == ["max_cycles"] * codes.size
    assert reason_labels(np.zeros(0, np.int8), np.zeros(0, bool)).shape == (0,)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="others"):
        TinSwarmSingleEnv(others="bogus", scenario="flat", n_robots=2)
    with pytest.raises(ValueError, match="others"):
        TinSwarmSingleEnv(others=object(), scenario="flat", n_robots=2)
    with pytest.raises(ValueError, match="reward"):
        TinSwarmCentralEnv(reward="max", scenario="flat", n_robots=2)
    single = TinSwarmSingleEnv(scenario="flat", n_robots=2)
    with pytest.raises(RuntimeError, match="reset"):
        single.step(np.zeros(2))
    single.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        single.step(np.zeros(3))
    with pytest.raises(ValueError, match="robot_0"):
        single.step(np.array([np.nan, 0.0]))
    central = TinSwarmCentralEnv(scenario="flat", n_robots=2)
    central.reset(seed=0)
    with pytest.raises(ValueError, match=r"\(2, 2\)"):
        central.step(np.zeros((3, 2)))


# -- bit for bit against the parallel env -----------------------------------------------------------
@pytest.mark.parametrize("scenario", ["cliff_goal", "hill"])
@pytest.mark.parametrize("others", ["still", "apf"])
def test_single_view_equals_the_parallel_env_bit_for_bit(scenario, others):
    kw = {"scenario": scenario, "n_robots": 4, "max_cycles": 30}
    view = TinSwarmSingleEnv(others=others, **kw)
    penv = TinSwarmEnv(**kw)
    apf = APFPolicy(penv) if others == "apf" else None
    acts = fixed_actions(30, (2,), seed=1)
    o, info = view.reset(seed=11)
    p = penv.reset_arrays(seed=11)
    assert np.array_equal(o, p[0]) and info == {}
    moved = 0.0
    for t in range(30):
        full = apf.act_batch(p) if apf is not None else np.zeros((4, 2), np.float32)
        full[0] = acts[t]
        o, r, term, trunc, info = view.step(acts[t])
        p, pr, pterm, ptrunc, preason = penv.step_arrays(full)
        assert np.array_equal(o, p[0]) and o.dtype == np.float32
        assert r == float(pr[0]) and term == bool(pterm[0]) and trunc == bool(ptrunc[0])
        assert np.array_equal(view.parallel_env.world_state.positions, penv.world_state.positions)  # the others too
        moved += np.abs(full[1:]).sum()
        if term or trunc:
            assert info["reason"] == reason_labels(preason[:1], ptrunc[:1])[0]
            break
        assert info == {}
    assert (moved > 0) == (others == "apf")


def test_random_others_are_seeded_by_the_episode_seed():
    def run(seed):
        env = TinSwarmSingleEnv(others="random", scenario="flat", n_robots=3, max_cycles=20)
        env.reset(seed=seed)
        for a in fixed_actions(10, (2,)):
            env.step(a)
        return env.parallel_env.world_state.positions.copy()

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))


def test_central_view_equals_the_parallel_env_bit_for_bit():
    kw = {"scenario": "cliff_goal", "n_robots": 5, "max_cycles": 30}
    view = TinSwarmCentralEnv(**kw)
    penv = TinSwarmEnv(**kw)
    acts = fixed_actions(30, (5, 2), seed=2)
    o, _ = view.reset(seed=5)
    assert np.array_equal(o, penv.reset_arrays(seed=5))
    for t in range(30):
        o, r, term, trunc, info = view.step(acts[t])
        p, pr, pterm, ptrunc, _ = penv.step_arrays(acts[t])
        assert np.array_equal(o, p) and o.dtype == np.float32 and o.shape == (5, 91)
        assert r == float(np.sum(pr, dtype=np.float64))
    assert trunc and not term and info["counts"]["max_cycles"] == int(ptrunc.sum()) > 0


# -- episode ends, dead robots, reasons ------------------------------------------------------------------
def test_single_view_ends_when_robot_0_falls_with_reason():
    env = TinSwarmSingleEnv(others="still", scenario="ramp", n_robots=2, max_cycles=60)
    env.reset(seed=0, options=FALL_START)
    for _ in range(10):
        _, r, term, trunc, info = env.step(EAST)
        if term:
            break
    assert term and not trunc and info == {"reason": "fell"}
    assert r <= env.parallel_env.config.rewards.fall + 5
    with pytest.raises(RuntimeError, match="reset"):
        env.step(EAST)


def test_central_view_done_robots_read_zeros_and_their_actions_are_ignored():
    env = TinSwarmCentralEnv(scenario="ramp", n_robots=2, max_cycles=15)
    obs, info = env.reset(seed=0, options=FALL_START)
    assert info["reasons"].tolist() == ["", ""] and info["counts"]["live"] == 2
    act = np.array([EAST, [0.0, 0.0]])
    for t in range(10):
        obs, r, term, trunc, info = env.step(act)
        if info["reasons"][0]:
            break
    assert info["reasons"].tolist() == ["fell", ""] and not term and not trunc
    assert np.any(obs[0] != 0)  # its last observation on the step it ends
    assert info["counts"] == {"live": 1, "arrived": 0, "fell": 1, "battery": 0, "max_cycles": 0}
    assert r <= env.parallel_env.config.rewards.fall + 5
    while not trunc:
        obs, r, term, trunc, info = env.step(np.array([[np.nan, np.nan], [0.0, 0.0]]))  # ignored, even NaN
        assert np.all(obs[0] == 0) and np.any(obs[1] != 0)
    assert not term and info["reasons"].tolist() == ["fell", "max_cycles"]
    assert info["counts"]["live"] == 0 and env.parallel_env.steps == 15


def test_central_view_terminates_when_every_robot_has_terminated_and_mean_reward():
    env = TinSwarmCentralEnv(reward="mean", scenario="flat", n_robots=1, max_cycles=100)
    penv = TinSwarmEnv(scenario="flat", n_robots=1, max_cycles=100)
    goal = env.parallel_env.config.targets.positions[0]
    start = {"robot_positions": [[goal[0] - 10.0, goal[1]]], "headings": [0.0]}
    env.reset(seed=0, options=start)
    penv.reset_arrays(seed=0, options=start)
    for _ in range(20):
        _, r, term, trunc, info = env.step(EAST[None])
        _, pr, *_ = penv.step_arrays(EAST[None])
        assert r == float(pr[0])  # mean over one robot
        if term:
            break
    assert term and not trunc and info["reasons"].tolist() == ["arrived"]
    two = TinSwarmCentralEnv(reward="mean", scenario="flat", n_robots=2, max_cycles=5)
    ref = TinSwarmEnv(scenario="flat", n_robots=2, max_cycles=5)
    two.reset(seed=1)
    ref.reset_arrays(seed=1)
    a = np.array([EAST, -EAST])
    _, r, *_ = two.step(a)
    assert r == float(np.sum(ref.step_arrays(a)[1], dtype=np.float64)) / 2


# -- seeding ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [TinSwarmSingleEnv, TinSwarmCentralEnv])
def test_seeding_the_gymnasium_way(cls):
    a, b = cls(scenario="flat", n_robots=3), cls(scenario="flat", n_robots=3)
    oa, _ = a.reset(seed=7)
    ob, _ = b.reset(seed=7)
    assert np.array_equal(oa, ob)
    # unseeded resets continue from np_random: the same sequence on both, a new episode each time
    oa2, _ = a.reset()
    ob2, _ = b.reset()
    assert np.array_equal(oa2, ob2) and not np.array_equal(oa, oa2)
    # never seeded: np_random from entropy, so two fresh views differ (not the scenario's fixed seed)
    assert not np.array_equal(cls(scenario="flat", n_robots=3).reset()[0], cls(scenario="flat", n_robots=3).reset()[0])
    # a seed given is the parallel env's seed; without one, the seed is drawn from np_random
    penv = TinSwarmEnv(scenario="flat", n_robots=3)
    for o, seed in ((oa, 7), (oa2, int(np.random.default_rng(7).integers(2**63 - 1)))):
        p = penv.reset_arrays(seed=seed)
        assert np.array_equal(o, p[0] if cls is TinSwarmSingleEnv else p)


# -- vector envs, wrappers, rendering, SB3 -------------------------------------------------------------
def _registered_make(env_id, kw):
    register_gymnasium()  # a spawned worker starts with Gymnasium's bare registry
    return gymnasium.make(env_id, **kw)


def _make(env_id, **kw):
    return functools.partial(_registered_make, env_id, {"scenario": "flat", "n_robots": 2, "max_cycles": 6, **kw})


@pytest.mark.parametrize("env_id", [SINGLE_ID, CENTRAL_ID])
def test_sync_vector_env_with_record_episode_statistics(env_id):
    venv = gymnasium.wrappers.vector.RecordEpisodeStatistics(
        gymnasium.vector.SyncVectorEnv([_make(env_id), _make(env_id)]))
    obs, _ = venv.reset(seed=[1, 2])
    ref = [gymnasium.make(env_id, scenario="flat", n_robots=2, max_cycles=6) for _ in range(2)]
    ref_obs = [e.reset(seed=s)[0] for e, s in zip(ref, (1, 2))]
    assert all(np.array_equal(obs[i], ref_obs[i]) for i in range(2))
    acts = fixed_actions(6, venv.action_space.shape, seed=3)
    returns = np.zeros(2)
    for t in range(6):
        obs, r, term, trunc, info = venv.step(acts[t])
        for i in range(2):
            o, ri, *_ = ref[i].step(acts[t][i])
            assert np.array_equal(obs[i], o) and r[i] == ri
        returns += r
    assert trunc.all() and not term.any()
    assert info["_episode"].all()
    np.testing.assert_allclose(info["episode"]["r"], returns, rtol=1e-6)
    assert info["episode"]["l"].tolist() == [6, 6]
    venv.close()


@pytest.mark.parametrize("env_id", [SINGLE_ID, CENTRAL_ID])
def test_async_vector_env_equals_sync(env_id):
    fns = [_make(env_id), _make(env_id)]
    acts = fixed_actions(4, (2, *gymnasium.make(env_id, scenario="flat", n_robots=2).action_space.shape))
    out = []
    for venv in (gymnasium.vector.SyncVectorEnv(fns), gymnasium.vector.AsyncVectorEnv(fns, context="spawn")):
        rows = [venv.reset(seed=4)[0]]
        rows += [venv.step(a)[0] for a in acts]
        venv.close()
        out.append(np.stack(rows))
    assert np.array_equal(out[0], out[1])
    assert not np.array_equal(out[0][:, 0], out[0][:, 1])  # seed 4 and 5: different episodes


def test_render_is_the_parallel_env_frame():
    view = TinSwarmCentralEnv(scenario="ramp", n_robots=3, render_mode="rgb_array")
    penv = TinSwarmEnv(scenario="ramp", n_robots=3, render_mode="rgb_array")
    view.reset(seed=2)
    penv.reset_arrays(seed=2)
    assert np.array_equal(view.render(), penv.render())
    assert view.metadata["render_modes"] == penv.metadata["render_modes"]
    assert view.metadata["render_fps"] == penv.metadata["render_fps"]


def test_sb3_ppo_runs_on_the_single_robot_view():
    pytest.importorskip("stable_baselines3", reason="the train extra")
    from stable_baselines3 import PPO

    env = gymnasium.make(SINGLE_ID, scenario="flat", n_robots=2, max_cycles=40)
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=128)
    assert model.num_timesteps >= 128
    obs, _ = env.reset(seed=0)
    a, _ = model.predict(obs, deterministic=True)
    assert a.shape == (2,) and env.action_space.contains(a.astype(np.float32))
