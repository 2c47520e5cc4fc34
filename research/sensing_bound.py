"""How much of issue #22's bars the *observation* allows: an idealised map-less robot, given what a
sensor could tell it, against the same robot given only what the observation's break slots hold.
Writes ``research/sensing_bound.md``:

    python research/sensing_bound.py [--families fork] [--seed-offsets 0,100] [--seeds 50]
                                  [--jacksboro-seeds 1] [--out FILE]

The idealised robot is a point that plans the shortest 8-connected way to its target on a raster of
the terrain (cells ``--res`` m) under the free-space assumption (ground it has not seen unsafe is
taken as open: the rule of the chart search, :mod:`tin_swarm_env.policies.chart`, and of D* and its
kin), never forgets, replans only when what it has seen blocks its way (under a growing set of
blocked cells a way that stays open stays shortest), and drives that way at top speed (one
``max_speed_mps * dt_s`` per step). It meets no other robot, never turns, never runs out of battery
and never falls: everything a real controller loses to driving is left out, so its arrival share
bounds what a controller given the same information can do with this planner. Unsafe ground is the
raster's cells whose centre lies off the TIN or on a triangle too steep to drive (``World.steep``),
and every cell a dangerous break crosses (:func:`mark_crossed`): else a way could slip between
two steep triangles that touch at one vertex (a *pinch*, which no robot drives through and the
cost-to-go does not pass), through cell centres safe on either side of it.
What it senses each step (``R`` the sensor range, breaks as :class:`~tin_swarm_env.terrain.Breaks`):

* ``disk``: every unsafe cell within ``R``, all round, through hills (no line of sight): the most
  a sensor of that range could tell it;
* ``scan K``: a scanner's ``K`` beams at equal bearings all round, each marking the first unsafe
  cell it meets within ``R`` (what a laser scanner on the robot would give);
* ``segments K``: the ``K`` nearest breaks within ``R`` (of any kind, as the observation's break
  slots are chosen), each dangerous one marked whole (the part within ``R``), and a cell behind it;
* ``points K``: the same ``K`` breaks, but only each one's closest point (and a cell behind it):
  what the observation's break slots hold (``K = 3`` is the default ``k_breaks``).

A robot can meet a wall it has not seen (or has forgotten): its step into an unsafe
cell is refused, the cell is marked and it replans (a bumper). Beside them, the rows ``chart
search`` run :class:`~tin_swarm_env.policies.APFPolicy` (``search="chart"``) in the environment on
the same seeds, with the scenario's ``k_breaks`` set to ``K``, or with the observation's terrain
scan (``[observation] k_scan``, :mod:`tin_swarm_env.env.observation`) added: the real controller on
the real observation.

Generated rows: the ``generated`` scenario restricted to one family (``bench/apf.py``'s rows), 20
robots, held-out seeds ``EVAL_SEED0 + offset`` on, the scenario's episode length. jacksboro rows:
the target-1 robots (67 of 200, the ones APF loses; ``research/apf_notes.md``) of seeds
``0..`` on the part of the map ``--jacksboro-window`` (which holds every target and the spawn
region), 1800 steps, raster ``--jacksboro-res`` m.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np
from numba import njit

import tin_swarm_env as tse
from tin_swarm_env.policies import APFPolicy
from tin_swarm_env.policies.chart import ChartParams, heap_pop, heap_push
from tin_swarm_env.scenario import load_scenario
from tin_swarm_env.terrain.breaks import ANGLE
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]
HARD = 1  # jacksboro's target whose robots APF loses
JACKSBORO_STEPS = 1800
S2 = np.sqrt(2.0)


@njit
def shortest_way(blocked, sa, sb, ta, tb):
    """A* from cell (sa, sb) to (ta, tb) over the cells not ``blocked (nx, ny)``, 8-connected, no
    corner cutting, a step costs its length in cells. Returns the way's cells ``(m, 2)`` from start
    to target (empty: none) and its length."""
    nx, ny = blocked.shape
    dist = np.full((nx, ny), np.inf)
    prev = np.full((nx, ny), -1, np.int64)
    closed = np.zeros((nx, ny), np.bool_)
    cap = nx * ny * 8 + 8
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    s2 = np.sqrt(2.0)
    dist[sa, sb] = 0.0
    dx, dy = abs(sa - ta), abs(sb - tb)
    hk[0] = max(dx, dy) + (s2 - 1) * min(dx, dy)
    hv[0] = sa * ny + sb
    hn = 1
    found = False
    while hn > 0:
        v, hn = heap_pop(hk, hv, hn)
        a, b = v // ny, v % ny
        if closed[a, b]:
            continue
        closed[a, b] = True
        if a == ta and b == tb:
            found = True
            break
        for da in range(-1, 2):
            for db in range(-1, 2):
                if da == 0 and db == 0:
                    continue
                na, nb = a + da, b + db
                if na < 0 or nb < 0 or na >= nx or nb >= ny or blocked[na, nb] or closed[na, nb]:
                    continue
                if da != 0 and db != 0 and (blocked[a + da, b] or blocked[a, b + db]):
                    continue
                nd = dist[a, b] + (s2 if da != 0 and db != 0 else 1.0)
                if nd < dist[na, nb]:
                    dist[na, nb] = nd
                    prev[na, nb] = a * ny + b
                    ex, ey = abs(na - ta), abs(nb - tb)
                    hn = heap_push(hk, hv, hn, nd + max(ex, ey) + (s2 - 1) * min(ex, ey), na * ny + nb)
    if not found:
        return np.zeros((0, 2), np.int64), np.inf
    n = 1
    v = ta * ny + tb
    while v != sa * ny + sb:
        v = prev[v // ny, v % ny]
        n += 1
    out = np.empty((n, 2), np.int64)
    v = ta * ny + tb
    for k in range(n - 1, -1, -1):
        out[k, 0], out[k, 1] = v // ny, v % ny
        if k:
            v = prev[v // ny, v % ny]
    return out, dist[ta, tb]


@njit
def _reveal_disk(known, unsafe, a, b, r):
    nx, ny = known.shape
    for i in range(max(a - r, 0), min(a + r + 1, nx)):
        for j in range(max(b - r, 0), min(b + r + 1, ny)):
            if unsafe[i, j] and (i - a) ** 2 + (j - b) ** 2 <= r * r:
                known[i, j] = True


@njit
def _reveal_scan(known, unsafe, px, py, res, range_m, beams):
    """A scanner's beams: along each of ``beams`` bearings, the first unsafe cell within ``range_m``."""
    nx, ny = known.shape
    for k in range(beams):
        ang = 2.0 * np.pi * k / beams
        dx, dy = np.cos(ang), np.sin(ang)
        t = 0.0
        while t <= range_m:
            i, j = int(np.floor((px + t * dx) / res)), int(np.floor((py + t * dy) / res))
            if i < 0 or j < 0 or i >= nx or j >= ny:
                break
            if unsafe[i, j]:
                known[i, j] = True
                break
            t += 0.25 * res


