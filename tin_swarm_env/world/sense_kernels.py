"""The per-observer sensing code: what one robot's row of the sensing passes computes.

The passes themselves (numba ``prange`` over observers) are :mod:`.batch_kernels`'
(:func:`~.batch_kernels.sense_copies`, the one path of the env and the vector env); the functions
here are what each iteration runs: candidates from a grid (:func:`near_row`, :func:`entity_row`),
field of view (:func:`in_view`), line of sight (:func:`sight1`, :func:`robot_sight`), the break
contacts (:func:`break_range`, :func:`count_breaks`, :func:`gather_breaks`), and the compaction of
the slots into contact lists (:func:`compact`). Every observer's outputs are computed by one
thread from inputs read in a fixed order (grid cells in index order, candidates sorted by
(distance, index)), and nothing is summed across threads, so the results are bit-identical for
any thread count and to the same functions run as plain Python (``kernel.py_func``: the serial
reference loops the tests compare against). Per-observer results land in fixed ``(n, K)`` slot
arrays and are compacted (an O(n) prefix sum) into the observer-major contact lists of
:mod:`.sensing`.

``T``, the terrain tuple of :func:`terrain_arrays`, carries what the triangle walks read.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..terrain._kernels import bucket_locate1, los_brute1, los_walk1, orient, walk_locate1
from .angles import wrap_pi
from .grid import SENSE_REACH, grid_block
from .scan_kernels import scan_start, scan_wedges

__all__ = ["terrain_arrays", "compact", "bearings", "break_grid", "touches", "entity_row", "near_row",
           "sight1", "deep_margin", "deep_inside", "in_view", "FOV_MARGIN", "locate1", "cell_distance",
           "BREAK_CELL", "range_class", "out_of_range", "RANGE_BAND", "break_row", "break_scratch", "BREAK_CHUNK"]


def terrain_arrays(tin):
    """The arrays the compiled walks read, as one tuple (built once per TIN and cached on it)."""
    T = tin.__dict__.get("_world_kernel_arrays")
    if T is None:
        b = tin._bucket
        tol, ztol = tin.tolerances
        vx, vy = tin.xy_columns
        border = np.ascontiguousarray(tin.edge_triangles[:, 1] < 0)
        T = (vx, vy, np.ascontiguousarray(tin.vertices[:, 2]), tin.triangles, tin.neighbors,
             np.ascontiguousarray(tin.planes[:, :2]), b["start"], b["tris"], float(b["x0"]), float(b["y0"]),
             float(b["inv_cs"]), int(b["nx"]), int(b["ny"]), np.ascontiguousarray(tin.edges), border,
             float(tol), float(ztol), int(tin.n_triangles + 3))
        tin.__dict__["_world_kernel_arrays"] = T
    return T


@njit(cache=True, inline="always")
def locate1(T, x, y, hint):
    """The triangle holding ``(x, y)``: walked from triangle ``hint`` (when ``>= 0``), else (or
    when the walk fails) through the bucket grid, as :meth:`Tin.locate`; -1 outside."""
    vx, vy, vz, tris, nbrs, grad, bs, bt, bx0, by0, binv, bnx, bny, edges, border, tol, ztol, ms = T
    t = -1
    if hint >= 0:
        t = walk_locate1(vx, vy, tris, nbrs, x, y, hint, ms, tol)
    if t < 0:
        t = bucket_locate1(vx, vy, tris, bs, bt, bx0, by0, binv, bnx, bny, x, y, tol)
    return t


@njit(cache=True, inline="always")
def _ground(T, x, y):
    """Terrain height at (x, y) (NaN outside), through the bucket grid."""
    vx, vy, vz, tris, nbrs, grad, bs, bt, bx0, by0, binv, bnx, bny, edges, border, tol, ztol, ms = T
    t = bucket_locate1(vx, vy, tris, bs, bt, bx0, by0, binv, bnx, bny, x, y, tol)
    if t < 0:
        return np.nan
    a = tris[t, 0]
    return vz[a] + grad[t, 0] * (x - vx[a]) + grad[t, 1] * (y - vy[a])


def deep_margin(tin) -> float:
    """How far inside its triangle (as the orientation value ``orient``, twice a signed area) a
    point must lie for every point within 1e-6 m of it to be found in that triangle by the walk,
    rounding included: ``L * (1.1e-6 + 4.5e-16 * C) + 4e-15 * L^2`` with ``L`` the longest
    triangle edge and ``C`` the largest coordinate magnitude (:func:`deep_inside`). Cached on the TIN."""
    m = tin.__dict__.get("_world_deep_margin")
    if m is None:
        v = tin.vertices[:, :2]
        e = v[tin.triangles[:, [1, 2, 0]]] - v[tin.triangles]
        L = float(np.sqrt((e ** 2).sum(axis=-1)).max()) if len(e) else 0.0
        C = float(np.abs(v).max()) if len(v) else 0.0
        m = tin.__dict__["_world_deep_margin"] = L * (1.1e-6 + 4.5e-16 * C) + 4e-15 * L * L
    return m


@njit(cache=True, inline="always")
def deep_inside(T, x, y, t, margin):
    """Whether ``(x, y)`` lies so far inside triangle ``t`` (every edge's ``orient > margin``,
    :func:`deep_margin`) that :func:`sight1`'s start-triangle search from ``t`` (a point at most
    1e-6 m away, walked from ``t``) would return ``t`` itself: then it can be skipped."""
    vx, vy, vz, tris, nbrs, grad, bs, bt, bx0, by0, binv, bnx, bny, edges, border, tol, ztol, ms = T
    if t < 0:
        return False
    for k in range(3):
        a = tris[t, (k + 1) % 3]
        b = tris[t, (k + 2) % 3]
        if not orient(vx[a], vy[a], vx[b], vy[b], x, y) > margin:
            return False
    return True


@njit(cache=True, inline="always")
def sight1(T, ax, ay, az, bx, by, bz, ta, deep):
    """Line of sight a -> b (``ta`` the triangle holding a): as :meth:`Tin.line_of_sight` does
    it, the walk starts in the triangle the segment enters and falls back to the brute force.
    ``deep``: a lies :func:`deep_inside` ``ta``, which is then the triangle the segment enters."""
    vx, vy, vz, tris, nbrs, grad, bs, bt, bx0, by0, binv, bnx, bny, edges, border, tol, ztol, ms = T
    if not deep:
        dx = bx - ax
        dy = by - ay
        length = math.hypot(dx, dy)
        if length > 0 and ta >= 0:
            f = min(1e-6 / length, 1e-3)
            t2 = locate1(T, ax + dx * f, ay + dy * f, ta)
            if t2 >= 0:
                ta = t2
    r = los_walk1(vx, vy, vz, tris, nbrs, grad, ax, ay, az, bx, by, bz, ta, ms, ztol)
    if r < 0:
        r = los_brute1(vx, vy, vz, edges, border, ax, ay, az, bx, by, bz, _ground(T, ax, ay), _ground(T, bx, by),
                       ztol, 1e-9)
    return r


@njit(cache=True)  # called, not inlined: see the docstring
def sight_of_entity(T, ax, ay, az, bx, by, bz, ta, deep):
    """:func:`sight1`, compiled once and called: :func:`entity_row` runs it for the targets and for the
    assets, and inlined there the sensing pass's loop would carry two more copies of the triangle walk
    (its compilation grows with each). A call costs a few ns beside the walk's hundreds."""
    return sight1(T, ax, ay, az, bx, by, bz, ta, deep)


