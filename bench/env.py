"""Environment throughput on the jacksboro DEM. Run by hand:

    python bench/env.py [--steps 30] [--processes 12] [--out docs/figures/env.md]
    python bench/env.py --scan 32 [--out docs/figures/env_scan.md]
    python bench/env.py --quick      # a smoke run of every path (seconds): 100 robots, 2 steps, an 8-beam scan;
                                     # prints only

For 100, 1 000 and 10 000 robots, in one process and on the same terrain and density, with 1
and 2 numba threads: the world step alone (step + sensing), the env's batched array path
(``step_arrays``: world + observations + rewards), and the PettingZoo dict API (``step`` with
per-agent dicts), as agent-steps per second; the API's overhead is the difference. Then the
time to draw a 500-robot frame (``rgb_array``, terrain background already drawn) against the
step time of 500 robots. Each path: ``--steps`` steps after a warm-up step and a full garbage
collection, the best of three runs interleaved with the other paths'. The table also goes to
``--out`` with the command and load average.

A ratio from one process moves by a point or two from process to process (where the kernels'
arrays land, which core each thread gets), so the batched/world ratio at 1 000 robots on two
threads is then measured again in ``--processes`` fresh processes, one after another (each: the
world step and the batched path only, interleaved, the best of 5 runs of ``--steps`` steps), and
its spread reported (min, median, max, and how many runs fell below 80%).

``--scan K`` measures instead what the observation's terrain scan (``[observation] k_scan``,
:mod:`tin_swarm_env.env.observation`) costs: the batched path with ``K`` beams against the same
scenario without them, at 1 000 and 10 000 robots on the numba threads there are (at most 2),
interleaved, each the best of ``REPEATS`` runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import math
import os
import statistics
import subprocess
import sys
import time

import numba

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.scenario import scenario_from_dict


REPEATS = 3  # each path measured this many times (interleaved with the others); the best counts


def config(n, range_m=60.0, k_scan=0):
    dem = tse.terrain.sample_dem("jacksboro")
    cx, cy = dem.x[-1] / 2, dem.y[-1] / 2
    side = math.sqrt(n * math.pi * range_m ** 2 / 10)  # ~10 robots within range of each
    region = [cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2]
    d = {"name": f"bench_{n}", "task": "goal", "max_cycles": 10_000,
         "terrain": {"source": "sample", "path": "jacksboro", "method": "greedy", "max_vertices": 10_100},
         "robots": {"count": n, "spawn_region": region, "min_separation_m": 1.0},
         "sensor": {"range_m": range_m},
         "observation": {"k_scan": k_scan},
         "targets": {"positions": [[cx, cy], [cx + side / 3, cy]]}}
    return scenario_from_dict(d, "bench")


def rate(fn, steps):
    """Seconds per call of ``fn`` over ``steps`` calls after one warm-up call, with a full garbage
    collection before the clock starts (as ``timeit`` does: the one-time collection of what the
    reset left would otherwise land in one path's window)."""
    fn()
    gc.collect()
    t = time.perf_counter()
    for _ in range(steps):
        fn()
    return (time.perf_counter() - t) / steps


def world_step(env, acts):
    """One world step + sensing from the env's state (not the env's own step): a closure that
    carries the state from call to call, starting at the env's current state."""
    w, state = env.world, {"s": env.world_state}

    def step():
        s, _ = w.step(state["s"], acts)
        w.sense(s)
        state["s"] = s

    return step


def world_and_batched(env, acts, steps):
    """Seconds per step of the world step and of ``step_arrays``, each from the same reset."""
    env.reset_arrays(seed=0)
    t_world = rate(world_step(env, acts), steps)
    env.reset_arrays(seed=0)
    return t_world, rate(lambda: env.step_arrays(acts), steps)


def measure(n, steps, threads):
    """Per numba thread count: seconds per step of world step + sensing, the batched env
    path, the dict API."""
    env = tse.parallel_env(scenario=config(n))
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (n, 2)).astype(np.float32)
    dacts = {a: acts[i] for i, a in enumerate(env.possible_agents)}
    out = {}
    for k in threads:
        numba.set_num_threads(k)
        best = [np.inf] * 3
        for _ in range(REPEATS):  # the three paths in turn, each from the same reset; best of REPEATS
            t_world, t_batch = world_and_batched(env, acts, steps)
            env.reset(seed=0)
            t_dict = rate(lambda: env.step({a: dacts[a] for a in env.agents}), steps)
            best = [min(b, t) for b, t in zip(best, (t_world, t_batch, t_dict))]
        out[k] = tuple(best)
    return out


