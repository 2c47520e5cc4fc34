"""TorchRL: make_torchrl_env's PettingZooWrapper keeps the swarm running when one robot falls,
masks the robots that ended, and reproduces a plain PettingZoo rollout step for step."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("torchrl", reason="torchrl not installed: pip install 'tin_swarm_env[torchrl]'")

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.adapters.torchrl import make_torchrl_env  # noqa: E402

N, CYCLES, STEPS = 4, 150, 200


def toward_target(td):  # drive at the assigned target: on cliff_goal the robots fall one by one
    td["robot", "action"] = td["robot", "observation"][..., 7:9].clone()
    return td


def reference(seed):
    """Plain PettingZoo: per step, rewards (n,), live-after-step mask (n,), done-this-step (n,)."""
    env = tse.parallel_env(scenario="cliff_goal", n_robots=N, max_cycles=CYCLES)
    env.reset(seed=seed)  # torchrl's wrapper resets with the seed at construction ...
    obs, _ = env.reset()  # ... and rollout() resets again, continuing the generator
    rows = []
    for _ in range(STEPS):
        if not env.agents:
            obs, _ = env.reset()
        acts = {a: obs[a][7:9].copy() for a in env.agents}
        obs, rew, term, trunc, _ = env.step(acts)
        rows.append(([rew.get(a, 0.0) for a in env.possible_agents], [a in env.agents for a in env.possible_agents],
                     [term.get(a, False) or trunc.get(a, False) for a in env.possible_agents]))
    return [np.array(x) for x in zip(*rows)]


def test_one_robot_falling_does_not_reset_the_swarm_and_matches_pettingzoo():
    env = make_torchrl_env("cliff_goal", n_robots=N, max_cycles=CYCLES, seed=0)
    assert env.group_map == {"robot": [f"robot_{i}" for i in range(N)]}
    td = env.rollout(STEPS, policy=toward_target, break_when_any_done=False)
    rew = td["next", "robot", "reward"][..., 0].numpy()  # (STEPS, N)
    mask = td["next", "robot", "mask"].numpy()
    done = td["next", "done"][:, 0].numpy()
    ref_rew, ref_live, ref_ended = reference(0)
    # the first robot to end fell while the others went on
    t_first = int(np.flatnonzero(ref_ended.any(1))[0])
    assert ref_ended[t_first].sum() < N and not done[t_first]
    assert mask[t_first].sum() == N - ref_ended[t_first].sum()
    assert mask[t_first + 1].sum() == N - ref_ended[t_first].sum()  # still masked: no reset
    # the swarm's episode ends exactly when the last robot has ended
    ends = np.flatnonzero(done)
    assert ends.size >= 1 and np.all(~ref_live[ends].any(1)) and np.all(ref_live[~done].any(1))
    # step for step the same rollout as plain PettingZoo (dead robots: reward 0)
    assert np.allclose(rew, ref_rew, atol=1e-5)
    assert np.array_equal(mask[~done], ref_live[~done])


def test_dead_robots_have_zero_observations_and_their_own_done():
    env = make_torchrl_env("cliff_goal", n_robots=N, max_cycles=CYCLES, seed=0)
    td = env.rollout(STEPS, policy=toward_target, break_when_any_done=True)
    nxt = td["next", "robot"]
    ending = td["robot", "mask"] & ~nxt["mask"]  # (T, N): the step a robot ends
    dead = ~td["robot", "mask"]  # ended at an earlier step
    assert dead.any() and td["next", "done"][-1].item()  # ran to the end of the swarm's episode
    assert not td["next", "done"][:-1].any()
    # the ending step carries the terminal observation and reward (a fall costs), then zeros
    assert torch.all(nxt["done"][ending]) and torch.all(nxt["observation"][ending].abs().sum(-1) > 0)
    assert torch.all(nxt["observation"][dead] == 0) and torch.all(nxt["reward"][dead] == 0)
    assert torch.all(nxt["done"][dead]) and torch.all(~nxt["done"][td["robot", "mask"] & nxt["mask"]])
