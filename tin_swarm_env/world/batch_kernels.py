"""The vector env's compiled passes: every robot of every copy in one call.

Robots are numbered globally, copy-major (copy ``c``'s robots are ``off[c]:off[c + 1]``), and
stand on the worlds of a :class:`~.pack.WorldPack` (``wor[i]``, the world of robot ``i``;
triangle indices global). Each pass is the single-world kernel's per-robot code
(:func:`~.locomotion.move1`, :func:`~.sense_kernels.sight1`, :func:`~.sense_kernels._near_row`,
the battery and status updates of :func:`~.step_kernel.step_kernel`, the break contacts of
:func:`~.sense_kernels.sense_pass2`) with the world's arrays chosen per robot
(:func:`terrain_of`) and every neighbour grid built per copy (:func:`grid_build_copies`), so a
robot never meets a robot, target or break of another copy, and each copy's results are the
same bits as its own single env's (``tests/env/test_vector.py`` checks it against separate
envs). Candidate lists are ordered by (distance, global index); global order within a copy is
the copy's own order, so ties break the same way.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .grid import grid_cells, sense_cell
from .locomotion import FELL_INTO, move1
from .sense_kernels import (
    _break_cell,
    _closest,
    _compact_out,
    _copy_kept,
    _insert,
    _kept,
    _mutual,
    _near_row,
    _offsets,
    _put,
    _touches,
    deep_inside,
    in_view,
    nearest_to_front,
    sight1,
    sort_contacts,
)
from .step_kernel import _max0

__all__ = ["terrain_of", "grid_build_copies", "step_copies", "sense_copies"]

_NONE, _FELL, _BATTERY = 0, 2, 3


@njit(cache=True, inline="always")
def terrain_of(T0, w):
    """World ``w``'s :func:`~.sense_kernels.terrain_arrays` tuple, read from the pack's ``T0``
    (global arrays, views of the per-world bucket rows and edges, the world's scalars)."""
    vx, vy, vz, tris, nbrs, grad, bstart, btris, edges, border, bx0, by0, binv, bnx, bny, tol, ztol, ms, bs_off, \
        e_off = T0
    return (vx, vy, vz, tris, nbrs, grad, bstart[bs_off[w]:bs_off[w + 1]], btris, bx0[w], by0[w], binv[w], bnx[w],
            bny[w], edges[e_off[w]:e_off[w + 1]], border[e_off[w]:e_off[w + 1]], tol[w], ztol[w], ms[w])


@njit(cache=True)
def grid_build_copies(x, y, use, off, min_cell):
    """:func:`~.grid.grid_build` for each copy's points ``off[c]:off[c + 1]`` at once: per copy
    ``(x0, y0, inv, nx, ny)`` ``(E,)`` arrays and its first cell ``base (E + 1,)``; one counting
    sort over every point, so ``items[start[base[c] + cell] : start[base[c] + cell + 1]]`` are
    copy ``c``'s points in that cell, in index order (the same cells as ``grid_build`` on the
    copy alone)."""
    E = off.shape[0] - 1
    n = x.shape[0]
    X0 = np.zeros(E)
    Y0 = np.zeros(E)
    INV = np.empty(E)
    NX = np.ones(E, dtype=np.int64)
    NY = np.ones(E, dtype=np.int64)
    base = np.zeros(E + 1, dtype=np.int64)
    cs0 = max(min_cell, 1e-9)
    for c in range(E):
        m = 0
        x0 = np.inf
        y0 = np.inf
        x1 = -np.inf
        y1 = -np.inf
        for i in range(off[c], off[c + 1]):
            if use[i]:
                m += 1
                x0 = min(x0, x[i])
                y0 = min(y0, y[i])
                x1 = max(x1, x[i])
                y1 = max(y1, y[i])
        if m == 0:
            INV[c] = 1.0 / cs0
            base[c + 1] = base[c] + 1
            continue
        cs = cs0
        max_cells = 4 * m + 64
        while True:
            nx = int((x1 - x0) / cs) + 1
            ny = int((y1 - y0) / cs) + 1
            if nx * ny <= max_cells:
                break
            cs *= 2.0
        X0[c] = x0
        Y0[c] = y0
        INV[c] = 1.0 / cs
        NX[c] = nx
        NY[c] = ny
        base[c + 1] = base[c] + nx * ny
    start = np.zeros(base[E] + 1, dtype=np.int64)
    cell = np.empty(n, dtype=np.int64)
    m = 0
    for c in range(E):
        for i in range(off[c], off[c + 1]):
            if use[i]:
                cx = min(int((x[i] - X0[c]) * INV[c]), NX[c] - 1)
                cy = min(int((y[i] - Y0[c]) * INV[c]), NY[c] - 1)
                k = base[c] + cy * NX[c] + cx
                cell[i] = k
                start[k + 1] += 1
                m += 1
    for k in range(base[E]):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    items = np.empty(m, dtype=np.int64)
    gx = np.empty(m)
    gy = np.empty(m)
    for i in range(n):
        if use[i]:
            k = cell[i]
            items[fill[k]] = i
            gx[fill[k]] = x[i]
            gy[fill[k]] = y[i]
            fill[k] += 1
    return X0, Y0, INV, NX, NY, base, start, items, gx, gy


@njit(cache=True, parallel=True)
def _collisions(px, py, cop, G, diameter):
    """:func:`~.sense_kernels.collision_counts` per copy (grid ``G`` of :func:`grid_build_copies`,
    cells >= ``diameter``): ``(n,)`` the present robots of its copy closer than ``diameter``."""
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = G
    n = px.shape[0]
    lo2 = -1.0
    hi2 = -1.0
    if 1e-100 <= diameter <= 1e100:
        lo2 = (diameter * (1.0 - 1e-6)) ** 2
        hi2 = (diameter * (1.0 + 1e-6)) ** 2
    if not hi2 > 0.0:
        hi2 = math.inf
    coll = np.zeros(n, dtype=np.int64)
    for q in prange(items.shape[0]):
        i = items[q]
        c = cop[i]
        nx = NX[c]
        st = start[base[c]:]
        cx_lo, cx_hi, cy_lo, cy_hi = grid_cells(X0[c], Y0[c], INV[c], nx, NY[c], px[i], py[i])
        k = 0
        for cy in range(cy_lo, cy_hi + 1):
            for m in range(st[cy * nx + cx_lo], st[cy * nx + cx_hi + 1]):
                j = items[m]
                if j != i and _touches(gx[m] - px[i], gy[m] - py[i], diameter, lo2, hi2):
                    k += 1
        coll[i] = k
    return coll


@njit(cache=True, parallel=True)
def _move_all(T0, steep, wor, pos, tri, head, heights, status, battery, cmd, max_speed, max_climb_deg, max_turn, dt,
              idle_j, drive_j_per_m, climb_j_per_m):
    n = pos.shape[0]
    out_pos = np.empty((n, 2))
    xs = np.empty(n)
    ys = np.empty(n)
    out_tri = np.empty(n, dtype=np.int64)
    out_head = np.empty(n)
    speeds = np.empty(n)
    out_h = np.empty(n)
    batt = np.empty(n)
    energy = np.empty(n)
    out_status = np.empty(n, dtype=np.int8)
    fell = np.empty(n, dtype=np.bool_)
    emptied = np.empty(n, dtype=np.bool_)
    present = np.empty(n, dtype=np.bool_)
    for i in prange(n):
        T = terrain_of(T0, wor[i])
        st = status[i]
        active = st == _NONE
        x, y, t, hd, sp, ev, z, mv, cl = move1(T, steep, pos[i, 0], pos[i, 1], tri[i], head[i], heights[i], active,
                                               cmd[i, 0], cmd[i, 1], max_speed, max_climb_deg, max_turn, dt)
        out_pos[i, 0] = x
        out_pos[i, 1] = y
        xs[i] = x
        ys[i] = y
        out_tri[i] = t
        out_head[i] = hd
        speeds[i] = sp
        out_h[i] = z
        use = idle_j + drive_j_per_m * mv + climb_j_per_m * _max0(cl)
        if not active:
            use = 0.0
        b = _max0(battery[i] - use)
        batt[i] = b
        energy[i] = battery[i] - b
        f = ev == FELL_INTO
        fell[i] = f
        if f:
            st = _FELL
        e = st == _NONE and b <= 0.0
        emptied[i] = e
        if e:
            st = _BATTERY
        out_status[i] = st
        present[i] = st == _NONE or st == _BATTERY
    return out_pos, xs, ys, out_tri, out_head, out_h, speeds, batt, energy, out_status, fell, emptied, present


def step_copies(T0, steep, wor, cop, off, pos, tri, head, heights, status, battery, cmd, p):
    """One world step of every robot of every copy (``p``: the scalars of
    :func:`~.step_kernel.step_kernel`, ``(max_speed, max_climb_deg, max_turn, dt, idle_j,
    drive_j_per_m, climb_j_per_m, diameter)``). Returns ``(pos, tri, head, heights, speeds,
    battery, energy, status, fell, emptied, collisions)``."""
    max_speed, max_climb_deg, max_turn, dt, idle_j, drive_j, climb_j, diameter = p
    (pos2, xs, ys, tri2, head2, h2, speeds, batt, energy, status2, fell, emptied, present) = _move_all(
        T0, steep, wor, pos, tri, head, heights, status, battery, cmd, max_speed, max_climb_deg, max_turn, dt,
        idle_j, drive_j, climb_j)
    coll = _collisions(xs, ys, cop, grid_build_copies(xs, ys, present, off, diameter), diameter)
    return pos2, tri2, head2, h2, speeds, batt, energy, status2, fell, emptied, coll


# -- sensing -----------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def _entity_row_copy(T, i, qx, qy, qz, h, ch, sh, ti, deep, ex, ey, ez, j0, j1, range_m, half_fov, cos_hf, check_los,
                     idx, dist, vis):
    """:func:`~.sense_kernels._entity_row` over the entities ``j0:j1`` of the robot's copy (a
    scan of the few entities instead of a grid: the same (distance, index) order, so the same
    slots)."""
    k = idx.shape[1]
    r2 = (range_m * (1.0 + 1e-9)) ** 2
    c = 0
    for j in range(j0, j1):
        dx = ex[j] - qx
        dy = ey[j] - qy
        d2 = dx * dx + dy * dy
        if d2 > r2:
            continue
        d = math.sqrt(d2)
        if d <= range_m:
            c = _insert(idx, dist, i, c, k, j, d)
    for s in range(c):
        j = idx[i, s]
        v = 1 if in_view(ex[j] - qx, ey[j] - qy, dist[i, s], ch, sh, h, half_fov, cos_hf) else 0
        if v and check_los:
            v = sight1(T, qx, qy, qz, ex[j], ey[j], ez[j], ti, deep)
        vis[i, s] = v
    return c