@njit
def _way_blocked(known, way, k0):
    for k in range(k0, len(way)):
        if known[way[k, 0], way[k, 1]]:
            return True
    return False


@dataclasses.dataclass(frozen=True)
class Raster:
    """Unsafe ground on cells of ``res`` m from ``(x0, y0)``; breaks in the raster's coordinates."""

    unsafe: np.ndarray
    res: float
    x0: float
    y0: float
    seg: np.ndarray  # (B, 2, 2) break segments, m from (x0, y0)
    danger: np.ndarray  # (B,) bool
    normal: np.ndarray  # (B, 2) toward the safe side

    def cell(self, p):
        nx, ny = self.unsafe.shape
        return min(max(int(p[0] / self.res), 0), nx - 1), min(max(int(p[1] / self.res), 0), ny - 1)


def raster(env, res: float, window=None) -> Raster:
    """The unsafe ground of ``env``'s current episode (cells whose centre is off the TIN or on a
    too-steep triangle) over the TIN's bounds or ``window`` (x0, y0, x1, y1)."""
    b = env.unwrapped
    tin = b.tin
    x0, y0, x1, y1 = window or [float(v) for v in np.asarray(tin.bounds).ravel()[:4]]
    xs = np.arange(x0 + res / 2, x1, res)
    ys = np.arange(y0 + res / 2, y1, res)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    t = tin.locate(np.stack([gx.ravel(), gy.ravel()], 1)).reshape(gx.shape)
    steep = np.asarray(b.world.steep)
    br = b.world.breaks
    seg = br.segments[:, :, :2] - np.array([x0, y0])
    danger = br.kinds != ANGLE
    unsafe = (t < 0) | steep[np.maximum(t, 0)]
    mark_crossed(unsafe, seg.astype(np.float64), danger, res)
    return Raster(unsafe=unsafe, res=res, x0=x0, y0=y0, seg=seg, danger=danger, normal=br.normals)


