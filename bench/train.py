"""PPO training throughput: environment steps per second while learning (collection plus
gradient updates), for 1 and 4 environment copies of 8 robots each. Run by hand:

    python bench/train.py [--timesteps 40000] [--scenario cliff_goal]

Each configuration learns for the same number of timesteps with the same PPO settings
(rollouts of 256 steps per sub-environment, batch 1024, 5 epochs, a 128x128 MLP, 2 torch
threads); the ratio between them is the figure to compare across machines.
"""

from __future__ import annotations

import argparse
import time


def run(scenario, n_envs, n_robots, timesteps):
    import torch
    from stable_baselines3 import PPO

    import tin_swarm_env as tse

    torch.set_num_threads(2)
    vec = tse.adapters.make_sb3_vec_env(scenario, n_robots=n_robots, n_envs=n_envs, seed=0)
    model = PPO("MlpPolicy", vec, n_steps=256, batch_size=1024, n_epochs=5, policy_kwargs={"net_arch": [128, 128]},
                seed=0, device="cpu", verbose=0)
    model.learn(total_timesteps=2 * 256 * vec.num_envs)  # warm-up: compilation, first allocations
    t = time.perf_counter()
    model.learn(total_timesteps=timesteps, reset_num_timesteps=False)
    dt = time.perf_counter() - t
    steps = model.num_timesteps - 2 * 256 * vec.num_envs
    # collection alone, for the split
    obs = vec.reset()
    t = time.perf_counter()
    n = 0
    while n < timesteps:
        a, _ = model.predict(obs, deterministic=False)
        obs, *_ = vec.step(a)
        n += vec.num_envs
    dc = time.perf_counter() - t
    return steps / dt, n / dc


def main(scenario, timesteps):
    print(f"PPO on {scenario}, 8 robots per copy; environment steps per second (one step = one robot)\n")
    print(f"{'copies':>7s} {'sub-envs':>9s} {'learning':>12s} {'collection only':>16s}")
    res = {}
    for copies in (1, 4):
        learn, collect = run(scenario, copies, 8, timesteps)
        res[copies] = learn
        print(f"{copies:7d} {8 * copies:9d} {learn:12.0f} {collect:16.0f}")
    print(f"\n4 copies / 1 copy: {res[4] / res[1]:.2f}x")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--timesteps", type=int, default=40_000)
    p.add_argument("--scenario", default="cliff_goal")
    a = p.parse_args()
    main(a.scenario, a.timesteps)
