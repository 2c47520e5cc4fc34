"""What each robot senses, per terrain, beside the raw vector env's rate: why the generated mix steps slower
than jacksboro. Run by hand:

    python bench/vector_load.py [--size 256x16] [--episodes 16] [--steps 20] [--out docs/figures/vector_load.md]
    python bench/vector_load.py --quick      # a smoke run (seconds); prints only

Rows: jacksboro, each synthetic generated family alone (``generated`` restricted to it, as
``bench/apf.py`` builds it) and the generated mix. Per row, in one process:

* the sensing load per live robot, from ``--episodes`` single envs of N robots (their seeds from 0),
  each reset and stepped ``LOAD_STEPS`` steps with uniform random actions, then sensed
  (``World.sense``): the robots it has in range, in view and in sight (its robot contacts), the break segments
  within range (mean and 90th percentile over the robots) and the dangerous ones among them (not a
  mere angle break: what the terrain scan's beams stop at);
* the raw vector env at E x N (``tse.vector_env``, seed 0; one uniform random action per robot, the same
  every step): robot-steps per
  second, the best of ``REPEATS`` runs of ``--steps`` steps after two warm-up steps (the rows' runs taken
  in turn, round after round), and the share of that step spent in sensing (``sense_copies``, timed by
  wrapping the vector env's reference to it).

Each copy has N robots placed as its scenario places them: a generated family spawns them in a square of
22-30 m a side, so with its 60 m sensor each robot has nearly all of its copy's robots in range; jacksboro
spawns its robots over its 1 km spawn square (150 m sensor), so N = 16 of them are far apart. Each break
contact costs a closest-point test, a keep-the-nearest insertion and, when dangerous, a crossing with
the scan's beams; each robot contact in view costs a line-of-sight walk over the TIN.
"""

from __future__ import annotations

import argparse
import gc
import os
import time

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.env import vector as vector_mod
from tin_swarm_env.terrain.breaks import ANGLE

ROWS = ("jacksboro", "canyon", "mesa", "hills", "fork", "trap", "generated")  # generated: the mix
REPEATS = 3
LOAD_STEPS = 10
QUICK = {"size": (4, 4), "episodes": 1, "steps": 2, "rows": ("jacksboro", "trap")}


def scenario_of(row: str):
    """The scenario of a row: a built-in name, or ``generated`` restricted to one family."""
    if row in ("jacksboro", "generated"):
        return row
    from tin_swarm_env.scenario import load_scenario

    return load_scenario("generated").with_families((row,))


def load_of(readings, danger: np.ndarray, live: np.ndarray) -> dict[str, np.ndarray]:
    """Per live robot (``live`` (n,) bool): robot contacts, break contacts and dangerous break contacts
    (``danger`` (B,) bool per break segment) of one :class:`~tin_swarm_env.world.sensing.SensorReadings`."""
    n = len(live)
    rob = np.bincount(readings.robots.observer, minlength=n)
    br = readings.breaks
    brk = np.bincount(br.observer, minlength=n)
    dng = np.bincount(br.observer[danger[br.break_idx]], minlength=n)
    return {"robots": rob[live], "breaks": brk[live], "dangerous": dng[live]}


def sensing_load(scenario, n_robots: int, episodes: int, steps: int = LOAD_STEPS) -> dict[str, np.ndarray]:
    """:func:`load_of` over ``episodes`` single envs (seeds 0..), each after ``steps`` random steps."""
    parts: dict[str, list] = {"robots": [], "breaks": [], "dangerous": []}
    rng = np.random.default_rng(0)
    for seed in range(episodes):
        env = tse.parallel_env(scenario=scenario, n_robots=n_robots)
        env.reset_arrays(seed=seed)
        for _ in range(steps):
            env.step_arrays(rng.uniform(-1, 1, (env.n, 2)))
        world = env.world
        danger = np.asarray(world.breaks.kinds) != ANGLE
        for k, v in load_of(world.sense(env.world_state), danger, np.asarray(env.live_mask)).items():
            parts[k].append(v)
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in parts.items()}


class _Timed:
    """The vector env's reference to ``sense_copies`` wrapped so that its time is summed (``spent``)."""

    def __init__(self):
        self.inner = vector_mod.sense_copies
        self.spent = 0.0
        self.calls = 0

    def __call__(self, *args, **kw):
        self.calls += 1
        t = time.perf_counter()
        try:
            return self.inner(*args, **kw)
        finally:
            self.spent += time.perf_counter() - t


