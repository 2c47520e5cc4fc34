"""Generated terrains in the env: time per reset and the APF / random baselines. Run by hand:

    nice -n 10 python bench/generated.py [--seeds 50] [--robots 20] [--repeats 20]
    python bench/generated.py --quick      # a smoke run (seconds): 1 reset, 1 episode of 4 robots, 100 steps

1. Time per reset on a 200 x 200 grid (398 m at 2 m cells, every family): terrain generation,
   greedy meshing (``max_error_m=0.5``), world build (breaks and their index) and the cost-to-go
   field, each measured on its own, then ``env.reset_arrays(seed)`` as a whole (which also checks
   solvability and spawns the robots), against the issue's target of 200 ms.
2. The built-in ``generated`` scenario (all families, resample on every reset) on seeds
   0..N-1 with the APF baseline and the random policy, through ``apps.rollout.rollout``: the
   share of robots that arrived, fell and timed out, and the mean step of arrival.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.generators import ALL_FAMILIES, generate
from tin_swarm_env.terrain import build_tin, cost_to_go
from tin_swarm_env.training.policy_factory import make_policy
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world import Reason, World

TARGET_MS = 200.0
GRID_200 = {"size_m": [398.0, 398.0], "cell_m": [2.0, 2.0]}  # 200 x 200 cells


def reset_times(repeats: int):
    cfg = load_scenario("generated")
    ranges = {fam: GRID_200 for fam in ALL_FAMILIES}
    parts = {"generate": [], "mesh": [], "world": [], "cost_to_go": []}
    for seed in range(repeats):
        t0 = time.perf_counter()
        task = generate(np.random.default_rng(seed), ranges=ranges)
        t1 = time.perf_counter()
        tin = build_tin(task.dem, method="greedy", max_error_m=0.5)
        t2 = time.perf_counter()
        world = World(tin, cfg.world)
        t3 = time.perf_counter()
        cost_to_go(tin, task.targets[0], ~world.steep)
        t4 = time.perf_counter()
        for k, dt in zip(parts, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
            parts[k].append(1000 * dt)
    cfg = cfg.replace(terrain=dataclasses.replace(cfg.terrain, ranges=ranges))
    env = tse.parallel_env(scenario=cfg, n_robots=20)
    whole = []
    for seed in range(repeats):
        t = time.perf_counter()
        env.reset_arrays(seed=seed)
        whole.append(1000 * (time.perf_counter() - t))
    print(f"time per reset on a 200 x 200 grid, {repeats} seeds, ms (median / max):")
    for k, v in {**parts, "env.reset_arrays (all of it)": whole}.items():
        print(f"  {k:30s} {np.median(v):7.1f} / {np.max(v):7.1f}")
    print(f"  target {TARGET_MS:.0f} ms per reset: {'met' if np.median(whole) <= TARGET_MS else 'NOT met'}")


def baselines(seeds: int, robots: int, max_cycles: int | None = None):
    env = tse.parallel_env(scenario="generated", n_robots=robots, max_cycles=max_cycles)
    print(f"\n`generated`, {seeds} seeds x {robots} robots, max_cycles {env.max_cycles}:")
    print("| policy | arrived | fell | timed out | mean arrival step | s/episode |")
    print("|---|---|---|---|---|---|")
    for name in ("apf", "random"):
        pol = make_policy(env, name, seed=0)
        outs = [rollout(env, pol, seed) for seed in range(seeds)]
        reasons = np.concatenate([o.reasons for o in outs])
        steps = np.concatenate([o.steps for o in outs])
        share = {r: np.mean(reasons == r) for r in (Reason.ARRIVED, Reason.FELL, Reason.TIMEOUT)}
        got = reasons == Reason.ARRIVED
        mean_step = f"{steps[got].mean():.0f}" if got.any() else "-"
        secs = np.mean([o.seconds for o in outs])
        print(f"| {name} | {share[Reason.ARRIVED]:.0%} | {share[Reason.FELL]:.0%} | {share[Reason.TIMEOUT]:.0%} "
              f"| {mean_step} | {secs:.1f} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--robots", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--quick", action="store_true",
                    help="a smoke run (seconds): 1 reset, 1 seed of 4 robots and 100 steps")
    a = ap.parse_args()
    if a.quick:
        a.repeats, a.seeds, a.robots = 1, 1, 4
    reset_times(a.repeats)
    if a.seeds:
        baselines(a.seeds, a.robots, 100 if a.quick else None)


if __name__ == "__main__":
    main()
