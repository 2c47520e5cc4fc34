"""The world step's compiled core: locomotion, battery, status and collisions in one call.

:func:`step_kernel` runs :func:`~.locomotion.move1` for every robot in one parallel loop, drains
the battery there (:func:`~.battery.drain` is the numpy reference: the same terms, added in the
same order), updates the status codes (a fall, then an empty battery), and then counts the
contacts among the robots still on the terrain (a grid of cell = the collision diameter,
:func:`~.sense_kernels.collision_counts`). One compiled call per step instead of a kernel,
a collision kernel and a dozen numpy passes over the robots; each robot is computed by one
iteration from its own inputs, so the results are the same bit for bit on any thread count and
equal to that sequence of numpy and kernel calls (``tests/world/test_step_kernel.py``).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .grid import grid_build
from .locomotion import FELL_INTO, move1
from .sense_kernels import collision_counts

__all__ = ["step_kernel", "after_move"]

_NONE, _FELL, _BATTERY = 0, 2, 3  # state.Reason codes (numba reads plain ints)


@njit(cache=True, inline="always")
def _max0(v):
    """``np.maximum(v, 0.0)`` for one value (NaN kept, as numpy does)."""
    return v if (v >= 0.0 or v != v) else 0.0


@njit(cache=True, inline="always")
def after_move(st, active, ev, mv, cl, b0, idle_j, drive_j_per_m, climb_j_per_m):
    """One robot's bookkeeping after :func:`~.locomotion.move1` (its one home: the env's step and
    the vector env's): :func:`~.battery.drain` term by term, then the status codes (a fall, then an
    empty battery). Returns ``(battery, energy, status, fell, emptied, present)``."""
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
def step_kernel(T, steep, pos, tri, head, heights, status, battery, cmd, max_speed, max_climb_deg, max_turn, dt,
                idle_j, drive_j_per_m, climb_j_per_m, diameter):
    """One world step for all robots. ``T`` is :func:`~.sense_kernels.terrain_arrays`;
    ``idle_j`` the idle and sensing draw of one step (``(idle_w + sensing_w) * dt``). Returns
    ``(pos (n, 2), tri, head, heights, speeds, events, moved, climb, battery, energy, status,
    fell, emptied, collisions, pairs)`` (see :meth:`~.world.World.step`)."""
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
    for i in prange(n):
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
        event[i] = ev
        out_h[i] = z
        moved[i] = mv
        climb[i] = cl
        batt[i], energy[i], out_status[i], fell[i], emptied[i], present[i] = after_move(
            st, active, ev, mv, cl, battery[i], idle_j, drive_j_per_m, climb_j_per_m)
    coll, pairs = collision_counts(xs, ys, present, grid_build(xs, ys, present, diameter), diameter)
    return (out_pos, out_tri, out_head, out_h, speeds, event, moved, climb, batt, energy, out_status, fell, emptied,
            coll, pairs)