@njit(cache=True, inline="always")
def insert_sorted(idx, dist, i, cnt, k, j, d):
    """Insert (d, j) into row i's sorted buffer of at most k, ordered by (distance, index)."""
    if cnt == k and (d > dist[i, k - 1] or (d == dist[i, k - 1] and j > idx[i, k - 1])):
        return cnt
    p = cnt if cnt < k else k - 1
    while p > 0 and (dist[i, p - 1] > d or (dist[i, p - 1] == d and idx[i, p - 1] > j)):
        if p < k:
            dist[i, p] = dist[i, p - 1]
            idx[i, p] = idx[i, p - 1]
        p -= 1
    dist[i, p] = d
    idx[i, p] = j
    return min(cnt + 1, k)


@njit(cache=True, inline="always")
def _bearing(dx, dy, heading):
    return wrap_pi(math.atan2(dy, dx) - heading)  # (atan2 - heading + pi) % 2pi - pi, bit for bit


FOV_MARGIN = 1e-9  # relative: the dot-product field-of-view test defers to the exact one within it


@njit(cache=True, inline="always")
def in_view(dx, dy, d, ch, sh, heading, half_fov, cos_hf):
    """``abs(_bearing(dx, dy, heading)) <= half_fov`` (the exact test, an atan2 per call),
    decided by the dot product with the heading ``(ch, sh) = (cos, sin)(heading)`` where it
    is clear: ``dx ch + dy sh`` against ``cos(half_fov) d`` (``d`` the distance). The dot product
    and the bearing are both within ~1e-15 (relative) of the true values, so outside a band of
    :data:`FOV_MARGIN` ``* d`` around the threshold they agree; inside it (and for NaN, a zero
    distance) the exact test decides. The same decision as the exact test, bit for bit."""
    if half_fov >= math.pi:
        return True  # every bearing lies in [-pi, pi]
    q = dx * ch + dy * sh - cos_hf * d
    m = FOV_MARGIN * d
    if q > m:
        return True
    if q < -m:
        return False
    return abs(_bearing(dx, dy, heading)) <= half_fov


