"""TorchRL: make_torchrl_env is a native EnvBase over the vector env (batch_size [E], group "robot"
[E, N]); it passes check_env_specs, keeps a copy running when one robot falls, masks the robots that
ended, resets only the copies named by "_reset", and gives the parallel env's numbers."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("torchrl", reason="torchrl not installed: pip install 'tin_swarm_env[torchrl]'")

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.adapters.torchrl import make_torchrl_env  # noqa: E402
from tin_swarm_env.scenario import load_scenario  # noqa: E402

E, N, CYCLES, STEPS = 2, 4, 150, 200


def toward_target(td):  # drive at the assigned target: on cliff_goal the robots fall one by one
    td["robot", "action"] = td["robot", "observation"][..., 7:9].clone()
    return td


def test_check_env_specs_and_shapes():
    from torchrl.envs.utils import check_env_specs

    env = make_torchrl_env("cliff_goal", n_envs=3, n_robots=N, seed=0, max_cycles=10)
    check_env_specs(env)
    assert tuple(env.batch_size) == (3,)
    assert env.group_map == {"robot": [f"robot_{i}" for i in range(N)]}
    td = env.rollout(5)
    assert td["next", "robot", "observation"].shape == (3, 5, N, env.vec.layout.size)
    assert td["next", "robot", "reward"].shape == (3, 5, N, 1) and td["next", "done"].shape == (3, 5, 1)
    assert env.full_observation_spec_unbatched["robot", "observation"].shape == (N, env.vec.layout.size)


def test_the_same_numbers_as_separate_parallel_envs_and_a_fall_does_not_end_the_copy():
    env = make_torchrl_env("cliff_goal", n_envs=E, n_robots=N, max_cycles=CYCLES, seed=0)
    td = env.rollout(STEPS, policy=toward_target, break_when_any_done=True)
    seeds = env.vec.copy_seeds.copy()
    T = td.shape[1]
    nxt = td["next", "robot"]
    for c in range(E):
        pe = tse.parallel_env("cliff_goal", n_robots=N, max_cycles=CYCLES)
        obs = pe.reset_arrays(seed=int(seeds[c]))
        np.testing.assert_array_equal(td["robot", "observation"][c, 0].numpy(), obs)
        for t in range(T):
            obs, rew, term, trunc, why = pe.step_arrays(obs[:, 7:9].astype(np.float64))
            np.testing.assert_array_equal(nxt["reward"][c, t, :, 0].numpy(), rew)
            np.testing.assert_array_equal(nxt["observation"][c, t].numpy(), obs)
            np.testing.assert_array_equal(nxt["mask"][c, t].numpy(), pe.live_mask)
            assert bool(td["next", "done"][c, t, 0]) == (not pe.live_mask.any())
    ending = td["robot", "mask"] & ~nxt["mask"]  # (E, T, N): the step a robot ends
    dead = ~td["robot", "mask"]  # ended at an earlier step
    assert dead.any() and td["next", "done"][:, -1].any()
    # the first robot to end fell while its copy went on
    first = ending.any(-1)
    assert (first & ~td["next", "done"][..., 0]).any()
    assert torch.all(nxt["done"][ending]) and torch.all(nxt["observation"][ending].abs().sum(-1) > 0)
    assert torch.all(nxt["observation"][dead] == 0) and torch.all(nxt["reward"][dead] == 0)
    assert torch.all(nxt["done"][dead]) and torch.all(~nxt["done"][td["robot", "mask"] & nxt["mask"]])
    assert (nxt["info", "reason"][ending] > 0).all()


def test_partial_reset_resets_only_the_copies_named():
    cfg = load_scenario("ramp")
    env = make_torchrl_env([cfg.replace(max_cycles=3), cfg.replace(max_cycles=50)], n_envs=2, n_robots=3, seed=1)
    td = env.reset()
    seeds0 = env.vec.copy_seeds.copy()
    for _ in range(3):
        td["robot", "action"] = torch.zeros(2, 3, 2)
        td = env.step(td)["next"]
    assert td["done"][:, 0].tolist() == [True, False] and td["truncated"][:, 0].tolist() == [True, False]
    assert td["robot", "truncated"][0].all() and not td["robot", "terminated"].any()
    td["_reset"] = td["done"].clone()
    td = env.reset(td)
    assert env.vec.copy_seeds[0] != seeds0[0] and env.vec.copy_seeds[1] == seeds0[1]
    assert env.vec.steps.tolist() == [0, 3]
    assert td["robot", "mask"].all() and not td["done"].any() and not td["robot", "truncated"].any()


def test_a_collector_runs_and_resets_the_copies():
    from torchrl.collectors import SyncDataCollector

    env = make_torchrl_env("ramp", n_envs=2, n_robots=3, seed=0, max_cycles=10)
    col = SyncDataCollector(env, None, frames_per_batch=2 * 25, total_frames=2 * 50)
    batches = list(col)
    assert len(batches) == 2 and batches[0].shape == (2, 25)
    assert sum(int(b["next", "done"].sum()) for b in batches) == 2 * 5  # every copy truncated every 10 steps
    col.shutdown()
