"""World-step throughput on the real jacksboro DEM. Run by hand:

    python bench/world.py [--short] [--out docs/figures/world.md]
    python bench/world.py --quick       # a smoke run (seconds): tiny sizes, 2 steps; prints only

One world step plus sensing (robots, targets, breaks, with line of sight) on a ~20k-triangle
greedy TIN of jacksboro, robots packed so that about 10 lie within sensor range of each
(``robots seen/robot`` says how many were seen after field of view and line of sight). Prints,
in one process:

1. time per stage at 1 000 and 10 000 robots: move (locomotion walk, battery, collisions),
   neighbours (grid and candidate search, field of view), robots seen (line of sight to robots
   and targets), breaks (break search), observation (the env's encoder), reward (distance to
   go and the reward terms). A stage's time is the marginal cost of switching it on;
2. robot-steps per second (step + sensing) at 100 / 1 000 / 10 000 / 100 000 robots with 1 and
   2 numba threads (``numba.set_num_threads``), and the memory of the 100 000-robot row;
3. how the cost grows with robots (at that density) and with TIN size (at 1 000 robots):
   least-squares exponents of log time against log size.

The tables also go to ``--out`` (default ``docs/figures/world.md``) with the command and the
load average; on a shared machine compare the rows of one run, not runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import resource
import sys
import time

import numba
import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.env.observation import ObsLayout, build_observations
from tin_swarm_env.env.reward import compute_rewards, distance_to_go
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.world import World, WorldParams, spawn_positions
from tin_swarm_env.world.sensing import BreakIndex

NEIGHBOURS_IN_RANGE = 10


def make_state(world, n, rng, neighbours=NEIGHBOURS_IN_RANGE):
    r = world.params.sensor.range_m
    side = math.sqrt(n * math.pi * r * r / neighbours)
    x0, y0, x1, y1 = world.tin.bounds
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    region = (max(cx - side / 2, x0), max(cy - side / 2, y0), min(cx + side / 2, x1), min(cy + side / 2, y1))
    pos = spawn_positions(world.tin, world.steep, n, rng, region=region)
    tg = spawn_positions(world.tin, world.steep, max(1, n // 50), rng, region=region)
    return world.reset(rng, pos, targets=tg, targets_mobile=True)


def time_steps(world, state, steps, rng):
    """(seconds per step + sense, robots seen per robot)."""
    n = state.n_robots
    cmds = rng.uniform(-1, 1, (steps, n, 2))
    world.sense(world.step(state, cmds[0])[0])  # warm-up (compilation, caches)
    s = state
    n_seen = 0
    t = time.perf_counter()
    for k in range(steps):
        s, _ = world.step(s, cmds[k])
        n_seen += len(world.sense(s).robots)
    return (time.perf_counter() - t) / steps, n_seen / steps / n


def best_of(fn, reps):
    fn()
    best = math.inf
    for _ in range(reps):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def no_breaks(world):
    """The same world with no break segments (to time the break search by difference)."""
    w = World(world.tin, world.params)

    class _Empty:
        segments = np.zeros((0, 2, 3))

    w.break_index = BreakIndex(_Empty, piece_m=world.params.sensor.range_m, bounds=world.tin.bounds)
    return w


def stages(tin, n, reps, rng):
    """Marginal seconds per stage at n robots (best of ``reps``)."""
    P = WorldParams()
    full = World(tin, P)
    st = make_state(full, n, rng)
    cmds = rng.uniform(-1, 1, (n, 2))
    nolos = World(tin, dataclasses.replace(P, sensor=dataclasses.replace(P.sensor, check_los=False)))
    bare = no_breaks(nolos)
    bare_los = no_breaks(full)
    cfg = load_scenario("cliff_goal")
    tidx = np.arange(n) % len(st.targets)
    live = np.ones(n, dtype=bool)
    readings = full.sense(st)
    new, ev = full.step(st, cmds)
    d0 = distance_to_go(st, tidx, (None,) * len(st.targets))
    layout = ObsLayout()
    t_move = best_of(lambda: full.step(st, cmds), reps)
    t_nb = best_of(lambda: bare.sense(st), reps)
    t_los = best_of(lambda: bare_los.sense(st), reps)
    t_all = best_of(lambda: full.sense(st), reps)
    t_obs = best_of(lambda: build_observations(full, st, readings, tidx, live, layout), reps)
    t_rew = best_of(lambda: compute_rewards(cfg, d0, distance_to_go(new, tidx, (None,) * len(new.targets)), new, ev,
                                            tidx, live), reps)
    return {"move": t_move, "neighbours": t_nb, "robots seen": max(t_los - t_nb, 0.0),
            "breaks": max(t_all - t_los, 0.0), "observation": t_obs, "reward": t_rew}


def fit_exponent(x, y):
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def nbytes(obj):
    """Bytes of the numpy arrays an object (dataclass, tuple) holds, one level down."""
    total = 0
    for v in (obj.__dict__.values() if hasattr(obj, "__dict__") else obj):
        if isinstance(v, np.ndarray):
            total += v.nbytes
        elif hasattr(v, "__dict__") and not isinstance(v, np.random.Generator):
            total += nbytes(v)
    return total


SIZES = {  # per mode: stage rows' robots, best-of reps, {robots: steps} of the rate rows, TIN sizes and steps
    "full": ((1000, 10_000), 7, {100: 100, 1000: 40, 10_000: 8, 100_000: 3},
             (1300, 2600, 5100, 10_100, 20_100, 40_100), 40),
    "short": ((1000, 10_000), 3, {100: 40, 1000: 15, 10_000: 4, 100_000: 2}, (2600, 10_100, 40_100), 15),
    "quick": ((100,), 1, {100: 2, 1000: 2}, (1300, 2600), 2),
}


def main(mode: str, out: str | None):
    lines = []

    def emit(s=""):
        print(s, flush=True)
        lines.append(s)

    load = os.getloadavg()
    rng = np.random.default_rng(0)
    dem = tse.terrain.sample_dem("jacksboro")
    tin = tse.terrain.build_tin(dem, method="greedy", max_vertices=10_100)
    params = WorldParams()
    world = World(tin, params)
    threads = sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)})
    stage_sizes, reps, steps_for, tin_sizes, tin_steps = SIZES[mode]
    cmd = "python bench/world.py" + ("" if mode == "full" else f" --{mode}")
    emit(f"Measured with `{cmd}` in one run. Load average at start {load[0]:.2f} / {load[1]:.2f} / "
         f"{load[2]:.2f} (1 / 5 / 15 min) on "
         f"{os.cpu_count()} cores; numba {numba.__version__}, threading layer "
         f"{numba.config.THREADING_LAYER}, {numba.config.NUMBA_NUM_THREADS} threads at most. {tin!r}; sensor range "
         f"{params.sensor.range_m} m, fov {params.sensor.fov_deg} deg, line of sight on; {len(world.breaks)} break "
         f"segments; robots packed ~{NEIGHBOURS_IN_RANGE} within range of each.\n")

    emit(f"**Time per stage** (ms per step; a stage's time is the marginal cost of switching it on; "
         f"best of {reps})\n")
    emit("| robots | threads | " + " | ".join(("move", "neighbours", "robots seen", "breaks", "observation", "reward"))
         + " | total | robot-steps/s |")
    emit("|---:|---:|" + "---:|" * 8)
    for n in stage_sizes:
        for k in threads:
            numba.set_num_threads(k)
            t = stages(tin, n, reps if n <= 1000 else max(2, reps // 2), np.random.default_rng(1))
            tot = sum(t.values())
            emit(f"| {n} | {k} | " + " | ".join(f"{v * 1e3:.2f}" for v in t.values())
                 + f" | {tot * 1e3:.2f} | {n / tot:.3e} |")

    emit("\n**Robot-steps per second**, world step + sensing with line of sight\n")
    emit("| robots | " + " | ".join(f"{k} thread{'s' if k > 1 else ''}" for k in threads)
         + " | speed-up | robots seen/robot |")
    emit("|---:|" + "---:|" * (len(threads) + 2))
    times = {}
    mem = ""
    for n, steps in steps_for.items():
        rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        st = make_state(world, n, np.random.default_rng(2))
        row = {}
        for k in threads:
            numba.set_num_threads(k)
            row[k], seen = time_steps(world, st, steps, np.random.default_rng(3))
        times[n] = row
        emit(f"| {n} | " + " | ".join(f"{n / row[k]:.3e}" for k in threads)
             + f" | {row[threads[0]] / row[threads[-1]]:.2f}x | {seen:.1f} |")
        if n == 100_000:
            s1, _ = world.step(st, np.zeros((n, 2)))
            r1 = world.sense(s1)
            rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
            mem = (f"\n100 000 robots: state {nbytes(s1) / 2**20:.1f} MiB, one step's sensor readings "
                   f"{sum(nbytes(getattr(r1, p)) for p in ('robots', 'targets', 'assets', 'breaks')) / 2**20:.1f} MiB; "
                   f"process peak RSS {rss1 / 1024:.0f} MiB ({(rss1 - rss0) / 1024:.0f} MiB more than before the row).")
    emit(mem)
    k = threads[-1]
    numba.set_num_threads(k)
    g = [n for n in times if n <= 10_000]
    emit(f"\n**Growth** ({k} threads)\n")
    emit(f"- cost vs robots at fixed density ({g[0]}..{g[-1]}): time ~ n^"
         f"{fit_exponent(g, [times[n][k] for n in g]):.2f}")
    tri_counts, tri_times = [], []
    for nv in tin_sizes:
        t2 = tse.terrain.build_tin(dem, method="greedy", max_vertices=nv)
        w2 = World(t2, params)
        st = make_state(w2, 1000, np.random.default_rng(1))
        dt, _ = time_steps(w2, st, tin_steps, np.random.default_rng(2))
        tri_counts.append(t2.n_triangles)
        tri_times.append(dt)
        emit(f"  - {t2.n_triangles} triangles, 1000 robots: {dt * 1e3:.2f} ms/step")
    emit(f"- cost vs TIN size at 1000 robots ({tri_counts[0]}..{tri_counts[-1]} triangles): time ~ T^"
         f"{fit_exponent(tri_counts, tri_times):.2f}")
    load = os.getloadavg()
    emit(f"\nLoad average at the end {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}.")
    if out:
        os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
        tmp = out + ".tmp"
        with open(tmp, "w") as f:
            f.write("\n".join(lines) + "\n")
        os.replace(tmp, out)
        print(f"\nwrote {out}", file=sys.stderr)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--short", action="store_true", help="fewer steps and TIN sizes (about a minute; what "
                   "docs/figures/world.md was measured with)")
    p.add_argument("--quick", action="store_true", help="a smoke run (seconds): 100 and 1000 robots, 2 steps, two "
                   "small TINs; prints only")
    p.add_argument("--out", default=None, help="Markdown file for the tables ('' for none; default "
                   "docs/figures/world.md, none with --quick)")
    a = p.parse_args()
    mode = "quick" if a.quick else ("short" if a.short else "full")
    out = a.out if a.out is not None else (None if a.quick else "docs/figures/world.md")
    main(mode, out or None)
