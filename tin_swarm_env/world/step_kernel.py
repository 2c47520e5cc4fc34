"""The world step's compiled core, the one step path of the env and the vector env: locomotion,
battery, status and collisions of every robot of every copy.

Robots are numbered globally, copy-major (copy ``c``'s robots are ``off[c]:off[c + 1]``), and stand on
the worlds of a :class:`~.pack.WorldPack` (``wor[i]``, the world of robot ``i``; triangle indices global).
:func:`step_copies` runs :func:`~.locomotion.move1` and :func:`after_move` for every robot in one
parallel loop (:func:`move_all`), with the world's arrays chosen per robot
(:func:`~.batch_kernels.terrain_of`), then counts the contacts among the robots still on the terrain,
within each copy (:func:`collisions`, a grid of cell = the collision diameter per copy). A single
:class:`~.world.World` is the one-copy case (``World._step``); the vector env passes all its copies.
Each robot is computed by one iteration from its own inputs, so the results are the same bit for bit
on any thread count and equal to the sequence of numpy and kernel references
(:func:`~.reference.move_kernel`, :func:`~.battery.drain`; ``tests/world/test_step_kernel.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .batch_kernels import RUNS, terrain_of
from .grid import grid_build_copies, grid_cells
from .locomotion import FELL_INTO, move1
from .sense_kernels import touches

__all__ = ["step_copies", "after_move", "move_all", "collisions"]

_NONE, _FELL, _BATTERY = 0, 2, 3  # state.Reason codes (numba reads plain ints)


@njit(cache=True, inline="always")
def _max0(v):
    """``np.maximum(v, 0.0)`` for one value (NaN kept, as numpy does)."""
    return v if (v >= 0.0 or v != v) else 0.0


@njit(cache=True, inline="always")
def after_move(st, active, ev, mv, cl, b0, idle_j, drive_j_per_m, climb_j_per_m):
    """One robot's bookkeeping after :func:`~.locomotion.move1` (its one home):
    :func:`~.battery.drain` term by term, then the status codes (a fall, then an empty battery).
    Returns ``(battery, energy, status, fell, emptied, present)``."""
    use = idle_j + drive_j_per_m * mv + climb_j_per_m * _max0(cl)
    if not active:
        use = 0.0
    b = _max0(b0 - use)
    f = ev == FELL_INTO
    if f:
        st = _FELL
    e = st == _NONE and b <= 0.0
    if e:
        st = _BATTERY
    return b, b0 - b, st, f, e, st == _NONE or st == _BATTERY


@njit(cache=True, parallel=True)
def move_all(T0, steep, wor, pos, tri, head, heights, status, battery, cmd, max_speed, max_climb_deg, max_turn, dt,
             idle_j, drive_j_per_m, climb_j_per_m):
    """The per-robot move loop (its one home): :func:`~.locomotion.move1` and :func:`after_move` for
    every robot, on its world ``wor[i]`` of the pack's terrain ``T0``. Returns ``(pos (n, 2), xs, ys,
    tri, head, heights, speeds, events, moved, climb, battery, energy, status, fell, emptied,
    present)``."""
    n = pos.shape[0]
    out_pos = np.empty((n, 2))
    xs = np.empty(n)
    ys = np.empty(n)
    out_tri = np.empty(n, dtype=np.int64)
    out_head = np.empty(n)
    speeds = np.empty(n)
    event = np.empty(n, dtype=np.int8)
    out_h = np.empty(n)
    moved = np.empty(n)
    climb = np.empty(n)
    batt = np.empty(n)
    energy = np.empty(n)
    out_status = np.empty(n, dtype=np.int8)
    fell = np.empty(n, dtype=np.bool_)
    emptied = np.empty(n, dtype=np.bool_)
    present = np.empty(n, dtype=np.bool_)
    C = min(n, RUNS)
    for run in prange(C):
        i0 = run * n // C
        wc = wor[i0]
        T = terrain_of(T0, wc)  # the world's views are taken when it changes, not per robot
        for i in range(i0, (run + 1) * n // C):
            if wor[i] != wc:
                wc = wor[i]
                T = terrain_of(T0, wc)
            st = status[i]
            active = st == _NONE
            x, y, t, hd, sp, ev, z, mv, cl = move1(T, steep, pos[i, 0], pos[i, 1], tri[i], head[i], heights[i],
                                                   active, cmd[i, 0], cmd[i, 1], max_speed, max_climb_deg, max_turn, dt)
            out_pos[i, 0] = x
            out_pos[i, 1] = y
            xs[i] = x
            ys[i] = y
            out_tri[i] = t
            out_head[i] = hd
            speeds[i] = sp
            event[i] = ev
            out_h[i] = z
            moved[i] = mv
            climb[i] = cl
            batt[i], energy[i], out_status[i], fell[i], emptied[i], present[i] = after_move(
                st, active, ev, mv, cl, battery[i], idle_j, drive_j_per_m, climb_j_per_m)
    return (out_pos, xs, ys, out_tri, out_head, out_h, speeds, event, moved, climb, batt, energy, out_status, fell,
            emptied, present)


@njit(cache=True, parallel=True)
def collisions(px, py, cop, G, diameter):
    """Per robot, the present robots of its copy closer than ``diameter`` (``(n,)`` int64; grid ``G``
    of :func:`~.grid.grid_build_copies` over the present robots, cells >= ``diameter``), and the
    pairs ``(C, 2)`` with i < j in (i, j) order (a serial pass over the few robots that touch one)."""
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = G
    n = px.shape[0]
    lo2 = -1.0  # outside [1e-100, 1e100] the squared distance may under/overflow: hypot always
    hi2 = -1.0
    if 1e-100 <= diameter <= 1e100:
        lo2 = (diameter * (1.0 - 1e-6)) ** 2
        hi2 = (diameter * (1.0 + 1e-6)) ** 2
    if not hi2 > 0.0:
        hi2 = math.inf
    coll = np.zeros(n, dtype=np.int64)
    higher = np.zeros(n, dtype=np.int64)
    nq = items.shape[0]
    C = min(nq, RUNS)
    for run in prange(C):
        q0 = run * nq // C
        cc = cop[items[q0]]
        st = start[base[cc]:]  # the copy's view is taken when it changes, not per robot
        for q in range(q0, (run + 1) * nq // C):
            i = items[q]
            c = cop[i]
            if c != cc:
                cc = c
                st = start[base[c]:]
            nx = NX[c]
            cx_lo, cx_hi, cy_lo, cy_hi = grid_cells(X0[c], Y0[c], INV[c], nx, NY[c], px[i], py[i])
            k = 0
            h = 0
            for cy in range(cy_lo, cy_hi + 1):
                for m in range(st[cy * nx + cx_lo], st[cy * nx + cx_hi + 1]):
                    j = items[m]
                    if j != i and touches(gx[m] - px[i], gy[m] - py[i], diameter, lo2, hi2):
                        k += 1
                        if j > i:
                            h += 1
            coll[i] = k
            higher[i] = h
    return coll, _pairs(px, py, cop, G, diameter, lo2, hi2, higher)


@njit(cache=True)
def _pairs(px, py, cop, G, diameter, lo2, hi2, higher):
    """The touching pairs ``(C, 2)``, i < j, in (i, j) order: a serial pass over the robots with
    ``higher[i]`` touching robots of higher index."""
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = G
    tot = 0
    for i in range(higher.shape[0]):
        tot += higher[i]
    pairs = np.empty((tot, 2), dtype=np.int64)
    p = 0
    for i in range(higher.shape[0]):
        if higher[i] == 0:
            continue
        c = cop[i]
        nx = NX[c]
        st = start[base[c]:]
        cx_lo, cx_hi, cy_lo, cy_hi = grid_cells(X0[c], Y0[c], INV[c], nx, NY[c], px[i], py[i])
        p0 = p
        for cy in range(cy_lo, cy_hi + 1):
            for m in range(st[cy * nx + cx_lo], st[cy * nx + cx_hi + 1]):
                j = items[m]
                if j > i and touches(gx[m] - px[i], gy[m] - py[i], diameter, lo2, hi2):
                    q = p
                    while q > p0 and pairs[q - 1, 1] > j:  # sorted by j
                        pairs[q, 0] = i
                        pairs[q, 1] = pairs[q - 1, 1]
                        q -= 1
                    pairs[q, 0] = i
                    pairs[q, 1] = j
                    p += 1
    return pairs


@njit(cache=True)  # compiled: one call from Python a step (each call's argument checks cost ~10 us)
def step_copies(T0, steep, wor, cop, off, pos, tri, head, heights, status, battery, cmd, p):
    """One world step of every robot of every copy (``p``: ``(max_speed, max_climb_deg, max_turn, dt,
    idle_j, drive_j_per_m, climb_j_per_m, diameter)``, ``idle_j`` the idle and sensing draw of one step,
    ``(idle_w + sensing_w) * dt``, as :meth:`~.world.World.step` computes them). Returns ``(pos (n, 2),
    tri, head, heights, speeds, events, moved, climb, battery, energy, status, fell, emptied, collisions,
    pairs)`` (see :meth:`~.world.World.step`)."""
    max_speed, max_climb_deg, max_turn, dt, idle_j, drive_j, climb_j, diameter = p
    (pos2, xs, ys, tri2, head2, h2, speeds, event, moved, climb, batt, energy, status2, fell, emptied,
     present) = move_all(T0, steep, wor, pos, tri, head, heights, status, battery, cmd, max_speed, max_climb_deg,
                         max_turn, dt, idle_j, drive_j, climb_j)
    coll, pairs = collisions(xs, ys, cop, grid_build_copies(xs, ys, present, off, diameter), diameter)
    return pos2, tri2, head2, h2, speeds, event, moved, climb, batt, energy, status2, fell, emptied, coll, pairs
