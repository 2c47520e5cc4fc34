"""Does the default TIN keep the unseen shapes' drivable ways open? The nine shapes of
``bench/apf_unseen.py`` (2 m cells, robots' limit 30 deg), each reduced by the scenario's default
builder (``greedy``, 0.5 m vertical error) and by the robot-aware one (``robot``, the same error),
scored with issue 45's measures (``bench/terrain.py``'s :class:`TrustReference`, defined there once)
against the full-resolution surface, with the noise floor (the other diagonal) beside them; then,
per shape, the drivable way from the bench's spawn centre to its target on each TIN (the cost-to-go
field over its drivable triangles: a point robot) against the full surface's, and the ground the TIN
*narrows*: where the full surface leaves a robot room (at least OPEN_M to steep ground) and the TIN
puts steep ground within CLOSED_M (a steep sliver across a pass or a ramp's mouth).

    python research/unseen_tin.py [--only crater,...] [--out research/unseen_tin.md]

Run from the repository root. Seconds per shape.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import distance_transform_edt

from tin_swarm_env.scenario.build import build_stage
from tin_swarm_env.terrain import load_dem

ROOT = Path(__file__).resolve().parents[1]
SLOPE_DEG = 30.0  # the robots' default max_slope_deg, the shapes' limit
METHODS = ("greedy", "robot")


def _module(name: str, path: Path):
    mod = sys.modules.get(name)
    if mod is None:
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
    return mod


UNSEEN = _module("bench_apf_unseen", ROOT / "bench" / "apf_unseen.py")
TERRAIN = _module("bench_terrain", ROOT / "bench" / "terrain.py")


RASTER_M = 0.5  # the clearance raster's cell
OPEN_M, CLOSED_M = 2.0, 0.5  # ground the full surface leaves this far from steep ground, the TIN this near


def _clearance(tin, xs, ys, slope_deg):
    """Distance (m) from each raster point ``(ys, xs)`` (on ``tin``) to the nearest raster point where
    ``tin`` is steeper than ``slope_deg``."""
    X, Y = np.meshgrid(xs, ys)
    steep = tin.slope_at(np.column_stack([X.ravel(), Y.ravel()])) > slope_deg
    if not steep.any():  # no steep ground in the raster: room everywhere
        return np.full(X.shape, np.inf)
    return distance_transform_edt(~steep.reshape(X.shape)) * RASTER_M


def narrowed(tin, full, slope_deg: float, dem) -> tuple[float, float]:
    """Plan area (m^2) of ground where the full surface leaves at least OPEN_M to steep ground and
    ``tin`` at most CLOSED_M (a steep sliver of the TIN on open ground: a pass narrowed or shut), and
    the share of the full surface's open ground (clearance >= OPEN_M) it is."""
    xs = np.arange(dem.x[0], dem.x[-1], RASTER_M)
    ys = np.arange(dem.y[0], dem.y[-1], RASTER_M)
    c_full, c_tin = _clearance(full, xs, ys, slope_deg), _clearance(tin, xs, ys, slope_deg)
    open_ = c_full >= OPEN_M
    bad = open_ & (c_tin <= CLOSED_M)
    return float(bad.sum() * RASTER_M ** 2), float(bad.sum() / max(open_.sum(), 1))


def shape_rows(shape: str, folder, rng) -> list[dict]:
    path = UNSEEN.write_dem(shape, folder)
    dem = load_dem(path)
    cfg = UNSEEN.shape_config(shape, folder)
    x0, y0, x1, y1 = cfg.robots.spawn_region
    start = np.array([[(x0 + x1) / 2, (y0 + y1) / 2]])
    goal = np.asarray(cfg.targets.positions[0], float)
    ref = TERRAIN.TrustReference(dem, SLOPE_DEG, rng)
    full = ref.full
    rows = []
    for name, tin in [("noise floor (other diagonal)", ref.other), *[(m, None) for m in METHODS]]:
        t = time.perf_counter()
        if tin is None:  # the scenario's own TIN (what the bench's robots drive on)
            tin = build_stage(UNSEEN.shape_config(shape, folder, method=name)).world.tin
        secs = time.perf_counter() - t
        way = float(ref.surface_distance(tin, goal, start)[0])
        area, share = narrowed(tin, full, SLOPE_DEG, dem)
        rows.append({"shape": shape, "tin": name, "vertices": len(tin.vertices), "secs": secs, **ref.score(tin),
                     "way": way, "narrowed_m2": area, "narrowed": share})
    rows.insert(0, {"shape": shape, "tin": "full surface", "way": float(ref.surface_distance(full, goal, start)[0])})
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--only", type=lambda s: s.split(","), default=None, help=f"shapes of {list(UNSEEN.SHAPES)}")
    p.add_argument("--out", default=str(ROOT / "research" / "unseen_tin.md"))
    a = p.parse_args(argv)
    shapes = a.only or list(UNSEEN.SHAPES)
    bad = [s for s in shapes if s not in UNSEEN.SHAPES]
    if bad:
        p.error(f"--only: unknown shape(s) {bad}")
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, check=False).stdout.strip() or "?"
    load = " / ".join(f"{x:.2f}" for x in os.getloadavg())
    lines = [f"Measured with `python research/unseen_tin.py{' ' + ' '.join(argv or sys.argv[1:]) if (argv or sys.argv[1:]) else ''}` "
             f"at commit {commit}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {load} "
             "(2 cores, shared).", "",
             f"The shapes of `bench/apf_unseen.py`, robots' limit {SLOPE_DEG:.0f} deg; slope class, cost-to-go and "
             "reachability as in `bench/terrain.py` (issue 45's measures); way: the drivable way from the spawn "
             "centre to the target on that surface (a point robot: inf, none); narrowed: ground the full surface "
             f"leaves at least {OPEN_M:g} m from steep ground and the TIN at most {CLOSED_M:g} m (a steep sliver "
             f"on open ground; {RASTER_M:g} m raster), plan area and share of the full surface's open ground.", "",
             "| shape | surface | vertices | slope class | cost-to-go error median / p90 | reachability | "
             "line of sight | way (m) | narrowed (m^2) | narrowed share | build (s) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    rng = np.random.default_rng(0)
    with tempfile.TemporaryDirectory() as folder:
        for shape in shapes:
            for r in shape_rows(shape, folder, rng):
                if r["tin"] == "full surface":
                    lines.append(f"| {shape} | full surface | | | | | | {r['way']:.0f} | | | |")
                else:
                    lines.append(f"| {shape} | {r['tin']} | {r['vertices']} | {r['slope']:.1%} | "
                                 f"{r['ctg_med']:.1%} / {r['ctg_p90']:.1%} | {r['reach']:.1%} | {r['los']:.1%} | "
                                 f"{r['way']:.0f} | {r['narrowed_m2']:.0f} | {r['narrowed']:.2%} | {r['secs']:.2f} |")
                print(lines[-1], flush=True)
    Path(a.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