@njit
def mark_crossed(unsafe, seg, danger, res):
    """Mark unsafe every cell of ``unsafe (nx, ny)`` (cells ``res`` m) that a dangerous segment of
    ``seg (B, 2, 2)`` (m) meets, both neighbours where it passes exactly through a cell corner
    (a grid walk, Amanatides and Woo). No way on the raster then crosses a dangerous break, not even
    where two steep triangles touch at one vertex (a pinch, which no robot can drive through and the
    cost-to-go does not pass), though the cell centres either side of it are safe."""
    nx, ny = unsafe.shape

    def mark(a, b):
        if 0 <= a < nx and 0 <= b < ny:
            unsafe[a, b] = True

    for j in range(len(seg)):
        if not danger[j]:
            continue
        x0, y0 = seg[j, 0, 0] / res, seg[j, 0, 1] / res
        x1, y1 = seg[j, 1, 0] / res, seg[j, 1, 1] / res
        a, b = int(np.floor(x0)), int(np.floor(y0))
        a1, b1 = int(np.floor(x1)), int(np.floor(y1))
        dx, dy = x1 - x0, y1 - y0
        sa = 1 if dx > 0 else -1
        sb = 1 if dy > 0 else -1
        tdx = abs(1.0 / dx) if dx != 0 else np.inf
        tdy = abs(1.0 / dy) if dy != 0 else np.inf
        tmx = ((a + 1 - x0) if dx > 0 else (x0 - a)) * tdx if dx != 0 else np.inf
        tmy = ((b + 1 - y0) if dy > 0 else (y0 - b)) * tdy if dy != 0 else np.inf
        mark(a, b)
        for _ in range(abs(a1 - a) + abs(b1 - b) + 2):
            if min(tmx, tmy) > 1.0 + 1e-9:  # the next cell line lies past the segment's end
                break
            if abs(tmx - tmy) < 1e-9:  # through a corner: both neighbours too
                mark(a + sa, b)
                mark(a, b + sb)
                a += sa
                b += sb
                tmx += tdx
                tmy += tdy
            elif tmx < tmy:
                a += sa
                tmx += tdx
            else:
                b += sb
                tmy += tdy
            mark(a, b)


