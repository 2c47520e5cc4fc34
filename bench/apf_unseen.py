"""The default APF and the map-knowing reference on terrain shapes the project has not seen: twelve DEMs
built here (numpy arrays written to a temporary ``.npz``, played through ``scenario_from_dict`` with
``[terrain] source = "dem"``), each as built and in its north-south mirror image
(:func:`~tin_swarm_env.scenario.mirror.mirror_scenario`). Writes ``docs/figures/apf_unseen.md``:

    python bench/apf_unseen.py                 # the full run: 10 seeds x 20 robots per shape and image
    python bench/apf_unseen.py --quick         # a smoke run (seconds): one shape, 1 seed of 4 robots; prints only
    [--seeds 10] [--robots 20] [--only u_pocket,spiral,...] [--cap 2500] [--jobs 1] [--out FILE]
    [--method robot] [--only crater@robot,...] # the shapes' TIN built by another [terrain] method

Every shape is a 300 x 300 m map of 2 m cells (the scenario's greedy TIN, 0.5 m error, unless ``--method``
names another builder of :data:`~tin_swarm_env.terrain.build.METHODS`: its rows are labelled with it),the robots'
default 30 deg slope limit; 20 robots spawn in ``SPAWN`` on the west side and the target lies east,
where the straight way crosses ground the robots cannot drive: a *cliff* (a sheer one-cell step of
6-14 m) or *steep hillside* (a 40 deg slope, no break in it, just too steep to climb or to drive down).
None of them is a recipe of :mod:`tin_swarm_env.scenario.terrains`, a generated family
(:mod:`~tin_swarm_env.scenario.generators`: canyon, mesa, hills, fork, trap; realdem) or a test terrain
(``tests/helpers/canyons.py``):

============== ========= ====================================================================
shape          ground    what is in the way
============== ========= ====================================================================
u_pocket       cliff     a U of 10 m walls opening toward the robots: a dead end to back out of
s_walls        steep     two staggered 12 m ridges: round the north end of one, the south of the other
crater         both      a ring rim (steep outside, a cliff inside down to a sunk floor), the target in
                         the middle, the only way in a ramped cut on the far (east) side
diag_trench    cliff     a 6 m deep, 12 m wide diagonal trench with a crossing only past its north end
pillars        cliff     a hexagonal field of 10 m pillars, 10 m gaps, one on the straight line
ridge_saddle   steep     a 14 m ridge across the whole map, one 10 deg saddle 100 m north of the line
spiral         cliff     a two-turn spiral of 8 m walls around the target, its mouth on the outside
switchback     cliff     a 12 m escarpment; the way up a two-leg switchback ramp against its face
                         (leg over leg: a drop between them, and off the ramp's open side)
nested_u       steep     two nested U pockets of 12 m ridges, both opening toward the robots
comb           cliff     a 10 m wall across the map, its one gap at the south edge; two spurs on its
                         face make a 30 m deep pocket on the straight line
funnel         cliff     a V of 10 m walls opening toward the robots, a 6 m gap at its apex, a wall
                         behind the gap to go round
l_ridges       steep     a 12 m ridge across the way with both ends open; past its south end a
                         second ridge runs east to the map's edge, so only the north end leads on
============== ========= ====================================================================

Episode length: GeodesicPolicy (knows the map) runs first with ``--cap`` steps; each shape's horizon
is twice its median steps to arrive (the larger of the two images), rounded up to 50 steps, and both
policies are scored at that horizon (the reference's episodes are cut there: ``max_cycles`` only ends
an episode, so its first steps are the same). APF's episodes run on to twice that (at most the cap),
and the last two columns score both at twice the horizon: an observation-only robot pays for every dead
end it has to look into, so a shape with nested pockets can take it longer than twice the map-knowing
reference's time (the battery lasts about 2 000 steps). Per row: arrived, fell, timed out (with the battery
empty: none expected), stalled and looping (of the timed out, :mod:`tin_swarm_env.training.trajectory`),
median steps of the robots that arrived. After the table: where the APF robots that timed out ended
(the median of their distance-to-go on the map at the start and at the end, their median end point).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.scenario import scenario_from_dict
from tin_swarm_env.scenario.build import build_stage
from tin_swarm_env.scenario.mirror import mirror_scenario
from tin_swarm_env.terrain.build import METHODS
from tin_swarm_env.training.rollout import rollout
from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[1]


def _load_apf():
    """bench/apf.py as a module (its policies, load average, argparse types): one definition of each."""
    mod = sys.modules.get("bench_apf")
    if mod is None:
        spec = importlib.util.spec_from_file_location("bench_apf", ROOT / "bench" / "apf.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules["bench_apf"] = mod  # dataclasses look their module up there
        spec.loader.exec_module(mod)
    return mod


apf = _load_apf()
POLICY_NAMES = ("geodesic (knows the map)", "apf")  # apf.POLICIES' keys: the reference first (it sets the horizon)
IMAGES = (("", "as built"), ("ns", "mirror (north-south)"))

SIZE_M, CELL_M = 300.0, 2.0
STEEP_DEG = 40.0  # the hillside shapes' slope: above the robots' 30 deg, far below a cliff
SPAWN = (16.0, 125.0, 46.0, 175.0)  # x0, y0, x1, y1 m: the robots' spawn region, west side
METHOD = "greedy"  # the scenario's [terrain] method unless --method names another
QUICK = {"only": ["u_pocket"], "seeds": 1, "robots": 4, "cap": 600}


def _grid():
    c = np.arange(CELL_M / 2, SIZE_M, CELL_M)  # cell centres, south to north / west to east
    return c, np.meshgrid(c, c)  # X, Y: (rows, cols), row 0 south


def _seg_dist(X, Y, a, b):
    """Distance (m) of every grid point to the segment a-b."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    t = np.clip(((X - a[0]) * d[0] + (Y - a[1]) * d[1]) / max(d @ d, 1e-12), 0.0, 1.0)
    return np.hypot(X - a[0] - t * d[0], Y - a[1] - t * d[1])


