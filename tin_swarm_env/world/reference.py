"""Slow, obvious references for the batched world (tests and benches): :func:`reference_sense`,
one robot at a time, for the sensing; :func:`move_kernel`, the locomotion as its own parallel
pass, for the fused step kernel.

Independent of the code it checks: line of sight and entity heights come from the brute-force
terrain references (every edge tested, barycentric heights: :mod:`tin_swarm_env.terrain.reference`),
never from :meth:`Tin.line_of_sight` or :meth:`Tin.height_at`."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..terrain.reference import height_brute, line_of_sight_brute
from .locomotion import move1
from .state import Reason

__all__ = ["reference_sense", "move_kernel"]


def _nearest_in_range(xy, pts, ok, range_m, k):
    """Indices of the at most k nearest of ``pts`` (where ``ok``) within range_m of xy."""
    d = [(math.hypot(p[0] - xy[0], p[1] - xy[1]), j) for j, p in enumerate(pts) if ok[j]]
    return {j for dj, j in sorted(d)[:k] if dj <= range_m}


def reference_sense(w, s):
    """One robot at a time, every other robot / entity / break checked by hand. Returns the
    sets of (observer, target) pairs for robots, targets, assets and breaks. Only each
    observer's ``max_candidates`` nearest robots (entities) within range are candidates."""
    sp, P = w.params.sensor, w.params
    robots, targets, assets, breaks = set(), set(), set(), set()
    fov = math.radians(sp.fov_deg) / 2 + 1e-12
    z = s.heights + sp.height_m
    for i in range(s.n_robots):
        if s.status[i] != Reason.NONE:
            continue

        def sees(xy, zt, i=i):
            dx, dy = xy[0] - s.positions[i, 0], xy[1] - s.positions[i, 1]
            if math.hypot(dx, dy) > sp.range_m:
                return False
            b = (math.atan2(dy, dx) - s.headings[i] + math.pi) % (2 * math.pi) - math.pi
            if abs(b) > fov:
                return False
            if not sp.check_los:
                return True
            a = np.array([[s.positions[i, 0], s.positions[i, 1], z[i]]])
            return bool(line_of_sight_brute(w.tin, a, np.array([[xy[0], xy[1], zt]]))[0])

        K = sp.max_candidates
        others = [j != i and s.status[j] in (Reason.NONE, Reason.BATTERY) for j in range(s.n_robots)]
        for j in _nearest_in_range(s.positions[i], s.positions, others, sp.range_m, K):
            if sees(s.positions[j], z[j]):
                robots.add((i, j))
        for ents, out in ((s.targets, targets), (s.assets, assets)):
            for j in _nearest_in_range(s.positions[i], ents.positions, [True] * len(ents), sp.range_m, K):
                zt = height_brute(w.tin, ents.positions[j:j + 1])[0] + P.entity_height_m
                if sees(ents.positions[j], zt):
                    out.add((i, j))
        for j, seg in enumerate(w.breaks.segments):
            a, b = seg[0, :2], seg[1, :2]
            ab = b - a
            u = min(max(np.dot(s.positions[i] - a, ab) / np.dot(ab, ab), 0.0), 1.0)
            if np.linalg.norm(s.positions[i] - (a + u * ab)) <= sp.range_m:
                breaks.add((i, j))
    return robots, targets, assets, breaks


@njit(cache=True, parallel=True)
def move_kernel(T, steep, pos, tri, head, heights, active, cmd, max_speed, max_climb_deg, max_turn, dt):
    """:func:`~.locomotion.move` fused into one parallel pass, plus the new ground heights,
    distances driven and climbs: ``(pos (n, 2), tri, head, speeds, events, heights, moved,
    climb)``. ``T`` is :func:`~.sense_kernels.terrain_arrays`. Tested against the numpy
    :func:`~.locomotion.move`; the world step runs the same :func:`~.locomotion.move1` inside
    :func:`~.step_kernel.move_all`. Each robot is computed by one iteration from its own inputs only."""
    n = pos.shape[0]
    out_pos = np.empty((n, 2))
    out_tri = np.empty(n, dtype=np.int64)
    out_head = np.empty(n)
    speeds = np.empty(n)
    event = np.empty(n, dtype=np.int8)
    out_h = np.empty(n)
    moved = np.empty(n)
    climb = np.empty(n)
    for i in prange(n):
        x, y, t, hd, sp, ev, z, mv, cl = move1(T, steep, pos[i, 0], pos[i, 1], tri[i], head[i], heights[i], active[i],
                                               cmd[i, 0], cmd[i, 1], max_speed, max_climb_deg, max_turn, dt)
        out_pos[i, 0] = x
        out_pos[i, 1] = y
        out_tri[i] = t
        out_head[i] = hd
        speeds[i] = sp
        event[i] = ev
        out_h[i] = z
        moved[i] = mv
        climb[i] = cl
    return out_pos, out_tri, out_head, speeds, event, out_h, moved, climb