@njit(cache=True, inline="always")
def _break_range(bst, bx0, by0, binv, bnx, bny, b0, b1, x, y):
    """``(lo, hi, gridded)``: the break-grid rows of ``(x, y)`` in its world's grid (start rows
    ``bst``), or every break of the world ``b0:b1`` outside the grid."""
    cell = _break_cell(bx0, by0, binv, bnx, bny, x, y)
    if cell >= 0:
        return bst[cell], bst[cell + 1], True
    return b0, b1, False


@njit(cache=True, parallel=True)
def _sense1(T0, wor, cop, margin, px, py, head, tri, sz, active, G, range_m, half_fov, cos_hf, check_los,
            r_idx, r_dist, r_vis, r_cnt, tx, ty, tz, t_rng, t_idx, t_dist, t_vis, t_cnt,
            ax_, ay_, az_, a_rng, a_idx, a_dist, a_vis, a_cnt, B, bcnt, deep):
    bax, bay, bbx, bby, BX0, BY0, BINV, BNX, BNY, bstart, bitems, bs_off, b_off = B
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = G
    r2 = (range_m * (1.0 + 1e-9)) ** 2
    for q in prange(items.shape[0]):
        i = items[q]
        w = wor[i]
        c = cop[i]
        T = terrain_of(T0, w)
        dp = deep_inside(T, px[i], py[i], tri[i], margin[w])
        deep[i] = dp
        if not active[i]:
            continue
        h = head[i]
        ch = math.cos(h)
        sh = math.sin(h)
        k = _near_row(i, px[i], py[i], X0[c], Y0[c], INV[c], NX[c], NY[c], start[base[c]:], items, gx, gy, i, range_m,
                      r2, r_idx, r_dist)
        for s in range(k):
            j = r_idx[i, s]
            r_vis[i, s] = 0
            if not in_view(px[j] - px[i], py[j] - py[i], r_dist[i, s], ch, sh, h, half_fov, cos_hf):
                r_idx[i, s] = -1 - j
        r_cnt[i] = k
        t_cnt[i] = _entity_row_copy(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, tx, ty, tz, t_rng[c, 0],
                                    t_rng[c, 1], range_m, half_fov, cos_hf, check_los, t_idx, t_dist, t_vis)
        a_cnt[i] = _entity_row_copy(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, ax_, ay_, az_, a_rng[c, 0],
                                    a_rng[c, 1], range_m, half_fov, cos_hf, check_los, a_idx, a_dist, a_vis)
        lo, hi, gridded = _break_range(bstart[bs_off[w]:bs_off[w + 1]], BX0[w], BY0[w], BINV[w], BNX[w], BNY[w],
                                       b_off[w], b_off[w + 1], px[i], py[i])
        m = 0
        for v in range(lo, hi):
            e = bitems[v] if gridded else v
            if _closest(px[i], py[i], bax[e], bay[e], bbx[e], bby[e])[2] <= range_m:
                m += 1
        bcnt[i] = m


