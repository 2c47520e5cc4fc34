"""A TIN built for robots: the slope class (drivable / too steep), breaks and sight lines kept.

``build_tin(dem, method="robot", max_vertices=N and/or max_error_m=E, max_slope_deg=S)``.

Reference surface and error
---------------------------
The surface a robot would see at full resolution is :func:`full_surface`: every cell centre a
vertex, each grid square split along its south-west -> north-east diagonal (two triangles per
cell). Each of its triangles holds one *sample* (:func:`sample_points`: an interior point off
every line through two grid nodes, so no TIN edge hides it on a boundary) with that
triangle's class (slope > S) and height. All samples stand for the same plan area. The robot
error of a TIN triangle (:func:`triangle_cost`) sums over its samples ``weight`` when its class
differs (a drivable sample under a too-steep triangle weighs ``false_steep_weight`` = 3: that
is the thin steep sliver that cuts drivable ground into pieces; the other way 1: it only
shortens paths) plus ``vertical_weight x |dz| / (tan S x cell)``, vertical error as the
tie-breaker.

Method
------
1. Vertices by greedy insertion on vertical error (Garland and Heckbert 1995, "Fast polygonal
   approximation of terrains and height fields", via pydelatin: :func:`~.greedy.greedy_mesh`):
   it places cliff feet and tops, valley floors and crests first, the breaks and the sight
   lines. When it fills ``max_vertices`` (the default ``seed_fraction`` = 1, unless
   ``max_error_m`` stops it first) its own triangles go to step 3.
2. Otherwise (``max_error_m`` reached first, or ``seed_fraction`` < 1) a batched greedy insertion on
   the robot error: the rest of the budget, after ``crest_fraction`` of it on *crest* cells
   (:func:`crest_score`: higher than both neighbours on a row, column or diagonal profile, the
   ridges that hide things), goes in rounds: Delaunay in x, y (scipy/Qhull, on a copy sheared
   by ``SHEAR`` so a square with all four corners kept is split SW-NE like the full surface);
   every sample to its TIN triangle (:func:`raster_samples`); per triangle, the corner of its
   worst sample's grid triangle with the largest vertical error is a candidate
   (:func:`score_triangles`); the ``batch_fraction`` x V best triangles by misclassified weight
   get theirs. It stops at ``max_vertices``, or when no sample is misclassified and every
   vertical error at a sample is at most ``max_error_m`` (then the TIN has the full surface's
   class at every sample: a cliff band is bounded by TIN edges), or when nothing is left to add.
3. Data-dependent edge flips (Dyn, Levin and Rippa 1990, "Data dependent triangulations for
   piecewise linear interpolation"), ``flip_passes`` sweeps (:func:`flip_edges`): the diagonal
   of each convex quadrilateral goes where the robot error of the two triangles
   (``flip_vertical_weight`` for the vertical term) is lower, never making an angle below
   ``MIN_FLIP_ANGLE_DEG`` (no new slivers). When step 2 met ``max_error_m`` the flips are kept
   only if the bound still holds.

Cost: greedy insertion (C++), then one scan of the samples for the triangle costs and, per
sweep, two triangle costs per interior edge (each a scan of the samples in a triangle's rows):
O(rows x cols) per sweep, compiled (numba). Step 2 adds per round a Delaunay of V points and a
scan of the samples. Measured against greedy at the same vertex count: ``docs/figures/terrain_robot.md``
(``python bench/terrain.py --robot --write``).

``build_tin(dem, method="trust", ...)`` is this builder with :data:`TRUST_SETTINGS`: half the
budget by greedy insertion (step 1), the other half in step 2 (``crest_fraction`` of the budget on
crest cells, the rest by the robot error), then the flips. Against the full surface, with the measures of
``bench/terrain.py --trust`` (docs/figures/terrain_robot.md), at 10 % of jacksboro's cells and
20 deg: slope class at firm points 90.8 % (greedy 88.1 %), reachability 90.3 % (84.7 %), line of
sight 90.7 % (92.9 %); 0.28 s and 37 MB peak (greedy 0.07 s, 14 MB), 0.03 s for a 128 x 128 crop.
Its errors lean towards drivable ground: it can open a barrier the ground keeps (the jacksboro
scenario's way to one target at 10 000 vertices is the straight line, 2211 m, against 2634-2884 m
on the full surfaces), which is why it is not a scenario default.

Limits: on a DEM whose slope field is noisy at the cell scale (jacksboro at 20 deg: the two
halves of 14 % of its cells have different classes, 36 % of its cells touch both classes) no
TIN with a tenth of the cells reproduces the full surface's classes or drivable distances: the
same full surface with the *other* diagonal in every cell agrees with it on slope class at
about 90 % of points and on cost-to-go (within 5 %) at about 45 % (bench/terrain.py, row
"other diagonal").
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import ArgumentError, DemFormatError
from .dem import Dem

__all__ = ["robot_mesh", "full_surface", "full_surface_triangles", "full_surface_slope_deg", "sample_points",
           "raster_samples", "score_triangles", "crest_score", "triangle_cost", "flip_edges"]

SEED_FRACTION = 1.0  # of max_vertices, from plain greedy insertion (vertical error)
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
FLIP_PASSES = 1  # sweeps of data-dependent edge flips after the last insertion
FLIP_VERTICAL_WEIGHT = 1.0  # per cell-scale vertical error, in the flips' cost
MIN_FLIP_GAIN = 0.25  # a pair of triangles costing less is not worth a flip (cost: one misclassified sample = 1)
# build_tin(method="trust"): half the budget by greedy insertion, the rest on the robot error (issue 45's
# measures, docs/figures/terrain_robot.md: at 10 % of jacksboro's cells, 20 deg, reachability 90 % against
# greedy's 85 % and robot's 87 %)
TRUST_SETTINGS = {"seed_fraction": 0.5}
MIN_FLIP_ANGLE_DEG = 5.0  # a flip may not make a triangle with a smaller angle (no slivers)


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


def _check_robot_args(dem, max_slope_deg, max_vertices, max_error_m, seed_fraction, crest_fraction,
                      batch_fraction) -> None:
    """:func:`robot_mesh`'s arguments, each refused with a message that names it."""
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


