"""Issue 45: how much of a DEM's slope-class field a TIN with a tenth of the cells can hold.

    python research/trust_limits.py [--dem jacksboro] [--slope 20]

Exact areas on the full surface (every cell centre a vertex, SW-NE diagonals; the reference of
``bench/terrain.py --trust``): each grid square is cut by both diagonals into four quarters, each
inside one triangle of the full surface and one of the other-diagonal surface (the noise floor),
so the *firm* area (both surfaces agree on the class, where the trust measure scores slope class) is
a sum of quarters. Prints:

* the firm share, and the share of firm area within one cell of a class boundary of the full surface;
* the class islands of the full surface (edge-connected half-cell triangles of one class): how many,
  their sizes, and the firm area in islands smaller than the mean triangle of a TIN at 2/5/10/20 %;
* the boundary's corner nodes (grid nodes where the class boundary turns or branches): a TIN
  that keeps the boundary exactly needs each as a vertex;
* the island bound: a TIN with V vertices has < 2V triangles; every island it gets right needs a
  triangle of its own class that overlaps it, and two islands of one class apart need two
  triangles (or one triangle that also covers the other class between them), so at most 2V
  islands are right: the best case keeps the 2V largest and loses the rest (firm area).
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

import tin_swarm_env as tse
from tin_swarm_env.terrain.robot import full_surface_slope_deg


def quarter_classes(dem, slope_deg):
    """``(full, other, area)``: per quarter (square k, quarter q in S, E, N, W) the class of its
    full-surface triangle and of its other-diagonal triangle (True: steep), and its area (cells)."""
    z, dx, dy = dem.z, dem.dx, dem.dy
    tan_s = np.tan(np.radians(slope_deg))
    sf = (full_surface_slope_deg(dem) > slope_deg).reshape(-1, 2)  # (K, 2): (SW,SE,NE), (SW,NE,NW)
    a, b, c, d = z[:-1, :-1], z[:-1, 1:], z[1:, 1:], z[1:, :-1]  # SW, SE, NE, NW
    g0 = np.hypot((b - a) / dx, (d - a) / dy)  # (SW, SE, NW)
    g1 = np.hypot((c - d) / dx, (c - b) / dy)  # (SE, NE, NW)
    so = np.stack([g0.ravel() > tan_s, g1.ravel() > tan_s], 1)
    full = np.stack([sf[:, 0], sf[:, 0], sf[:, 1], sf[:, 1]], 1)  # S, E in tri 0; N, W in tri 1
    other = np.stack([so[:, 0], so[:, 1], so[:, 1], so[:, 0]], 1)  # S, W in (SW,SE,NW); E, N in the other
    return full, other


def islands(shape, steep):
    """Labels of the edge-connected components of one class among the full surface's triangles
    (``steep`` (2K,) in the order of full_surface_triangles) and their count."""
    rows, cols = shape
    nr, nc = rows - 1, cols - 1
    k = np.arange(nr * nc).reshape(nr, nc)
    t0, t1 = 2 * k, 2 * k + 1
    pairs = [(t0.ravel(), t1.ravel()),  # across the diagonal
             (t0[1:, :].ravel(), t1[:-1, :].ravel()),  # tri 0's south edge = tri 1's north edge of the square below
             (t0[:, :-1].ravel(), t1[:, 1:].ravel())]  # tri 0's east edge = tri 1's west edge of the square right
    i = np.concatenate([p[0] for p in pairs])
    j = np.concatenate([p[1] for p in pairs])
    same = steep[i] == steep[j]
    n = 2 * nr * nc
    g = coo_matrix((np.ones(same.sum()), (i[same], j[same])), shape=(n, n))
    return connected_components(g, directed=False)


def corner_nodes(dem, steep):
    """Grid nodes on the class boundary where it does not run straight through (turns, branches, ends)."""
    rows, cols = dem.shape
    nr, nc = rows - 1, cols - 1
    s = steep.reshape(nr, nc, 2)
    # boundary edges by direction, as (node a, node b): horizontal, vertical, diagonal
    node = np.arange(rows * cols).reshape(rows, cols)
    edges = []
    diag = s[:, :, 0] != s[:, :, 1]
    edges.append((node[:-1, :-1][diag], node[1:, 1:][diag], 2))
    south = s[1:, :, 0] != s[:-1, :, 1]  # square (i+1, j) tri 0 south edge vs square (i, j) tri 1 north edge
    edges.append((node[1:-1, :-1][south], node[1:-1, 1:][south], 0))
    east = s[:, :-1, 0] != s[:, 1:, 1]
    edges.append((node[:-1, 1:-1][east], node[1:, 1:-1][east], 1))
    deg = np.zeros((rows * cols, 3), np.int64)
    for a, b, kind in edges:
        np.add.at(deg[:, kind], a, 1)
        np.add.at(deg[:, kind], b, 1)
    tot = deg.sum(1)
    straight = (tot == 2) & (deg.max(1) == 2)
    return int(((tot > 0) & ~straight).sum()), int((tot > 0).sum())


def main(dem_name, slope_deg, fractions=(0.02, 0.05, 0.10, 0.20)):
    dem = tse.terrain.sample_dem(dem_name)
    rows, cols = dem.shape
    n_cells = rows * cols
    full, other = quarter_classes(dem, slope_deg)
    firm = full == other
    firm_area = firm.sum() / 4.0  # cells
    print(f"{dem_name} {rows}x{cols} at {slope_deg:g} deg: firm share {firm.mean():.1%}, "
          f"steep share of firm area {full[firm].mean():.1%}")
    steep = full_surface_slope_deg(dem) > slope_deg
    # within one cell of the boundary: quarter centroids (cell units) near a quarter of the other full-surface class
    from scipy.spatial import cKDTree

    nr, nc = rows - 1, cols - 1
    ii, jj = np.meshgrid(np.arange(nr, dtype=float), np.arange(nc, dtype=float), indexing="ij")
    off = np.array([[0.5, 1 / 6], [5 / 6, 0.5], [0.5, 5 / 6], [1 / 6, 0.5]])  # (x, y) of S, E, N, W quarter centroids
    qx = (jj.ravel()[:, None] + off[None, :, 0]).ravel()
    qy = (ii.ravel()[:, None] + off[None, :, 1]).ravel()
    fq = full.ravel()
    pts = np.column_stack([qx, qy])
    for r in (0.5, 1.0, 2.0):
        near = np.zeros(len(fq), bool)
        for cls in (True, False):
            tree = cKDTree(pts[fq != cls])
            d, _ = tree.query(pts[fq == cls], distance_upper_bound=r + 1e-9)
            near[fq == cls] = np.isfinite(d)
        print(f"  firm area within {r:g} cell of a class boundary: {near[firm.ravel()].mean():.1%}")
    n_isl, lab = islands(dem.shape, steep)
    # firm area per island: each triangle holds two quarters
    qtri = np.stack([2 * np.arange(nr * nc)] * 2 + [2 * np.arange(nr * nc) + 1] * 2, 1).ravel()
    firm_per = np.bincount(lab[qtri], weights=firm.ravel() / 4.0, minlength=n_isl)
    area = np.bincount(lab, minlength=n_isl) / 2.0
    cls = np.zeros(n_isl, bool)
    cls[lab] = steep
    print(f"  class islands: {n_isl} ({cls.sum()} steep, {(~cls).sum()} drivable) = {n_isl / n_cells:.1%} of the cells;"
          f" sizes (cells) median {np.median(area):.1f}, 90% {np.quantile(area, 0.9):.1f}")
    for f in fractions:
        v = int(round(f * n_cells))
        mean_tri = n_cells / (2 * v)  # cells: a TIN with V vertices has about 2V triangles
        small = area < mean_tri
        order = np.argsort(-firm_per)
        kept = firm_per[order[: 2 * v]].sum()
        print(f"  {f:4.0%}: V={v}, mean triangle {mean_tri:.1f} cells; islands smaller: {small.sum()} holding "
              f"{firm_per[small].sum() / firm_area:.1%} of the firm area; island bound (2V largest right, the rest "
              f"wrong): slope class <= {kept / firm_area:.1%}")
    corners, bnodes = corner_nodes(dem, steep)
    print(f"  class-boundary nodes {bnodes} ({bnodes / n_cells:.1%} of the cells), corner nodes {corners} "
          f"({corners / n_cells:.1%} of the cells)")


# -- the idealised boundary-conforming TIN ------------------------------------------------------------


def boundary_chains(dem, steep):
    """The full surface's class boundary as chains of grid nodes (lists), split at nodes where it branches or ends."""
    rows, cols = dem.shape
    nr, nc = rows - 1, cols - 1
    s = steep.reshape(nr, nc, 2)
    node = np.arange(rows * cols).reshape(rows, cols)
    a, b = [], []
    diag = s[:, :, 0] != s[:, :, 1]
    a.append(node[:-1, :-1][diag]), b.append(node[1:, 1:][diag])
    south = s[1:, :, 0] != s[:-1, :, 1]
    a.append(node[1:-1, :-1][south]), b.append(node[1:-1, 1:][south])
    east = s[:, :-1, 0] != s[:, 1:, 1]
    a.append(node[:-1, 1:-1][east]), b.append(node[1:, 1:-1][east])
    a, b = np.concatenate(a), np.concatenate(b)
    adj = {}
    for u, v in zip(a.tolist(), b.tolist()):
        adj.setdefault(u, []).append(v)
        adj.setdefault(v, []).append(u)
    used = set()
    chains = []

    def walk(start, nxt):
        ch = [start, nxt]
        used.add((min(start, nxt), max(start, nxt)))
        while len(adj[ch[-1]]) == 2 and ch[-1] != start:
            u = ch[-1]
            w = [x for x in adj[u] if (min(u, x), max(u, x)) not in used]
            if not w:
                break
            used.add((min(u, w[0]), max(u, w[0])))
            ch.append(w[0])
        return ch

    for u in sorted(adj, key=lambda u: len(adj[u]) == 2):  # branch / end nodes first, then loops
        for v in adj[u]:
            if (min(u, v), max(u, v)) not in used:
                chains.append(walk(u, v))
    return chains