def ratio(n: int, steps: int, repeats: int = 5) -> tuple[float, float]:
    """Seconds per step of the world step and the batched path at ``n`` robots on two threads:
    interleaved, each the best of ``repeats`` runs from the same reset."""
    env = tse.parallel_env(scenario=config(n))
    acts = np.random.default_rng(0).uniform(-1, 1, (n, 2)).astype(np.float32)
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    best = [np.inf, np.inf]
    for _ in range(repeats):
        best = [min(b, t) for b, t in zip(best, world_and_batched(env, acts, steps))]
    return best[0], best[1]


def spread(processes: int, steps: int, n: int = 1000) -> list[float]:
    """batched/world at ``n`` robots on two threads, once per fresh process (``--ratio``)."""
    got = []
    for _ in range(processes):
        r = subprocess.run([sys.executable, __file__, "--ratio", str(n), "--steps", str(steps)], capture_output=True,
                           text=True, check=True)
        got.append(float(r.stdout.split()[-1]))
    return got


def _finish(emit, lines, out):
    """The closing load-average line, then the table to ``out`` (written whole, then renamed)."""
    load = os.getloadavg()
    emit(f"\nLoad average at the end {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f}.")
    if out:
        os.makedirs(os.path.dirname(out) or ".", exist_ok=True)
        with open(out + ".tmp", "w") as f:
            f.write("\n".join(lines) + "\n")
        os.replace(out + ".tmp", out)
        print(f"wrote {out}", file=sys.stderr)