@njit(cache=True, inline="always")
def near_row(i, qx, qy, x0, y0, inv, nx, ny, start, items, gx, gy, skip, range_m, r2, idx, dist):
    """Row ``i``: the at most K nearest grid points (a :func:`~.grid.grid_build` grid of cells
    ``>= range_m / SENSE_REACH`` (:func:`~.grid.sense_cell`), unpacked) within ``range_m`` of ``(qx, qy)``
    (point ``skip`` left out), nearest first, ties to the lower index; returns how many."""
    k = idx.shape[1]
    c = 0
    cx_lo, cx_hi, cy_lo, cy_hi = grid_block(x0, y0, inv, nx, ny, qx, qy, SENSE_REACH)
    for cy in range(cy_lo, cy_hi + 1):
        for m in range(start[cy * nx + cx_lo], start[cy * nx + cx_hi + 1]):
            dx = gx[m] - qx
            dy = gy[m] - qy
            d2 = dx * dx + dy * dy
            if d2 > r2:
                continue
            j = items[m]
            if j == skip:
                continue
            d = math.sqrt(d2)
            if d <= range_m:
                c = insert_sorted(idx, dist, i, c, k, j, d)
    return c


@njit(cache=True, inline="always")
def entity_row(T, i, qx, qy, qz, h, ch, sh, ti, deep, ex, ey, ez, x0, y0, inv, nx, ny, start, items, gx, gy, range_m,
                half_fov, cos_hf, check_los, idx, dist, vis):
    """Row ``i``'s entity candidates (observer at ``(qx, qy, qz)`` in triangle ``ti``, heading
    ``h``), in view and in sight; returns how many. (At most 30 arguments: CPython passes more
    as ``*args``, which numba does not inline.)"""
    if ex.shape[0] == 0:
        return 0
    c = near_row(i, qx, qy, x0, y0, inv, nx, ny, start, items, gx, gy, -1, range_m, (range_m * (1.0 + 1e-9)) ** 2,
                  idx, dist)
    for s in range(c):
        j = idx[i, s]
        v = 1 if in_view(ex[j] - qx, ey[j] - qy, dist[i, s], ch, sh, h, half_fov, cos_hf) else 0
        if v and check_los:
            v = sight_of_entity(T, qx, qy, qz, ex[j], ey[j], ez[j], ti, deep)
        vis[i, s] = v
    return c


@njit(cache=True, inline="always")
def _break_cell(x0, y0, inv, nx, ny, x, y):
    fx = math.floor((x - x0) * inv)
    fy = math.floor((y - y0) * inv)
    if fx < 0 or fy < 0 or fx >= nx or fy >= ny:
        return -1
    return int(fy) * nx + int(fx)


@njit(cache=True, inline="always")
def mark_out_of_view(i, c, px, py, h, ch, sh, half_fov, cos_hf, r_idx, r_dist, r_vis, r_cnt):
    """Row ``i``'s ``c`` robot candidates: those out of view keep their slot, marked ``-1 - j``."""
    for s in range(c):
        j = r_idx[i, s]
        r_vis[i, s] = 0
        if not in_view(px[j] - px[i], py[j] - py[i], r_dist[i, s], ch, sh, h, half_fov, cos_hf):
            r_idx[i, s] = -1 - j  # in range but out of view: keeps its slot, marked negative
    r_cnt[i] = c


@njit(cache=True, inline="always")
def break_range(bst, bx0, by0, binv, bnx, bny, b0, b1, x, y):
    """``(lo, hi, gridded)``: the break-grid rows of ``(x, y)`` (start rows ``bst``), or every
    break ``b0:b1`` of the terrain when the point is outside the grid."""
    cell = _break_cell(bx0, by0, binv, bnx, bny, x, y)
    if cell >= 0:
        return bst[cell], bst[cell + 1], True
    return b0, b1, False


@njit(cache=True, inline="always")
def count_breaks(x, y, bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m):
    """How many break segments of rows ``lo:hi`` (:func:`break_range`) lie within ``range_m``: each told
    by :func:`range_class` (no division, no root), the few in its band by :func:`_closest` (the test
    :func:`gather_breaks` makes), so the same count."""
    m = 0
    lo2 = range_m * range_m * (1.0 - RANGE_BAND)
    hi2 = range_m * range_m * (1.0 + RANGE_BAND)
    for w in range(lo, hi):
        e = bitems[w] if gridded else w
        v = range_class(x, y, bax[e], bay[e], bbx[e], bby[e], lo2, hi2)
        if v == 1 or (v == 2 and _closest(x, y, bax[e], bay[e], bbx[e], bby[e])[2] <= range_m):
            m += 1
    return m


