"""What the unseen shapes' horizon asks of a robot that does not know the map: the idealised map-less
robot of ``research/sensing_bound.py`` (a point that plans the shortest way under the free-space
assumption, never forgets, never turns, meets no other robot and drives at top speed) on the
shapes of ``bench/apf_unseen.py``, both images, beside the episode length that bench scores at
(twice the map-knowing reference's median steps) and APF's own rows read from its records
(``docs/figures/apf_unseen_parts/<shape>.json``). Writes ``research/unseen_bound.md``:

    python research/unseen_bound.py [--only nested_u,crater] [--seeds 3] [--jobs 2] [--out FILE]

Sensing (``R`` the sensor range, 60 m by default): ``disk``, every unsafe cell within ``R`` all
round and through hills: the most a sensor of that range could tell; and ``scan``, the beams of the
default observation's terrain scan alone (``[observation] k_scan`` at equal bearings, each marking the
first unsafe cell within ``R``). Both plan on a raster of 1 m cells. Everything a controller loses to
driving (speed on slopes, turning, other robots) is left out, so the ``disk`` row bounds what any
controller with a sensor of that range can do with this planner: where it arrives after the bench's
horizon, so does every such controller. The ``scan`` row is no bound for APF, which also reads the
observation's break slots and charts the cell behind each beam's hit. Neither bounds every strategy:
a robot that guessed the right side of a pocket before seeing it could be faster on one image and is
then slower on the mirror image.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path

import sensing_bound as BOUND  # research/ is on the path: the script's own folder
from unseen_tin import UNSEEN  # bench/apf_unseen.py, loaded once

ROOT = Path(__file__).resolve().parents[1]
RASTER_M = 1.0
SENSING = ("scan", "disk")
IMAGES = ("", "ns")


def ideal_steps(env, seed: int, sensing: str, cap: int) -> tuple[np.ndarray, np.ndarray]:
    """The idealised robot (:func:`sensing_bound.ideal_robots`, 1 m raster, the layout's scan beams) run
    from every robot's spawn point of ``env``'s episode ``seed`` (``env``'s ``max_cycles`` = ``cap``) to
    its target: ``(steps, geodesic)`` per robot, ``steps`` its arrival step (``cap + 1``: not by ``cap``),
    ``geodesic`` the shortest drivable way in steps at top speed."""
    env.reset(seed=seed)
    b = env.unwrapped
    if b.max_cycles != cap:
        raise ValueError(f"ideal_steps: the env's max_cycles is {b.max_cycles}, not cap = {cap}")
    res = BOUND.ideal_robots(env, range(b.n), sensing, b.layout.k_scan, RASTER_M)
    return np.array([r[0] for r in res]), np.array([r[1] for r in res])


def share_by(steps, horizon: int) -> float:
    """The share of ``steps`` (arrival steps) at most ``horizon``."""
    return float(np.mean(np.asarray(steps) <= horizon))


def _job(job):
    shape, image, sensing, seed, robots, cap, folder = job
    env = tse.parallel_env(scenario=UNSEEN.shape_config(shape, folder, image, robots, cap))
    return job, ideal_steps(env, seed, sensing, cap)


def _record(shape: str) -> dict | None:
    p = ROOT / "docs" / "figures" / "apf_unseen_parts" / f"{shape}.json"
    return json.loads(p.read_text()) if p.exists() else None


def _apf_cells(rec, image: str) -> str:
    """APF's row of the bench's record: median steps of those arrived, arrived by the horizon and by twice it."""
    if rec is None:
        return "| – | – | – |"
    row, lg = rec["rows"][image]["apf"], rec["at_long"][image]["apf"]
    med = "" if row["median"] is None else f"{row['median']:.0f}"
    return f"| {med} | {100 * row['arrived'] / row['n']:.1f}% | {100 * lg['arrived'] / row['n']:.1f}% |"


def table(results: dict, shapes, seeds: int, robots: int) -> list[str]:
    """The markdown rows: per shape, image and sensing, the idealised robot's median and p90 steps, its
    share by the bench's horizon and by twice it, the geodesic's median steps, and APF's row."""
    out = ["| shape | image | sensing | robots | median steps | p90 steps | by the horizon | by twice it | "
           "geodesic steps | bench horizon | APF median steps | APF by the horizon | APF by twice it |",
           "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for shape in shapes:
        rec = _record(shape)
        horizon = rec["horizon"] if rec else None
        for image in IMAGES:
            for sensing in SENSING:
                steps, geo = results[(shape, image, sensing)]
                by = (f"{100 * share_by(steps, horizon):.1f}% | {100 * share_by(steps, 2 * horizon):.1f}%"
                      if horizon else "– | –")
                out.append(f"| {shape} | {image or 'as built'} | {sensing} | {seeds} x {robots} | "
                           f"{np.median(steps):.0f} | {np.percentile(steps, 90):.0f} | {by} | "
                           f"{np.median(geo):.0f} | {horizon or '–'} " + _apf_cells(rec, image))
    return out


def _load() -> str:
    return " / ".join(f"{v:.2f}" for v in os.getloadavg())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--only", default=",".join(UNSEEN.SHAPES), help="shapes, comma-separated")
    p.add_argument("--seeds", type=int, default=3, help="episodes (seeds 0..) per shape and image")
    p.add_argument("--robots", type=int, default=20)
    p.add_argument("--cap", type=int, default=2500, help="steps the idealised robot is given")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--out", default=str(ROOT / "research" / "unseen_bound.md"))
    args = p.parse_args(argv)
    shapes = [s for s in args.only.split(",") if s]
    bad = [s for s in shapes if s not in UNSEEN.SHAPES]
    if bad or args.seeds < 1 or args.robots < 1 or args.cap < 1 or args.jobs < 1:
        p.error(f"unknown shapes {bad} (known: {', '.join(UNSEEN.SHAPES)})" if bad
                else "--seeds, --robots, --cap and --jobs must be at least 1")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT).stdout.strip()
    start, load0, t0 = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), _load(), time.time()
    with tempfile.TemporaryDirectory() as folder:
        jobs = [(s, im, se, seed, args.robots, args.cap, folder) for s in shapes for im in IMAGES
                for se in SENSING for seed in range(args.seeds)]
        for s in shapes:  # the DEM files, once, before the workers read them
            UNSEEN.write_dem(s, folder)
        with Pool(args.jobs) as pool:
            done = pool.map(_job, jobs)
    results: dict = {}
    for (s, im, se, *_), (steps, geo) in done:
        old = results.get((s, im, se), (np.empty(0), np.empty(0)))
        results[(s, im, se)] = (np.concatenate([old[0], steps]), np.concatenate([old[1], geo]))
    lines = [f"Measured with `python research/unseen_bound.py {' '.join(argv if argv is not None else sys.argv[1:])}`"
             f" at commit {commit}, {start}, load average {load0} at the start (2 cores, shared); "
             f"{time.time() - t0:.0f} s.", "",
             "The idealised map-less robot (module docstring of `research/unseen_bound.py`) on the shapes of "
             "`bench/apf_unseen.py`. steps: its arrival step (not arrived by the cap counts as the cap + 1); "
             "by the horizon: the share arrived by the episode length the bench scores at (twice the map-knowing "
             "reference's median steps, its record's `horizon`), and by twice that; geodesic steps: the shortest "
             "drivable way at top speed; APF: the bench's rows (`docs/figures/apf_unseen.md`, 10 seeds x 20 robots).",
             "", *table(results, shapes, args.seeds, args.robots)]
    text = "\n".join(lines) + "\n"
    print(text)
    with atomic_path(args.out) as tmp:  # the whole file or nothing
        Path(tmp).write_text(text)


if __name__ == "__main__":
    main()
