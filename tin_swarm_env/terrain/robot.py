"""A TIN built for robots: refine where the slope class (drivable / too steep) is wrong.

``build_tin(dem, method="robot", max_vertices=N or max_error_m=E, max_slope_deg=S)``.

Reference surface
-----------------
The surface a robot would see at full resolution is :func:`full_surface`: every cell centre a
vertex, each grid square split along its south-west -> north-east diagonal (two triangles per
cell). Its triangles are the *samples* of the error measure: each has a class (slope > S:
too steep) and a centroid height. All samples have the same plan area, so a share of samples
is a share of the map.

Method (a batched Garland-Heckbert greedy insertion on a robot error)
--------------------------------------------------------------------
1. Seed: the four corners; ``seed_fraction`` of the vertex budget from plain greedy
   insertion on vertical error (:func:`~.greedy.greedy_mesh`, Garland and Heckbert 1995,
   "Fast polygonal approximation of terrains and height fields", via pydelatin), which places
   the breaks of the surface (cliff tops and feet, valley floors) first; and ``crest_fraction``
   of the budget as *crest* nodes: cells higher than the mean of both neighbours on a row,
   column or diagonal profile, ranked by that height (VIP significance, Chen and Guevara 1987,
   restricted to convex cells), so the ridges that hide things from a robot's line of sight
   are vertices.
2. Repeat: Delaunay in x, y (scipy/Qhull) over the chosen cells; assign every sample to the
   TIN triangle holding its centroid (:func:`raster_samples`, a compiled scan of each
   triangle's bounding box of grid squares: O(samples) per round); score each TIN triangle by
   its *misclassified* samples (a sample on drivable ground under a too-steep TIN triangle
   counts ``false_steep_weight`` = 3, the other way 1: false steep cuts drivable ground into
   pieces, false drivable only shortens paths) plus ``vertical_weight`` x its largest vertical
   error in units of ``cell``-scale slope at S (the tie-breaker); insert, in the best
   ``batch_fraction`` x V triangles, the not-yet-kept corner of their worst sample's grid
   triangle with the largest vertical error (:func:`score_triangles`).
3. Stop at ``max_vertices``, or (``max_error_m``) when no sample is misclassified and every
   vertical error is at most ``max_error_m``, or when no triangle has a cell left to add.

Delaunay re-triangulation (not greedy's own triangles) is what keeps the thin steep slivers
away: an empty-circle triangulation has no needle spanning a valley floor.

Cost: one greedy run (pydelatin, C++), then per round a Delaunay of V points (O(V log V)) and
O(rows x cols) numpy/compiled work; with the default batch the vertex count grows by half
per round, so a handful of rounds. Memory: a few arrays of 2 x rows x cols.

Limits (measured in ``docs/figures/terrain.md``, ``bench/terrain.py``): on a DEM whose slope
field is noisy at the cell scale (jacksboro at 20 deg: the two halves of 14% of its cells
have different classes, 36% of its cells touch both classes), no TIN with a tenth of the
cells reproduces the full surface's class everywhere; a 3x3 majority filter of the class map
itself agrees at 89%.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import ArgumentError, DemFormatError
from .dem import Dem

__all__ = ["robot_mesh", "full_surface", "full_surface_triangles", "full_surface_slope_deg", "sample_points",
           "raster_samples", "score_triangles", "crest_score"]

SEED_FRACTION = 0.8  # of max_vertices, from plain greedy insertion (vertical error)
CREST_FRACTION = 0.05  # of max_vertices, crest cells (line of sight)
BATCH_FRACTION = 0.5  # vertices inserted per round, as a fraction of the current count
FALSE_STEEP_WEIGHT = 3.0  # a drivable sample under a too-steep TIN triangle
FALSE_DRIVABLE_WEIGHT = 1.0  # a too-steep sample under a drivable TIN triangle
# Where in its grid triangle a sample lies (cell units from the square's SW corner): inside, and
# off every line through two grid nodes of a DEM of up to thousands of cells a side (the
# centroid lies on many such lines, where a TIN edge could split it unseen)
SAMPLE_NEAR, SAMPLE_FAR = 0.30901699, 0.63819660
SHEAR = 1e-3  # cells of x shift per row, for the triangulation only
VERTICAL_WEIGHT = 0.1  # per cell-scale vertical error (tie-breaker)


def full_surface_triangles(shape: tuple[int, int]) -> np.ndarray:
    """``(2 (rows-1) (cols-1), 3)`` int64 CCW node triangles of the full-resolution surface
    (node ``i * cols + j`` = cell (row i, col j), row 0 south), square by square, row-major:
    triangle ``2k`` = (SW, SE, NE), ``2k + 1`` = (SW, NE, NW) of square ``k``."""
    rows, cols = shape
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(cols - 1), indexing="ij")
    a = (i * cols + j).ravel()
    b, c, d = a + 1, a + cols + 1, a + cols
    return np.stack([np.column_stack([a, b, c]), np.column_stack([a, c, d])], 1).reshape(-1, 3).astype(np.int64)


def full_surface_slope_deg(dem: Dem) -> np.ndarray:
    """``(2 (rows-1) (cols-1),)`` slope, deg, of each triangle of :func:`full_surface`, in the order of
    :func:`full_surface_triangles`."""
    z, dx, dy = dem.z, dem.dx, dem.dy
    a, b, c, d = z[:-1, :-1], z[:-1, 1:], z[1:, 1:], z[1:, :-1]  # SW, SE, NE, NW of each square
    g0 = np.hypot((b - a) / dx, (c - b) / dy)  # (SW, SE, NE)
    g1 = np.hypot((c - d) / dx, (d - a) / dy)  # (SW, NE, NW)
    return np.degrees(np.arctan(np.stack([g0, g1], -1).reshape(-1)))


def sample_points(dem: Dem) -> np.ndarray:
    """``(S, 3)`` m: the samples of the robot builder's error, one inside each triangle of
    :func:`full_surface` (same order), on it: ``2k`` at (row i + SAMPLE_NEAR, col j + SAMPLE_FAR),
    ``2k + 1`` at (i + SAMPLE_FAR, j + SAMPLE_NEAR) of square ``k = i (cols-1) + j``."""
    z = dem.z
    a, b, c, d = z[:-1, :-1], z[:-1, 1:], z[1:, 1:], z[1:, :-1]  # SW, SE, NE, NW
    z0 = a + (b - a) * SAMPLE_FAR + (c - b) * SAMPLE_NEAR  # on (SW, SE, NE)
    z1 = a + (d - a) * SAMPLE_FAR + (c - d) * SAMPLE_NEAR  # on (SW, NE, NW)
    i, j = np.meshgrid(np.arange(z.shape[0] - 1, dtype=float), np.arange(z.shape[1] - 1, dtype=float), indexing="ij")
    x0, y0 = dem.x[0] + (j + SAMPLE_FAR) * dem.dx, dem.y[0] + (i + SAMPLE_NEAR) * dem.dy
    x1, y1 = dem.x[0] + (j + SAMPLE_NEAR) * dem.dx, dem.y[0] + (i + SAMPLE_FAR) * dem.dy
    out = np.stack([np.stack([x0, y0, z0], -1), np.stack([x1, y1, z1], -1)], 2)
    return out.reshape(-1, 3)


def full_surface(dem: Dem):
    """The full-resolution :class:`~.tin.Tin` of ``dem`` (every cell centre a vertex, two
    triangles per cell): the reference the robot builder's error is measured against."""
    from .tin import Tin

    _check_dem(dem)
    v = np.column_stack([dem.cell_centres(), dem.z.ravel()])
    return Tin(v, full_surface_triangles(dem.shape), source=f"{dem.source} (full surface)")


