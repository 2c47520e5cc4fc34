"""Terrain benchmark on the real jacksboro DEM (matplotlib's sample). Run by hand:

    python bench/terrain.py [--sizes 1000,2000,5000,10000,20000] [--rays 10000]
    python bench/terrain.py --quick     # a smoke run (seconds): one 1000-vertex size, 500 rays, a tiny --trust
    python bench/terrain.py --trust [--write]     # what robots use (issue 45): 2/5/10/20 % of the cells

``--trust`` (:func:`trust_main`; ``--robot`` is its old name) scores each builder of
:func:`trust_builders` at 2, 5, 10 and 20 % of the cells with the measures of :class:`TrustReference`
(defined there once: slope class at firm points, cost-to-go error median and p90, reachability,
line of sight, against the full-resolution surface and its noise floor, the other diagonal) on
jacksboro at 20 and 15 deg, topobathy at 12 deg and 20 ``realdem`` crops (their mean), marks each
bar of issue 45 missed and names the smallest fraction meeting each. ``--write`` writes
docs/figures/terrain_robot.md and the curve bench/figures/terrain_trust.png.

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


# -- the trust measures (issue 45): what robots use, scored above the full surface's own noise --------


EYE_M = 2.0  # sight line endpoints above the ground
CLEAR_M = 1.0  # a ray is clear-cut when its sight line clears, or dips below, the bilinear DEM by more
EDGE_FRAC = 0.02  # sample points lie at least this share of the smaller extent inside the DEM's edges
FAR_FRAC = 0.05  # cost-to-go and reachability are scored at points farther than this share of the diagonal
RAY_FRAC = (0.005, 0.05)  # line-of-sight rays: this share of the diagonal long
BARS = {"slope": 0.97, "reach": 0.99, "los": 0.97, "los_floor_gap": 0.02, "ctg_med_gap": 0.02, "ctg_p90_gap": 0.06}


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


def inner_points(dem, n, rng):
    """``n`` uniform random points at least EDGE_FRAC of the smaller extent inside the edges."""
    m = EDGE_FRAC * min(dem.x[-1] - dem.x[0], dem.y[-1] - dem.y[0])
    return rng.uniform([dem.x[0] + m, dem.y[0] + m], [dem.x[-1] - m, dem.y[-1] - m], (n, 2))


def other_diagonal(dem):
    """Every cell centre a vertex, the other (NW-SE) diagonal in every square: the noise floor."""
    rows, cols = dem.shape
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (i * cols + j).ravel()
    b, c, d = a + 1, a + cols + 1, a + cols
    tri = np.stack([np.column_stack([a, b, d]), np.column_stack([b, c, d])], 1).reshape(-1, 3)
    return tse.terrain.Tin(np.column_stack([dem.cell_centres(), dem.z.ravel()]), tri, source="other diagonal")


class TrustReference:
    """The measures of issue 45, defined here once: a TIN of ``dem`` against its full-resolution surface.

    * **reference**: the full surface (every cell centre a vertex, SW-NE diagonals:
      ``terrain.robot.full_surface``); **noise floor**: the same vertices with the other diagonal
      (:func:`other_diagonal`), scored like any TIN.
    * **slope class** at ``slope_deg``: ``n_points`` random points (:func:`inner_points`), scored
      only at *firm* points, where both full surfaces agree on the class (slope > ``slope_deg``).
    * **cost-to-go**: ``n_goals`` random goals on firm drivable points; ``n_ctg`` random points each
      farther than FAR_FRAC of the diagonal. The error at a point both full surfaces reach is
      ``|d_tin - d_ref| / d_ref`` (1 where the TIN cannot reach it); median and p90 over all goals.
    * **reachability**: at the same points, where both full surfaces agree (both reach, or neither),
      the share at which the TIN agrees with them.
    * **line of sight**: ``n_rays`` rays RAY_FRAC of the diagonal long, endpoints EYE_M above the
      ground (the bilinear DEM for the truth, the TIN's own height for the TIN); truth from a
      march every quarter cell over the bilinear DEM; only rays whose minimum clearance is more
      than CLEAR_M either way are scored.
    """

    def __init__(self, dem, slope_deg, rng, n_points=40_000, n_goals=6, n_ctg=4000, n_rays=5000):
        from tin_swarm_env.terrain.robot import full_surface

        self.dem, self.slope_deg = dem, float(slope_deg)
        self.full, self.other = full_surface(dem), other_diagonal(dem)
        diag = float(np.hypot(dem.x[-1] - dem.x[0], dem.y[-1] - dem.y[0]))
        pts = inner_points(dem, n_points, rng)
        c0, c1 = self.full.slope_at(pts) > slope_deg, self.other.slope_at(pts) > slope_deg
        self.firm_share = float(np.mean(c0 == c1))
        self.pts, self.cls = pts[c0 == c1], c0[c0 == c1]
        self.fields = []  # (goal, points, reference distance, both reach, neither reaches)
        tries = 0
        while len(self.fields) < n_goals and tries < 200 * n_goals:
            tries += 1
            g = inner_points(dem, 1, rng)
            if self.full.slope_at(g)[0] > slope_deg or self.other.slope_at(g)[0] > slope_deg:
                continue
            p = inner_points(dem, n_ctg, rng)
            p = p[np.hypot(*(p - g[0]).T) > FAR_FRAC * diag]
            d0 = self.surface_distance(self.full, g[0], p)
            d1 = self.surface_distance(self.other, g[0], p)
            both, neither = np.isfinite(d0) & np.isfinite(d1), ~np.isfinite(d0) & ~np.isfinite(d1)
            if both.sum() >= 0.05 * len(p):
                self.fields.append((g[0], p, d0, both, neither))
        a, b = random_rays(dem, n_rays, rng, max_len=RAY_FRAC[1] * diag, min_len=RAY_FRAC[0] * diag)
        A = np.column_stack([a, dem_height(dem, a) + EYE_M])
        B = np.column_stack([b, dem_height(dem, b) + EYE_M])
        c = march_clearance(dem, A, B, 0.25 * min(dem.dx, dem.dy))
        clear = np.abs(c) > CLEAR_M
        self.ra, self.rb, self.vis = a[clear], b[clear], c[clear] > 0
        self.n_rays = n_rays

    def surface_distance(self, tin, goal, p):
        return tse.terrain.cost_to_go(tin, goal, tin.slope_deg <= self.slope_deg).distance_at(p)

    def score(self, tin):
        """``{"slope", "ctg_med", "ctg_p90", "reach", "los"}`` of ``tin`` (shares, 0-1)."""
        slope = float(np.mean((tin.slope_at(self.pts) > self.slope_deg) == self.cls))
        err, agree, n_agree = [], 0, 0
        for g, p, d0, both, neither in self.fields:
            d = self.surface_distance(tin, g, p)
            e = np.where(np.isfinite(d[both]), np.abs(d[both] - d0[both]) / d0[both], 1.0)
            err.append(np.minimum(e, 1.0))
            agree += int(np.isfinite(d[both]).sum() + (~np.isfinite(d[neither])).sum())
            n_agree += int(both.sum() + neither.sum())
        err = np.concatenate(err) if err else np.zeros(1)
        A = np.column_stack([self.ra, tin.height_at(self.ra) + EYE_M])
        B = np.column_stack([self.rb, tin.height_at(self.rb) + EYE_M])
        los = float(np.mean(tin.line_of_sight(A, B) == self.vis))
        return {"slope": slope, "ctg_med": float(np.median(err)), "ctg_p90": float(np.quantile(err, 0.9)),
                "reach": agree / max(n_agree, 1), "los": los}

    def bars(self, floor):
        """Issue 45's bars given the noise floor's score ``floor``: ``{measure: (bar, higher is better)}``."""
        los = BARS["los"] if floor["los"] >= 0.99 else floor["los"] - BARS["los_floor_gap"]
        return {"slope": (BARS["slope"], True), "ctg_med": (floor["ctg_med"] + BARS["ctg_med_gap"], False),
                "ctg_p90": (floor["ctg_p90"] + BARS["ctg_p90_gap"], False), "reach": (BARS["reach"], True),
                "los": (los, True)}

    def describe(self):
        n_ctg = sum(int(f[3].sum()) for f in self.fields)
        n_all = len(self.pts) / max(self.firm_share, 1e-9)
        return (f"{len(self.pts)} firm points ({self.firm_share:.0%} of {n_all:.0f}),"
                f" {len(self.fields)} goals, {n_ctg} cost-to-go points, {len(self.ra)} clear-cut rays of {self.n_rays}")


def meets(sc, bars):
    """The measures of score ``sc`` that meet ``bars`` (:meth:`TrustReference.bars`)."""
    return {k: (sc[k] >= b) if up else (sc[k] <= b) for k, (b, up) in bars.items()}


def trust_cases(n_crops=20, seed=0):
    """``[(name, dem, slope_deg)]``: jacksboro at 20 and 15 deg, topobathy at 12 deg, ``n_crops`` realdem crops."""
    j = tse.terrain.sample_dem("jacksboro")
    cases = [("jacksboro 20 deg", j, 20.0), ("jacksboro 15 deg", j, 15.0),
             ("topobathy 12 deg", tse.terrain.sample_dem("topobathy"), 12.0)]
    return cases + realdem_crops(n_crops, seed)


def realdem_crops(n, seed=0):
    """``n`` tasks of the realdem family (default ranges), each with its drawn slope limit."""
    from tin_swarm_env.scenario import generators

    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        task = generators.generate(rng, {"realdem": 1.0})
        p = task.params
        out.append((f"realdem {k} ({p['dem']}, {task.dem.shape[0]}^2)", task.dem, float(p["max_slope_deg"])))
    return out


def _fmt(sc, ok=None):
    cells = []
    for k in ("slope", "ctg_med", "ctg_p90", "reach", "los"):
        mark = "" if ok is None or ok[k] else " ✗"
        cells.append(f"{sc[k]:.1%}{mark}")
    return cells


def trust_tables(methods, fractions=(0.02, 0.05, 0.10, 0.20), n_crops=20, seed=0, quick=False):
    """Every measure for each ``methods`` (``{name: build_tin kwargs}``) and fraction of cells on
    :func:`trust_cases`. Returns ``{(case, method, fraction): score}`` (and ``(..., "ok")``: which bars
    are met), the noise floors per case, the build times and the cases."""

    rng = np.random.default_rng(seed)
    cases = trust_cases(0 if quick else n_crops, seed)
    if quick:
        cases = [(n, d, s) for n, d, s in cases[:1]]
    res, floors, times = {}, {}, {}
    for fn in methods.values():  # compile / warm up, outside the timings
        fn(cases[0][1], 200, cases[0][2])
    for name, dem, s in cases:
        kw = dict(n_points=4000, n_goals=2, n_ctg=500, n_rays=500) if quick else {}
        ref = TrustReference(dem, s, rng, **kw)
        floors[name] = ref.score(ref.other)
        print(f"{name}: {dem.shape}, {ref.describe()}; floor {_fmt(floors[name])}", flush=True)
        bars = ref.bars(floors[name])
        for f in fractions:
            n = max(4, int(round(f * dem.z.size)))
            for m, fn in methods.items():
                t0 = time.perf_counter()
                tin = fn(dem, n, s)
                times[(name, m, f)] = time.perf_counter() - t0
                res[(name, m, f)] = sc = ref.score(tin)
                res[(name, m, f, "ok")] = meets(sc, bars)
                if not name.startswith("realdem"):
                    print(f"  {m:10s} {f:4.0%} {tin.n_vertices:6d} {' '.join(_fmt(sc, meets(sc, bars)))} "
                          f"{times[(name, m, f)]:.3f}s", flush=True)
    return res, floors, times, cases


MEASURES = (("slope", "slope class, firm points"), ("ctg_med", "cost-to-go error, median"),
            ("ctg_p90", "cost-to-go error, p90"), ("reach", "reachability agrees"), ("los", "line of sight"))


def trust_builders():
    """``{name: fn(dem, n_vertices, slope_deg) -> Tin}``: the builders the trust tables compare."""
    return {"greedy": lambda dem, n, s: build_tin(dem, method="greedy", max_vertices=n),
            "greedy-Delaunay": lambda dem, n, s: build_tin(dem, method="greedy", max_vertices=n, delaunay=True),
            "robot": lambda dem, n, s: build_tin(dem, method="robot", max_vertices=n, max_slope_deg=s),
            "trust": lambda dem, n, s: build_tin(dem, method="trust", max_vertices=n, max_slope_deg=s)}


def _group(name):
    return "20 realdem crops (mean)" if name.startswith("realdem") else name


def trust_report(res, floors, times, cases, methods, fractions, header):
    """Markdown lines: per DEM (realdem crops as a mean) the floor and each method x fraction, with ✗
    where a bar is missed, and the smallest fraction at which each bar is met."""
    groups = {}
    for name, _, _ in cases:
        groups.setdefault(_group(name), []).append(name)
    lines = list(header)
    for g, names in groups.items():
        lines += ["", f"### {g}", "", "| TIN | cells | " + " | ".join(t for _, t in MEASURES) + " | build s |",
                  "|---|---:|" + "---:|" * (len(MEASURES) + 1)]
        fl = {k: float(np.mean([floors[n][k] for n in names])) for k, _ in MEASURES}
        lines.append("| other diagonal (noise floor) | 100% | " + " | ".join(_fmt(fl)) + " | |")
        for m in methods:
            for f in fractions:
                sc = {k: float(np.mean([res[(n, m, f)][k] for n in names])) for k, _ in MEASURES}
                ok = {k: all(res[(n, m, f, "ok")][k] for n in names) if len(names) == 1 else
                      _mean_meets(sc, fl, k) for k, _ in MEASURES}
                dt = max(times[(n, m, f)] for n in names)
                lines.append(f"| {m} | {f:.0%} | " + " | ".join(_fmt(sc, ok)) + f" | {dt:.3f} |")
        lines.append("")
        first = []
        for k, title in MEASURES:
            for m in methods:
                met = [f for f in fractions if _ok(res, names, m, f, k, fl)]
                at = f"{100 * met[0]:.0f}%" if met else f"not met at {100 * fractions[-1]:.0f}%"
                first.append(f"{title} / {m}: {at}")
        lines.append("Smallest fraction meeting each bar: " + "; ".join(first) + ".")
    return lines


def _mean_meets(sc, fl, k):
    los = BARS["los"] if fl["los"] >= 0.99 else fl["los"] - BARS["los_floor_gap"]
    bar = {"slope": BARS["slope"], "reach": BARS["reach"], "los": los, "ctg_med": fl["ctg_med"] + BARS["ctg_med_gap"],
           "ctg_p90": fl["ctg_p90"] + BARS["ctg_p90_gap"]}[k]
    return sc[k] >= bar if k in ("slope", "reach", "los") else sc[k] <= bar


def _ok(res, names, m, f, k, fl):
    if len(names) == 1:
        return res[(names[0], m, f, "ok")][k]
    return _mean_meets({k: float(np.mean([res[(n, m, f)][k] for n in names]))}, fl, k)


def trust_curve(res, cases, methods, fractions, path):
    """Each measure against the fraction of cells, per method, one panel per measure, a line per DEM group."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = {}
    for name, _, _ in cases:
        groups.setdefault(_group(name), []).append(name)
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    axes = axes.ravel()
    styles = ["-", "--", ":", "-."]
    for ax, (k, title) in zip(axes, MEASURES):
        for gi, (g, names) in enumerate(groups.items()):
            for mi, m in enumerate(methods):
                y = [100 * np.mean([res[(n, m, f)][k] for n in names]) for f in fractions]
                ax.plot([100 * f for f in fractions], y, styles[mi % 4], color=f"C{gi}", marker="o", ms=3,
                        label=f"{g}, {m}")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("% of cells")
        ax.set_xscale("log")
        ax.minorticks_off()
        ax.set_xticks([100 * f for f in fractions], [f"{100 * f:g}" for f in fractions])
        ax.set_ylabel("%")
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    axes[-1].axis("off")
    axes[-1].legend(handles, labels, fontsize=7, loc="center")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def build_costs(builders, repeat=3):
    """Lines: per builder, the best of ``repeat`` build times and the peak traced memory (tracemalloc: numpy
    buffers included) for jacksboro at 10 % of its cells (slope 20 deg) and a 128 x 128 crop of it at 10 %."""
    import tracemalloc

    j = tse.terrain.sample_dem("jacksboro")
    crop = tse.terrain.Dem(j.z[100:228, 100:228], j.x[100:228], j.y[100:228], source="jacksboro 128x128 crop")
    out = ["| builder | DEM | vertices | build s (best of 3) | peak memory MB |", "|---|---|---:|---:|---:|"]
    for name, fn in builders.items():
        for dem in (j, crop):
            n = int(round(0.1 * dem.z.size))
            fn(dem, 200, 20.0)  # warm up
            _, dt = timed(lambda fn=fn, dem=dem, n=n: fn(dem, n, 20.0), repeat)
            tracemalloc.start()
            fn(dem, n, 20.0)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            out.append(f"| {name} | {dem.source} | {n} | {dt:.3f} | {peak / 1e6:.0f} |")
            print(out[-1], flush=True)
    return out


def scenario_ways(builders):
    """Lines: the drivable way (cost-to-go, m) from the jacksboro scenario's spawn centre to each of its
    targets at its 20 deg limit on both full surfaces and on each builder's TIN at the scenario's 10 000
    vertices, beside the straight line: a TIN whose way is shorter than both full surfaces' has bridged
    steep ground that the ground has (the APF figure on such a TIN measures an easier map)."""
    from tin_swarm_env.scenario import load_scenario
    from tin_swarm_env.terrain.robot import full_surface

    cfg = load_scenario("jacksboro")
    s = cfg.world.robot.max_slope_deg
    x0, y0, x1, y1 = cfg.robots.spawn_region
    spawn = np.array([0.5 * (x0 + x1), 0.5 * (y0 + y1)])
    targets = np.asarray(cfg.targets.positions, dtype=float)
    dem = tse.terrain.sample_dem("jacksboro")
    tins = {"full surface": full_surface(dem), "other diagonal": other_diagonal(dem)}
    tins.update({name: fn(dem, cfg.terrain.max_vertices, s) for name, fn in builders.items()})
    out = ["| surface | " + " | ".join(f"target {k} ({t[0]:.0f}, {t[1]:.0f})" for k, t in enumerate(targets)) + " |",
           "|---|" + "---:|" * len(targets),
           "| straight line | " + " | ".join(f"{np.hypot(*(t - spawn)):.0f}" for t in targets) + " |"]
    for name, tin in tins.items():
        d = [tse.terrain.cost_to_go(tin, t, tin.slope_deg <= s).distance_at(spawn[None])[0] for t in targets]
        out.append(f"| {name} | " + " | ".join(f"{v:.0f}" for v in d) + " |")
        print(out[-1], flush=True)
    return out


def trust_main(write=False, quick=False, fractions=(0.02, 0.05, 0.10, 0.20), n_crops=20):
    """The trust tables (``--trust``) and, with ``write``, docs/figures/terrain_robot.md and its curve."""
    import os
    import sys
    import tempfile
    from pathlib import Path

    load = os.getloadavg()[0]
    builders = trust_builders()
    if quick:
        builders = {k: builders[k] for k in ("greedy", "trust")}
        fractions = (0.05,)
    res, floors, times, cases = trust_tables(builders, fractions, n_crops, quick=quick)
    root = Path(__file__).resolve().parents[1]
    png = (root / "bench" / "figures" if write else Path(tempfile.mkdtemp())) / "terrain_trust.png"
    header = [f"Written by `python bench/terrain.py {' '.join(sys.argv[1:])}` (load average {load:.2f} at the start). "
              "The measures of issue 45, defined once in `TrustReference` (bench/terrain.py): agreement with the "
              "full-resolution surface (every cell centre a vertex, SW-NE diagonals); the noise floor is the same "
              "surface with the other diagonal. Slope class scored at firm points only (both diagonals agree); "
              "cost-to-go error relative, 1 where the TIN cannot reach a point both full surfaces reach; "
              "reachability where both full surfaces agree; line of sight on clear-cut rays 0.5-5% of the "
              "diagonal, 2 m above ground, against a dense bilinear march. ✗: the bar of issue 45 missed "
              "(slope >= 97%, reach >= 99%, line of sight >= 97% or floor - 2 points, cost-to-go median <= floor "
              "+ 2 points and p90 <= floor + 6 points). Build time: one build, seconds (the slowest over the group).",
              "", "![each measure against the fraction of cells](bench/figures/terrain_trust.png)"]
    lines = trust_report(res, floors, times, cases, list(builders), fractions, header)
    lines += ["", "### Build cost at 10 % of the cells (20 deg)", ""] + build_costs(builders, 1 if quick else 3)
    lines += ["", "### The jacksboro scenario's ways (m, spawn centre to each target, 20 deg, 10 000 vertices)", "",
              "Shorter than both full surfaces: the TIN has bridged steep ground the ground keeps.", ""]
    lines += scenario_ways(builders)
    trust_curve(res, cases, list(builders), fractions, png)
    print("\n".join(lines))
    print(f"curve: {png}")
    if write:
        out = root / "docs" / "figures" / "terrain_robot.md"
        tmp = out.with_suffix(".md.tmp")
        tmp.write_text("\n".join(lines) + "\n")
        tmp.replace(out)
        print(f"wrote {out}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trust", action="store_true", help="only the trust tables of issue 45 (slope class, cost-to-go, "
                   "reachability, line of sight against the full surface and its noise floor)")
    p.add_argument("--robot", action="store_true", help="the same as --trust (its old name)")
    p.add_argument("--write", action="store_true", help="with --trust: write docs/figures/terrain_robot.md and "
                   "bench/figures/terrain_trust.png")
    p.add_argument("--sizes", default="1000,2000,5000,10000,20000")
    p.add_argument("--rays", type=int, default=10_000)
    p.add_argument("--queries", type=int, default=100_000)
    p.add_argument("--quick", action="store_true", help="a smoke run (seconds): size 1000, 500 rays, 10 000 queries")
    ns = p.parse_args()
    if ns.robot or ns.trust:
        trust_main(write=ns.write, quick=ns.quick)
        raise SystemExit(0)
    if ns.quick:
        main(Args(sizes=(1000,), rays=500, queries=10_000))
        trust_main(quick=True)  # the trust measures too (tiny: jacksboro 20 deg, greedy and trust at 5 %)
    else:
        main(Args(sizes=tuple(int(s) for s in ns.sizes.split(",")), rays=ns.rays, queries=ns.queries))