RANGE_BAND = 1e-6  # relative, on the squared range: range_class defers to the exact distance within it


@njit(cache=True, inline="always")
def range_class(x, y, ax, ay, bx, by, lo2, hi2):
    """Whether segment ``a -> b`` lies within range of ``(x, y)``, from its squared distance without a
    division or a root (to the nearer end, or ``cross^2`` against ``lo2 L^2`` / ``hi2 L^2`` along the
    segment): 1 clearly in (``< lo2``), 0 clearly out (``> hi2``), 2 in the band between, where only
    :func:`_closest`'s distance decides. ``lo2, hi2`` the squared range times ``1 -/+``
    :data:`RANGE_BAND`; both distances are within ~1e-15 (1 + L / range + |coordinates| / range) of
    the true one, far inside the band (coordinates below 1e7 m, segments below 1e6 ranges), so
    outside it they agree with :func:`_closest`'s test."""
    num, den = sq_dist(x, y, ax, ay, bx, by)
    return 1 if num < lo2 * den else (0 if num > hi2 * den else 2)


@njit(cache=True, inline="always")
def out_of_range(x, y, ax, ay, bx, by, hi2):
    """``range_class(x, y, ax, ay, bx, by, 0.0, hi2) == 0`` (segment ``a -> b`` clearly out of range): the
    same :func:`sq_dist` and comparison, no branch waiting on the test."""
    num, den = sq_dist(x, y, ax, ay, bx, by)
    return num > hi2 * den


@njit(cache=True, inline="always")
def sq_dist(x, y, ax, ay, bx, by):
    """``(num, den)``: the squared distance from ``(x, y)`` to segment ``a -> b`` is ``num / den``, with no
    division or root: to the nearer end (``den`` 1), or ``cross^2 / L^2`` along the segment (every case
    computed, the one that applies selected). :func:`range_class` and :func:`out_of_range` read it."""
    apx = x - ax
    apy = y - ay
    abx = bx - ax
    aby = by - ay
    dot = apx * abx + apy * aby
    L2 = abx * abx + aby * aby
    qx = x - bx
    qy = y - by
    cr = apx * aby - apy * abx
    end = dot <= 0.0 or dot >= L2
    num = apx * apx + apy * apy if dot <= 0.0 else (qx * qx + qy * qy if dot >= L2 else cr * cr)
    return num, 1.0 if end else L2


@njit(cache=True)  # called, not inlined: one compiled body for the env and the vector env
def gather_breaks(i, x, y, bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m, p0, dist, seg, closest, obs):
    """Robot ``i``'s break contacts (rows ``lo:hi`` of :func:`break_range`, gathered in ascending
    segment index; those :func:`range_class` puts clearly out skipped before :func:`_closest`) written from
    ``p0`` on, sorted by (distance, index) (:func:`sort_contacts`)."""
    m = 0
    hi2 = range_m * range_m * (1.0 + RANGE_BAND)
    for w in range(lo, hi):
        e = bitems[w] if gridded else w
        if range_class(x, y, bax[e], bay[e], bbx[e], bby[e], 0.0, hi2) == 0:
            continue  # clearly out of range: no division, no root
        cx, cy, d = _closest(x, y, bax[e], bay[e], bbx[e], bby[e])
        if d <= range_m:
            _put(dist, seg, closest, p0 + m, d, e, cx, cy)
            m += 1
    sort_contacts(dist, seg, closest, p0, m)
    for p in range(p0, p0 + m):
        obs[p] = i


BREAK_CHUNK = 128  # break_row takes a robot's candidate segments this many at a time


@njit(cache=True, inline="always")
def break_scratch(K):
    """:func:`break_row`'s scratch (one per thread's run of robots): ``(b (K, 3)`` the scan's beams,
    ``near (2, BREAK_CHUNK)`` a chunk's segments in range and their places in it, ``geo (4, BREAK_CHUNK)`` its
    dangerous ones relative to the robot, ``pairs (2 BREAK_CHUNK + 2, 2)`` their beams
    (:func:`~.scan_kernels.scan_wedges`), ``nd (2, BREAK_CHUNK)`` the chunk's :func:`sq_dist`, ``ga (4,
    BREAK_CHUNK)`` its segments' ends (:func:`_near_chunk`), ``spans (2, BREAK_CHUNK))`` the wedges' beams
    (:func:`~.scan_kernels.wedge_spans`)."""
    return (np.empty((max(K, 1), 3)), np.empty((2, BREAK_CHUNK), dtype=np.int64), np.empty((4, BREAK_CHUNK)),
            np.empty((2 * BREAK_CHUNK + 2, 2), dtype=np.int64), np.empty((2, BREAK_CHUNK)), np.empty((4, BREAK_CHUNK)),
            np.empty((2, BREAK_CHUNK), dtype=np.int64))


