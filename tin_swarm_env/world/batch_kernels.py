"""The vector env's compiled passes: every robot of every copy in one call.

Robots are numbered globally, copy-major (copy ``c``'s robots are ``off[c]:off[c + 1]``), and
stand on the worlds of a :class:`~.pack.WorldPack` (``wor[i]``, the world of robot ``i``;
triangle indices global). Each pass is the single-world kernel's per-robot code
(:func:`~.locomotion.move1`, :func:`~.sense_kernels.sight1`, :func:`~.sense_kernels.near_row`,
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

from .grid import grid_build_copies, grid_cells, sense_cell
from .locomotion import move1
from .sense_kernels import (
    break_range,
    compact_out,
    copy_kept,
    count_breaks,
    deep_inside,
    gather_breaks,
    in_view,
    insert_sorted,
    kept_count,
    mark_out_of_view,
    near_row,
    prefix_offsets,
    robot_sight,
    sight1,
    touches,
)
from .step_kernel import after_move

__all__ = ["terrain_of", "grid_build_copies", "step_copies", "sense_copies"]

_NONE = 0  # state.Reason.NONE (numba reads plain ints)


@njit(cache=True, inline="always")
def terrain_of(T0, w):
    """World ``w``'s :func:`~.sense_kernels.terrain_arrays` tuple, read from the pack's ``T0``
    (global arrays, views of the per-world bucket rows and edges, the world's scalars)."""
    vx, vy, vz, tris, nbrs, grad, bstart, btris, edges, border, bx0, by0, binv, bnx, bny, tol, ztol, ms, bs_off, \
        e_off = T0
    return (vx, vy, vz, tris, nbrs, grad, bstart[bs_off[w]:bs_off[w + 1]], btris, bx0[w], by0[w], binv[w], bnx[w],
            bny[w], edges[e_off[w]:e_off[w + 1]], border[e_off[w]:e_off[w + 1]], tol[w], ztol[w], ms[w])


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
                if j != i and touches(gx[m] - px[i], gy[m] - py[i], diameter, lo2, hi2):
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
        batt[i], energy[i], out_status[i], fell[i], emptied[i], present[i] = after_move(
            st, active, ev, mv, cl, battery[i], idle_j, drive_j_per_m, climb_j_per_m)
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

@njit(cache=True)
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
            c = insert_sorted(idx, dist, i, c, k, j, d)
    for s in range(c):
        j = idx[i, s]
        v = 1 if in_view(ex[j] - qx, ey[j] - qy, dist[i, s], ch, sh, h, half_fov, cos_hf) else 0
        if v and check_los:
            v = sight1(T, qx, qy, qz, ex[j], ey[j], ez[j], ti, deep)
        vis[i, s] = v
    return c


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
        k = near_row(i, px[i], py[i], X0[c], Y0[c], INV[c], NX[c], NY[c], start[base[c]:], items, gx, gy, i, range_m,
                      r2, r_idx, r_dist)
        mark_out_of_view(i, k, px, py, h, ch, sh, half_fov, cos_hf, r_idx, r_dist, r_vis, r_cnt)
        t_cnt[i] = _entity_row_copy(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, tx, ty, tz, t_rng[c, 0],
                                    t_rng[c, 1], range_m, half_fov, cos_hf, check_los, t_idx, t_dist, t_vis)
        a_cnt[i] = _entity_row_copy(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, ax_, ay_, az_, a_rng[c, 0],
                                    a_rng[c, 1], range_m, half_fov, cos_hf, check_los, a_idx, a_dist, a_vis)
        lo, hi, gridded = break_range(bstart[bs_off[w]:bs_off[w + 1]], BX0[w], BY0[w], BINV[w], BNX[w], BNY[w],
                                      b_off[w], b_off[w + 1], px[i], py[i])
        bcnt[i] = count_breaks(px[i], py[i], bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m)


@njit(cache=True, parallel=True)
def _sense2(T0, wor, px, py, sz, tri, active, items, range_m, check_los, r_idx, r_dist, r_vis, r_cnt, B, bcnt,
            deep, k_front):
    bax, bay, bbx, bby, BX0, BY0, BINV, BNX, BNY, bstart, bitems, bs_off, b_off = B
    n = px.shape[0]
    off = prefix_offsets(bcnt)
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
        robot_sight(terrain_of(T0, w), i, px, py, sz, tri, deep, check_los, r_idx, r_dist, r_vis, r_cnt)
        if bcnt[i] == 0:
            continue
        lo, hi, gridded = break_range(bstart[bs_off[w]:bs_off[w + 1]], BX0[w], BY0[w], BINV[w], BNX[w], BNY[w],
                                      b_off[w], b_off[w + 1], px[i], py[i])
        gather_breaks(i, px[i], py[i], bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m, off[i], dist, seg,
                      closest, obs, k_front)
    rows = np.empty(n, dtype=np.int64)
    for i in prange(n):
        rows[i] = kept_count(r_idx, r_vis, r_cnt, i) if active[i] else 0
    start, ro, rt, rd = compact_out(rows)
    for i in prange(n):
        if rows[i]:
            copy_kept(r_idx, r_dist, r_vis, r_cnt, i, start[i], ro, rt, rd)
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