@njit(cache=True)
def raster_samples(ni, nj, tris, rows, cols):
    """Owner TIN triangle of every full-surface sample (``-1``: none), in grid-index space.

    ``ni``, ``nj``: (rows*cols,) float64 row / column of each node; ``tris`` (T, 3) node ids.
    Sample ``2k`` lies at (i + SAMPLE_NEAR, j + SAMPLE_FAR), sample ``2k + 1`` at
    (i + SAMPLE_FAR, j + SAMPLE_NEAR) of square ``k = i (cols-1) + j`` (:func:`sample_points`).
    A sample on an edge shared by two triangles goes to the later one.
    """
    owner = np.full(2 * (rows - 1) * (cols - 1), -1, np.int64)
    for t in range(tris.shape[0]):
        a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
        ai, aj, bi, bj, ci, cj = ni[a], nj[a], ni[b], nj[b], ni[c], nj[c]
        d = (bj - aj) * (ci - ai) - (bi - ai) * (cj - aj)
        if d == 0.0:
            continue
        i0, i1 = int(min(ai, bi, ci)), int(max(ai, bi, ci))
        j0, j1 = int(min(aj, bj, cj)), int(max(aj, bj, cj))
        for i in range(i0, min(i1, rows - 1)):
            for j in range(j0, min(j1, cols - 1)):
                for k in range(2):
                    pi = i + (SAMPLE_NEAR if k == 0 else SAMPLE_FAR)
                    pj = j + (SAMPLE_FAR if k == 0 else SAMPLE_NEAR)
                    w0 = (bj - aj) * (pi - ai) - (bi - ai) * (pj - aj)
                    w1 = (cj - bj) * (pi - bi) - (ci - bi) * (pj - bj)
                    w2 = (aj - cj) * (pi - ci) - (ai - ci) * (pj - cj)
                    if (d > 0 and w0 >= 0 and w1 >= 0 and w2 >= 0) or (d < 0 and w0 <= 0 and w1 <= 0 and w2 <= 0):
                        owner[2 * (i * (cols - 1) + j) + k] = t
    return owner


