"""Locomotion: commanded body-frame velocity -> motion over the TIN, for all robots at once.

Per step and robot (only active robots, status ``Reason.NONE``, move):

1. The command ``(u, v)`` (body frame: x forward, y left; fractions of max speed) is clipped to
   ``[-1, 1]^2`` and then to norm 1, and rotated into the world frame by the current heading.
2. Uphill pitch slows the robot: with the pitch ``p`` of its current triangle along the
   direction of motion, the speed scales by ``clip(1 - p / max_climb_deg, 0, 1)`` (downhill
   and level: 1).
3. The displacement segment is walked exactly through the TIN, triangle by triangle (the same
   walk as line of sight), so no step length can tunnel through a thin steep band:
   entering a triangle steeper than ``max_slope_deg`` while going *down* its slope
   (``grad . d < 0``) is a fall: the robot stops just inside it and is destroyed (``Reason.FELL``);
   entering one going up or across it (``grad . d >= 0``) is blocked, and so is the TIN's
   border: the robot stops 1 mm before the edge (and stays in its triangle).
4. The heading turns toward the direction of the commanded motion by at most
   ``turn_rate_dps * dt_s``.

Collisions (robots closer than two radii) are counted, not resolved: bodies are not pushed
apart, so one robot can never shove another off a cliff; the environment penalises contact.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..terrain import exit_edge
from ..terrain._kernels import bucket_locate1, walk_locate1
from .angles import wrap_pi
from .state import Reason

__all__ = ["MOVED", "BLOCKED_BORDER", "BLOCKED_STEEP", "FELL_INTO", "body_to_world", "move", "turn_toward",
           "uphill_factor", "walk", "move_walk"]

MOVED, BLOCKED_BORDER, BLOCKED_STEEP, FELL_INTO, STUCK = 0, 1, 2, 3, -2
_PULLBACK_M = 1e-3


@njit(cache=True)
def move_walk1(vx, vy, tris, nbrs, grad, steep, ax, ay, t, dx, dy, max_steps):
    """One robot's walk of ``(dx, dy)`` from ``(ax, ay)`` in triangle ``t``: ``(x, y, tri,
    event)`` (see :func:`move_walk`); ``(ax, ay, t, STUCK)`` when no exit edge was found."""
    if dx == 0.0 and dy == 0.0:
        return ax, ay, t, MOVED
    length = math.sqrt(dx * dx + dy * dy)
    ds_pull = _PULLBACK_M / length
    t0 = t
    s_in = 0.0  # where the segment entered t
    for _ in range(max_steps):
        ex, s, _u = exit_edge(vx, vy, tris, t, ax, ay, dx, dy)
        if ex < 0:
            break
        if s >= 1.0:
            return ax + dx, ay + dy, t, MOVED
        nb = nbrs[t, ex]
        if nb >= 0 and steep[nb] and grad[nb, 0] * dx + grad[nb, 1] * dy < 0.0:
            s_fall = min(s + ds_pull, 1.0)
            return ax + s_fall * dx, ay + s_fall * dy, nb, FELL_INTO
        if nb < 0 or steep[nb]:
            s_stop = max(min(s - ds_pull, s), s_in, 0.0)
            return ax + s_stop * dx, ay + s_stop * dy, t, (BLOCKED_BORDER if nb < 0 else BLOCKED_STEEP)
        s_in = max(s, s_in)
        t = nb
    return ax, ay, t0, STUCK


@njit(cache=True, parallel=True)
def move_walk(vx, vy, tris, nbrs, grad, steep, pos, tri, disp, max_steps):
    """Walk each robot's displacement through the TIN (see the module docstring).

    Returns new positions ``(n, 2)``, triangles ``(n,)`` and events ``(n,)`` int8 (MOVED,
    BLOCKED_BORDER, BLOCKED_STEEP, FELL_INTO, or STUCK when no exit edge was found: the robot
    sits exactly on a vertex with its triangle behind it; the caller nudges and retries).
    """
    n = pos.shape[0]
    out_pos = pos.copy()
    out_tri = tri.copy()
    event = np.zeros(n, dtype=np.int8)
    for i in prange(n):  # one robot per iteration, nothing shared: any thread count, same result
        x, y, t, ev = move_walk1(vx, vy, tris, nbrs, grad, steep, pos[i, 0], pos[i, 1], tri[i], disp[i, 0],
                                 disp[i, 1], max_steps)
        out_pos[i, 0] = x
        out_pos[i, 1] = y
        out_tri[i] = t
        event[i] = ev
    return out_pos, out_tri, event


@njit(cache=True, inline="always")
def move1(T, steep, px, py, t0, h, h0, active, cmd0, cmd1, max_speed, max_climb_deg, max_turn, dt):
    """One robot's locomotion (its one home: the world's step kernel runs it, and so does
    :func:`~.reference.move_kernel`, the test reference): from its position, triangle ``t0``, heading ``h``,
    ground height ``h0`` and command, ``(x, y, tri, heading, speed, event, height, moved, climb)``."""
    vx, vy, vz, tris, nbrs, grad, bs, bt, bx0, by0, binv, bnx, bny, edges, border, tol, ztol, ms = T
    # 1. body-frame command -> world velocity (clipped to the square, then the disc)
    c0 = min(max(cmd0, -1.0), 1.0)
    c1 = min(max(cmd1, -1.0), 1.0)
    q2 = c0 * c0 + c1 * c1
    nrm = 1.0 if q2 <= 0.999 else max(math.hypot(c0, c1), 1.0)  # inside the disc: hypot < 1 surely
    c0 = c0 / nrm
    c1 = c1 / nrm
    ch = math.cos(h)
    sh = math.sin(h)
    vxw = max_speed * (ch * c0 - sh * c1)
    vyw = max_speed * (sh * c0 + ch * c1)
    if not active:
        vxw = 0.0
        vyw = 0.0
    # 2. uphill pitch slows
    sp = math.hypot(vxw, vyw)
    rise = (grad[t0, 0] * vxw + grad[t0, 1] * vyw) / max(sp, 1e-300)
    pitch = math.degrees(math.atan(max(rise, 0.0)))
    f = min(max(1.0 - pitch / max_climb_deg, 0.0), 1.0) * dt
    dx = vxw * f
    dy = vyw * f
    # 3. the walk, starting in the triangle the motion enters
    x, y, t, ev = px, py, t0, MOVED
    length = math.hypot(dx, dy)
    if length > 0:
        g = min(1e-6 / length, 1e-3)
        qx = px + dx * g
        qy = py + dy * g
        ta = -1
        if 0 <= t0 < tris.shape[0]:
            ta = walk_locate1(vx, vy, tris, nbrs, qx, qy, t0, ms, tol)
        if ta < 0:
            ta = bucket_locate1(vx, vy, tris, bs, bt, bx0, by0, binv, bnx, bny, qx, qy, tol)
        if ta < 0:
            ev = BLOCKED_BORDER
        elif steep[ta]:
            if grad[ta, 0] * dx + grad[ta, 1] * dy < 0:
                x, y, t, ev = qx, qy, ta, FELL_INTO
            else:
                ev = BLOCKED_STEEP
        else:
            x, y, t, ev = move_walk1(vx, vy, tris, nbrs, grad, steep, px, py, ta, dx, dy, ms)
            if ev == STUCK:  # degenerate geometry: nudge 1 um toward the start triangle's centroid
                cx = (vx[tris[ta, 0]] + vx[tris[ta, 1]] + vx[tris[ta, 2]]) / 3.0
                cy = (vy[tris[ta, 0]] + vy[tris[ta, 1]] + vy[tris[ta, 2]]) / 3.0
                ddx = cx - px
                ddy = cy - py
                dn = max(math.hypot(ddx, ddy), 1e-300)
                x, y, t, ev = move_walk1(vx, vy, tris, nbrs, grad, steep, px + 1e-6 * ddx / dn,
                                         py + 1e-6 * ddy / dn, ta, dx, dy, ms)
                if ev == STUCK:  # give up: stay put this step
                    x, y, t, ev = px, py, t0, BLOCKED_BORDER
    mv = math.hypot(x - px, y - py)
    # 4. heading turns toward the commanded motion
    if sp > 0:
        diff = wrap_pi(math.atan2(vyw, vxw) - h)  # (atan2 - h + pi) % 2pi - pi, bit for bit
        h = h + min(max(diff, -max_turn), max_turn)
    a = tris[t, 0]
    z = vz[a] + grad[t, 0] * (x - vx[a]) + grad[t, 1] * (y - vy[a])
    climb = z - h0
    return x, y, t, wrap_pi(h), mv / dt, ev, z, mv, climb


def walk(tin, steep, positions, tri_idx, disp):
    """Move each robot by ``disp (n, 2)`` over the TIN: new ``positions``, ``tri_idx`` and
    ``events`` (see the module docstring).

    A robot sitting exactly on a vertex or an edge belongs to several triangles; the walk
    starts in the one its motion enters (:meth:`~tin_swarm_env.terrain.Tin.locate_ahead`). When
    that one is too steep or outside, the robot meets the cliff or the border where it stands
    (fall or block at zero distance).
    """
    grad = np.ascontiguousarray(tin.planes[:, :2])
    args = (*tin.xy_columns, tin.triangles, tin.neighbors, grad, steep)
    max_steps = tin.n_triangles + 3
    pos = positions.copy()
    tri = tri_idx.copy()
    ev = np.full(len(pos), MOVED, dtype=np.int8)
    length = np.hypot(disp[:, 0], disp[:, 1])
    mv = np.flatnonzero(length > 0)
    if len(mv) == 0:
        return pos, tri, ev
    ahead, t_ahead = tin.locate_ahead(positions[mv], disp[mv], hint=tri_idx[mv])
    out = t_ahead < 0
    cliff = ~out & steep[np.where(out, 0, t_ahead)]
    down = cliff & (np.einsum("ij,ij->i", grad[np.where(out, 0, t_ahead)], disp[mv]) < 0)
    ev[mv[out]] = BLOCKED_BORDER
    ev[mv[cliff & ~down]] = BLOCKED_STEEP
    ev[mv[down]] = FELL_INTO
    pos[mv[down]] = ahead[down]
    tri[mv[down]] = t_ahead[down]
    go = ~out & ~cliff
    w = mv[go]
    p, t, e = move_walk(*args, positions[w], t_ahead[go], disp[w], max_steps)
    stuck = e == STUCK
    if stuck.any():
        # degenerate geometry: nudge 1 um toward the start triangle's centroid and walk again
        ws = w[stuck]
        c = tin.vertices[tin.triangles[t_ahead[go][stuck]], :2].mean(axis=1)
        d = c - positions[ws]
        p2 = positions[ws] + 1e-6 * d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-300)[:, None]
        p3, t3, e3 = move_walk(*args, p2, t_ahead[go][stuck], disp[ws], max_steps)
        still = e3 == STUCK  # give up: stay put this step
        p3[still], t3[still], e3[still] = positions[ws][still], tri_idx[ws][still], BLOCKED_BORDER
        p[stuck], t[stuck], e[stuck] = p3, t3, e3
    pos[w], tri[w], ev[w] = p, t, e
    return pos, tri, ev


def body_to_world(commands, headings, max_speed_mps):
    """Clip body-frame commands (n, 2) to the unit square then the unit disc; rotate to world
    velocities (n, 2) m/s."""
    c = np.clip(commands, -1.0, 1.0)
    norm = np.hypot(c[:, 0], c[:, 1])
    c = c / np.maximum(norm, 1.0)[:, None]
    ch, sh = np.cos(headings), np.sin(headings)
    return max_speed_mps * np.column_stack([ch * c[:, 0] - sh * c[:, 1], sh * c[:, 0] + ch * c[:, 1]])


def uphill_factor(grad, velocity, max_climb_deg):
    """Speed factor ``clip(1 - pitch / max_climb, 0, 1)`` with pitch the slope of the plane
    along the direction of motion (positive uphill). ``grad`` (n, 2) is dz/dx, dz/dy."""
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    rise = np.einsum("ij,ij->i", grad, velocity) / np.maximum(speed, 1e-300)
    pitch_deg = np.degrees(np.arctan(np.maximum(rise, 0.0)))
    return np.clip(1.0 - pitch_deg / max_climb_deg, 0.0, 1.0)


def turn_toward(headings, velocity, max_turn_rad):
    """Turn headings toward the velocity's direction by at most ``max_turn_rad``."""
    want = np.arctan2(velocity[:, 1], velocity[:, 0])
    diff = (want - headings + np.pi) % (2 * np.pi) - np.pi
    moving = np.hypot(velocity[:, 0], velocity[:, 1]) > 0
    turn = np.where(moving, np.clip(diff, -max_turn_rad, max_turn_rad), 0.0)
    return (headings + turn + np.pi) % (2 * np.pi) - np.pi


def move(tin, steep, positions, tri_idx, headings, status, commands, robot, dt_s):
    """One locomotion step for all robots. Returns ``(positions, tri_idx, headings, speeds,
    events)``; robots that are not active do not move (event MOVED with zero displacement)."""
    vel_cmd = body_to_world(commands, headings, robot.max_speed_mps)
    vel_cmd[status != Reason.NONE] = 0.0
    grad = tin.planes[:, :2]
    disp = vel_cmd * (uphill_factor(grad[tri_idx], vel_cmd, robot.max_climb_deg) * dt_s)[:, None]
    new_pos, new_tri, ev = walk(tin, steep, positions, tri_idx, disp)
    moved = new_pos - positions
    speeds = np.hypot(moved[:, 0], moved[:, 1]) / dt_s
    new_head = turn_toward(headings, vel_cmd, math.radians(robot.turn_rate_dps) * dt_s)
    return new_pos, new_tri, new_head, speeds, ev
