"""Terrain benchmark on the real jacksboro DEM (matplotlib's sample). Run by hand:

    python bench/terrain.py [--sizes 1000,2000,5000,10000,20000] [--rays 10000]
    python bench/terrain.py --quick     # a smoke run (seconds): one 1000-vertex size, 500 rays
    python bench/terrain.py --robot [--write]     # what robots use: VIP, greedy, robot at 2/5/10 %

``--robot`` (see :func:`robot_tables`) measures, per DEM (jacksboro, jacksboro transposed and
mirrored, a generated terrain), VIP, greedy and the robot builder at 2 %, 5 % and 10 % of the cells
against the full-resolution surface (:func:`tin_swarm_env.terrain.robot.full_surface`: every cell
centre a vertex, two triangles per cell, SW-NE diagonals) and prints: slope-class agreement at
random points; cost-to-go agreement (within 5 %) from random goals; line-of-sight agreement on
clear-cut rays; vertical RMS; build time. ``--write`` writes the tables to docs/figures/terrain_robot.md.

Prints, per method and vertex budget: triangles, max and RMS vertical error against every DEM
cell, build time, bytes per triangle, and the line-of-sight fidelity (share of random
robot-scale rays, <= 2 km long, 2 m above ground, on which the TIN agrees with a dense march
over the full DEM). Then pydelatin/hmm and pymartini run directly, side by side, and the
query speeds: locate for 1e5 points (cold, through the bucket grid, and walking from a hint
one step away) and line_of_sight for 1e5 pairs on a 20k-triangle TIN, each against the
brute-force reference as a ratio, in the same process.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.terrain import build_tin, reference, vertical_error


@dataclass
class Args:
    sizes: tuple = (1000, 2000, 5000, 10000, 20000)
    rays: int = 10_000
    queries: int = 100_000
    seed: int = 0


def timed(fn, repeat=3):
    best = np.inf
    out = None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return out, best


# -- line-of-sight ground truth over the DEM -----------------------------------------------


def dem_height(dem, xy):
    """Bilinear interpolation of the DEM at cell-centre coordinates."""
    fx = np.clip((xy[:, 0] - dem.x[0]) / dem.dx, 0, dem.shape[1] - 1 - 1e-9)
    fy = np.clip((xy[:, 1] - dem.y[0]) / dem.dy, 0, dem.shape[0] - 1 - 1e-9)
    i, j = fy.astype(int), fx.astype(int)
    u, v = fx - j, fy - i
    z = dem.z
    return ((1 - u) * (1 - v) * z[i, j] + u * (1 - v) * z[i, j + 1]
            + (1 - u) * v * z[i + 1, j] + u * v * z[i + 1, j + 1])


def dem_los(dem, a, b, step_m):
    """Dense march: visible iff the sight line is above the bilinear DEM at every sample."""
    out = np.empty(len(a), dtype=bool)
    for s in range(0, len(a), 500):
        A, B = a[s:s + 500], b[s:s + 500]
        L = np.linalg.norm(B[:, :2] - A[:, :2], axis=1)
        n = int(np.ceil(L.max() / step_m)) + 2
        t = np.linspace(0, 1, n)[1:-1]
        P = A[:, None, :] + t[None, :, None] * (B - A)[:, None, :]
        g = dem_height(dem, P[..., :2].reshape(-1, 2)).reshape(P.shape[:2])
        out[s:s + 500] = np.all(P[..., 2] >= g, axis=1)
    return out


def random_rays(dem, n, rng, max_len=2000.0, min_len=0.0):
    x0, x1, y0, y1 = dem.x[0], dem.x[-1], dem.y[0], dem.y[-1]
    a = np.empty((0, 2))
    b = np.empty((0, 2))
    while len(a) < n:
        p = rng.uniform([x0, y0], [x1, y1], (2 * n, 2))
        ang = rng.uniform(0, 2 * np.pi, 2 * n)
        L = rng.uniform(min_len, max_len, 2 * n)
        q = p + L[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
        ok = (q[:, 0] >= x0) & (q[:, 0] <= x1) & (q[:, 1] >= y0) & (q[:, 1] <= y1)
        a, b = np.vstack([a, p[ok]]), np.vstack([b, q[ok]])
    return a[:n], b[:n]


def fidelity(tin, a, b, truth, h=2.0):
    A = np.column_stack([a, tin.height_at(a) + h])
    B = np.column_stack([b, tin.height_at(b) + h])
    return float(np.mean(tin.line_of_sight(A, B) == truth))


# -- competitors run directly ---------------------------------------------------------------


def hmm_direct(dem, n):
    from pydelatin import Delatin

    z = np.ascontiguousarray(dem.z[::-1], dtype=np.float32)
    (d, dt) = timed(lambda: Delatin(z, width=dem.shape[1], height=dem.shape[0], max_error=0.0, max_points=n), 1)
    return len(d.vertices), len(d.triangles), float(d.error), dt


def martini_tin(dem, n_target):
    """pymartini (RTIN, square 2^k+1 grids): jacksboro padded by edge replication to 513x513;
    the error threshold is bisected to land near ``n_target`` vertices. Vertices in the pad
    count too (the pad is flat, so it costs few)."""
    import pymartini

    rows, cols = dem.shape
    size = 513
    zp = np.pad(dem.z, ((0, size - rows), (0, size - cols)), mode="edge").astype(np.float32)
    t0 = time.perf_counter()
    m = pymartini.Martini(size)
    tile = m.create_tile(zp)
    lo, hi = 0.0, 500.0
    best = None
    for _ in range(30):
        e = 0.5 * (lo + hi)
        v, t = tile.get_mesh(e)
        nv = np.asarray(v).size // 2
        best = (e, v, t)
        if abs(nv - n_target) <= 0.01 * n_target:
            break
        if nv > n_target:
            lo = e
        else:
            hi = e
    dt = time.perf_counter() - t0
    e, v, t = best
    v = np.asarray(v).reshape(-1, 2).astype(np.int64)  # (col, row) in the padded grid
    col, row = v[:, 0], v[:, 1]
    x = dem.x[0] + dem.dx * col
    y = dem.y[0] + dem.dy * row
    z = zp[row, col].astype(np.float64)
    tin = tse.terrain.Tin(np.column_stack([x, y, z]), np.asarray(t).reshape(-1, 3), source="martini")
    return tin, dt


def main(args: Args):
    rng = np.random.default_rng(args.seed)
    dem = tse.terrain.sample_dem("jacksboro")
    print(f"{dem!r}\n")
    a, b = random_rays(dem, args.rays, rng)
    step = 0.25 * min(dem.dx, dem.dy)
    gz_a, gz_b = dem_height(dem, a) + 2.0, dem_height(dem, b) + 2.0
    truth = dem_los(dem, np.column_stack([a, gz_a]), np.column_stack([b, gz_b]), step)
    print(f"line-of-sight truth: {len(a)} rays <= 2 km, 2 m above the bilinear DEM, marched every "
          f"{step:.1f} m; {truth.mean():.1%} visible\n")

    variants = [
        ("vip (thesis: no border, no backbone)", dict(method="vip", border="none", backbone=0.0)),
        ("vip border=line backbone=0", dict(method="vip", backbone=0.0)),
        ("vip default (backbone 0.5)", dict(method="vip")),
        ("lattice (backbone ~1)", dict(method="vip", backbone=0.999)),
        ("greedy (pydelatin/hmm)", dict(method="greedy")),
        ("greedy, Delaunay re-triangulated", dict(method="greedy", delaunay=True)),
    ]
    hdr = (f"{'method':38s} {'verts':>6s} {'tris':>6s} {'max m':>7s} {'rms m':>6s} {'build s':>8s} "
           f"{'B/tri':>6s} {'LOS fid':>7s}")
    print(hdr)
    print("-" * len(hdr))
    rms_at = {}
    for n in args.sizes:
        for name, kw in variants:
            tin, dt = timed(lambda n=n, kw=kw: build_tin(dem, max_vertices=n, **kw), 1)
            st, _ = vertical_error(tin, dem)
            fid = fidelity(tin, a, b, truth)
            rms_at[(name, n)] = st.rms_m
            print(f"{name:38s} {tin.n_vertices:6d} {tin.n_triangles:6d} {st.max_m:7.1f} {st.rms_m:6.2f} "
                  f"{dt:8.3f} {tin.nbytes / tin.n_triangles:6.0f} {fid:7.1%}")
        hv, ht, he, hdt = hmm_direct(dem, n)
        print(f"{'  pydelatin direct (index space)':38s} {hv:6d} {ht:6d} {he:7.1f} {'':6s} {hdt:8.3f}")
        try:
            mt, mdt = martini_tin(dem, n)
        except ImportError:
            print(f"{'  pymartini':38s} not installed (pip install pymartini)")
        else:
            st, _ = vertical_error(mt, dem)
            print(f"{'  pymartini (513x513 padded grid)':38s} {mt.n_vertices:6d} {mt.n_triangles:6d} "
                  f"{st.max_m:7.1f} {st.rms_m:6.2f} {mdt:8.3f} {'':6s} {fidelity(mt, a, b, truth):7.1%}")
        print()
    if 50_000 not in args.sizes:
        tin = build_tin(dem, method="greedy", max_vertices=50_000)
        print(f"greedy at 50k vertices: LOS fidelity {fidelity(tin, a, b, truth):.1%}\n")
    if 10000 in args.sizes:
        g = rms_at[("greedy (pydelatin/hmm)", 10000)]
        for name, _ in variants:
            if name == "greedy (pydelatin/hmm)":
                continue
            print(f"RMS at 10k vertices, {name}: {rms_at[(name, 10000)] / g:.2f}x greedy/hmm")
        print()

    # -- query speed ---------------------------------------------------------------------
    tin = build_tin(dem, method="greedy", max_vertices=10_100)
    bucket_bytes = tin.index_nbytes
    print(f"queries on {tin!r}; bucket index {bucket_bytes / tin.n_triangles:.0f} B/tri")
    n = args.queries
    x0, y0, x1, y1 = tin.bounds
    xy = rng.uniform([x0, y0], [x1, y1], (n, 2))
    tin.locate(xy[:10])
    t_idx, dt_cold = timed(lambda: tin.locate(xy))
    moved = np.clip(xy + rng.normal(0, 5.0, xy.shape), [x0, y0], [x1, y1])  # a robot's step
    tin.locate(moved[:10], hint=t_idx[:10])
    _, dt_walk = timed(lambda: tin.locate(moved, hint=t_idx))
    m = 2000
    _, dt_ref = timed(lambda: reference.locate_brute(tin, xy[:m]), 1)
    print(f"locate {n} points, bucket grid : {dt_cold * 1e3:8.2f} ms  {n / dt_cold:12.3e} points/s "
          f"({dt_ref / m / (dt_cold / n):.0f}x brute force)")
    print(f"locate {n} points, walk from hint: {dt_walk * 1e3:8.2f} ms  {n / dt_walk:12.3e} points/s")
    ra, rb = random_rays(dem, n, rng)
    A = np.column_stack([ra, tin.height_at(ra) + 2.0])
    B = np.column_stack([rb, tin.height_at(rb) + 2.0])
    tin.line_of_sight(A[:10], B[:10])
    vis, dt_los = timed(lambda: tin.line_of_sight(A, B))
    m = 300
    _, dt_lref = timed(lambda: reference.line_of_sight_brute(tin, A[:m], B[:m]), 1)
    print(f"line_of_sight {n} pairs <= 2 km: {dt_los * 1e3:8.2f} ms  {n / dt_los:12.3e} pairs/s "
          f"({dt_los / n * 1e9:.0f} ns/ray; {dt_lref / m / (dt_los / n):.0f}x brute force); {vis.mean():.1%} visible")


# -- what robots use: slope class, cost-to-go, line of sight -----------------------------------


SLOPE_DEG = 20.0  # the jacksboro scenario's max_slope_deg
CLEAR_M = 1.0  # a ray is clear-cut when its sight line clears, or dips below, the bilinear DEM by more
EYE_M = 2.0  # sight line endpoints above the ground
FAR_M = 2000.0  # cost-to-go is compared at points farther than this from the goal


def march_clearance(dem, a_xyz, b_xyz, step_m):
    """min over a dense march of (sight line z - bilinear DEM z), per ray, m."""
    out = np.empty(len(a_xyz))
    for s in range(0, len(a_xyz), 500):
        A, B = a_xyz[s:s + 500], b_xyz[s:s + 500]
        L = np.linalg.norm(B[:, :2] - A[:, :2], axis=1)
        n = int(np.ceil(L.max() / step_m)) + 2
        t = np.linspace(0, 1, n)[1:-1]
        P = A[:, None, :] + t[None, :, None] * (B - A)[:, None, :]
        g = dem_height(dem, P[..., :2].reshape(-1, 2)).reshape(P.shape[:2])
        out[s:s + 500] = np.min(P[..., 2] - g, axis=1)
    return out


def uniform_points(dem, n, rng):
    return rng.uniform([dem.x[0], dem.y[0]], [dem.x[-1], dem.y[-1]], (n, 2))


class RobotReference:
    """The full-resolution surface of ``dem`` and the sample points every TIN is scored on.

    * slope class: ``n_points`` uniform random points; class = slope > ``SLOPE_DEG`` of the
      triangle holding the point, on the TIN and on the full surface.
    * cost-to-go: ``n_goals`` uniform random goals on drivable ground of the full surface;
      ``n_ctg`` uniform random points each, kept where farther than ``FAR_M`` from the goal and
      reachable on the full surface (``tse.terrain.cost_to_go`` with ``passable = slope <=
      SLOPE_DEG``); a point agrees when the TIN's distance is within 5 % of the full surface's
      (unreachable on the TIN: disagrees).
    * line of sight: ``n_rays`` rays 0.2-2 km long, endpoints ``EYE_M`` above the ground (the
      bilinear DEM for the truth, each TIN's own height for the TIN); truth from a march every
      quarter cell over the bilinear DEM; only clear-cut rays (clearance beyond ``CLEAR_M``)
      are scored.
    """

    def __init__(self, dem, rng, n_points=20_000, n_goals=16, n_ctg=1500, n_rays=5000):
        from tin_swarm_env.terrain.robot import full_surface

        self.dem = dem
        self.full = full_surface(dem)
        self.pts = uniform_points(dem, n_points, rng)
        self.cls = self.full.slope_at(self.pts) > SLOPE_DEG
        passable = self.full.slope_deg <= SLOPE_DEG
        self.fields = []
        tries = 0
        while len(self.fields) < n_goals and tries < 50 * n_goals:
            tries += 1
            g = uniform_points(dem, 1, rng)[0]
            if self.full.slope_at(g[None])[0] > SLOPE_DEG:
                continue
            p = uniform_points(dem, n_ctg, rng)
            p = p[np.hypot(*(p - g).T) > FAR_M]
            d = tse.terrain.cost_to_go(self.full, g, passable).distance_at(p)
            if np.isfinite(d).sum():
                self.fields.append((g, p[np.isfinite(d)], d[np.isfinite(d)]))
        a, b = random_rays(dem, n_rays, rng, min_len=200.0)
        A = np.column_stack([a, dem_height(dem, a) + EYE_M])
        B = np.column_stack([b, dem_height(dem, b) + EYE_M])
        c = march_clearance(dem, A, B, 0.25 * min(dem.dx, dem.dy))
        clear = np.abs(c) > CLEAR_M
        self.ra, self.rb, self.vis = a[clear], b[clear], c[clear] > 0
        self.n_rays = n_rays

    def score(self, tin):
        slope = float(np.mean((tin.slope_at(self.pts) > SLOPE_DEG) == self.cls))
        passable = tin.slope_deg <= SLOPE_DEG
        hit = n = 0
        for g, p, d in self.fields:
            dt = tse.terrain.cost_to_go(tin, g, passable).distance_at(p)
            hit += int(np.sum(np.abs(dt - d) <= 0.05 * d))
            n += len(p)
        A = np.column_stack([self.ra, tin.height_at(self.ra) + EYE_M])
        B = np.column_stack([self.rb, tin.height_at(self.rb) + EYE_M])
        los = float(np.mean(tin.line_of_sight(A, B) == self.vis))
        st, _ = vertical_error(tin, self.dem)
        return {"slope": slope, "ctg": hit / max(n, 1), "los": los, "rms": st.rms_m}


def other_diagonal(dem):
    """Every cell centre a vertex, the other (NW-SE) diagonal in every square: the noise floor."""
    rows, cols = dem.shape
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (i * cols + j).ravel()
    b, c, d = a + 1, a + cols + 1, a + cols
    tri = np.stack([np.column_stack([a, b, d]), np.column_stack([b, c, d])], 1).reshape(-1, 3)
    return tse.terrain.Tin(np.column_stack([dem.cell_centres(), dem.z.ravel()]), tri, source="other diagonal")


def generated_dem(seed=3, shape=(240, 300), cell_m=40.0, steep_share=0.25):
    """A seeded terrain nobody tuned on: octaves of smoothed noise plus sharp ridges (|noise|
    folded), scaled so ``steep_share`` of the full surface is steeper than ``SLOPE_DEG``."""
    from scipy import ndimage

    from tin_swarm_env.terrain.robot import full_surface_slope_deg

    rng = np.random.default_rng(seed)
    z = np.zeros(shape)
    for sigma, amp in ((40, 1.0), (16, 0.5), (6, 0.25), (2, 0.1)):
        n = ndimage.gaussian_filter(rng.normal(size=shape), sigma)
        n /= n.std()
        z += amp * (np.abs(n) if sigma == 16 else n)  # the folded octave: ridges and gullies
    y = np.arange(shape[0]) * cell_m
    x = np.arange(shape[1]) * cell_m
    lo, hi = 1.0, 1e4
    for _ in range(40):  # bisect the vertical scale for the steep share
        mid = np.sqrt(lo * hi)
        share = np.mean(full_surface_slope_deg(tse.terrain.Dem(z * mid, x, y)) > SLOPE_DEG)
        lo, hi = (mid, hi) if share < steep_share else (lo, mid)
    return tse.terrain.Dem(z * lo, x, y, source=f"generated(seed={seed})")


def robot_dems():
    j = tse.terrain.sample_dem("jacksboro")
    # transposed and mirrored: rows become columns (cells 92.5 m east-west), then east-west flipped
    jt = tse.terrain.Dem(j.z.T[:, ::-1], j.y, j.x, source="jacksboro transposed+mirrored")
    return [j, jt, generated_dem()]


def _row(rows, ref, name, tin, dt=None, ratio=None):
    sc = ref.score(tin)
    t = "" if dt is None else f"{dt:.3f}"
    r = "" if ratio is None else f"{ratio:.1f}"
    rows.append(f"| {name} | {tin.n_vertices} | {sc['slope']:.1%} | {sc['ctg']:.1%} | {sc['los']:.1%} | "
                f"{sc['rms']:.2f} | {t} | {r} |")
    print(rows[-1], flush=True)


def robot_tables(fractions=(0.02, 0.05, 0.10), seed=0, write=False):
    import os
    import sys

    rng = np.random.default_rng(seed)
    methods = [("vip", {"method": "vip"}), ("greedy", {"method": "greedy"}),
               ("robot", {"method": "robot", "max_slope_deg": SLOPE_DEG})]
    lines = [f"Written by `python bench/terrain.py {' '.join(sys.argv[1:])}`; load average "
             f"{os.getloadavg()[0]:.2f} at the start. Slope class at {SLOPE_DEG:g} deg; agreement with the "
             "full-resolution surface (every cell centre a vertex, SW-NE diagonals); definitions: "
             "`RobotReference` in bench/terrain.py. 'other diagonal' is the same full surface with the "
             "other diagonal in every cell: the noise floor of these measures. Build time: best of 3, "
             "seconds, same process; ratio to greedy at the same vertex count.", ""]
    for dem in robot_dems():
        ref = RobotReference(dem, rng)
        n_cells = dem.z.size
        head = (f"### {dem.source} ({dem.shape[0]}x{dem.shape[1]} cells; {len(ref.fields)} goals, "
                f"{sum(len(p) for _, p, _ in ref.fields)} cost-to-go points, {len(ref.ra)} clear-cut rays "
                f"of {ref.n_rays})")
        rows = [head, "", "| TIN | vertices | slope class | cost-to-go within 5% | line of sight | RMS m | build s "
                "| x greedy |", "|---|---|---|---|---|---|---|---|"]

        print(head, flush=True)
        _row(rows, ref, "full surface", ref.full)
        _row(rows, ref, "other diagonal", other_diagonal(dem))
        for f in fractions:
            n = int(round(f * n_cells))
            times = {}
            for name, kw in methods:
                build_tin(dem, max_vertices=min(n, 200), **kw)  # compile / warm up
                tin, dt = timed(lambda kw=kw, dem=dem, n=n: build_tin(dem, max_vertices=n, **kw), 3)
                times[name] = dt
                _row(rows, ref, f"{name} {f:.0%}", tin, dt, dt / times["greedy"] if "greedy" in times else None)
        lines += rows + [""]
    text = "\n".join(lines)
    if write:
        from pathlib import Path

        out = Path(__file__).resolve().parents[1] / "docs" / "figures" / "terrain_robot.md"
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_suffix(".md.tmp")
        tmp.write_text(text)
        tmp.replace(out)
        print(f"wrote {out}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robot", action="store_true", help="only the robot tables (slope, cost-to-go, LOS)")
    p.add_argument("--write", action="store_true", help="with --robot: write docs/figures/terrain_robot.md")
    p.add_argument("--sizes", default="1000,2000,5000,10000,20000")
    p.add_argument("--rays", type=int, default=10_000)
    p.add_argument("--queries", type=int, default=100_000)
    p.add_argument("--quick", action="store_true", help="a smoke run (seconds): size 1000, 500 rays, 10 000 queries")
    ns = p.parse_args()
    if ns.robot:
        robot_tables(write=ns.write)
        raise SystemExit(0)
    if ns.quick:
        main(Args(sizes=(1000,), rays=500, queries=10_000))
    else:
        main(Args(sizes=tuple(int(s) for s in ns.sizes.split(",")), rays=ns.rays, queries=ns.queries))