def robot_mesh(dem: Dem, max_slope_deg: float, max_vertices: int | None = None, max_error_m: float | None = None,
               *, seed_fraction: float = SEED_FRACTION, crest_fraction: float = CREST_FRACTION,
               batch_fraction: float = BATCH_FRACTION, false_steep_weight: float = FALSE_STEEP_WEIGHT,
               vertical_weight: float = VERTICAL_WEIGHT, false_drivable_weight: float = FALSE_DRIVABLE_WEIGHT,
               flip_passes: int = FLIP_PASSES, flip_vertical_weight: float = FLIP_VERTICAL_WEIGHT):
    """Vertices ``(V, 3)`` m and triangles ``(T, 3)`` of the robot TIN of ``dem`` (module docstring)."""
    _check_robot_args(dem, max_slope_deg, max_vertices, max_error_m, seed_fraction, crest_fraction, batch_fraction)
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
    greedy_tri = None
    if n_seed >= 4 or max_error_m is not None:
        kw = {"max_vertices": max(4, n_seed)} if max_vertices is not None else {}
        v, greedy_tri = greedy_mesh(dem, max_error_m=max_error_m, **kw)
        jj = np.rint((v[:, 0] - dem.x[0]) / dx).astype(np.int64)
        ii = np.rint((v[:, 1] - dem.y[0]) / dy).astype(np.int64)
        greedy_tri = (ii * cols + jj)[greedy_tri]
        keep[ii * cols + jj] = True
    if greedy_tri is not None and max_vertices is not None and len(v) >= budget:
        # the whole budget from greedy insertion: its own triangles, then the flips
        idx = np.flatnonzero(keep)
        return _finish(dem, idx, greedy_tri, None, flip_passes, flip_vertical_weight, None, ni, nj, vx, vy,
                       sx, sy, sz, steep_f, weight, tan_s, cell_err, None)
    n_crest = min(int(crest_fraction * budget), budget - int(keep.sum()))
    if n_crest > 0:
        cs = crest_score(z).ravel()
        cs[keep] = 0.0
        top = np.argpartition(-cs, min(n_crest, n_cells - 1))[:n_crest]
        keep[top[cs[top] > 0]] = True

    def stats(tri):
        owner = raster_samples(ni, nj, tri, rows, cols)
        q = np.stack([vx[tri], vy[tri], zf[tri]], -1)
        n = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
        flat = n[:, 2] == 0  # a zero-area triangle from Qhull (collinear cells): owns no sample
        nz = np.where(flat, 1.0, n[:, 2])
        gx, gy = np.where(flat, 0.0, -n[:, 0] / nz), np.where(flat, 0.0, -n[:, 1] / nz)
        c0 = q[:, 0, 2] - gx * q[:, 0, 0] - gy * q[:, 0, 1]
        steep_t = np.hypot(gx, gy) > tan_s
        return score_triangles(owner, gx, gy, c0, steep_t, sx, sy, sz, steep_f, weight, nodes, vx, vy, zf, keep,
                               vertical_weight, cell_err)

    reached = False  # the loop ended with every sample classified right and within max_error_m
    while True:
        idx = np.flatnonzero(keep)
        if len(idx) > budget:  # the seeds overshot a tiny budget: keep the corners and the first ones
            idx = idx[:budget]
        # Delaunay of a slightly sheared copy: a grid square with its four corners kept is then
        # split along SW-NE like the full surface, not as Qhull breaks the co-circular tie
        d = Delaunay(np.column_stack([vx[idx] - SHEAR * dx * ni[idx], vy[idx]]), qhull_options="Qbb Qc Qz Q12")
        tri = idx[d.simplices]
        if len(idx) >= budget:
            break
        best, cell, wrong, err = stats(tri)
        if max_error_m is not None and not wrong.any() and err.max() <= max_error_m:
            reached = True
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
    return _finish(dem, idx, tri, d.neighbors.astype(np.int64), flip_passes, flip_vertical_weight,
                   max_error_m if reached else None, ni, nj,
                   vx, vy, sx, sy, sz, steep_f, weight, tan_s, cell_err, stats)


