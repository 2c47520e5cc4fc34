"""Sensing, the one compiled path of the env and the vector env: what every robot of every copy senses.

Robots are numbered globally, copy-major (copy ``c``'s robots are ``off[c]:off[c + 1]``), and
stand on the worlds of a :class:`~.pack.WorldPack` (``wor[i]``, the world of robot ``i``;
triangle indices global). Two parallel passes (:func:`sense_copies`) run the per-robot code of
:mod:`.sense_kernels` (:func:`~.sense_kernels.near_row`, :func:`~.sense_kernels.entity_row`,
:func:`~.sense_kernels.robot_sight`, the break contacts) with the world's arrays chosen per robot
(:func:`terrain_of`) and every neighbour grid (robots, targets, assets) built per copy
(:func:`~.grid.grid_build_copies`), so a robot never meets a robot, target or break of another
copy. A single :class:`~.world.World` senses as the one-copy case (:func:`~.sensing.sense`); the
vector env passes all its copies, so each copy's results are the same bits as its own single
env's (``tests/env/test_vector.py`` checks it against separate envs). Candidate lists are ordered
by (distance, global index); global order within a copy is the copy's own order, so ties break
the same way. (The world step's pass over the copies is :mod:`.step_kernel`.)
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .grid import grid_build_copies, sense_cell
from .pack import frozen
from .sense_kernels import (
    break_range,
    break_row,
    break_scratch,
    compact_out,
    copy_kept,
    count_breaks,
    deep_inside,
    entity_row,
    gather_breaks,
    kept_count,
    mark_out_of_view,
    near_row,
    prefix_offsets,
    robot_sight,
)

__all__ = ["terrain_of", "sense_copies"]

_NONE, _BATTERY = 0, 3  # state.Reason codes (numba and numpy compare with plain ints fastest)
# the parallel passes cut the robots into this many runs of consecutive ones, shared among the threads; in a run the
# views of a robot's world and copy are taken when they change (a copy's robots are consecutive), not per robot
# (a view costs a reference count). Every robot's row is still computed alone: the same bits on any thread count.
RUNS = 64


@njit(cache=True, inline="always")
def terrain_of(T0, w):
    """World ``w``'s :func:`~.sense_kernels.terrain_arrays` tuple, read from the pack's ``T0``
    (global arrays, views of the per-world bucket rows and edges, the world's scalars)."""
    vx, vy, vz, tris, nbrs, grad, bstart, btris, edges, border, bx0, by0, binv, bnx, bny, tol, ztol, ms, bs_off, \
        e_off = T0
    return (vx, vy, vz, tris, nbrs, grad, bstart[bs_off[w]:bs_off[w + 1]], btris, bx0[w], by0[w], binv[w], bnx[w],
            bny[w], edges[e_off[w]:e_off[w + 1]], border[e_off[w]:e_off[w + 1]], tol[w], ztol[w], ms[w])


# -- sensing -----------------------------------------------------------------------------------

@njit(cache=True, parallel=True)
def _sense1(T0, wor, cop, margin, px, py, head, tri, sz, active, G, range_m, half_fov, cos_hf, check_los,
            r_idx, r_dist, r_vis, r_cnt, tx, ty, tz, TGG, t_idx, t_dist, t_vis, t_cnt,
            ax_, ay_, az_, AGG, a_idx, a_dist, a_vis, a_cnt, B, bcnt, deep, count):
    """First parallel pass over the robots (in grid order, for locality): each present robot's
    ``deep`` flag (:func:`~.sense_kernels.deep_inside` its triangle); each active observer's robot
    candidates (``r_*``, (n, K) slots; out of view marked ``-1 - j``), its targets and assets
    (``t_*``/``a_*``: the entities and their per-copy grids ``TGG``/``AGG``, in sight already) and
    how many break segments lie in range (``bcnt``, when ``count``: not for :func:`~.sense_kernels.break_row`;
    ``B`` the pack's break arrays and grids). Collision-free: every row is written by its own iteration only."""
    bax, bay, bbx, bby, BX0, BY0, BINV, BNX, BNY, bstart, bitems, bs_off, b_off = B
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = G
    TX0, TY0, TINV, TNX, TNY, tbase, tstart, titems, tgx, tgy = TGG  # (the parallel loop takes arrays, not tuples)
    AX0, AY0, AINV, ANX, ANY, abase, astart, aitems, agx, agy = AGG
    r2 = (range_m * (1.0 + 1e-9)) ** 2
    nq = items.shape[0]
    C = min(nq, RUNS)
    for run in prange(C):
        q0 = run * nq // C
        q1 = (run + 1) * nq // C
        wc = wor[items[q0]]  # the views of a world and a copy are taken when they change, not per robot
        cc = cop[items[q0]]
        T = terrain_of(T0, wc)
        bst = bstart[bs_off[wc]:bs_off[wc + 1]]
        st, tst, ast_ = start[base[cc]:], tstart[tbase[cc]:], astart[abase[cc]:]
        for q in range(q0, q1):
            i = items[q]
            w = wor[i]
            c = cop[i]
            if w != wc:
                wc = w
                T = terrain_of(T0, w)
                bst = bstart[bs_off[w]:bs_off[w + 1]]
            if c != cc:
                cc = c
                st, tst, ast_ = start[base[c]:], tstart[tbase[c]:], astart[abase[c]:]
            dp = deep_inside(T, px[i], py[i], tri[i], margin[w])
            deep[i] = dp
            if not active[i]:
                continue
            h = head[i]
            ch = math.cos(h)
            sh = math.sin(h)
            k = near_row(i, px[i], py[i], X0[c], Y0[c], INV[c], NX[c], NY[c], st, items, gx, gy, i, range_m, r2, r_idx,
                         r_dist)
            mark_out_of_view(i, k, px, py, h, ch, sh, half_fov, cos_hf, r_idx, r_dist, r_vis, r_cnt)
            t_cnt[i] = entity_row(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, tx, ty, tz, TX0[c], TY0[c],
                                  TINV[c], TNX[c], TNY[c], tst, titems, tgx, tgy, range_m, half_fov, cos_hf, check_los,
                                  t_idx, t_dist, t_vis)
            a_cnt[i] = entity_row(T, i, px[i], py[i], sz[i], h, ch, sh, tri[i], dp, ax_, ay_, az_, AX0[c], AY0[c],
                                  AINV[c], ANX[c], ANY[c], ast_, aitems, agx, agy, range_m, half_fov, cos_hf, check_los,
                                  a_idx, a_dist, a_vis)
            if count:
                lo, hi, gridded = break_range(bst, BX0[w], BY0[w], BINV[w], BNX[w], BNY[w], b_off[w], b_off[w + 1],
                                              px[i], py[i])
                bcnt[i] = count_breaks(px[i], py[i], bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m)


@njit(cache=True, parallel=True)
def _sense2(T0, wor, px, py, sz, tri, active, items, range_m, check_los, r_idx, r_dist, r_vis, r_cnt, B, bcnt,
            deep, head, S, OB):
    """Second parallel pass: line of sight of every in-view robot slot
    (:func:`~.sense_kernels.robot_sight`: a pair walked once, each slot with one writer), the break
    contacts (:func:`~.sense_kernels.gather_breaks`), then the robot contacts compacted (rows
    counted and copied in parallel). Returns the breaks ``(observer, break, distance, closest (P,
    2), start (n + 1,))``, observer-major, nearest first (ties: lower index), and the
    robots ``(observer, target, distance, start)`` (no bearings: :func:`~.sense_kernels.bearings`
    computes them when they are read). With slot rows ``S`` (:func:`~.sense_kernels.break_row`'s; ``OB``
    its danger, ends and beam units) the break contacts are kept there instead, with the scan, and none
    is returned."""
    bax, bay, bbx, bby, BX0, BY0, BINV, BNX, BNY, bstart, bitems, bs_off, b_off = B
    n = px.shape[0]
    fused = S[0].shape[0] > 0  # break_row's slot rows instead of the contact list
    off = prefix_offsets(bcnt)
    tot = off[n]
    obs = np.empty(tot, dtype=np.int64)
    seg = np.empty(tot, dtype=np.int64)
    dist = np.empty(tot)
    closest = np.empty((tot, 2))
    nq = items.shape[0]
    C = min(nq, RUNS)
    for run in prange(C):
        q0 = run * nq // C
        q1 = (run + 1) * nq // C
        wc = wor[items[q0]]  # the views of a world are taken when it changes, not per robot
        T = terrain_of(T0, wc)
        bst = bstart[bs_off[wc]:bs_off[wc + 1]]
        W = break_scratch(S[3].shape[1])  # break_row's scratch, one per run
        for q in range(q0, q1):
            i = items[q]
            if not active[i]:
                continue
            w = wor[i]
            if w != wc:
                wc = w
                T = terrain_of(T0, w)
                bst = bstart[bs_off[w]:bs_off[w + 1]]
            robot_sight(T, i, px, py, sz, tri, deep, check_los, r_idx, r_dist, r_vis, r_cnt)
            if fused:
                lo, hi, gridded = break_range(bst, BX0[w], BY0[w], BINV[w], BNX[w], BNY[w], b_off[w], b_off[w + 1],
                                              px[i], py[i])
                break_row(i, px[i], py[i], (bax, bay, bbx, bby, bitems), lo, hi, gridded, range_m, S, OB,
                          math.cos(head[i]), math.sin(head[i]), W)
                continue
            if bcnt[i] == 0:
                continue
            lo, hi, gridded = break_range(bst, BX0[w], BY0[w], BINV[w], BNX[w], BNY[w], b_off[w], b_off[w + 1], px[i],
                                          py[i])
            gather_breaks(i, px[i], py[i], bax, bay, bbx, bby, bitems, lo, hi, gridded, range_m, off[i], dist, seg,
                          closest, obs)
    rows = np.empty(n, dtype=np.int64)
    for i in prange(n):
        rows[i] = kept_count(r_idx, r_vis, r_cnt, i) if active[i] else 0
    start, ro, rt, rd = compact_out(rows)
    for i in prange(n):
        if rows[i]:
            copy_kept(r_idx, r_dist, r_vis, r_cnt, i, start[i], ro, rt, rd)
    return (obs[:tot], seg[:tot], dist[:tot], closest[:tot], off), (ro, rt, rd, start)


_NO_ROWS = (np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0)), np.zeros((0, 0, 2)), np.zeros((0, 0)))
_NO_UNITS = frozen(np.zeros((0, 2)))  # read-only as the vector env's units (ObsLayout.scan_units): one compilation


