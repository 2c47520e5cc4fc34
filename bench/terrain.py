"""Terrain benchmark on the real jacksboro DEM (matplotlib's sample). Run by hand:

    python bench/terrain.py [--sizes 1000,2000,5000,10000,20000] [--rays 10000] [--quick]

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


def random_rays(dem, n, rng, max_len=2000.0):
    x0, x1, y0, y1 = dem.x[0], dem.x[-1], dem.y[0], dem.y[-1]
    a = np.empty((0, 2))
    b = np.empty((0, 2))
    while len(a) < n:
        p = rng.uniform([x0, y0], [x1, y1], (2 * n, 2))
        ang = rng.uniform(0, 2 * np.pi, 2 * n)
        L = rng.uniform(0, max_len, 2 * n)
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


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="1000,2000,5000,10000,20000")
    p.add_argument("--rays", type=int, default=10_000)
    p.add_argument("--queries", type=int, default=100_000)
    p.add_argument("--quick", action="store_true", help="sizes 2000,10000 and 2000 rays")
    ns = p.parse_args()
    sizes = (2000, 10000) if ns.quick else tuple(int(s) for s in ns.sizes.split(","))
    main(Args(sizes=sizes, rays=2000 if ns.quick else ns.rays, queries=ns.queries))