def vector_rates(scenarios: dict, E: int, N: int, steps: int) -> dict[str, tuple[float, float]]:
    """``{row: (robot-steps/s, share of the step in sensing)}`` of the raw vector env at E x N for each
    ``scenarios[row]``: every env built and warmed first, then REPEATS rounds over them in turn (so a
    passing load on the host falls on every row alike), each row's best run kept with its sensing share."""
    envs = {}
    a = np.random.default_rng(0).uniform(-1, 1, (E, N, 2))
    timer = _Timed()
    vector_mod.sense_copies = timer
    try:
        for row, scen in scenarios.items():
            envs[row] = tse.vector_env(scen, n_envs=E, n_robots=N, seed=0)
            envs[row].reset()
            envs[row].step(a)
            envs[row].step(a)
        best = {row: (np.inf, 0.0) for row in envs}
        for _ in range(REPEATS):
            for row, v in envs.items():
                gc.collect()
                timer.spent = 0.0
                t = time.perf_counter()
                for _ in range(steps):
                    v.step(a)
                dt = time.perf_counter() - t
                if dt < best[row][0]:
                    best[row] = (dt, timer.spent / dt)
    finally:
        vector_mod.sense_copies = timer.inner
    if timer.calls == 0:  # the vector env no longer senses through this name: the share would read 0 %
        raise RuntimeError("bench/vector_load.py: tin_swarm_env.env.vector.sense_copies was never called; "
                           "time the vector env's sensing where it now happens")
    return {row: (E * N * steps / dt, share) for row, (dt, share) in best.items()}


def main(E: int, N: int, episodes: int, steps: int, rows, out: str | None, command: str) -> None:
    import numba

    lines = []

    def emit(s=""):
        print(s, flush=True)
        lines.append(s)

    load = os.getloadavg()
    emit(f"Measured with `{command}`, {numba.get_num_threads()} numba threads, load average at the start "
         f"{load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} on {os.cpu_count()} cores.")
    emit()
    emit(f"Sensing load per live robot: {episodes} episodes of {N} robots per row, after {LOAD_STEPS} random steps. "
         f"Raw vector env: {E} x {N}, the best of {REPEATS} runs of {steps} steps.")
    emit()
    emit("| row | robot contacts / robot | break contacts / robot: mean | p90 | dangerous / robot "
         "| raw vector env robot-steps/s | / jacksboro | sensing, share of the step | sensing, us per robot |")
    emit("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    loads = {row: sensing_load(scenario_of(row), N, episodes) for row in rows}
    rates = vector_rates({row: scenario_of(row) for row in rows}, E, N, steps)
    ref = rates[rows[0]][0]
    for row in rows:
        ld = loads[row]
        rate, share = rates[row]
        us = share / rate * 1e6  # seconds of sensing per robot-step
        label = row if row in ("jacksboro", "generated") else f"generated: {row}"
        label = "generated (the mix)" if row == "generated" else label
        emit(f"| {label} | {ld['robots'].mean():.1f} | {ld['breaks'].mean():.1f} "
             f"| {np.percentile(ld['breaks'], 90):.0f} "
             f"| {ld['dangerous'].mean():.1f} | {rate:.3g} | {rate / ref:.0%} | {share:.0%} | {us:.2f} |")
    load = os.getloadavg()
    emit(f"\nRatios against the first row, measured in this run. Load average at the end {load[0]:.2f} / {load[1]:.2f} "
         f"/ {load[2]:.2f}.")
    if out:
        tmp = f"{out}.part"
        with open(tmp, "w") as fh:
            fh.write("# Sensing load per terrain\n\n" + "\n".join(lines) + "\n")
        os.replace(tmp, out)


def _size(text: str) -> tuple[int, int]:
    try:
        E, N = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size {text!r}: expected E x N, e.g. 256x16") from None
    if E < 1 or N < 1:
        raise argparse.ArgumentTypeError(f"--size {text!r}: E and N must be at least 1")
    return E, N


def _positive(text: str) -> int:
    v = int(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"{text!r}: must be at least 1")
    return v


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--size", type=_size, default=(256, 16), help="E x N of the vector env (default 256x16)")
    p.add_argument("--episodes", type=_positive, default=16, help="single envs per row for the sensing load")
    p.add_argument("--steps", type=_positive, default=20, help="steps per timed run of the vector env")
    p.add_argument("--out", default=None, help="write the table here (Markdown); default: print only")
    p.add_argument("--quick", action="store_true", help=f"a smoke run ({QUICK}); prints only")
    a = p.parse_args()
    if a.quick:
        main(*QUICK["size"], QUICK["episodes"], QUICK["steps"], QUICK["rows"], None,
             "python bench/vector_load.py --quick")
    else:
        cmd = (f"python bench/vector_load.py --size {a.size[0]}x{a.size[1]} --episodes {a.episodes} --steps {a.steps}"
               + (f" --out {a.out}" if a.out else ""))
        main(*a.size, a.episodes, a.steps, ROWS, a.out, cmd)