def douglas_peucker(p, tol):
    """Indices into ``p`` (n, 2) kept by Douglas-Peucker at ``tol`` (first and last always; a closed
    chain is split at its farthest point first)."""
    n = len(p)
    if n <= 2:
        return list(range(n))
    if np.allclose(p[0], p[-1]):
        far = int(np.argmax(np.hypot(*(p - p[0]).T)))
        left = douglas_peucker(p[: far + 1], tol)
        right = douglas_peucker(p[far:], tol)
        return left + [far + k for k in right[1:]]
    keep = np.zeros(n, bool)
    keep[[0, n - 1]] = True
    stack = [(0, n - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        d = p[j] - p[i]
        q = p[i + 1:j] - p[i]
        L = np.hypot(*d)
        dist = np.abs(d[0] * q[:, 1] - d[1] * q[:, 0]) / L if L > 0 else np.hypot(*q.T)
        k = int(np.argmax(dist))
        if dist[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return list(np.flatnonzero(keep))


def ideal_cdt(dem, steep, tol, min_cells=0.0, extra=None):
    """Constrained Delaunay (Shewchuk's Triangle) of the class boundary simplified at ``tol`` cells
    (islands under ``min_cells`` dropped first: their boundary is not kept), the DEM's corners and
    ``extra`` node ids. Returns a Tin with full-surface heights (Steiner points included)."""
    import triangle as tr

    from tin_swarm_env.terrain.robot import full_surface

    rows, cols = dem.shape
    if min_cells > 0:
        n_isl, lab = islands(dem.shape, steep)
        area = np.bincount(lab, minlength=n_isl) / 2.0
        steep = steep.copy()
        for _ in range(3):  # small islands take the class of the larger side
            small = area[lab] < min_cells
            if not small.any():
                break
            steep[small] = ~steep[small]
            n_isl, lab = islands(dem.shape, steep)
            area = np.bincount(lab, minlength=n_isl) / 2.0
    chains = boundary_chains(dem, steep)
    nodes = {0, cols - 1, rows * cols - cols, rows * cols - 1}
    segs = []
    for ch in chains:
        ch = np.asarray(ch)
        p = np.column_stack([ch % cols, ch // cols]).astype(float)
        k = ch[douglas_peucker(p, tol)]
        nodes.update(k.tolist())
        segs += list(zip(k[:-1].tolist(), k[1:].tolist()))
    if extra is not None:
        nodes.update(np.asarray(extra).tolist())
    idx = np.array(sorted(nodes))
    pos = {int(n): i for i, n in enumerate(idx)}
    xy = np.column_stack([idx % cols, idx // cols]).astype(float)
    s = np.array([(pos[u], pos[v]) for u, v in segs if u != v], dtype=np.int32).reshape(-1, 2)
    out = tr.triangulate({"vertices": xy, "segments": np.vstack([s, [[pos[0], pos[cols - 1]],
                                                                      [pos[cols - 1], pos[rows * cols - 1]],
                                                                      [pos[rows * cols - 1], pos[rows * cols - cols]],
                                                                      [pos[rows * cols - cols], pos[0]]]])}, "p")
    v = out["vertices"]
    wx, wy = dem.x[0] + v[:, 0] * dem.dx, dem.y[0] + v[:, 1] * dem.dy
    fs = full_surface(dem)
    z = fs.height_at(np.column_stack([np.clip(wx, dem.x[0], dem.x[-1]), np.clip(wy, dem.y[0], dem.y[-1])]))
    # Triangle can return a segment crossing twice: merge vertices at the same x, y, drop what collapses
    _, first, inv = np.unique(np.round(v, 9), axis=0, return_index=True, return_inverse=True)
    tri = first[inv.ravel()][out["triangles"]]
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
    return tse.terrain.Tin(np.column_stack([wx, wy, z]), tri, source=f"ideal CDT tol {tol}")


def firm_accuracy(dem, slope_deg, tin):
    """(slope class on the firm area with the TIN's own heights, with each triangle given the firm area's
    majority class inside it: the oracle labels) of ``tin``, exact over quarter centroids."""
    rows, cols = dem.shape
    nr, nc = rows - 1, cols - 1
    full, other = quarter_classes(dem, slope_deg)
    firm = (full == other).ravel()
    ii, jj = np.meshgrid(np.arange(nr, dtype=float), np.arange(nc, dtype=float), indexing="ij")
    off = np.array([[0.5, 1 / 6], [5 / 6, 0.5], [0.5, 5 / 6], [1 / 6, 0.5]])
    qx = dem.x[0] + (jj.ravel()[:, None] + off[None, :, 0]).ravel() * dem.dx
    qy = dem.y[0] + (ii.ravel()[:, None] + off[None, :, 1]).ravel() * dem.dy
    q = np.column_stack([qx, qy])[firm]
    truth = full.ravel()[firm]
    t = tin.locate(q)
    own = (tin.slope_at(q) > slope_deg) == truth
    n_t = tin.n_triangles
    st = np.bincount(t, weights=truth, minlength=n_t)
    tot = np.bincount(t, minlength=n_t)
    lab = st > 0.5 * tot
    tin_steep = tin.slope_at(q) > slope_deg
    firm_accuracy.split = (float(np.mean(truth & ~tin_steep)), float(np.mean(~truth & tin_steep)))
    return float(own.mean()), float((lab[t] == truth).mean())


def ideal_main(dem_name, slope_deg, tols=(0.75, 1.0, 1.5, 2.0, 3.0), min_cells=(0.0, 2.0, 5.0), baselines=True,
               score_tol=None):
    """The idealised boundary-conforming TINs: vertex share and firm slope-class accuracy, own and oracle."""
    dem = tse.terrain.sample_dem(dem_name)
    steep = full_surface_slope_deg(dem) > slope_deg
    n_cells = dem.z.size
    from tin_swarm_env.terrain import build_tin

    for f in (0.05, 0.10, 0.20) if baselines else ():
        n = int(round(f * n_cells))
        for m in ("greedy", "trust"):
            kw = {} if m == "greedy" else {"max_slope_deg": slope_deg}
            own, oracle = firm_accuracy(dem, slope_deg, build_tin(dem, method=m, max_vertices=n, **kw))
            print(f"  {m} {f:.0%}: firm slope class {own:.1%} own heights, {oracle:.1%} oracle labels; wrong: steep "
                  f"under a drivable triangle {firm_accuracy.split[0]:.1%}, the other way {firm_accuracy.split[1]:.1%}",
                  flush=True)
    for mc in min_cells:
        for tol in tols:
            try:
                tin = ideal_cdt(dem, steep, tol, mc)
            except RuntimeError as e:  # Triangle gives up on some sets of crossing segments
                print(f"  ideal CDT, islands < {mc:g} cells dropped, DP tol {tol:g} cells: Triangle failed ({e})")
                continue
            own, oracle = firm_accuracy(dem, slope_deg, tin)
            print(f"  ideal CDT, islands < {mc:g} cells dropped, DP tol {tol:g} cells: {tin.n_vertices} vertices "
                  f"({tin.n_vertices / n_cells:.1%} of the cells); firm slope class {own:.1%} own heights, "
                  f"{oracle:.1%} oracle labels; wrong: steep under a drivable triangle {firm_accuracy.split[0]:.1%},"
                  f" the other way {firm_accuracy.split[1]:.1%}", flush=True)
    if score_tol is not None:  # every measure of bench/terrain.py --trust on one of them
        import sys
        from pathlib import Path

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "bench"))
        from terrain import TrustReference, _fmt, meets

        ref = TrustReference(dem, slope_deg, np.random.default_rng(0))
        floor = ref.score(ref.other)
        print(f"  trust measures (slope, ctg med, ctg p90, reach, los): floor {' '.join(_fmt(floor))}")
        for tol, mc in score_tol:
            tin = ideal_cdt(dem, steep, tol, mc)
            sc = ref.score(tin)
            cells = " ".join(_fmt(sc, meets(sc, ref.bars(floor))))
            print(f"  ideal CDT tol {tol:g}, islands < {mc:g} dropped ({tin.n_vertices / n_cells:.1%}): {cells}",
                  flush=True)


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dem", default="jacksboro")
    p.add_argument("--slope", type=float, default=20.0)
    p.add_argument("--ideal", action="store_true", help="the idealised boundary-conforming CDTs")
    p.add_argument("--tols", default="0.75,1,1.5,2,3", help="Douglas-Peucker tolerances, cells")
    p.add_argument("--min-cells", default="0,2", help="islands smaller than this (cells) dropped first")
    p.add_argument("--no-baselines", action="store_true", help="skip greedy and trust with oracle labels")
    p.add_argument("--score", default="",
                   help="tol/min_cells pairs whose CDT gets every trust measure, e.g. 0.75/2,0.5/4")
    ns = p.parse_args()
    if ns.ideal:
        score = [tuple(float(x) for x in t.split("/")) for t in ns.score.split(",")] if ns.score else None
        ideal_main(ns.dem, ns.slope, tols=tuple(float(t) for t in ns.tols.split(",")),
                   min_cells=tuple(float(m) for m in ns.min_cells.split(",")), baselines=not ns.no_baselines,
                   score_tol=score)
    else:
        main(ns.dem, ns.slope)