def sense_copies(pack, wor, cop, off, px, py, head, tri, heights, status, params, R, TG, AS, rows=None):
    """What every robot of every copy senses (its one home: :func:`~.sensing.sense` is the one-copy
    case): ``(breaks (observer, break, distance, closest, start), robots (observer, target, distance,
    start))``, robot and break ids global. ``heights`` the robots' ground heights, ``status`` their
    :class:`~.state.Reason` codes, ``params`` the :class:`~.params.WorldParams` (the sensor, the
    entities' sight height); ``R``/``TG``/``AS`` the ``(idx, dist, vis, cnt)`` candidate slots
    (``cnt`` zeroed) and the entities ``(ex, ey, ez, eoff (E + 1,), use)`` of ``TG``/``AS`` (copy c's
    are ``eoff[c]:eoff[c + 1]``, those with ``use``; ``ez`` their ground heights), the slots of the
    targets and assets left for :func:`~.sense_kernels.compact`. ``rows``: what the
    observation reads instead of the contact list, ``(idx (n, kb), dist (n, kb), closest (n, kb, 2), scan (n,
    K), units (K, 2))`` filled in place (:func:`~.sense_kernels.break_row`: each robot's ``kb`` nearest
    break contacts and its ``K``-beam scan, the same bits as the observation encoder computes from the
    list); the returned break contacts are then empty."""
    sensor = params.sensor
    r = float(sensor.range_m)
    cell = sense_cell(r)
    half_fov = math.radians(sensor.fov_deg) / 2 + 1e-12
    los = bool(sensor.check_los)
    active = status == _NONE
    present = active | (status == _BATTERY)  # is_present: robots out of battery are still seen
    sz = np.ascontiguousarray(heights + sensor.height_m)
    eh = params.entity_height_m
    (tx, ty, tz, t_off, t_use), t_slots = TG
    (ax_, ay_, az_, a_off, a_use), a_slots = AS
    return _sense_passes(pack.T0, pack.B, pack.margin, wor, cop, off, px, py, head, tri, sz, active, present,
                         (r, cell, half_fov, math.cos(half_fov), los), R,
                         (tx, ty, tz + eh, t_off, t_use), t_slots, (ax_, ay_, az_ + eh, a_off, a_use), a_slots,
                         _NO_ROWS if rows is None else rows[:4],
                         (pack.OB[2], pack.OB[3], _NO_UNITS if rows is None else rows[4]))


