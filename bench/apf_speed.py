"""APF's speed with the env: robot-steps per second of the policy's ``act_batch`` plus the env's
``step_arrays`` on jacksboro (its 200 robots, observations with the terrain scan's 32 beams), as a
ratio to the env alone in the same process. By hand:

    python bench/apf_speed.py                # jacksboro, 900 steps (an episode); prints the table
    python bench/apf_speed.py --quick        # a smoke run (seconds): 20 robots, 30 steps; prints only
    [--steps 900] [--seed 0] [--k-scan 32] [--repeats 3] [--out docs/figures/apf_speed.md]

Rows: the chart search (``APFPolicy(env, search="chart")``) at the default
:class:`~tin_swarm_env.policies.chart.ChartParams` (512 cells, ``unseen_gap = 1``: narrow gaps left out unless
seen through, every scan beam marks the cells it passes over), at 256 cells and with ``unseen_gap = 0`` (the
default before: no beam marks), and the bug search (``search="bug"``). Each run is one episode from the same
reset with a fresh policy, its actions recorded; the env alone then replays those actions from the same reset,
so it drives the same trajectory (the same robots live, arriving, colliding) with no policy. Each the best of
``--repeats`` runs, interleaved. Robot-steps count every row ``step_arrays`` takes (robots x steps, as
``bench/env.py`` counts agent-steps); the live share says how many of them were robots still in the episode. For
the chart search also the A* runs per live robot-step (``ChartMemory.plans``: it plans again only when its way
may no longer be least-cost, the :mod:`tin_swarm_env.policies.apf` docstring's rule).
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import os
import sys
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.chart import ChartParams
from tin_swarm_env.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
POLICIES = {
    "chart search, 512 cells (default ChartParams)": lambda env: APFPolicy(env, search="chart"),
    "chart search, 256 cells": lambda env: APFPolicy(env, search="chart", chart=ChartParams(cells=256)),
    "chart search, unseen_gap = 0 (the default before)":
        lambda env: APFPolicy(env, search="chart", chart=ChartParams(unseen_gap=0.0)),
    "bug search": lambda env: APFPolicy(env, search="bug"),
}
QUICK = {"robots": 20, "steps": 30, "repeats": 1}


def jacksboro(k_scan: int, robots: int | None = None):
    """The jacksboro scenario with ``[observation] k_scan`` beams (``robots``: its count, default its own)."""
    cfg = load_scenario("jacksboro")
    cfg = cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=k_scan))
    return tse.parallel_env(scenario=cfg, n_robots=robots)


def with_policy(env, make, steps: int, seed: int):
    """One episode of ``steps`` steps under a fresh policy: ``(seconds, actions, live robot-steps, policy)``."""
    pol = make(env)
    obs = env.reset_arrays(seed)
    acts, live = [], 0
    gc.collect()
    t = time.perf_counter()
    for _ in range(steps):
        live += int(env.live_mask.sum())
        a = pol.act_batch(obs)
        obs = env.step_arrays(a)[0]
        acts.append(a)
    return time.perf_counter() - t, acts, live, pol


def env_alone(env, acts, seed: int) -> float:
    """Seconds the env takes to replay ``acts`` from the same reset (the same trajectory, no policy)."""
    env.reset_arrays(seed)
    gc.collect()
    t = time.perf_counter()
    for a in acts:
        env.step_arrays(a)
    return time.perf_counter() - t


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=None, help="steps per run (default: the scenario's max_cycles, 900)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--k-scan", type=int, default=32, help="the terrain scan's beams ([observation] k_scan)")
    p.add_argument("--repeats", type=int, default=3, help="runs of each row, interleaved; the best counts")
    p.add_argument("--robots", type=int, default=None, help="robots (default: the scenario's 200)")
    p.add_argument("--quick", action="store_true", help=f"a smoke run ({QUICK}); prints only")
    p.add_argument("--out", default=None, help="also write the table to this Markdown file")
    args = p.parse_args(argv)
    if args.quick:
        for k, v in QUICK.items():
            setattr(args, k, v if getattr(args, k) is None or k == "repeats" else min(getattr(args, k), v))
    env = jacksboro(args.k_scan, args.robots)
    steps = min(args.steps or env.max_cycles, env.max_cycles)
    lines = []

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    emit(f"Measured with `python bench/apf_speed.py {' '.join(argv)}`, load average "
         f"{' / '.join(f'{x:.2f}' for x in os.getloadavg())} at the start ({os.cpu_count()} cores, shared).")
    emit(f"\njacksboro, {env.n} robots, k_scan = {args.k_scan}, {steps} steps from reset seed {args.seed}; "
         f"each the best of {args.repeats} (interleaved); robot-steps = robots x steps\n")
    emit("| policy | robot-steps/s, policy + env | env alone, same actions | with / alone | live share "
         "| A* runs per live robot-step |")
    emit("|---|---:|---:|---:|---:|---:|")
    best = {name: [np.inf, np.inf, 0, None] for name in POLICIES}
    for _ in range(args.repeats):
        for name, make in POLICIES.items():
            t_pol, acts, live, pol = with_policy(env, make, steps, args.seed)
            t_env = env_alone(env, acts, args.seed)
            b = best[name]
            b[0], b[1], b[2], b[3] = min(b[0], t_pol), min(b[1], t_env), live, pol
    for name, (t_pol, t_env, live, pol) in best.items():
        rs = env.n * steps
        plans = f"{pol.charts.plans.sum() / max(live, 1):.4f}" if pol.search == "chart" else ""
        emit(f"| {name} | {rs / t_pol:.3g} | {rs / t_env:.3g} | {t_env / t_pol:.1%} | {live / rs:.0%} | {plans} |")
    emit(f"\nLoad average at the end: {' / '.join(f'{x:.2f}' for x in os.getloadavg())}.")
    if args.out:
        with atomic_path(args.out) as tmp:  # the whole file or nothing
            Path(tmp).write_text("\n".join(lines) + "\n")
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
