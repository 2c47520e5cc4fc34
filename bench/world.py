"""World-step throughput on the real jacksboro DEM. Run by hand:

    python bench/world.py [--steps 20] [--quick]

Prints robot-steps per second of one world step plus sensing (robots, targets, breaks, with
line of sight) for 100, 1 000 and 10 000 robots on a ~20k-triangle greedy TIN of jacksboro, at
a fixed density (about 10 robots within sensor range of each robot); then how the cost grows
with robots at that density, and with TIN size at 1 000 robots (least-squares exponents of
log time against log size); and the batched sensing against the per-robot reference loop at
100 robots, in the same process; and the memory of one sensing call (tracemalloc peak) at
10 000 robots at that density and packed 10x denser (bounded neighbours per robot keep the
dense one within about the default's).

    python bench/world.py --memory-only      # just the memory figures
"""

from __future__ import annotations

import argparse
import math
import time
import tracemalloc

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.world import World, WorldParams, spawn_positions
from tin_swarm_env.world.reference import reference_sense

NEIGHBOURS_IN_RANGE = 10


def make_state(world, n, rng, neighbours=NEIGHBOURS_IN_RANGE):
    r = world.params.sensor.range_m
    area = n * math.pi * r * r / neighbours
    side = math.sqrt(area)
    x0, y0, x1, y1 = world.tin.bounds
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    region = (cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2)
    pos = spawn_positions(world.tin, world.steep, n, rng, region=region)
    tg = spawn_positions(world.tin, world.steep, max(1, n // 50), rng, region=region)
    return world.reset(rng, pos, targets=tg, targets_mobile=True)


def time_steps(world, state, steps, rng):
    n = state.n_robots
    cmds = rng.uniform(-1, 1, (steps, n, 2))
    world.sense(world.step(state, cmds[0])[0])  # warm-up (compilation, caches)
    t = time.perf_counter()
    s = state
    n_seen = 0
    for k in range(steps):
        s, _ = world.step(s, cmds[k])
        r = world.sense(s)
        n_seen += len(r.robots)
    dt = (time.perf_counter() - t) / steps
    return dt, n_seen / steps / n


def sensing_memory(world, n, neighbours, rng):
    """(tracemalloc peak bytes of one world.sense call, robots seen per robot) at n robots."""
    st = make_state(world, n, rng, neighbours)
    world.sense(st)  # warm-up: compilation and cached indexes are not the call's memory
    tracemalloc.start()
    r = world.sense(st)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak, len(r.robots) / n


def print_memory(world, n=10_000):
    rng = np.random.default_rng(4)
    base, seen0 = sensing_memory(world, n, NEIGHBOURS_IN_RANGE, rng)
    dense, seen1 = sensing_memory(world, n, 10 * NEIGHBOURS_IN_RANGE, rng)
    print(f"\nsensing memory at {n} robots (tracemalloc peak of one sense call):")
    print(f"  default density ({NEIGHBOURS_IN_RANGE} robots in range): {base / 2**20:7.1f} MiB, "
          f"{seen0:.1f} robots seen per robot")
    print(f"  10x denser      ({10 * NEIGHBOURS_IN_RANGE} robots in range): {dense / 2**20:7.1f} MiB, "
          f"{seen1:.1f} robots seen per robot")
    print(f"  dense / default: {dense / base:.2f}x")


def fit_exponent(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main(steps: int, quick: bool, memory_only: bool = False):
    rng = np.random.default_rng(0)
    dem = tse.terrain.sample_dem("jacksboro")
    tin = tse.terrain.build_tin(dem, method="greedy", max_vertices=10_100)
    params = WorldParams()
    world = World(tin, params)
    if memory_only:
        print_memory(world)
        return
    print(f"{tin!r}; sensor range {params.sensor.range_m} m, fov {params.sensor.fov_deg} deg, "
          f"line of sight on; {len(world.breaks)} break segments\n")
    print(f"{'robots':>7s} {'step+sense ms':>14s} {'robot-steps/s':>14s} {'robots seen/robot':>18s}")
    sizes = (100, 1000, 10_000)
    growth = (100, 300, 1000, 3000, 10_000) if not quick else (100, 1000, 3000)
    times = {}
    for n in sorted(set(sizes) | set(growth)):
        st = make_state(world, n, rng)
        dt, seen = time_steps(world, st, steps if n <= 3000 else max(3, steps // 4), rng)
        times[n] = dt
        if n in sizes:
            print(f"{n:7d} {dt * 1e3:14.2f} {n / dt:14.3e} {seen:18.1f}")
    g = list(growth)
    print(f"\ncost vs robots at fixed density ({g[0]}..{g[-1]}): time ~ n^{fit_exponent(g, [times[n] for n in g]):.2f}")

    tri_counts, tri_times = [], []
    for nv in ((1300, 2600, 5100, 10_100, 20_100, 40_100) if not quick else (2600, 10_100, 40_100)):
        t2 = tse.terrain.build_tin(dem, method="greedy", max_vertices=nv)
        w2 = World(t2, params)
        st = make_state(w2, 1000, np.random.default_rng(1))
        dt, _ = time_steps(w2, st, steps, np.random.default_rng(2))
        tri_counts.append(t2.n_triangles)
        tri_times.append(dt)
        print(f"  {t2.n_triangles:6d} triangles, 1000 robots: {dt * 1e3:7.2f} ms/step")
    print(f"cost vs TIN size at 1000 robots ({tri_counts[0]}..{tri_counts[-1]} triangles): "
          f"time ~ T^{fit_exponent(tri_counts, tri_times):.2f}")

    st = make_state(world, 100, np.random.default_rng(3))
    world.sense(st)
    t = time.perf_counter()
    for _ in range(5):
        world.sense(st)
    t_batch = (time.perf_counter() - t) / 5
    t = time.perf_counter()
    reference_sense(world, st)
    t_ref = time.perf_counter() - t
    print(f"\nsensing, 100 robots: batched {t_batch * 1e3:.2f} ms, per-robot reference loop {t_ref * 1e3:.0f} ms "
          f"({t_ref / t_batch:.0f}x)")
    print_memory(world)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--memory-only", action="store_true")
    a = p.parse_args()
    main(a.steps, a.quick, a.memory_only)