def _finish(dem, idx, tri, nbrs, flip_passes, flip_vertical_weight, max_error_m, ni, nj, vx, vy, sx, sy, sz, steep_f,
            weight, tan_s, cell_err, stats):
    """The flips (:func:`flip_edges`) and the vertices/triangles to return; ``nbrs`` None: computed.
    ``max_error_m`` not None: the bound the triangles meet, kept (flips undone when they break it)."""
    rows, cols = dem.shape
    zf = dem.z.ravel()
    if flip_passes > 0:
        if nbrs is None:
            from .tin import triangle_neighbors

            tri_f, _ = _ccw(tri, np.zeros_like(tri), vx, vy)
            nbrs = triangle_neighbors(tri_f, vx, dem.source)
        else:
            tri_f, nbrs = _ccw(tri, nbrs, vx, vy)
        flip_edges(tri_f, nbrs, vx, vy, zf, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s,
                   flip_vertical_weight, cell_err, np.cos(np.radians(MIN_FLIP_ANGLE_DEG)), flip_passes)
        if max_error_m is None:
            tri = tri_f
        else:  # keep the flips only where they keep the bound the loop reached
            _, _, wrong, err = stats(tri_f)
            if not wrong.any() and err.max() <= max_error_m:
                tri = tri_f
    xyz = np.column_stack([dem.x[idx % cols], dem.y[idx // cols], zf[idx]])
    return xyz, np.searchsorted(idx, tri)


def _ccw(tri, nbrs, vx, vy):
    """Copies of ``tri`` and its neighbours with every triangle counter-clockwise in x, y."""
    tri, nbrs = tri.copy(), nbrs.copy()
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    cw = (vx[b] - vx[a]) * (vy[c] - vy[a]) - (vy[b] - vy[a]) * (vx[c] - vx[a]) < 0
    tri[cw] = tri[cw][:, [0, 2, 1]]
    nbrs[cw] = nbrs[cw][:, [0, 2, 1]]
    return tri, nbrs


@njit(cache=True)
def triangle_cost(p, q, r, vx, vy, vz, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s, vw, cell_err):
    """Robot error of the triangle (p, q, r) (cells, CCW) over the samples inside it:
    ``sum(weight * misclassified + vw * |dz| / cell_err)``; ``inf`` when not counter-clockwise."""
    ax, ay, bx, by, cx, cy = vx[p], vy[p], vx[q], vy[q], vx[r], vy[r]
    if (bx - ax) * (cy - ay) - (by - ay) * (cx - ax) <= 0:
        return np.inf
    ux, uy, uz = bx - ax, by - ay, vz[q] - vz[p]
    wx, wy, wz = cx - ax, cy - ay, vz[r] - vz[p]
    nz = ux * wy - uy * wx
    gx, gy = -(uy * wz - uz * wy) / nz, -(uz * wx - ux * wz) / nz
    steep = gx * gx + gy * gy > tan_s * tan_s
    i0, i1 = int(min(ni[p], ni[q], ni[r])), int(max(ni[p], ni[q], ni[r]))
    j0, j1 = int(min(nj[p], nj[q], nj[r])), int(max(nj[p], nj[q], nj[r]))
    c = 0.0
    for i in range(i0, min(i1, rows - 1)):
        for k in range(2):
            # the columns where the row of samples k crosses the triangle (index space), one cell of slack;
            # the exact test below decides
            fi = i + (SAMPLE_NEAR if k == 0 else SAMPLE_FAR)
            off = SAMPLE_FAR if k == 0 else SAMPLE_NEAR
            lo, hi = _row_span(ni[p], nj[p], ni[q], nj[q], ni[r], nj[r], fi)
            ja, jb = max(j0, int(np.floor(lo - off)) - 1), min(j1, int(np.ceil(hi - off)) + 1, cols - 2)
            for j in range(ja, jb + 1):
                s = 2 * (i * (cols - 1) + j) + k
                px, py = sx[s], sy[s]
                if ((bx - ax) * (py - ay) - (by - ay) * (px - ax) >= 0
                        and (cx - bx) * (py - by) - (cy - by) * (px - bx) >= 0
                        and (ax - cx) * (py - cy) - (ay - cy) * (px - cx) >= 0):
                    c += vw * abs(vz[p] + gx * (px - ax) + gy * (py - ay) - sz[s]) / cell_err
                    if steep != steep_f[s]:
                        c += weight[s]
    return c


@njit(cache=True)
def _row_span(ai, aj, bi, bj, ci, cj, fi):
    """(lo, hi): the column range where the line row = fi crosses triangle a, b, c (index space);
    lo > hi when it misses."""
    lo, hi = np.inf, -np.inf
    for pi, pj, qi, qj in ((ai, aj, bi, bj), (bi, bj, ci, cj), (ci, cj, ai, aj)):
        if (pi <= fi <= qi) or (qi <= fi <= pi):
            if pi == qi:
                x0, x1 = min(pj, qj), max(pj, qj)
            else:
                x0 = x1 = pj + (fi - pi) * (qj - pj) / (qi - pi)
            lo, hi = min(lo, x0), max(hi, x1)
    return lo, hi


@njit(cache=True)
def _max_cos(ax, ay, bx, by, cx, cy):
    """The cosine of the smallest angle of a triangle."""
    best = -1.0
    for px, py, qx, qy, rx, ry in ((ax, ay, bx, by, cx, cy), (bx, by, cx, cy, ax, ay), (cx, cy, ax, ay, bx, by)):
        ux, uy, wx, wy = qx - px, qy - py, rx - px, ry - py
        best = max(best, (ux * wx + uy * wy) / np.sqrt((ux * ux + uy * uy) * (wx * wx + wy * wy)))
    return best


@njit(cache=True)
def flip_edges(tris, nbrs, vx, vy, vz, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s, vw, cell_err,
               max_cos, passes):
    """Data-dependent edge flips, in place: each interior edge of a convex quadrilateral is
    flipped when the two new triangles have a lower :func:`triangle_cost` and no angle below
    ``arccos(max_cos)`` (no slivers); ``passes`` sweeps over the triangles. ``tris`` CCW,
    ``nbrs[t, k]`` the triangle opposite vertex k. Returns the number of flips."""
    nt = tris.shape[0]
    cost = np.empty(nt)
    for t in range(nt):
        cost[t] = triangle_cost(tris[t, 0], tris[t, 1], tris[t, 2], vx, vy, vz, ni, nj, rows, cols, sx, sy, sz,
                                steep_f, weight, tan_s, vw, cell_err)
    n_flips = 0
    for _ in range(passes):
        changed = 0
        for t1 in range(nt):
            for k1 in range(3):
                t2 = nbrs[t1, k1]
                if t2 < t1 or cost[t1] + cost[t2] < MIN_FLIP_GAIN:  # each edge once; nothing to gain
                    continue
                c, a, b = tris[t1, k1], tris[t1, (k1 + 1) % 3], tris[t1, (k1 + 2) % 3]
                k2 = -1
                for kk in range(3):
                    if nbrs[t2, kk] == t1:
                        k2 = kk
                if k2 < 0:
                    continue
                d = tris[t2, k2]
                # the new triangles (c, a, d) and (d, b, c) must be CCW (a convex quadrilateral)
                if ((vx[a] - vx[c]) * (vy[d] - vy[c]) - (vy[a] - vy[c]) * (vx[d] - vx[c]) <= 0
                        or (vx[b] - vx[d]) * (vy[c] - vy[d]) - (vy[b] - vy[d]) * (vx[c] - vx[d]) <= 0):
                    continue
                if (_max_cos(vx[c], vy[c], vx[a], vy[a], vx[d], vy[d]) > max_cos
                        or _max_cos(vx[d], vy[d], vx[b], vy[b], vx[c], vy[c]) > max_cos):
                    continue
                n1 = triangle_cost(c, a, d, vx, vy, vz, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s, vw,
                                   cell_err)
                n2 = triangle_cost(d, b, c, vx, vy, vz, ni, nj, rows, cols, sx, sy, sz, steep_f, weight, tan_s, vw,
                                   cell_err)
                if n1 + n2 < cost[t1] + cost[t2] - 1e-9:
                    na, nb = nbrs[t1, (k1 + 1) % 3], nbrs[t1, (k1 + 2) % 3]  # across b-c, c-a
                    mb, ma = nbrs[t2, (k2 + 1) % 3], nbrs[t2, (k2 + 2) % 3]  # across a-d, d-b
                    tris[t1, 0], tris[t1, 1], tris[t1, 2] = c, a, d
                    nbrs[t1, 0], nbrs[t1, 1], nbrs[t1, 2] = mb, t2, nb
                    tris[t2, 0], tris[t2, 1], tris[t2, 2] = d, b, c
                    nbrs[t2, 0], nbrs[t2, 1], nbrs[t2, 2] = na, t1, ma
                    if mb >= 0:
                        for kk in range(3):
                            if nbrs[mb, kk] == t2:
                                nbrs[mb, kk] = t1
                    if na >= 0:
                        for kk in range(3):
                            if nbrs[na, kk] == t1:
                                nbrs[na, kk] = t2
                    cost[t1], cost[t2] = n1, n2
                    changed += 1
                    break  # t1 is a new triangle: its edges next sweep
        n_flips += changed
        if changed == 0:
            break
    return n_flips