@njit(cache=True, error_model="numpy")  # called, not inlined; no division is by zero (no check needed)
def break_row(i, x, y, B, lo, hi, gridded, range_m, S, OB, c, s, W):
    """Robot ``i``'s break contacts (rows ``lo:hi`` of :func:`break_range`, as :func:`gather_breaks`
    finds them: the same tests on the same numbers) kept only as what the observation reads: its
    ``kb`` nearest by (distance, index) in slot row ``i`` (``S``: ``(idx (n, kb), dist, closest (n, kb,
    2), scan (n, K))``, ``idx`` -1 in empty slots), and with ``K`` beams its scan, the dangerous contacts
    crossed by :func:`~.scan_kernels.scan_wedges` (the minimum over the crossings
    :func:`~tin_swarm_env.env.observation.scan_beams` makes over the gathered list, so the same bits),
    over ``range_m`` (1 where no dangerous contact). No contact list is written, so no count pass
    is needed. ``B`` the segments ``(ax, ay, bx, by, items)``; ``OB`` ``(danger, ends (B, 4), units (K, 2))``,
    ``ends`` the same numbers as ``B``'s ``(ax, ay, bx, by)`` side by side (a segment's four in one cache line:
    the pack builds both from the break index) and the ones read here;
    ``(c, s)`` the heading's cos and sin; ``W`` the scratch of :func:`break_scratch`. The rows are taken
    :data:`BREAK_CHUNK` at a time, each in three passes with few branches on fresh results (those that
    stall the pipeline when mispredicted): the segments in range (:func:`_near_chunk`), the nearest kept
    and the dangerous ones listed (:func:`_keep_chunk`: the exact distance only for a segment in the range's
    band or one that may be among the ``kb`` nearest), the scan (:func:`~.scan_kernels.scan_wedges`).
    The kept slots and the scan do not depend on the order the contacts come in, so the same bits."""
    s_idx, s_dist, s_cl, scan = S
    danger, ends, units = OB
    b, near, geo, pairs, nd, ga, spans = W
    kb = s_idx.shape[1]
    K = scan.shape[1]
    for q in range(kb):
        s_idx[i, q] = -1
    m = 0
    used = False
    hi2 = range_m * range_m * (1.0 + RANGE_BAND)
    lo2 = range_m * range_m * (1.0 - RANGE_BAND)
    for w0 in range(lo, hi, BREAK_CHUNK):
        nb = _near_chunk(x, y, ends, B[4], w0, min(w0 + BREAK_CHUNK, hi), gridded, hi2, near, nd, ga)
        m, nc = _keep_chunk(i, x, y, near, nd, ga, nb, range_m, lo2, S, m, danger, geo)
        if K == 0 or nc == 0:
            continue
        if not used:
            used = True
            scan_start(b, c, s, units, range_m, K)
        scan_wedges(b, geo, nc, pairs, c, s, K, spans)
    for k in range(K):
        scan[i, k] = b[k, 0] / range_m if used else 1.0


@njit(cache=True, inline="always")
def _near_chunk(x, y, ends, bitems, w0, w1, gridded, hi2, near, nd, ga):
    """The segments of rows ``w0:w1`` not clearly out of range (:func:`out_of_range`): their ids written to
    ``near[0, :nb]`` and their places in the chunk to ``near[1, :nb]``, in row order; returns ``nb``. In three
    loops: the ends gathered to ``ga (4, chunk)`` (``ax, ay, bx, by``), every :func:`sq_dist` to ``nd (2,
    chunk)`` (a loop with no gather or branch, which the compiler runs several segments at a time), the ones
    not clearly out listed without a branch on the test (no loop-carried wait on a fresh result)."""
    L = w1 - w0
    for q in range(L):
        e = bitems[w0 + q] if gridded else w0 + q
        ga[0, q] = ends[e, 0]
        ga[1, q] = ends[e, 1]
        ga[2, q] = ends[e, 2]
        ga[3, q] = ends[e, 3]
    for q in range(L):
        num, den = sq_dist(x, y, ga[0, q], ga[1, q], ga[2, q], ga[3, q])
        nd[0, q] = num
        nd[1, q] = den
    nb = 0
    for q in range(L):
        near[0, nb] = bitems[w0 + q] if gridded else w0 + q
        near[1, nb] = q
        nb += 0 if nd[0, q] > hi2 * nd[1, q] else 1
    return nb


KEEP_TOL = 1e-6  # of a range (and 1e-6 m): how much nearer than sq_dist says a segment is taken to be, at most