def _poly_dist(X, Y, pts):
    return np.min([_seg_dist(X, Y, p, q) for p, q in zip(pts[:-1], pts[1:])], axis=0)


def _cliff_wall(d, half_m, height_m):
    """A wall with sheer sides: ``height_m`` where ``d <= half_m``."""
    return np.where(d <= half_m, height_m, 0.0)


def _steep_ridge(d, height_m, deg=STEEP_DEG):
    """A ridge whose flanks are steep hillside at ``deg``: its crest on ``d = 0``."""
    return np.maximum(0.0, height_m - d * math.tan(math.radians(deg)))


def u_pocket(X, Y):
    pts = [(95.0, 80.0), (175.0, 80.0), (175.0, 220.0), (95.0, 220.0)]
    return _cliff_wall(_poly_dist(X, Y, pts), 3.0, 10.0), (250.0, 150.0)


def s_walls(X, Y):
    z = np.maximum(_steep_ridge(_seg_dist(X, Y, (110, -20), (110, 195)), 12.0),
                   _steep_ridge(_seg_dist(X, Y, (190, 105), (190, 320)), 12.0))
    return z, (260.0, 150.0)


def crater(X, Y):
    c = (175.0, 150.0)
    r = np.hypot(X - c[0], Y - c[1])
    rim = np.clip((80.0 - r) * math.tan(math.radians(STEEP_DEG)), 0.0, None)  # steep outer flank
    # crest 8.4 m from r 64 to 70; a sheer inner wall down to the -5 m floor
    z = np.where(r < 64.0, -5.0, np.minimum(rim, 10.0 * math.tan(math.radians(STEEP_DEG))))
    cut = (X > c[0]) & (np.abs(Y - c[1]) < 10.0) & (r < 90.0)  # the way in: 5 m down over 26 m (11 deg)
    z = np.where(cut, -5.0 + 5.0 * np.clip((r - 64.0) / 26.0, 0.0, 1.0), z)
    return z, c


def diag_trench(X, Y):
    d = _seg_dist(X, Y, (80.0, -20.0), (200.0, 262.0))
    return np.where(d <= 6.0, -6.0, 0.0), (250.0, 120.0)


def pillars(X, Y):
    d, dy = np.full(X.shape, np.inf), 26.0 * math.sqrt(3) / 2  # a hexagonal lattice, 26 m between centres
    for j in range(-6, 7):  # row 0 on the straight line (y = 150): pillars centred on it at x = 95, 121, ...
        for x in np.arange(95.0 + (13.0 if j % 2 else 0.0), 235.0, 26.0):
            d = np.minimum(d, np.hypot(X - x, Y - 150.0 - j * dy))
    return _cliff_wall(d, 8.0, 10.0), (262.0, 150.0)