@njit(cache=True)
def score_triangles(owner, gx, gy, c0, steep_t, sx, sy, sz, steep_f, weight, nodes, vx, vy, vz, keep,
                    vertical_weight, cell_err):
    """One refinement round's bookkeeping, per TIN triangle ``t`` (``owner`` from
    :func:`raster_samples`; ``gx, gy, c0, steep_t`` the planes and classes of the TIN triangles;
    ``sx, sy, sz, steep_f, weight`` the samples' centroids, classes and misclassification
    weights; ``nodes`` (S, 3) the samples' grid-triangle corners; ``vx, vy, vz`` the cells).

    Returns ``best`` (T,): the largest sample score ``vertical_weight * |dz| / cell_err +
    weight * misclassified`` among samples with a corner not yet kept; ``cell`` (T,): for that
    sample, its not-kept corner of largest vertical error (``-1``: none); ``wrong`` (T,): summed
    weight of its misclassified samples; ``err`` (T,): its largest vertical error at a sample
    centroid, m.
    """
    n_t = gx.shape[0]
    best = np.full(n_t, -1.0)
    cell = np.full(n_t, -1, np.int64)
    wrong = np.zeros(n_t)
    err = np.zeros(n_t)
    for s in range(owner.shape[0]):
        t = owner[s]
        if t < 0:
            continue
        dz = abs(gx[t] * sx[s] + gy[t] * sy[s] + c0[t] - sz[s])
        if dz > err[t]:
            err[t] = dz
        sc = vertical_weight * dz / cell_err
        if steep_t[t] != steep_f[s] and weight[s] > 0:
            wrong[t] += weight[s]
            sc += weight[s]
        if sc <= best[t]:
            continue
        m, e = -1, -1.0
        for k in range(3):
            v = nodes[s, k]
            ev = abs(gx[t] * vx[v] + gy[t] * vy[v] + c0[t] - vz[v])
            if not keep[v] and ev > e:
                m, e = v, ev
        if m >= 0:
            best[t] = sc
            cell[t] = m
    return best, cell, wrong, err


def crest_score(z: np.ndarray) -> np.ndarray:
    """``(rows, cols)`` m: how far a cell rises above the mean of its two neighbours on the
    row, column or diagonal profile where it rises most; 0 where it is below on all four
    (not a crest) and on the border."""
    out = np.zeros_like(z)
    c = z[1:-1, 1:-1]
    pairs = ((z[1:-1, :-2], z[1:-1, 2:]), (z[:-2, 1:-1], z[2:, 1:-1]), (z[:-2, :-2], z[2:, 2:]),
             (z[:-2, 2:], z[2:, :-2]))
    for p, q in pairs:
        np.maximum(out[1:-1, 1:-1], c - 0.5 * (p + q), out=out[1:-1, 1:-1])
    return out


def _check_dem(dem: Dem) -> None:
    if not isinstance(dem, Dem):
        raise ArgumentError(f"dem: method='robot' needs a Dem (a regular grid), got {type(dem).__name__}")
    if np.isnan(dem.z).any():
        raise DemFormatError(f"{dem.source}: {dem.n_nodata} NODATA cells; the robot builder needs a complete "
                             "grid (use dem.fill_nodata() or crop them away)")