def _sense_slots(known, ras: Raster, pos, R, k, whole):
    a, b = ras.seg[:, 0], ras.seg[:, 1]
    ab = b - a
    u = np.clip(np.sum((pos - a) * ab, 1) / np.maximum(np.sum(ab * ab, 1), 1e-12), 0.0, 1.0)
    c = a + u[:, None] * ab
    d = np.hypot(*(c - pos).T)
    idx = np.nonzero(d <= R)[0]
    idx = idx[np.argsort(d[idx], kind="stable")][:k]
    h = ras.res
    for j in idx:
        if not ras.danger[j]:
            continue
        if whole:
            m = max(int(np.hypot(*ab[j]) / (0.5 * h)) + 1, 2)
            pts = a[j] + np.linspace(0.0, 1.0, m)[:, None] * ab[j]
            pts = pts[np.hypot(*(pts - pos).T) <= R]
        else:
            pts = c[j][None]
        for p in np.concatenate([pts, pts - 0.6 * h * ras.normal[j]]):
            i, jj = int(p[0] // h), int(p[1] // h)
            if 0 <= i < known.shape[0] and 0 <= jj < known.shape[1]:
                known[i, jj] = True


def drive(ras: Raster, start, target, *, sensing: str, k: int, range_m: float, step_m: float,
          arrive_m: float, max_steps: int) -> tuple[int, int]:
    """``(steps, forgot)``: the steps the idealised robot takes from ``start`` to within ``arrive_m``
    of ``target`` (m, in the raster's coordinates; ``max_steps + 1`` when it has not arrived by then)
    and the times what it had marked shut every way and it forgot it."""
    known = np.zeros_like(ras.unsafe)
    forgot = 0
    pos = np.asarray(start, float).copy()
    target = np.asarray(target, float)
    r_cells = int(range_m / ras.res)
    way, k_at = None, 0
    for n in range(max_steps + 1):
        if np.hypot(*(pos - target)) <= arrive_m:
            return n, forgot
        a, b = ras.cell(pos)
        if sensing == "disk":
            _reveal_disk(known, ras.unsafe, a, b, r_cells)
        elif sensing == "scan":
            _reveal_scan(known, ras.unsafe, pos[0], pos[1], ras.res, range_m, k)
        else:
            _sense_slots(known, ras, pos, range_m, k, sensing == "segments")
        if way is None or _way_blocked(known, way, k_at):
            known[a, b] = False  # where it stands is open to it
            way, _ = shortest_way(known, a, b, *ras.cell(target))
            k_at = 1
            if len(way) == 0:  # what it marked shuts every way: it forgets it (as the chart search does)
                known[:] = False
                forgot += 1
                way, _ = shortest_way(known, a, b, *ras.cell(target))
        left = step_m
        while left > 1e-9 and k_at < len(way):
            nxt = way[k_at]
            if ras.unsafe[nxt[0], nxt[1]]:  # the bumper: a wall it had not seen (or had forgotten)
                known[nxt[0], nxt[1]] = True
                way = None
                break
            c = (nxt + 0.5) * ras.res
            d = np.hypot(*(c - pos))
            if d <= left:
                pos, left, k_at = c, left - d, k_at + 1
            else:
                pos, left = pos + (c - pos) * left / d, 0.0
        if way is not None and k_at >= len(way):
            pos = target.copy()
    return max_steps + 1, forgot


def _observing(cfg, k_breaks: int | None, k_scan: int):
    obs = cfg.observation
    return cfg.replace(observation=dataclasses.replace(obs, k_breaks=obs.k_breaks if k_breaks is None else k_breaks,
                                                       k_scan=k_scan))


def _generated_env(family: str, k_breaks: int | None = None, k_scan: int = 0):
    cfg = load_scenario("generated")
    cfg = cfg.with_families((family,))
    return tse.parallel_env(scenario=_observing(cfg, k_breaks, k_scan))


def _jacksboro_env(k_breaks: int | None = None, k_scan: int = 0):
    cfg = load_scenario("jacksboro").replace(max_cycles=JACKSBORO_STEPS)
    return tse.parallel_env(scenario=_observing(cfg, k_breaks, k_scan))


def ideal_robots(env, rows, sensing: str, k: int, res: float, window=None) -> list[tuple[int, float, int]]:
    """The idealised robot run from the spawn point of each robot ``rows`` of ``env``'s episode (reset
    already) to its target on a raster of ``res`` m (over ``window``, default the TIN's bounds), given
    the episode's ``max_cycles``: (arrival step or ``max_cycles + 1``, geodesic steps at top speed,
    times it forgot) per robot."""
    b = env.unwrapped
    ras = raster(env, res, window)
    p = b.world.params
    step_m = p.robot.max_speed_mps * p.dt_s
    st = b.world_state
    pos = np.asarray(st.positions)[:, :2] - [ras.x0, ras.y0]
    tg = np.asarray(st.targets.positions)[:, :2] - [ras.x0, ras.y0]
    asg = b.target_assignment
    geo = b.distance_to_go() / step_m
    arrive = b.config.targets.arrival_radius_m
    out = []
    for i in rows:
        n, forgot = drive(ras, pos[i], tg[asg[i]], sensing=sensing, k=k, range_m=p.sensor.range_m, step_m=step_m,
                          arrive_m=arrive, max_steps=b.max_cycles)
        out.append((n, float(geo[i]), forgot))
    return out


def ideal_episode(job) -> list[tuple[int, float, int]]:
    """``job``: (terrain, seed, sensing, k, res, window, part, parts): the robots ``part::parts`` of the
    episode's robots run. (steps, geodesic steps, forgot) per robot run (:func:`ideal_robots`)."""
    terrain, seed, sensing, k, res, window, part, parts = job
    env = _jacksboro_env() if terrain == "jacksboro" else _generated_env(terrain)
    env.reset(seed=seed)
    asg = env.unwrapped.target_assignment
    rows = np.nonzero(asg == HARD)[0] if terrain == "jacksboro" else np.nonzero(asg >= 0)[0]
    return ideal_robots(env, rows[part::parts], sensing, k, res, window)


def chart_episode(job) -> list[tuple[int, float, int]]:
    """The chart search in the environment (``job``: terrain, seed, k_breaks, k_scan, chart cells): (arrival
    step or max_cycles + 1, geodesic steps, times it forgot its chart) per robot."""
    terrain, seed, k, k_scan, cells = job
    env = _jacksboro_env(k, k_scan) if terrain == "jacksboro" else _generated_env(terrain, k, k_scan)
    pol = APFPolicy(env, search="chart", chart=ChartParams(cells=cells))
    b = env.unwrapped
    env.reset(seed=seed)
    p = b.world.params
    geo = b.distance_to_go() / (p.robot.max_speed_mps * p.dt_s)
    asg = b.target_assignment
    out = rollout(env, pol, seed)
    rows = np.nonzero(asg == HARD)[0] if terrain == "jacksboro" else np.arange(out.n_robots)
    steps = np.where(out.reasons == Reason.ARRIVED, out.steps, b.max_cycles + 1)
    return [(int(steps[i]), float(geo[i]), int(pol.charts.forgot[i])) for i in rows]


def _summary(res, max_steps):
    n = np.array([r[0] for r in res])
    g = np.array([r[1] for r in res])
    ok = n <= max_steps
    half = f"{np.mean(n <= max_steps // 2):.1%}"
    med = f"{np.median(n[ok]):.0f}" if ok.any() else "-"
    return len(n), f"{ok.mean():.1%}", half, med, f"{np.median(g):.0f}", f"{np.mean([r[2] > 0 for r in res]):.1%}"


def _header(argv) -> str:
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip() or "?"
    cmd = " ".join(["python research/sensing_bound.py", *argv])
    return (f"Measured with `{cmd}` at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
            f"load average {_load()} at the start ({os.cpu_count()} cores, shared).")


def _load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def _ints(text: str) -> list[int]:
    try:
        out = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated integers, got {text!r}") from None
    if any(v < 0 for v in out):
        raise argparse.ArgumentTypeError(f"expected integers >= 0, got {text!r}")
    return out


def _cells(text: str) -> list[int]:
    out = _ints(text)
    if not out or min(out) < 4:
        raise argparse.ArgumentTypeError(f"expected chart sizes of at least 4 cells, got {text!r}")
    return out


def _window(text: str) -> list[float]:
    try:
        w = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected x0,y0,x1,y1 in metres, got {text!r}") from None
    if len(w) != 4 or not (w[0] < w[2] and w[1] < w[3]):
        raise argparse.ArgumentTypeError(f"expected x0,y0,x1,y1 with x0 < x1 and y0 < y1, got {text!r}")
    return w


def _positive(text: str) -> float:
    v = float(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return v


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--families", default="fork", help="generated families, comma-separated ('' for none)")
    p.add_argument("--seed-offsets", type=_ints, default=[0, 100],
                   help="held-out seed sets of the generated rows: EVAL_SEED0 + offset on")
    p.add_argument("--seeds", type=int, default=50, help="seeds per generated row")
    p.add_argument("--res", type=_positive, default=1.0, help="raster cell of the generated rows, m")
    p.add_argument("--jacksboro-seeds", type=int, default=1)
    p.add_argument("--jacksboro-res", type=_positive, default=5.0)
    p.add_argument("--jacksboro-window", type=_window, default=[13000.0, 13000.0, 21000.0, 20000.0])
    p.add_argument("--jacksboro-slots", type=_ints, default=[3], help="K of jacksboro's idealised slot rows")
    p.add_argument("--slots", type=_ints, default=[3, 16], help="K of the segments/points/chart rows")
    p.add_argument("--beams", type=_ints, default=[32, 64], help="K of the idealised scanner rows")
    p.add_argument("--scan", type=_ints, default=[32, 64],
                   help="k_scan of the chart search rows that add the observation's scan (k_breaks as the scenario's)")
    p.add_argument("--ideal", action=argparse.BooleanOptionalAction, default=True, help="the idealised rows")
    p.add_argument("--chart-cells", type=_cells, default=[ChartParams.cells],
                   help="chart sizes of the chart search rows (ChartParams.cells), comma-separated")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default=str(ROOT / "research" / "sensing_bound.md"))
    args = p.parse_args(argv)
    lines = [_header(argv), ""]

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    emit("The models are in the module docstring of `research/sensing_bound.py`. arrived: share of the robots run that "
         "reach their target within the episode (generated: the scenario's 1000 steps; jacksboro: 1800); by half: "
         "within half of it (jacksboro: 900 steps, issue #22's other bar); steps: "
         "median step of arrival of those that do, beside the shortest drivable path's at top speed (geodesic); "
         "forgot: share of the robots whose marks shut every way at least once, so that they forgot them "
         "(the chart search does the same); s: seconds per row.\n")
    emit("| terrain | seeds | robots | robot | sensing | arrived | by half | steps | geodesic steps | forgot | s |")
    emit("|---|---|---:|---|---|---:|---:|---:|---:|---:|---:|")
    fams = [f for f in args.families.split(",") if f]
    slot_models = [(s, k) for k in args.slots for s in ("segments", "points")]
    terrains = [(f, f"{f}, {EVAL_SEED0 + o}..{EVAL_SEED0 + o + args.seeds - 1}",
                 list(range(EVAL_SEED0 + o, EVAL_SEED0 + o + args.seeds)), args.res, None, slot_models, 1)
                for f in fams for o in args.seed_offsets]
    if args.jacksboro_seeds:
        terrains.append(("jacksboro", f"jacksboro (target-{HARD} robots), 0..{args.jacksboro_seeds - 1}",
                         list(range(args.jacksboro_seeds)), args.jacksboro_res, args.jacksboro_window,
                         [(s, k) for k in args.jacksboro_slots for s in ("segments", "points")], 4 * args.jobs))
    with Pool(args.jobs) as pool:
        for terrain, label, seeds, res, window, slot_models, parts in terrains:
            steps = JACKSBORO_STEPS if terrain == "jacksboro" else _generated_env(terrain).unwrapped.max_cycles
            for sensing, k in ([("disk", 0)] + [("scan", k) for k in args.beams] + slot_models) * args.ideal:
                t = time.perf_counter()
                jobs = [(terrain, s, sensing, k, res, window, part, parts) for s in seeds for part in range(parts)]
                res_ = [r for rr in pool.map(ideal_episode, jobs, chunksize=1) for r in rr]
                n, arr, half, med, geo, forgot = _summary(res_, steps)
                what = {"disk": "all unsafe ground in range", "scan": f"scanner, {k} beams"}.get(
                    sensing, f"{k} nearest breaks: {sensing}")
                emit(f"| {label} | {len(seeds)} | {n} | idealised, raster {res:g} m | {what} | {arr} | {half} | "
                     f"{med} | {geo} | {forgot} | {time.perf_counter() - t:.0f} |")
            for (k, k_scan), cells in [(m, c) for m in [(k, 0) for k in args.slots] + [(None, k) for k in args.scan]
                                       for c in args.chart_cells]:
                t = time.perf_counter()
                res_ = [r for rr in pool.map(chart_episode, [(terrain, s, k, k_scan, cells) for s in seeds],
                                             chunksize=1) for r in rr]
                n, arr, half, med, geo, forgot = _summary(res_, steps)
                what = f"observation, k_breaks = {k}" if k is not None else f"observation with scan, k_scan = {k_scan}"
                robot = "APF, chart search" + ("" if cells == ChartParams.cells else f", {cells} cells")
                emit(f"| {label} | {len(seeds)} | {n} | {robot} | {what} | {arr} | {half} | "
                     f"{med} | {geo} | {forgot} | {time.perf_counter() - t:.0f} |")
    emit(f"\nLoad average at the end: {_load()}.")
    if args.out:
        tmp = Path(args.out).with_suffix(".md.tmp")
        tmp.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(args.out)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