def ridge_saddle(X, Y):
    ridge = _steep_ridge(np.abs(X - 150.0), 14.0)
    saddle = np.maximum(0.0, 3.0 - np.abs(X - 150.0) * math.tan(math.radians(10.0)))
    return np.where(np.abs(Y - 250.0) < 9.0, np.minimum(ridge, saddle), ridge), (250.0, 150.0)


def spiral(X, Y):
    c, pitch = np.array([175.0, 150.0]), 30.0
    th = np.arange(0.0, 4.0 * math.pi + 1e-9, 0.05)
    r = 16.0 + pitch * th / (2 * math.pi)
    a = th + math.pi / 2  # the inner end due north of the centre, the mouth 2 turns out
    pts = np.column_stack([c[0] + r * np.cos(a), c[1] + r * np.sin(a)])
    return _cliff_wall(_poly_dist(X, Y, pts), 2.5, 8.0), tuple(c)


def switchback(X, Y):
    z = np.where(X >= 150.0, 12.0, 0.0)  # the escarpment, its sheer face on x = 150
    leg1 = (X >= 124.0) & (X < 136.0) & (Y >= 80.0) & (Y < 120.0)  # 0 -> 6 m going north (8.5 deg)
    z = np.where(leg1, 6.0 * (Y - 80.0) / 40.0, z)
    landing = (X >= 124.0) & (X < 150.0) & (Y >= 120.0) & (Y < 136.0)
    z = np.where(landing, 6.0, z)
    leg2 = (X >= 136.0) & (X < 150.0) & (Y >= 76.0) & (Y < 120.0)  # 6 -> 12 m going south (11 deg), then level
    return np.where(leg2, 6.0 + 6.0 * np.clip((120.0 - Y) / 30.0, 0.0, 1.0), z), (240.0, 150.0)  # onto the top


def nested_u(X, Y):
    outer = [(85.0, 55.0), (205.0, 55.0), (205.0, 245.0), (85.0, 245.0)]
    inner = [(120.0, 105.0), (165.0, 105.0), (165.0, 195.0), (120.0, 195.0)]
    return np.maximum(_steep_ridge(_poly_dist(X, Y, outer), 12.0),
                      _steep_ridge(_poly_dist(X, Y, inner), 12.0)), (262.0, 150.0)


def comb(X, Y):
    wall = _poly_dist(X, Y, [(150.0, 40.0), (150.0, 330.0)])  # the gap: south of y 37, at the map's edge
    spurs = np.minimum(_seg_dist(X, Y, (150.0, 120.0), (120.0, 120.0)), _seg_dist(X, Y, (150.0, 180.0), (120.0, 180.0)))
    return _cliff_wall(np.minimum(wall, spurs), 3.0, 10.0), (250.0, 150.0)


def funnel(X, Y):
    v = np.minimum(_seg_dist(X, Y, (90.0, 60.0), (172.0, 140.0)), _seg_dist(X, Y, (90.0, 240.0), (172.0, 152.0)))
    block = _seg_dist(X, Y, (195.0, 120.0), (195.0, 180.0))  # behind the 6 m gap at the V's apex
    return _cliff_wall(np.minimum(v, block), 3.0, 10.0), (250.0, 150.0)


def l_ridges(X, Y):
    z = np.maximum(_steep_ridge(_seg_dist(X, Y, (130.0, 40.0), (130.0, 260.0)), 12.0),
                   _steep_ridge(_seg_dist(X, Y, (130.0, 100.0), (330.0, 100.0)), 12.0))
    return z, (250.0, 150.0)  # round the north end; the south end leads under the east ridge, closed


SHAPES = {f.__name__: f for f in (u_pocket, s_walls, crater, diag_trench, pillars, ridge_saddle, spiral, switchback,
                                  nested_u, comb, funnel, l_ridges)}


def write_dem(name: str, folder) -> Path:
    """Shape ``name``'s DEM as ``folder/name.npz`` (``z`` rows south first, ``x``/``y`` cell centres)."""
    c, (X, Y) = _grid()
    z, _ = SHAPES[name](X, Y)
    p = Path(folder) / f"{name}.npz"
    np.savez(p, z=z, x=c, y=c)
    return p