@njit(cache=True, inline="always")
def _keep_chunk(i, x, y, near, nd, ga, nb, range_m, lo2, S, m, danger, geo):
    """The ``nb`` segments ``near`` (:func:`_near_chunk`'s: ``nd`` their :func:`sq_dist`, ``ga`` their ends):
    those within ``range_m`` kept in row ``i``'s slots (:func:`_keep_nearest`, ``m`` kept so far) and, when
    dangerous, written to ``geo`` as ``(wx, wy, ex, ey)`` (``w -> w + e`` relative to the robot; ``geo (4,
    chunk)``). Returns ``(m, how many in geo)``. A segment is in range when its squared distance is clearly
    below the range's (``lo2``, as :func:`range_class`), else when :func:`_closest`'s distance is at most
    ``range_m``; :func:`_closest` (a division and a root) runs only there and for a segment that may be among
    the ``kb`` nearest: while fewer are kept, or when ``sq_dist`` is not clearly beyond the farthest kept (by
    :data:`KEEP_TOL` of a range, far above its rounding: ~1e-15 of the coordinates and the range), so the same
    slots, bit for bit, as every contact's distance would give."""
    s_idx, s_dist, s_cl, scan = S
    kb = s_idx.shape[1]
    tol = KEEP_TOL * (range_m + 1.0)
    nc = 0
    for q in range(nb):
        e = near[0, q]
        p = near[1, q]
        num = nd[0, p]
        den = nd[1, p]
        ax = ga[0, p]
        ay = ga[1, p]
        bx = ga[2, p]
        by = ga[3, p]
        if num >= lo2 * den and _closest(x, y, ax, ay, bx, by)[2] > range_m:
            continue  # in the range's band and out by the exact distance
        if kb and (m < kb or num <= (s_dist[i, kb - 1] + tol) ** 2 * den):
            cx, cy, d = _closest(x, y, ax, ay, bx, by)
            m = _keep_nearest(s_idx, s_dist, s_cl, i, m, kb, e, d, cx, cy)
        geo[0, nc] = ax - x
        geo[1, nc] = ay - y
        geo[2, nc] = bx - ax
        geo[3, nc] = by - ay
        nc += 1 if danger[e] != 0.0 else 0
    return m, nc


@njit(cache=True, inline="always")
def _keep_nearest(idx, dist, cl, i, m, k, e, d, cx, cy):
    """Insert contact ``(d, e)`` (closest point ``(cx, cy)``) into row ``i``'s ``m`` kept, sorted by
    (distance, index), at most ``k``; returns the new count."""
    if m == k and (d > dist[i, k - 1] or (d == dist[i, k - 1] and e > idx[i, k - 1])):
        return m
    p = m if m < k else k - 1
    while p > 0 and (dist[i, p - 1] > d or (dist[i, p - 1] == d and idx[i, p - 1] > e)):
        idx[i, p] = idx[i, p - 1]
        dist[i, p] = dist[i, p - 1]
        cl[i, p, 0] = cl[i, p - 1, 0]
        cl[i, p, 1] = cl[i, p - 1, 1]
        p -= 1
    idx[i, p] = e
    dist[i, p] = d
    cl[i, p, 0] = cx
    cl[i, p, 1] = cy
    return min(m + 1, k)


@njit(cache=True)  # called, not inlined: one compiled body for the env and the vector env
def robot_sight(T, i, px, py, sz, tri, deep, check_los, r_idx, r_dist, r_vis, r_cnt):
    """Line of sight of row ``i``'s in-view robot slots: a pair is walked once, from its lower
    index to its higher; when both see each other in view, the lower-index observer writes both
    slots (the other skips it), so each slot has exactly one writer."""
    for s in range(r_cnt[i]):
        j = r_idx[i, s]
        if j < 0:
            continue
        if not check_los:
            r_vis[i, s] = 1
            continue
        m = _mutual(r_idx, r_dist, r_cnt, j, i, r_dist[i, s])
        if j < i and m >= 0:
            continue  # j walks it and writes this slot
        lo = min(i, j)
        hi = max(i, j)
        v = sight1(T, px[lo], py[lo], sz[lo], px[hi], py[hi], sz[hi], tri[lo], deep[lo])
        r_vis[i, s] = v
        if m >= 0:
            r_vis[j, m] = v


@njit(cache=True, inline="always")
def _mutual(idx, dist, cnt, j, i, d):
    """Slot of ``i`` among ``j``'s in-view candidates, or -1. ``d`` is their distance: ``j``'s row
    is sorted by (distance, index) and holds the same ``d`` for ``i`` (the squared differences
    are the same numbers either way round), so the scan stops at the first farther slot."""
    for s in range(cnt[j]):
        dj = dist[j, s]
        if dj > d:
            return -1
        if dj == d and idx[j, s] == i:
            return s
    return -1


@njit(cache=True, inline="always")
def kept_count(idx, vis, cnt, i):
    m = 0
    for s in range(cnt[i]):
        if idx[i, s] >= 0 and vis[i, s]:
            m += 1
    return m