@njit(cache=True)  # compiled: one call from Python a step (each call's argument checks cost ~10 us)
def _sense_passes(T0, B, margin, wor, cop, off, px, py, head, tri, sz, active, present, S, R, TE, TS, AE, AS, SR,
                  OB):
    """The grids per copy (robots, targets, assets) and the two passes of :func:`sense_copies`
    (``S``: range, grid cell, half field of view and its cosine, line of sight; ``SR``, ``OB``:
    :func:`~.sense_kernels.break_row`'s slot rows and arrays)."""
    r, cell, half_fov, cos_hf, los = S
    r_idx, r_dist, r_vis, r_cnt = R
    tx, ty, tz, t_off, t_use = TE
    ax_, ay_, az_, a_off, a_use = AE
    t_idx, t_dist, t_vis, t_cnt = TS
    a_idx, a_dist, a_vis, a_cnt = AS
    G = grid_build_copies(px, py, present, off, cell)
    n = px.shape[0]
    bcnt = np.zeros(n, dtype=np.int64)
    deep = np.empty(n, dtype=np.bool_)
    if SR[0].shape[0]:  # every robot's slot rows empty and its scan clear, but those break_row fills
        SR[0][:] = -1
        SR[3][:] = 1.0
    _sense1(T0, wor, cop, margin, px, py, head, tri, sz, active, G, r, half_fov, cos_hf, los,
            r_idx, r_dist, r_vis, r_cnt, tx, ty, tz, grid_build_copies(tx, ty, t_use, t_off, cell),
            t_idx, t_dist, t_vis, t_cnt, ax_, ay_, az_, grid_build_copies(ax_, ay_, a_use, a_off, cell),
            a_idx, a_dist, a_vis, a_cnt, B, bcnt, deep, SR[0].shape[0] == 0)
    return _sense2(T0, wor, px, py, sz, tri, active, G[7], r, los, r_idx, r_dist, r_vis, r_cnt, B, bcnt, deep,
                   head, SR, OB)