def shape_config(name: str, folder, image: str = "", robots: int = 20, max_cycles: int = 1000,
                 method: str = METHOD):
    """The scenario of shape ``name`` (its DEM written into ``folder`` if not there yet), ``image``
    "" as built or "ns" its mirror image (terrain, spawn region and target reflected), its TIN built
    by ``method`` (0.5 m error)."""
    p = Path(folder) / f"{name}.npz"
    if not p.exists():
        write_dem(name, folder)
    c, (X, Y) = _grid()
    _, target = SHAPES[name](X[:2, :2], Y[:2, :2])
    cfg = scenario_from_dict({
        "name": f"unseen_{name}", "task": "goal", "max_cycles": max_cycles,
        "terrain": {"source": "dem", "path": p.name, "method": method, "max_error_m": 0.5},
        "robots": {"count": robots, "spawn_region": list(SPAWN)},
        "targets": {"positions": [list(target)], "arrival_radius_m": 8.0},
    }, source=f"bench/apf_unseen.py ({name})", base_dir=str(folder))
    return mirror_scenario(cfg, image) if image else cfg


CLIFF_DEG = 60.0  # steeper: a cliff (the generators' cliff_min_deg for a 30 deg robot); between max_slope_deg
# and this: hillside too steep to drive
GROUND = {"u_pocket": "cliff", "s_walls": "hillside", "crater": "both", "diag_trench": "cliff", "pillars": "cliff",
          "ridge_saddle": "hillside", "spiral": "cliff", "switchback": "cliff", "nested_u": "hillside",
          "comb": "cliff", "funnel": "cliff", "l_ridges": "hillside"}


def solvability(cfg, samples: int = 400) -> dict:
    """``way_m``: the drivable way from the spawn region's centre to the target (the cost-to-go
    field; inf: none); ``corners_m``: the same from the spawn region's corners; ``straight_m``;
    ``blocked``: the share of the straight line's sample points on ground the robots cannot drive
    (a steep triangle, or off the TIN), ``hillside`` and ``cliff`` those of them under and over
    :data:`CLIFF_DEG`."""
    stage = build_stage(cfg)
    field, goal = stage.fields[0], stage.targets[0]
    x0, y0, x1, y1 = stage.spawn_region
    start = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
    line = start + np.linspace(0.0, 1.0, samples)[:, None] * (goal - start)
    tri = stage.world.tin.locate(line)
    slope = np.where(tri < 0, 90.0, stage.world.tin.slope_deg[np.maximum(tri, 0)])
    bad = (tri < 0) | stage.world.steep[np.maximum(tri, 0)]
    corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]])
    return {"way_m": float(field.distance_at(start[None])[0]), "corners_m": field.distance_at(corners),
            "straight_m": float(np.hypot(*(goal - start))), "blocked": float(bad.mean()),
            "hillside": float(np.mean(bad & (slope <= CLIFF_DEG))), "cliff": float(np.mean(bad & (slope > CLIFF_DEG)))}


_ROWS: list = []  # (shape, image, max_cycles, robots, TIN method) per row, set before the worker processes fork
_FOLDER: list = []  # the temporary folder of the DEM files
_ENVS: dict = {}  # row index -> its env, in this process


def _episode(job):
    """One episode ``(row index, policy name, seed)`` with a fresh policy: its Outcome, with the
    timed-out robots' distance-to-go at the start and the end, and their end points."""
    k, name, seed = job
    shape, image, max_cycles, robots, method = _ROWS[k]
    env = _ENVS.get(k)
    if env is None:
        _ENVS.clear()  # one env per process at a time: the rows run one after the other
        env = _ENVS[k] = tse.parallel_env(scenario=shape_config(shape, _FOLDER[0], image, robots, max_cycles,
                                                                method))
    env.reset_arrays(seed=seed)
    field = env.target_fields[0]
    d0 = field.distance_at(env.world_state.positions.copy())
    out = rollout(env, apf.POLICIES[name](env), seed)
    pos = env.world_state.positions.copy()
    out.end = (d0, field.distance_at(pos), pos)
    return out


def _cut(out, horizon: int):
    """``(reasons, steps)`` of ``out`` as if the episode had ended at ``horizon`` steps."""
    late = out.steps > horizon
    return np.where(late, Reason.TIMEOUT, out.reasons), np.minimum(out.steps, horizon)


