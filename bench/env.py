"""Environment throughput on the jacksboro DEM. Run by hand:

    python bench/env.py [--steps 30]

For 100 and 1 000 robots, in one process and on the same terrain and density: the world step
alone (step + sensing), the env's batched array path (``step_arrays``: world + observations +
rewards), and the PettingZoo dict API (``step`` with per-agent dicts), as agent-steps per second;
the API's overhead is the difference. Then the time to draw a 500-robot frame (``rgb_array``,
terrain background already drawn) against the step time of 500 robots.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.scenario import scenario_from_dict


def config(n, range_m=60.0):
    dem = tse.terrain.sample_dem("jacksboro")
    cx, cy = dem.x[-1] / 2, dem.y[-1] / 2
    side = math.sqrt(n * math.pi * range_m ** 2 / 10)  # ~10 robots within range of each
    region = [cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2]
    d = {"name": f"bench_{n}", "task": "goal", "max_cycles": 10_000,
         "terrain": {"source": "sample", "path": "jacksboro", "method": "greedy", "max_vertices": 10_100},
         "robots": {"count": n, "spawn_region": region, "min_separation_m": 1.0},
         "sensor": {"range_m": range_m},
         "targets": {"positions": [[cx, cy], [cx + side / 3, cy]]}}
    return scenario_from_dict(d, "bench")


def rate(fn, steps):
    fn()
    t = time.perf_counter()
    for _ in range(steps):
        fn()
    return (time.perf_counter() - t) / steps


def measure(n, steps):
    """Seconds per step: world step + sensing, the batched env path, the dict API."""
    env = tse.parallel_env(scenario=config(n))
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
    env.reset_arrays(seed=0)
    w = env.world
    state = {"s": env.world_state}

    def world_step():
        s, _ = w.step(state["s"], acts)
        w.sense(s)
        state["s"] = s

    dacts = {a: acts[i] for i, a in enumerate(env.possible_agents)}
    t_world = rate(world_step, steps)
    env.reset_arrays(seed=0)
    t_batch = rate(lambda: env.step_arrays(acts), steps)
    env.reset(seed=0)
    t_dict = rate(lambda: env.step({a: dacts[a] for a in env.agents}), steps)
    return t_world, t_batch, t_dict


def main(steps: int):
    print("agent-steps per second (higher is better); the same terrain, density and actions for each path\n")
    print(f"{'robots':>7s} {'world step':>12s} {'batched env':>12s} {'dict API':>12s} {'batched/world':>14s}")
    for n in (100, 1000):
        t_world, t_batch, t_dict = measure(n, steps)
        print(f"{n:7d} {n / t_world:12.3e} {n / t_batch:12.3e} {n / t_dict:12.3e} {t_world / t_batch:14.0%}")

    n = 500
    env = tse.parallel_env(scenario=config(n), render_mode="rgb_array")
    env.reset(seed=0)
    acts = {a: np.zeros(2, np.float32) for a in env.agents}
    t0 = time.perf_counter()
    env.render()
    t_bg = time.perf_counter() - t0
    t_draw = rate(env.render, steps)
    t_step = rate(lambda: env.step(acts), steps)
    print(f"\n500 robots: drawing a frame {t_draw * 1e3:.2f} ms vs a step {t_step * 1e3:.2f} ms "
          f"({t_draw / t_step:.0%} of the step); the terrain background once: {t_bg * 1e3:.0f} ms")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=30)
    main(p.parse_args().steps)