@njit(cache=True, parallel=True)
def _sense2(T0, wor, px, py, sz, tri, active, items, range_m, check_los, r_idx, r_dist, r_vis, r_cnt, B, bcnt,
            deep, k_front):
    bax, bay, bbx, bby, BX0, BY0, BINV, BNX, BNY, bstart, bitems, bs_off, b_off = B
    n = px.shape[0]
    off = _offsets(bcnt)
    tot = off[n]
    obs = np.empty(tot, dtype=np.int64)
    seg = np.empty(tot, dtype=np.int64)
    dist = np.empty(tot)
    closest = np.empty((tot, 2))
    for q in prange(items.shape[0]):
        i = items[q]
        if not active[i]:
            continue
        w = wor[i]
        for s in range(r_cnt[i]):
            j = r_idx[i, s]
            if j < 0:
                continue
            if not check_los:
                r_vis[i, s] = 1
                continue
            m = _mutual(r_idx, r_dist, r_cnt, j, i, r_dist[i, s])
            if j < i and m >= 0:
                continue
            lo = min(i, j)
            hi = max(i, j)
            v = sight1(terrain_of(T0, w), px[lo], py[lo], sz[lo], px[hi], py[hi], sz[hi], tri[lo], deep[lo])
            r_vis[i, s] = v
            if m >= 0:
                r_vis[j, m] = v
        if bcnt[i] == 0:
            continue
        lo, hi, gridded = _break_range(bstart[bs_off[w]:bs_off[w + 1]], BX0[w], BY0[w], BINV[w], BNX[w], BNY[w],
                                       b_off[w], b_off[w + 1], px[i], py[i])
        p0 = off[i]
        m = 0
        for v in range(lo, hi):
            e = bitems[v] if gridded else v
            cx, cy, d = _closest(px[i], py[i], bax[e], bay[e], bbx[e], bby[e])
            if d <= range_m:
                _put(dist, seg, closest, p0 + m, d, e, cx, cy)
                m += 1
        if k_front < 0:
            sort_contacts(dist, seg, closest, p0, m)
        else:
            nearest_to_front(dist, seg, closest, p0, m, k_front)
        for p in range(p0, p0 + m):
            obs[p] = i
    rows = np.empty(n, dtype=np.int64)
    for i in prange(n):
        rows[i] = _kept(r_idx, r_vis, r_cnt, i) if active[i] else 0
    start, ro, rt, rd = _compact_out(rows)
    for i in prange(n):
        if rows[i]:
            _copy_kept(r_idx, r_dist, r_vis, r_cnt, i, start[i], ro, rt, rd)
    return (obs, seg, dist, closest, off), (ro, rt, rd, start)


