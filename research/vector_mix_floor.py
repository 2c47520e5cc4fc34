"""How fast can the generated mix step? The raw vector env on the mix against its own floors.

Issue #43 asks the raw vector env for >= 5e5 robot-steps/s on the generated mix (and >= 1e6 on
jacksboro). This study measures, in one process, the raw vector env on jacksboro and on the mix at the
issue's sizes, then the mix again with parts of its sensing switched off, as floors: with no break
sensing at all (every break grid emptied: no contact, no scan), with no line of sight (the terrain blocks
nothing), and with neither. A floor is not an env anyone may ship (its observations differ); it says how
fast the mix could step if that part cost nothing. What each robot senses on each terrain, the workload
that sets these rates, is ``bench/vector_load.py``'s table (``docs/figures/vector_load.md``).

    python research/vector_mix_floor.py [--steps 20] [--rounds 7] [--out research/vector_mix_floor.md]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import time

import numpy as np

import tin_swarm_env as tse
import tin_swarm_env.env.vector as V
from tin_swarm_env.world.pack import frozen

ROWS = (("jacksboro", 1024, 4), ("jacksboro", 256, 16), ("generated", 1024, 4), ("generated", 256, 16))
FLOORS = {"full": (True, True), "no break sensing": (False, True), "no line of sight": (True, False),
          "no breaks, no line of sight": (False, False)}  # (breaks, line of sight)
REF = ("jacksboro", 256, 16)  # the row the others are given against, round by round


class _NoBreaks:
    """A pack seen through a sensing pass with no break segment: every break-grid cell and world empty (read-only,
    as every pack array: the same compiled pass, not a second one for writable arrays)."""

    def __init__(self, pack):
        self.T0, self.margin, self.OB = pack.T0, pack.margin, pack.OB
        B = list(pack.B)
        B[9] = frozen(np.zeros_like(B[9]))  # gstart: every cell lists no segment
        B[12] = frozen(np.zeros_like(B[12]))  # brk_off: no world has a segment (the points off the grid)
        self.B = tuple(B)


def _sense_without(breaks: bool, los: bool):
    """``vector.sense_copies`` with break sensing and/or line of sight switched off."""
    real = V.sense_copies

    def sense(pack, *a, **k):
        a = list(a)
        if not breaks:
            pack = _NoBreaks(pack)
        if not los:
            P = a[9]  # (wor, cop, off, px, py, head, tri, heights, status, params, ...)
            a[9] = dataclasses.replace(P, sensor=dataclasses.replace(P.sensor, check_los=False))
        return real(pack, *a, **k)

    return real, sense


def timed_run(env, steps: int, rng, breaks: bool = True, los: bool = True) -> tuple[float, int]:
    """``(seconds, copies reset)`` of ``steps`` random steps of ``env`` with the sensing parts given."""
    E, N = env.n_envs, env.n_robots
    acts = rng.uniform(-1, 1, (steps, E, N, 2))
    real, patched = _sense_without(breaks, los)
    V.sense_copies = real if breaks and los else patched
    try:
        env.step(acts[0])
        resets = 0
        t = time.perf_counter()
        for s in range(steps):
            resets += int(env.step(acts[s])[4]["_final"].sum())
        return time.perf_counter() - t, resets
    finally:
        V.sense_copies = real


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=20, help="steps per timed run")
    ap.add_argument("--rounds", type=int, default=7, help="timed runs of each row, taken in turn")
    ap.add_argument("--out", default="research/vector_mix_floor.md", help="write the tables here (Markdown)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    rng = np.random.default_rng(0)
    envs = {}
    for scen, E, N in ROWS:
        envs[scen, E, N] = tse.vector_env(scen, n_envs=E, n_robots=N, seed=0)
        envs[scen, E, N].reset()
    runs = [(key, name, *parts) for key in envs
            for name, parts in (FLOORS.items() if key[0] == "generated" else [("full", FLOORS["full"])])]
    secs = {r[:2]: [] for r in runs}
    resets = {r[:2]: 0 for r in runs}
    for _ in range(args.rounds):  # every run once a round: a drift of the host's speed falls on all of them
        for key, name, breaks, los in runs:
            t, k = timed_run(envs[key], args.steps, rng, breaks, los)
            secs[key, name].append(t)
            resets[key, name] += k
    ref = np.array(secs[REF, "full"])
    lines = []
    for (key, name), t in secs.items():
        E, N = key[1], key[2]
        t = np.array(t)
        lines.append(f"| {key[0]} | {E} x {N} | {name} | {E * N * args.steps / t.min():.3g} | "
                     f"{E * N * args.steps / np.median(t):.3g} | {100 * np.median(ref / t):.0f}% | "
                     f"{resets[key, name] / (args.rounds * args.steps):.2f} |")
        print(lines[-1], flush=True)
    out = [f"Measured at commit {_commit()}, with `python research/vector_mix_floor.py --steps {args.steps} "
           f"--rounds {args.rounds}` in one process (each row timed once a round, in turn), 2 numba threads, "
           f"load average at the start {load0[0]:.2f} / {load0[1]:.2f} / {load0[2]:.2f}, at the end "
           "{:.2f} / {:.2f} / {:.2f}.".format(*os.getloadavg()), "",
           "**Raw vector env, robot-steps/s** (random actions; a floor switches a part of the sensing off, so its "
           "observations are not the env's; against jacksboro 256 x 16: the median over the rounds of the rate "
           "ratio within a round)", "",
           "| scenario | E x N | sensing | best | median | against jacksboro 256 x 16 | copies reset per step |",
           "|---|---|---|---:|---:|---:|---:|",
           *lines, "", "What a robot senses on each terrain (the workload behind these rates): "
           "`docs/figures/vector_load.md` (`bench/vector_load.py`)."]
    with open(args.out, "w") as f:
        f.write("\n".join(out) + "\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
