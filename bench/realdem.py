"""The ``realdem`` family (crops of the bundled real DEMs, slopes kept, the robots' slope limit drawn
so that part of the hillside is too steep): time per reset, then APF against the map-knowing
reference on held-out seeds. By hand:

    python bench/realdem.py                 # the full run; writes docs/figures/realdem.md
    python bench/realdem.py --quick         # a smoke run (seconds): 2 resets, 1 seed of 4 robots, 100 steps; prints only
    [--seeds 50] [--robots 20] [--repeats 20] [--jobs 2] [--max-cycles N] [--out FILE]

1. Time per reset (``env.reset_arrays(seed)`` of the built-in ``generated`` scenario restricted to
   ``realdem``, as a whole: drawing the crop, meshing it and placing spawn and target on its
   cost-to-go, the scenario builder's own mesh, world and solvability check, spawning), and the
   family's draw alone (:func:`~tin_swarm_env.scenario.generators.generate`), median and max over
   ``--repeats`` seeds.
2. Policies on ``--seeds`` held-out seeds (``EVAL_SEED0`` on) x ``--robots`` robots, episodes of the
   scenario's length (1 000 steps): the default APF (``APFPolicy(env)`` on the default observation: the
   chart search reading the 32-beam terrain scan), APF with the bug search (``search="bug"``, the default
   before, a weaker baseline) and :class:`~tin_swarm_env.policies.GeodesicPolicy`
   (knows the map: the reference, not a baseline). Arrived, fell and timed out are shares of every
   robot; median steps is over the robots that arrived. Every episode runs through
   :func:`~tin_swarm_env.training.rollout.rollout`.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.policies import APFPolicy, GeodesicPolicy
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.scenario.generators import generate
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
K_SCAN = 32
POLICIES = {  # name -> (k_scan of its env, policy factory)
    f"apf (default: chart search, {K_SCAN}-beam scan)": (K_SCAN, lambda env: APFPolicy(env)),
    "apf, bug search": (K_SCAN, lambda env: APFPolicy(env, search="bug")),
    "geodesic (knows the map)": (None, lambda env: GeodesicPolicy(env)),
}
QUICK = {"repeats": 2, "seeds": 1, "robots": 4, "max_cycles": 100}


def make_env(robots: int | None, k_scan: int | None = None, max_cycles: int | None = None):
    """The built-in ``generated`` scenario restricted to ``realdem`` (``k_scan``: its ``[observation]
    k_scan``, None: the default)."""
    cfg = load_scenario("generated").with_families(("realdem",))
    if k_scan is not None:
        cfg = cfg.replace(observation=dataclasses.replace(cfg.observation, k_scan=k_scan))
    return tse.parallel_env(scenario=cfg, n_robots=robots, max_cycles=max_cycles)


def reset_times(repeats: int, emit):
    env = make_env(20)
    env.reset_arrays(seed=EVAL_SEED0 - 1)  # loads the DEMs, compiles what the first reset compiles
    draw, whole = [], []
    for seed in range(repeats):
        t = time.perf_counter()
        generate(np.random.default_rng(seed), ("realdem",))
        draw.append(1000 * (time.perf_counter() - t))
        t = time.perf_counter()
        env.reset_arrays(seed=seed)
        whole.append(1000 * (time.perf_counter() - t))
    emit(f"Time per reset, {repeats} seeds, ms (median / max): the family's draw (crop, mesh, slope limit, "
         f"spawn and target on the cost-to-go) {np.median(draw):.1f} / {np.max(draw):.1f}; "
         f"`env.reset_arrays` as a whole (the draw, the builder's mesh, world and check, spawning) "
         f"{np.median(whole):.1f} / {np.max(whole):.1f}.\n")


def _episode(job):
    """One episode ``(policy name, seed, robots, max_cycles) -> (reasons, steps)`` in a fresh env."""
    name, seed, robots, max_cycles = job
    k_scan, make = POLICIES[name]
    env = make_env(robots, k_scan, max_cycles)
    out = rollout(env, make(env), seed)
    return out.reasons, out.steps


def policy_rows(seeds: int, robots: int, max_cycles: int | None, pool, emit):
    """The policies' table; ``pool``: a process pool forked before this process used the compiled
    kernels' threads (None: one process)."""
    emit(f"{seeds} held-out seeds (from {EVAL_SEED0}) x {robots} robots, episodes of "
         f"{max_cycles or 'the scenario length,'} {'steps' if max_cycles else '1 000 steps'}; s: seconds per row.\n")
    emit("| policy | seeds x robots | arrived | fell | timed out | median steps (arrived) | s |")
    emit("|---|---:|---:|---:|---:|---:|---:|")
    for name in POLICIES:
        t = time.perf_counter()
        jobs = [(name, EVAL_SEED0 + s, robots, max_cycles) for s in range(seeds)]
        outs = pool.map(_episode, jobs, chunksize=1) if pool else [_episode(j) for j in jobs]
        reasons = np.concatenate([r for r, _ in outs])
        steps = np.concatenate([s for _, s in outs])
        got = reasons == Reason.ARRIVED
        med = f"{np.median(steps[got]):.0f}" if got.any() else "-"
        emit(f"| {name} | {seeds} x {robots} | {got.mean():.1%} | {np.mean(reasons == Reason.FELL):.1%} | "
             f"{np.mean(reasons == Reason.TIMEOUT):.1%} | {med} | {time.perf_counter() - t:.0f} |")


def _header(argv) -> str:
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                            check=False).stdout.strip() or "?"
    load = " / ".join(f"{v:.2f}" for v in os.getloadavg())
    cmd = shlex.join(["python", "bench/realdem.py", *argv])  # quoted: the line can be run as it stands
    return (f"Measured with `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"load average {load} at the start (2 cores, shared).")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=50)
    p.add_argument("--robots", type=int, default=20)
    p.add_argument("--repeats", type=int, default=20)
    p.add_argument("--max-cycles", type=int, default=None)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--quick", action="store_true", help=f"a smoke run ({QUICK}); prints only, unless --out is given")
    p.add_argument("--out", default=None, help="the page to write (default docs/figures/realdem.md; --quick: none)")
    a = p.parse_args(argv)
    if a.quick:
        a.repeats, a.seeds, a.robots, a.max_cycles = (QUICK[k] for k in ("repeats", "seeds", "robots", "max_cycles"))
    out = a.out if a.out is not None else (None if a.quick else str(ROOT / "docs" / "figures" / "realdem.md"))
    lines = []

    def emit(s):
        print(s, flush=True)
        lines.append(s)

    pool = None
    if a.jobs > 1:  # forked first: a process forked after the compiled kernels ran their threads dies
        import multiprocessing

        pool = multiprocessing.get_context("fork").Pool(a.jobs)
    try:
        emit(_header(argv) + "\n")
        reset_times(a.repeats, emit)
        policy_rows(a.seeds, a.robots, a.max_cycles, pool, emit)
    finally:
        if pool is not None:
            pool.close()
            pool.join()
    if out:
        tmp = Path(out).with_suffix(".md.tmp")
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(out)  # whole file or nothing


if __name__ == "__main__":
    main()