@njit(cache=True, inline="always")
def copy_kept(idx, dist, vis, cnt, i, p, obs, tgt, d):
    """Row ``i``'s kept slots, written from position ``p`` on."""
    for s in range(cnt[i]):
        j = idx[i, s]
        if j >= 0 and vis[i, s]:
            obs[p] = i
            tgt[p] = j
            d[p] = dist[i, s]
            p += 1


@njit(cache=True, inline="always")
def prefix_offsets(rows):
    """``(n + 1,)`` exclusive prefix sum of ``rows (n,)``: row i's items go to ``[out[i], out[i + 1])``."""
    n = rows.shape[0]
    out = np.empty(n + 1, dtype=np.int64)
    out[0] = 0
    for i in range(n):
        out[i + 1] = out[i] + rows[i]
    return out


@njit(cache=True, inline="always")
def compact_out(rows):
    start = prefix_offsets(rows)
    tot = start[rows.shape[0]]
    return start, np.empty(tot, dtype=np.int64), np.empty(tot, dtype=np.int64), np.empty(tot)


@njit(cache=True)
def bearings(obs, tgt, px, py, head, ex, ey):
    """``(P,)`` the bearing of each contact's point ``(ex, ey)[tgt]`` relative to its observer's
    heading ``head[obs]`` from ``(px, py)[obs]``, in [-pi, pi). The robot contacts' bearings are
    computed by this only when read (:class:`~.sensing.Contacts`): the env's observations do not use them."""
    b = np.empty(obs.shape[0])
    for p in range(obs.shape[0]):
        i = obs[p]
        j = tgt[p]
        b[p] = _bearing(ex[j] - px[i], ey[j] - py[i], head[i])
    return b


@njit(cache=True)
def compact(idx, dist, vis, cnt, px, py, head, ex, ey):
    """The kept slots (``idx >= 0`` and ``vis``) as ``(observer, target, distance, bearing,
    start (n + 1,))`` flattened observer-major: row i's contacts are ``start[i]:start[i + 1]``,
    nearest first; bearings of the points ``(ex, ey)`` relative to each observer's heading."""
    n = idx.shape[0]
    rows = np.empty(n, dtype=np.int64)
    for i in range(n):
        rows[i] = kept_count(idx, vis, cnt, i)
    start, obs, tgt, d = compact_out(rows)
    for i in range(n):
        copy_kept(idx, dist, vis, cnt, i, start[i], obs, tgt, d)
    return obs, tgt, d, bearings(obs, tgt, px, py, head, ex, ey), start


@njit(cache=True, inline="always")
def _put(dist, seg, closest, p, d, e, cx, cy):
    dist[p] = d
    seg[p] = e
    closest[p, 0] = cx
    closest[p, 1] = cy


SORT_BY_INSERTION = 24  # contacts: fewer are sorted in place by insertion, more by a stable merge sort


@njit(cache=True)  # called, not inlined: one compiled body for the env and the vector env
def sort_contacts(dist, seg, closest, p0, m):
    """Order rows ``p0:p0 + m`` (one observer's break contacts, gathered in ascending segment
    index) by (distance, index): a stable sort by distance, as the insertion the contacts were
    once placed by. Insertion for a few; a merge sort (O(m log m)) for the many a robot meets
    where breaks are dense (a generated terrain's: up to ~400 in range), which insertion sorted
    in O(m^2)."""
    if m < 2:
        return
    if m <= SORT_BY_INSERTION:
        for q in range(p0 + 1, p0 + m):
            d = dist[q]
            e = seg[q]
            cx = closest[q, 0]
            cy = closest[q, 1]
            p = q
            while p > p0 and dist[p - 1] > d:
                _put(dist, seg, closest, p, dist[p - 1], seg[p - 1], closest[p - 1, 0], closest[p - 1, 1])
                p -= 1
            _put(dist, seg, closest, p, d, e, cx, cy)
        return
    order = np.argsort(dist[p0:p0 + m], kind="mergesort")
    d = dist[p0:p0 + m].copy()
    e = seg[p0:p0 + m].copy()
    c = closest[p0:p0 + m].copy()
    for k in range(m):
        j = order[k]
        _put(dist, seg, closest, p0 + k, d[j], e[j], c[j, 0], c[j, 1])


# -- terrain breaks ----------------------------------------------------------------------------

BREAK_CELL = 0.5  # break-grid cells of this many sensor ranges (cells <= 0.7 ranges: see break_grid)