def sense_copies(pack, wor, cop, off, px, py, head, tri, sz, active, present, sensor, R, TG, AS, k_front=-1):
    """What every robot of every copy senses: ``(robots (observer, target, distance, start),
    breaks (observer, break, distance, closest, start), targets_rows, assets_rows)``, robot
    and break ids global; ``R``/``TG``/``AS`` the ``(idx, dist, vis, cnt)`` candidate slots
    (``cnt`` zeroed) and the entities ``(ex, ey, ez, rng (E, 2))`` of ``TG``/``AS`` (copy c's are
    ``rng[c, 0]:rng[c, 1]``), the slots of the targets and assets left for
    :func:`~.sense_kernels.compact`. ``k_front >= 0``: each robot's break contacts hold its
    ``k_front`` nearest first, in (distance, index) order, and the rest in no order
    (:func:`~.sense_kernels.nearest_to_front`; -1: all sorted)."""
    r = float(sensor.range_m)
    half_fov = math.radians(sensor.fov_deg) / 2 + 1e-12
    los = bool(sensor.check_los)
    G = grid_build_copies(px, py, present, off, sense_cell(r))
    n = px.shape[0]
    bcnt = np.zeros(n, dtype=np.int64)
    deep = np.empty(n, dtype=np.bool_)
    (tx, ty, tz, t_rng), t_slots = TG
    (ax_, ay_, az_, a_rng), a_slots = AS
    B = pack.B
    _sense1(pack.T0, wor, cop, pack.margin, px, py, head, tri, sz, active, G, r, half_fov, math.cos(half_fov), los,
            *R, tx, ty, tz, t_rng, *t_slots, ax_, ay_, az_, a_rng, *a_slots, B, bcnt, deep)
    return _sense2(pack.T0, wor, px, py, sz, tri, active, G[7], r, los, *R, B, bcnt, deep, int(k_front))