def scan_cost(k_scan: int, steps: int, out: str | None, sizes=(1000, 10_000)):
    """``--scan``: agent-steps per second of the batched path with and without ``k_scan`` beams."""
    lines = []

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    load = os.getloadavg()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    emit(f"Measured with `python bench/env.py --scan {k_scan} --steps {steps}` in one run. Load average at start "
         f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores, "
         f"{numba.get_num_threads()} numba threads. The batched env path (`step_arrays`) on the scenario of the "
         f"table above, with and without a terrain scan of {k_scan} beams: agent-steps per second, each the best of "
         f"{REPEATS} interleaved runs of {steps} steps (10 000 robots: {max(3, steps // 5)}) from the same reset.\n")
    emit("A beam costs nothing to a robot that senses no dangerous break (it reads 1 without its "
         "trigonometry), so the rows at lower robots' slope limits, where more of the ground is too steep, "
         "say what the scan costs where robots see breaks (`seeing`: robots with a beam short of its range "
         "after the timed steps).\n")
    emit(f"| robots | max slope | seeing | without the scan | with {k_scan} beams | with / without |")
    emit("|---:|---:|---:|---:|---:|---:|")
    for n in sizes:
        st = steps if n <= 1000 else max(3, steps // 5)
        for slope in ((None, 20.0, 18.0) if n <= 1000 else (None,)):
            envs = [tse.parallel_env(scenario=_with_slope(config(n, k_scan=k), slope)) for k in (0, k_scan)]
            acts = np.random.default_rng(0).uniform(-1, 1, (n, 2)).astype(np.float32)
            best = [np.inf, np.inf]
            for _ in range(REPEATS):
                for j, env in enumerate(envs):
                    env.reset_arrays(seed=0)
                    best[j] = min(best[j], rate(lambda env=env, acts=acts: env.step_arrays(acts), st))
            obs = envs[1].step_arrays(acts)[0]
            seeing = (obs[:, envs[1].layout.scan] < 1).any(axis=1).mean()
            lim = envs[1].world.params.robot.max_slope_deg
            emit(f"| {n} | {lim:g} deg | {seeing:.0%} | {n / best[0]:.3e} | {n / best[1]:.3e} | "
                 f"{best[0] / best[1]:.0%} |")
    _finish(emit, lines, out)


def _with_slope(cfg, slope):
    """``cfg`` with the robots' ``max_slope_deg`` set to ``slope`` (None: as it is)."""
    if slope is None:
        return cfg
    w = cfg.world
    return cfg.replace(world=dataclasses.replace(w, robot=dataclasses.replace(w.robot, max_slope_deg=slope)))


QUICK = {"sizes": (100,), "steps": 2, "render_robots": 50, "scan": 8}  # --quick: every path once (seconds)


def main(steps: int, out: str | None, processes: int = 0, sizes=(100, 1000, 10_000), render_robots: int = 500,
         quick: bool = False):
    lines = []

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    load = os.getloadavg()
    threads = sorted({1, min(2, numba.config.NUMBA_NUM_THREADS)})
    emit(f"Measured with `python bench/env.py --steps {steps} --processes {processes}{' --quick' if quick else ''}` "
         "in one run. Load average at "
         f"start {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores. "
         "Agent-steps per second (higher is better); the same terrain (jacksboro, ~20k triangles), density "
         "(~10 robots within the 60 m range) and actions for each path; each path's best of "
         f"{REPEATS} runs of {steps} steps (10 000 robots: {max(3, steps // 5)}), interleaved, each run after a "
         "warm-up step and a full garbage collection.\n")
    emit("| robots | threads | world step | batched env | dict API | batched/world | dict/batched |")
    emit("|---:|---:|---:|---:|---:|---:|---:|")
    for n in sizes:
        res = measure(n, steps if n <= 1000 else max(3, steps // 5), threads)
        for k in threads:
            t_world, t_batch, t_dict = res[k]
            emit(f"| {n} | {k} | {n / t_world:.3e} | {n / t_batch:.3e} | {n / t_dict:.3e} | "
                 f"{t_world / t_batch:.0%} | {t_batch / t_dict:.0%} |")

    if processes and threads[-1] == 2:
        got = sorted(spread(processes, steps))
        below = sum(g < 0.8 for g in got)
        emit(f"\nbatched/world at 1000 robots, 2 threads, in {processes} fresh processes one after another "
             f"(`--processes {processes}`): min {got[0]:.1%}, median {statistics.median(got):.1%}, "
             f"max {got[-1]:.1%}; {below} of {processes} below 80%.")

    numba.set_num_threads(threads[-1])
    n = render_robots
    env = tse.parallel_env(scenario=config(n), render_mode="rgb_array")
    env.reset(seed=0)
    acts = {a: np.zeros(2, np.float32) for a in env.agents}
    t0 = time.perf_counter()
    env.render()
    t_bg = time.perf_counter() - t0
    t_draw = rate(env.render, steps)
    t_step = rate(lambda: env.step(acts), steps)
    emit(f"\n{n} robots: drawing a frame {t_draw * 1e3:.2f} ms vs a step {t_step * 1e3:.2f} ms "
         f"({t_draw / t_step:.0%} of the step); the terrain background once: {t_bg * 1e3:.0f} ms")
    _finish(emit, lines, out)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=30)
    p.add_argument("--processes", type=int, default=12,
                   help="fresh processes measuring batched/world at 1 000 robots on 2 threads (0: none)")
    p.add_argument("--ratio", type=int, default=0, metavar="N",
                   help="(used by --processes) print batched/world at N robots on 2 threads and exit")
    p.add_argument("--scan", type=int, default=0, metavar="K",
                   help="measure instead the batched path with a K-beam terrain scan against without (K >= 1)")
    p.add_argument("--out", default=None, help="Markdown file for the table ('' for none; default "
                   "docs/figures/env.md, with --scan docs/figures/env_scan.md)")
    p.add_argument("--quick", action="store_true",
                   help=f"a smoke run of every path, printed only (seconds): {QUICK}, no fresh processes")
    a = p.parse_args()
    if a.quick:
        main(QUICK["steps"], None, 0, QUICK["sizes"], QUICK["render_robots"], quick=True)
        scan_cost(QUICK["scan"], QUICK["steps"], None, QUICK["sizes"])
        sys.exit(0)
    if a.scan < 0 or a.steps < 1:
        p.error(f"--scan must be >= 0 and --steps >= 1, got {a.scan} and {a.steps}")
    if a.out is None:
        a.out = "docs/figures/env_scan.md" if a.scan else "docs/figures/env.md"
    if a.scan:
        scan_cost(a.scan, a.steps, a.out or None)
    elif a.ratio:
        t_world, t_batch = ratio(a.ratio, a.steps)
        print(f"{t_world:.6e} {t_batch:.6e} {t_world / t_batch:.6f}")
    else:
        main(a.steps, a.out or None, a.processes)