def _run(rows_jobs, jobs: int):
    if jobs <= 1:
        return [_episode(j) for j in rows_jobs]
    import multiprocessing

    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        return pool.map(_episode, rows_jobs, chunksize=1)


def _stats(outs, horizon: int) -> dict:
    """One row's counts at ``horizon``, the median steps of the robots that arrived (None: none did) and,
    of the timed-out robots, ``where``: how many, the medians of their distance-to-go (the map's) at the
    start and the end, and of their end points x and y (m)."""
    reasons = np.concatenate([_cut(o, horizon)[0] for o in outs])
    steps = np.concatenate([_cut(o, horizon)[1] for o in outs])
    timed = reasons == Reason.TIMEOUT
    ran_out = timed & np.concatenate([o.reasons == Reason.TIMEOUT for o in outs])  # stalled/looping: to its end
    got = reasons == Reason.ARRIVED
    end = [np.concatenate([o.end[k] for o in outs])[timed] for k in range(3)]
    where = [int(timed.sum())] + ([float(np.median(end[0])), float(np.median(end[1])),
                                   float(np.median(end[2][:, 0])), float(np.median(end[2][:, 1]))]
                                  if timed.any() else [])
    return {"n": len(reasons), "arrived": int(got.sum()), "fell": int(np.sum(reasons == Reason.FELL)),
            "timed_out": int(timed.sum()), "battery": int(np.sum(reasons == Reason.BATTERY)),
            "stalled": int(np.concatenate([o.stalled for o in outs])[ran_out].sum()),
            "looping": int(np.concatenate([o.looping for o in outs])[ran_out].sum()),
            "median": float(np.median(steps[got])) if got.any() else None, "where": where}