def robot_mesh(dem: Dem, max_slope_deg: float, max_vertices: int | None = None, max_error_m: float | None = None,
               *, seed_fraction: float = SEED_FRACTION, crest_fraction: float = CREST_FRACTION,
               batch_fraction: float = BATCH_FRACTION, false_steep_weight: float = FALSE_STEEP_WEIGHT,
               vertical_weight: float = VERTICAL_WEIGHT, false_drivable_weight: float = FALSE_DRIVABLE_WEIGHT):
    """Vertices ``(V, 3)`` m and triangles ``(T, 3)`` of the robot TIN of ``dem`` (module docstring)."""
    _check_dem(dem)
    if max_slope_deg is None or not (np.isfinite(max_slope_deg) and 0 < max_slope_deg < 90):
        raise ArgumentError(f"max_slope_deg must be a number in (0, 90) for method='robot', got {max_slope_deg!r}")
    if max_vertices is None and max_error_m is None:
        raise ArgumentError("method='robot' needs max_vertices, max_error_m or both")
    if max_error_m is not None and not (np.isfinite(max_error_m) and max_error_m >= 0):
        raise ArgumentError(f"max_error_m must be a finite number >= 0, got {max_error_m}")
    if max_vertices is not None and (int(max_vertices) != max_vertices or max_vertices < 4):
        raise ArgumentError(f"max_vertices must be an integer >= 4, got {max_vertices}")
    for name, f in (("seed_fraction", seed_fraction), ("crest_fraction", crest_fraction),
                    ("batch_fraction", batch_fraction)):
        if not (np.isfinite(f) and 0 <= f <= 1) or (name == "batch_fraction" and f == 0):
            raise ArgumentError(f"{name} must be in [0, 1] (batch_fraction > 0), got {f}")
    from scipy.spatial import Delaunay

    from .greedy import greedy_mesh

    rows, cols = dem.shape
    n_cells = rows * cols
    budget = n_cells if max_vertices is None else min(int(max_vertices), n_cells)
    z = dem.z
    zf = z.ravel()
    dx, dy = dem.dx, dem.dy
    tan_s = np.tan(np.radians(max_slope_deg))
    nodes = full_surface_triangles(dem.shape)  # (S, 3): the samples
    ni = (np.arange(n_cells) // cols).astype(np.float64)
    nj = (np.arange(n_cells) % cols).astype(np.float64)
    vx, vy = nj * dx, ni * dy  # cell centres, m, from the south-west one
    steep_f = full_surface_slope_deg(dem) > max_slope_deg  # (S,) class of the full surface
    sp = sample_points(dem)
    sx, sy, sz = sp[:, 0] - dem.x[0], sp[:, 1] - dem.y[0], sp[:, 2]  # in the frame of vx, vy
    cell_err = tan_s * min(dx, dy)  # m: the vertical scale of one cell at the threshold slope
    weight = np.where(steep_f, false_drivable_weight, false_steep_weight)

    keep = np.zeros(n_cells, dtype=bool)
    keep[[0, cols - 1, n_cells - cols, n_cells - 1]] = True
    n_seed = int(seed_fraction * budget)
    if n_seed >= 4 or max_error_m is not None:
        kw = {"max_vertices": max(4, n_seed)} if max_vertices is not None else {}
        v, _ = greedy_mesh(dem, max_error_m=max_error_m, **kw)
        jj = np.rint((v[:, 0] - dem.x[0]) / dx).astype(np.int64)
        ii = np.rint((v[:, 1] - dem.y[0]) / dy).astype(np.int64)
        keep[ii * cols + jj] = True
    n_crest = int(crest_fraction * budget)
    if n_crest > 0:
        cs = crest_score(z).ravel()
        cs[keep] = 0.0
        top = np.argpartition(-cs, min(n_crest, n_cells - 1))[:n_crest]
        keep[top[cs[top] > 0]] = True
    while True:
        idx = np.flatnonzero(keep)
        if len(idx) > budget:  # the seeds overshot a tiny budget: keep the corners and the first ones
            idx = idx[:budget]
        # Delaunay of a slightly sheared copy: a grid square with its four corners kept is then
        # split along SW-NE like the full surface, not as Qhull breaks the co-circular tie
        tri = idx[Delaunay(np.column_stack([vx[idx] - SHEAR * dx * ni[idx], vy[idx]]),
                           qhull_options="Qbb Qc Qz Q12").simplices]
        if len(idx) >= budget:
            break
        owner = raster_samples(ni, nj, tri, rows, cols)
        q = np.stack([vx[tri], vy[tri], zf[tri]], -1)
        n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        flat = n[:, 2] == 0  # a zero-area triangle from Qhull (collinear cells): owns no sample
        nz = np.where(flat, 1.0, n[:, 2])
        gx, gy = np.where(flat, 0.0, -n[:, 0] / nz), np.where(flat, 0.0, -n[:, 1] / nz)
        c0 = q[:, 0, 2] - gx * q[:, 0, 0] - gy * q[:, 0, 1]
        steep_t = np.hypot(gx, gy) > tan_s
        best, cell, wrong, err = score_triangles(owner, gx, gy, c0, steep_t, sx, sy, sz, steep_f, weight, nodes,
                                                 vx, vy, zf, keep, vertical_weight, cell_err)
        if max_error_m is not None and not wrong.any() and err.max() <= max_error_m:
            break
        ok = cell >= 0
        if max_error_m is not None:  # error-bounded: only triangles that break a bound
            ok &= (wrong > 0) | (err > max_error_m)
        if not ok.any():
            break
        cand = np.flatnonzero(ok)
        cand = cand[np.argsort(-(wrong[cand] + best[cand]), kind="stable")]
        add = np.unique(cell[cand], return_index=True)[1]
        add = cell[cand][np.sort(add)][: max(1, min(int(batch_fraction * len(idx)), budget - len(idx)))]
        keep[add] = True
    xyz = np.column_stack([dem.x[idx % cols], dem.y[idx // cols], zf[idx]])
    return xyz, np.searchsorted(idx, tri)