@njit(cache=True)
def break_grid(ax, ay, bx, by, range_m, x0, y0, x1, y1):
    """A grid over ``[x0, x1] x [y0, y1]`` with cells of side ``>=`` :data:`BREAK_CELL` ``range_m``
    (more when that would exceed 16 cells per segment plus 4096); each cell lists (in index order)
    every segment within ``range_m`` of the cell (:func:`cell_distance`, with a margin over the
    rounding): all segments within range of any point of the cell, and, of those within range of
    the bounding box grown by ``range_m``, only those (a query meets ~1.7 times the segments in
    range, against ~2.6 for cells of a range listing the grown boxes). Returns ``(x0, y0, inv_cs,
    nx, ny, start, items)``. Cost: O(segments x the cells of each grown box)."""
    nseg = ax.shape[0]
    cs = max(BREAK_CELL * range_m, 1e-9)
    while True:
        nx = int((x1 - x0) / cs) + 1
        ny = int((y1 - y0) / cs) + 1
        if nx * ny <= 16 * nseg + 4096:
            break
        cs *= 2.0
    inv = 1.0 / cs
    exact = cs <= 0.7 * range_m  # cell_distance needs it; larger cells keep every grown box they meet
    reach = range_m * (1.0 + 1e-9) + 1e-6 + 1e-12 * (abs(x0) + abs(y0) + (nx + ny) * cs)
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    for pass_ in range(2):
        if pass_ == 1:
            for c in range(nx * ny):
                start[c + 1] += start[c]
            fill = start[:-1].copy()
            items = np.empty(start[nx * ny], dtype=np.int64)
        for e in range(nseg):
            lx = int(max(math.floor((min(ax[e], bx[e]) - range_m - x0) * inv), 0.0))
            hx = int(min(math.floor((max(ax[e], bx[e]) + range_m - x0) * inv), nx - 1.0))
            ly = int(max(math.floor((min(ay[e], by[e]) - range_m - y0) * inv), 0.0))
            hy = int(min(math.floor((max(ay[e], by[e]) + range_m - y0) * inv), ny - 1.0))
            for cy in range(ly, hy + 1):
                for cx in range(lx, hx + 1):
                    if exact and cell_distance(ax[e], ay[e], bx[e], by[e], x0 + cx * cs, y0 + cy * cs, cs) > reach:
                        continue
                    c = cy * nx + cx
                    if pass_ == 0:
                        start[c + 1] += 1
                    else:
                        items[fill[c]] = e
                        fill[c] += 1
    return x0, y0, inv, nx, ny, start, items


@njit(cache=True, inline="always")
def cell_distance(ax, ay, bx, by, cx, cy, cs):
    """The distance from segment ``a -> b`` to the square cell ``[cx, cx + cs] x [cy, cy + cs]``, or a
    value at most ``cs sqrt(2)`` when the segment crosses the cell: the least of its ends' distances
    to the cell and the cell corners' distances to it (a segment that crosses the cell passes within
    a diagonal of every corner, so with cells of at most 0.7 ranges it is never left out)."""
    d = min(_to_cell(ax, ay, cx, cy, cs), _to_cell(bx, by, cx, cy, cs))
    d = min(d, _closest(cx, cy, ax, ay, bx, by)[2], _closest(cx + cs, cy, ax, ay, bx, by)[2])
    return min(d, _closest(cx, cy + cs, ax, ay, bx, by)[2], _closest(cx + cs, cy + cs, ax, ay, bx, by)[2])


@njit(cache=True, inline="always")
def _to_cell(px, py, cx, cy, cs):
    """The distance from ``(px, py)`` to the cell ``[cx, cx + cs] x [cy, cy + cs]``."""
    dx = max(cx - px, 0.0, px - cx - cs)
    dy = max(cy - py, 0.0, py - cy - cs)
    return math.sqrt(dx * dx + dy * dy)


@njit(cache=True, inline="always")
def _closest(px, py, ax, ay, bx, by):
    """Closest point of segment a -> b to p and its distance (as ``breaks.closest_on_segments``)."""
    abx = bx - ax
    aby = by - ay
    L2 = max(abx * abx + aby * aby, 1e-300)
    u = min(max(((px - ax) * abx + (py - ay) * aby) / L2, 0.0), 1.0)
    cx = ax + u * abx
    cy = ay + u * aby
    ddx = px - cx
    ddy = py - cy
    return cx, cy, math.sqrt(ddx * ddx + ddy * ddy)


# -- collisions -----------------------------------------------------------------------------

@njit(cache=True, inline="always")
def touches(dx, dy, diameter, lo2, hi2):
    """``math.hypot(dx, dy) < diameter``, decided by the squared distance when it is clearly
    inside (``< lo2``) or outside (``> hi2``, a relative margin of 1e-6 on each side, far above
    rounding), so ``hypot`` (a libm call) runs only near the boundary: the same answer."""
    d2 = dx * dx + dy * dy
    if d2 < lo2:
        return True
    if d2 > hi2:
        return False
    return math.hypot(dx, dy) < diameter