def run_shape(shape: str, args, cmd: str, method: str = METHOD) -> dict:
    """Both images of ``shape`` (its TIN built by ``method``): the reference at ``args.cap``, the horizon,
    then APF, whose episodes run to twice the horizon (at most the cap). A record (JSON-able):
    ``rows[image][policy]`` the stats of :func:`_stats` at the horizon, ``at_long[image][policy]``
    the robots arrived and fallen by ``long`` steps (twice the horizon, at most the cap), with the run's seeds,
    robots, horizon, command, commit and load averages."""
    seeds = range(args.seeds)
    res, t, load = {}, time.perf_counter(), apf._load()
    geo = POLICY_NAMES[0]
    for image, _ in IMAGES:
        _ROWS.append((shape, image, args.cap, args.robots, method))
        res[(image, geo)] = _run([(len(_ROWS) - 1, geo, s) for s in seeds], args.jobs)
    meds = [_stats(res[(im, geo)], args.cap)["median"] for im, _ in IMAGES]
    horizon = args.cap if None in meds else min(args.cap, 50 * math.ceil(2 * max(meds) / 50))
    long = min(args.cap, 2 * horizon)
    for image, _ in IMAGES:
        _ROWS.append((shape, image, long, args.robots, method))
        res[(image, "apf")] = _run([(len(_ROWS) - 1, "apf", s) for s in seeds], args.jobs)
    print(f"  ({shape}: {time.perf_counter() - t:.0f} s)", flush=True)
    return {"shape": shape, "method": method, "seeds": args.seeds, "robots": args.robots, "cap": args.cap,
            "horizon": horizon, "long": long,
            "command": cmd, "commit": _commit(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
            "load_start": load, "load_end": apf._load(), "seconds": round(time.perf_counter() - t),
            "rows": {image: {name: _stats(res[(image, name)], horizon) for name in POLICY_NAMES}
                     for image, _ in IMAGES},
            "at_long": {image: {name: {k: _stats(res[(image, name)], long)[k] for k in ("arrived", "fell")}
                                for name in POLICY_NAMES} for image, _ in IMAGES}}


def result_rows(records: dict, emit):
    """The table: per shape and policy, its two images side by side (rows one after the other)."""
    emit("| shape | image | policy | seeds x robots | steps | arrived | fell | timed out | battery | stalled "
         "| looping | median steps | twice the steps: arrived | fell |")
    emit("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for shape, rec in records.items():
        for name in POLICY_NAMES:
            for image, label in IMAGES:
                s = rec["rows"][image][name]
                n = s["n"]
                med = "" if s["median"] is None else f"{s['median']:.0f}"
                lg = rec.get("at_long", {}).get(image, {}).get(name)  # records before the long horizon: none
                long = f"{lg['arrived'] / n:.1%} | {lg['fell'] / n:.1%}" if lg else " | "
                emit(f"| {shape} | {label} | {name} | {rec['seeds']} x {rec['robots']} | {rec['horizon']} | "
                     f"{s['arrived'] / n:.1%} | {s['fell'] / n:.1%} | {s['timed_out'] / n:.1%} | "
                     f"{s['battery'] / n:.1%} | {s['stalled'] / n:.1%} | {s['looping'] / n:.1%} | {med} | {long} |")
    emit("")
    for method in sorted({rec.get("method", METHOD) for rec in records.values()}, key=lambda m: m != METHOD):
        recs = [rec for rec in records.values() if rec.get("method", METHOD) == method]
        for name in POLICY_NAMES:
            emit(_total_line(recs, name, "all shapes and images" if method == METHOD else f"on the {method} TIN"))


def _total_line(recs: list, name: str, what: str) -> str:
    """Policy ``name``'s robots arrived and fallen over the records ``recs``, at the horizon and at twice it."""
    tot = [rec["rows"][image][name] for rec in recs for image, _ in IMAGES]
    n, got = sum(s["n"] for s in tot), sum(s["arrived"] for s in tot)
    lg = [rec["at_long"][image][name] for rec in recs if "at_long" in rec for image, _ in IMAGES]
    n2 = sum(rec["rows"][image][name]["n"] for rec in recs if "at_long" in rec for image, _ in IMAGES)
    long = (f"; by twice the steps (shapes run so): {sum(s['arrived'] for s in lg)} / {n2} "
            f"({sum(s['arrived'] for s in lg) / max(n2, 1):.1%}), {sum(s['fell'] for s in lg)} fell") if lg else ""
    return (f"- **{name}**, {what}: {got} / {n} robots arrived ({got / max(n, 1):.1%}), "
            f"{sum(s['fell'] for s in tot)} fell{long}.")


def where_rows(records: dict, emit):
    """Per shape and image, APF robots that timed out: how many, their median distance-to-go (the
    map's) at the start and at the end, and their median end point."""
    emit("\nAPF robots that timed out: distance-to-go on the map (m, median) at the start and at the end, and "
         "their median end point (x, y) m; rows with none left out")
    emit("| shape | image | timed out | distance-to-go at start | at end | end point (median) |")
    emit("|---|---|---:|---:|---:|---|")
    for shape, rec in records.items():
        for image, label in IMAGES:
            w = rec["rows"][image]["apf"]["where"]
            if w[0]:
                emit(f"| {shape} | {label} | {w[0]} | {w[1]:.0f} | {w[2]:.0f} | ({w[3]:.0f}, {w[4]:.0f}) |")


def runs_rows(records: dict, emit):
    emit("\nThe runs (one per shape where the bench ran shape by shape, `--parts`):\n")
    for shape, rec in records.items():
        emit(f"- {shape}: `{rec['command']}` at commit {rec['commit']}, {rec['date']}, load average "
             f"{rec['load_start']} at the start, {rec['load_end']} at the end, {rec['seconds']} s.")


def _commit() -> str:
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          check=False).stdout.strip() or "?"


def label(shape: str, method: str = METHOD) -> str:
    """A shape's name in the tables: with its TIN method where that is not the default's."""
    return shape if method == METHOD else f"{shape} ({method} TIN)"


def _record(shape: str, args, cmd: str, method: str = METHOD) -> dict:
    """Shape ``shape``'s record: read from ``args.parts`` when there (``<shape>.json``, or
    ``<shape>@<method>.json`` for another TIN method), else run (and saved there)."""
    name = shape if method == METHOD else f"{shape}@{method}"
    part = Path(args.parts) / f"{name}.json" if args.parts else None
    if part is not None and part.exists():
        return json.loads(part.read_text())
    rec = run_shape(shape, args, cmd, method)
    if part is not None:
        part.parent.mkdir(parents=True, exist_ok=True)
        tmp = part.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(rec, indent=1) + "\n")
        tmp.replace(part)
    return rec


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=apf._at_least(1), default=10, help="episodes per shape, image and policy")
    p.add_argument("--robots", type=apf._at_least(1), default=20, help="robots per episode (default 20)")
    p.add_argument("--cap", type=apf._at_least(1), default=2500, metavar="N",
                   help="the reference's episode length; the horizon is twice its median steps, at most this")
    p.add_argument("--only", type=lambda s: s.split(","), default=None,
                   help=f"comma-separated shapes of {list(SHAPES)}, each optionally as shape@method (its TIN "
                        "built by that method instead of --method's)")
    p.add_argument("--parts", default=None, metavar="DIR",
                   help="shape by shape: a shape's results are read from DIR/<shape>.json when there, else run and "
                        "saved there (run each shape with --only, then once without to write the whole table)")
    p.add_argument("--jobs", type=int, default=1, help="processes for the episodes (results do not depend on it)")
    p.add_argument("--method", default=METHOD, choices=METHODS,
                   help=f"the shapes' TIN builder ([terrain] method; default {METHOD}): rows labelled with it")
    p.add_argument("--quick", action="store_true", help=f"a smoke run ({QUICK}); prints only, unless --out is given")
    p.add_argument("--out", default=None, help="Markdown file (default docs/figures/apf_unseen.md; none with --quick "
                                                "or with --parts and --only)")
    args = p.parse_args(argv)
    if args.quick:
        args.only = args.only or QUICK["only"]
        for k in ("seeds", "robots", "cap"):
            setattr(args, k, min(getattr(args, k), QUICK[k]))
    shapes = [(s.partition("@")[0], s.partition("@")[2] or args.method) for s in args.only or SHAPES]
    bad = [s for s, _ in shapes if s not in SHAPES]
    if bad:
        p.error(f"--only: unknown shape(s) {bad}; choose from {','.join(SHAPES)}")
    bad = [m for _, m in shapes if m not in METHODS]
    if bad:
        p.error(f"--only: unknown TIN method(s) {bad} after '@'; choose from {','.join(METHODS)}")
    out = args.out if args.out is not None else (None if args.quick or (args.parts and args.only) else
                                                 str(ROOT / "docs" / "figures" / "apf_unseen.md"))
    cmd = shlex.join(["python", "bench/apf_unseen.py", *argv])  # quoted: the line can be run as it stands
    lines = [f"Written by `{cmd}` at commit {_commit()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
             f"load average {apf._load()} at the start ({os.cpu_count()} cores, shared); each shape's own run is "
             "listed at the end.", ""]

    def emit(line=""):
        print(line, flush=True)
        lines.append(line)

    emit(f"Seeds x robots per shape, image and policy: in the table (default {args.seeds} x {args.robots}). "
         "Episode length (steps): twice the reference's median steps to arrive on the shape (the larger image's), "
         f"rounded up to 50, at most the cap ({args.cap}); the reference ran cap-step episodes, scored at that "
         "horizon. battery: ran flat; stalled and looping: of the timed out that ran to the end; median steps: "
         "of the robots that arrived; twice the steps: both scored at twice the episode length, to which APF's "
         "episodes run on (at most the cap).\n")
    with tempfile.TemporaryDirectory(prefix="apf_unseen_") as folder:
        _FOLDER[:] = [folder]
        emit("The shapes: the drivable way from the spawn region's centre to the target (the cost-to-go field) "
             "against the straight line, and the share of the straight line on ground the robots cannot drive, "
             f"hillside ({STEEP_DEG:.0f} deg; up to {CLIFF_DEG:.0f}) and cliff (steeper).\n")
        emit("| shape | ground | way / straight line | straight line blocked: hillside | cliff |")
        emit("|---|---|---:|---:|---:|")
        for shape, method in shapes:
            sol = solvability(shape_config(shape, folder, method=method))
            emit(f"| {label(shape, method)} | {GROUND[shape]} | {sol['way_m']:.0f} m / {sol['straight_m']:.0f} m | "
                 f"{sol['hillside']:.1%} | {sol['cliff']:.1%} |")
        emit("")
        records = {label(shape, method): _record(shape, args, cmd, method) for shape, method in shapes}
    result_rows(records, emit)
    where_rows(records, emit)
    runs_rows(records, emit)
    emit(f"\nLoad average at the end: {apf._load()}.")
    if out:
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out) as tmp:  # the whole file or nothing
            Path(tmp).write_text("\n".join(lines) + "\n")
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
