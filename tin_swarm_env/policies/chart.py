"""The chart search of :class:`~tin_swarm_env.policies.APFPolicy` (``search="chart"``): each robot
keeps a coarse chart of the dangerous breaks it has seen and heads along the shortest way to its
target on that chart, taking unseen ground as open (planning under the free-space assumption,
as D* and its kin do). The rule, and why it terminates, is written once, in the
:mod:`tin_swarm_env.policies.apf` module docstring. Everything here is batched over robot rows;
the planner is a compiled A* over each robot's own chart.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numba import njit

from .base import DecodedObs, check_positive_fields

__all__ = ["ChartMemory", "ChartParams", "chart_update", "plan"]

OPEN, WALL, STUCK = 0, 1, 2  # chart cell values: not seen blocked, a dangerous break seen there, a stall there


MAX_CHART_CELLS = 2048  # ChartParams.cells: a chart is cells^2 bytes per robot (4 MiB at 2048; 200 robots 800 MiB)


@dataclass(frozen=True)
class ChartParams:
    """Constants of the chart search (the module docstring of :mod:`tin_swarm_env.policies.apf`
    says what each does).

    cells           the chart is ``cells x cells``, centred on the target (4 ..
                    :data:`MAX_CHART_CELLS`: one byte a cell, per robot)
    reach           its half-width is ``reach`` times the robot's distance to go at its first step
                    plus ``range_reach`` sensor ranges
    range_reach
    min_cell_m      cells are at least this wide (and at least one step at top speed)
    ahead_m         the robot heads for the farthest point of its planned way within this (and within
                    its sensor range) that it sees in a straight line on its chart
    stall_steps     a robot that has not got two body lengths (or 1.5 cells) from where it was this
                    many steps ago (twice as many with robots near) marks the straight way to the
                    point it heads for as shut (so that it plans another way)
    wall_cost       a step into a cell beside a shut cell costs this many cells more (the way keeps
                    off the walls)
    extend          a break point seen square on (not at its end) shuts the chart this many cells
                    either side of it along the break as well
    turn_m          a way that sets off against the way the robot was heading costs up to this much
                    more (it keeps to its way unless another is this much shorter: no dithering
                    between two ways of about the same length as the chart grows)
    behind          the cell this many cells behind each break point (away from its safe side) is
                    shut too: a wall two cells thick leaks no diagonal way through its holes
    link            a break point within this many cells of one seen last step shuts the cells
                    between them too (a wall driven along leaves no holes on the chart)
    """

    cells: int = 256
    reach: float = 1.5
    range_reach: float = 2.0
    min_cell_m: float = 1.0
    ahead_m: float = 20.0
    stall_steps: int = 20
    wall_cost: float = 2.0
    extend: float = 0.7
    link: float = 1.5
    behind: float = 0.8
    turn_m: float = 30.0

    def __post_init__(self):  # the chart is cells x cells bytes per robot: at most MAX_CHART_CELLS a side
        check_positive_fields(self, {"cells": {"lo": 4, "lo_open": False, "hi": MAX_CHART_CELLS},
                                     "stall_steps": {"hi": 10**9}})


@dataclass
class ChartMemory:
    """What each robot keeps (``n`` rows; its heading ``psi`` in its own frame ``F`` is the odometry
    of :func:`~tin_swarm_env.policies.bug.odometry`, kept in the bug memory beside this one):

    grid       (n, C, C) uint8   its chart, centred on its target in ``F``: 0 open (or not sensed),
                                 1 a wall (a dangerous break seen there), 2 stuck (it stalled there)
    cell       (n,)      m       the chart's cell width (0: no chart yet)
    way        (n, 2)    m       the point it heads for, in ``F`` relative to the target
    dirty      (n,)      bool    its chart changed since it last planned
    anchor     (n, 2)    m       where it was when the stall count started
    stall      (n,)      int     steps since it was last far enough from ``anchor``
    forgot     (n,)      int     times it forgot its whole chart (no way on it)
    last_pts   (n, K, 2) m       the break points it saw last step, in ``F`` (``last_ok``: which were
    last_ok    (n, K)    bool    dangerous), joined to this step's (``ChartParams.link``)
    have_way   (n,)      bool    ``way`` holds a planned point (its direction counts in ``turn_m``)
    """

    grid: np.ndarray
    cell: np.ndarray
    way: np.ndarray
    dirty: np.ndarray
    anchor: np.ndarray
    stall: np.ndarray
    forgot: np.ndarray
    last_pts: np.ndarray
    last_ok: np.ndarray
    have_way: np.ndarray

    @classmethod
    def empty(cls, n: int, cells: int, k: int = 0) -> ChartMemory:
        return cls(grid=np.zeros((n, cells, cells), np.uint8), cell=np.zeros(n), way=np.zeros((n, 2)),
                   dirty=np.ones(n, bool), anchor=np.zeros((n, 2)), stall=np.zeros(n, np.int64),
                   forgot=np.zeros(n, np.int64),
                   last_pts=np.zeros((n, k, 2)), last_ok=np.zeros((n, k), bool), have_way=np.zeros(n, bool))

    def grow(self, n: int) -> ChartMemory:
        have = len(self.cell)
        if n <= have:
            return self
        e = ChartMemory.empty(n - have, self.grid.shape[1], self.last_ok.shape[1])
        return ChartMemory(**{f.name: np.concatenate([getattr(self, f.name), getattr(e, f.name)])
                              for f in fields(self)})


def _rot(psi, v):
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1)


@njit(cache=True)
def _mark(grid, cell, rows, pts, ok):
    """Mark points ``pts (m, M, 2)`` (``ok (m, M)``) as walls on the charts of robots ``rows (m,)``;
    True where a cell changed."""
    n, m = ok.shape
    c = grid.shape[1]
    h = c // 2
    changed = np.zeros(n, np.bool_)
    for r in range(n):
        i = rows[r]
        if cell[i] <= 0:
            continue
        for k in range(m):
            if not ok[r, k]:
                continue
            a = int(np.floor(pts[r, k, 0] / cell[i])) + h
            b = int(np.floor(pts[r, k, 1] / cell[i])) + h
            if 0 <= a < c and 0 <= b < c and grid[i, a, b] != WALL:
                grid[i, a, b] = 1
                changed[r] = True
    return changed


@njit(cache=True)
def _mark_border(grid, cell, rows, pts, nrm, ok):
    """The terrain is a rectangle: a border point ``pts (m, K, 2)`` with its normal ``nrm`` (toward
    the terrain) closes the whole half-plane beyond it on the robot's chart. True where a cell changed."""
    n, m = ok.shape
    c = grid.shape[1]
    h = c // 2
    changed = np.zeros(n, np.bool_)
    for r in range(n):
        i = rows[r]
        w = cell[i]
        if w <= 0:
            continue
        for k in range(m):
            if not ok[r, k]:
                continue
            px, py, nx, ny = pts[r, k, 0], pts[r, k, 1], nrm[r, k, 0], nrm[r, k, 1]
            a = int(np.floor((px - 2 * w * nx) / w)) + h
            b = int(np.floor((py - 2 * w * ny) / w)) + h
            if 0 <= a < c and 0 <= b < c and grid[i, a, b] == WALL:
                continue  # this side is closed already
            for a in range(c):
                x = (a - h + 0.5) * w - px
                for b in range(c):
                    if x * nx + ((b - h + 0.5) * w - py) * ny < -0.5 * w and grid[i, a, b] != WALL:
                        grid[i, a, b] = WALL
                        changed[r] = True
    return changed


@njit(cache=True)
def _clear(g, a0, b0, a1, b1):
    """No wall on the straight line between cells (a0, b0) and (a1, b1) (supercover walk)."""
    da, db = a1 - a0, b1 - b0
    na, nb = abs(da), abs(db)
    sa = 1 if da > 0 else -1
    sb = 1 if db > 0 else -1
    a, b = a0, b0
    ia = ib = 0
    while ia < na or ib < nb:
        t = (1 + 2 * ia) * nb - (1 + 2 * ib) * na
        if t == 0:  # through a corner: both neighbours must be open
            if g[a + sa, b] != 0 or g[a, b + sb] != 0:
                return False
            a += sa
            b += sb
            ia += 1
            ib += 1
        elif t < 0:
            a += sa
            ia += 1
        else:
            b += sb
            ib += 1
        if g[a, b] != 0:
            return False
    return True


@njit(cache=True, inline="always")
def heap_pop(hk, hv, hn):
    """Pop the least key of the binary heap ``hk`` (keys) / ``hv`` (values) of ``hn`` entries:
    ``(value, hn - 1)``."""
    v = hv[0]
    hn -= 1
    if hn > 0:  # sift the last entry down from the root
        lk, lv = hk[hn], hv[hn]
        i = 0
        while True:
            j = 2 * i + 1
            if j >= hn:
                break
            if j + 1 < hn and hk[j + 1] < hk[j]:
                j += 1
            if hk[j] < lk:
                hk[i], hv[i] = hk[j], hv[j]
                i = j
            else:
                break
        hk[i], hv[i] = lk, lv
    return v, hn


@njit(cache=True, inline="always")
def heap_push(hk, hv, hn, key, value):
    """Push ``key``/``value`` onto the heap of :func:`heap_pop`; returns ``hn + 1``."""
    i = hn
    while i > 0:  # sift up
        p = (i - 1) // 2
        if hk[p] > key:
            hk[i], hv[i] = hk[p], hv[p]
            i = p
        else:
            break
    hk[i], hv[i] = key, value
    return hn + 1


@njit(cache=True)
def plan(g, sa, sb, ta, tb, ahead, wall_cost=2.0, ha=0.0, hb=0.0, turn=0.0):
    """A* over chart ``g (C, C)`` (8-connected, no corner cutting, unit cells; a step costs its
    length, plus ``wall_cost`` into a cell with a non-open cell among its 8 neighbours) from cell
    (sa, sb) to (ta, tb); only open cells are entered (the start itself may be shut). Returns
    ``(found, wa, wb, cost)``: the farthest cell of the least-cost way within ``ahead`` cells of
    the start (straight-line distance) that is in a straight open line from it (at least the way's
    first cell), and the way's cost (inf: none)."""
    c = g.shape[0]
    dist = np.full((c, c), 1e30)
    prev = np.full((c, c), -1, np.int64)
    closed = np.zeros((c, c), np.bool_)
    return _astar(g, sa, sb, ta, tb, ahead, wall_cost, ha, hb, turn, dist, prev, closed)


@njit(cache=True)
def _astar(g, sa, sb, ta, tb, ahead, wall_cost, ha, hb, turn, dist, prev, closed):
    """:func:`plan` on work arrays ``dist`` (all 1e30), ``prev`` (all -1) and ``closed`` (all
    False), ``(C, C)`` each, which it leaves as it found them (only the cells it touched are reset):
    the planner of many robots allocates them once and its cost follows the cells searched, not C^2."""
    c = g.shape[0]
    INF = 1e30
    cap = 64 * c + 64  # the heap grows by doubling (a cell is pushed at most 8 times)
    heap_k = np.empty(cap)
    heap_v = np.empty(cap, np.int64)
    touched = np.empty(cap, np.int64)
    nt = 0
    hn = 0
    dist[sa, sb] = 0.0
    touched[0] = sa * c + sb
    nt = 1
    s2 = np.sqrt(2.0)

    def h(a, b):
        dx, dy = abs(a - ta), abs(b - tb)
        return max(dx, dy) + (s2 - 1.0) * min(dx, dy)

    heap_k[0] = h(sa, sb)
    heap_v[0] = sa * c + sb
    hn = 1
    found = False
    while hn > 0:
        v, hn = heap_pop(heap_k, heap_v, hn)
        a, b = v // c, v % c
        if closed[a, b]:
            continue
        closed[a, b] = True
        if a == ta and b == tb:
            found = True
            break
        for da in range(-1, 2):
            for db in range(-1, 2):
                if da == 0 and db == 0:
                    continue
                na, nb = a + da, b + db
                if na < 0 or nb < 0 or na >= c or nb >= c or g[na, nb] != 0 or closed[na, nb]:
                    continue
                if da != 0 and db != 0 and (g[a + da, b] != 0 or g[a, b + db] != 0):
                    continue
                step = s2 if da != 0 and db != 0 else 1.0
                nd = dist[a, b] + step
                if a == sa and b == sb and turn > 0:  # leaving the start against the way it was going
                    nd += turn * 0.5 * (1.0 - (da * ha + db * hb) / step)
                if _beside_wall(g, na, nb):  # a cell beside a wall costs more: the way keeps a cell off the walls
                    nd += wall_cost
                if nd < dist[na, nb]:
                    if dist[na, nb] >= INF:  # first touch: remembered, to be reset
                        if nt == len(touched):
                            touched = _doubled(touched, nt)
                        touched[nt] = na * c + nb
                        nt += 1
                    dist[na, nb] = nd
                    prev[na, nb] = a * c + b
                    if hn == len(heap_k):
                        heap_k, heap_v = _doubled(heap_k, hn), _doubled(heap_v, hn)
                    hn = heap_push(heap_k, heap_v, hn, nd + h(na, nb), na * c + nb)
    wa, wb, cost = sa, sb, np.inf
    if found:
        wa, wb = _way_point(g, prev, sa, sb, ta, tb, ahead)
        cost = dist[ta, tb]
    for k in range(nt):  # leave the work arrays as found
        v = touched[k]
        dist[v // c, v % c] = INF
        prev[v // c, v % c] = -1
        closed[v // c, v % c] = False
    return found, wa, wb, cost


@njit(cache=True, inline="always")
def _beside_wall(g, a, b):
    """A non-open cell among the 8 neighbours of cell (a, b) (or the cell itself) of chart ``g``."""
    c = g.shape[0]
    near = False
    for ea in range(-1, 2):
        for eb in range(-1, 2):
            xa, xb = a + ea, b + eb
            if 0 <= xa < c and 0 <= xb < c and g[xa, xb] != 0:
                near = True
    return near


@njit(cache=True, inline="always")
def _doubled(arr, n):
    """A copy of ``arr``'s first ``n`` entries in an array twice as long (the rest unset)."""
    out = np.empty(2 * n, arr.dtype)
    out[:n] = arr[:n]
    return out


@njit(cache=True)
def _way_point(g, prev, sa, sb, ta, tb, ahead):
    """The way :func:`_astar` found, walked back from (ta, tb) along ``prev`` to the start (sa, sb):
    its farthest cell within ``ahead`` cells of the start (straight-line distance) in a straight
    open line from it (at least the way's first cell), as ``(wa, wb)``."""
    c = g.shape[0]
    way = [ta * c + tb]
    v = ta * c + tb
    while v != sa * c + sb:
        v = prev[v // c, v % c]
        way.append(v)
    # way[-1] is the start; the farthest in reach and in line
    n = len(way)
    best = n - 1
    for k in range(n - 2, -1, -1):
        a, b = way[k] // c, way[k] % c
        if (a - sa) ** 2 + (b - sb) ** 2 > ahead * ahead and k < n - 2:
            break
        if k == n - 2 or _clear(g, sa, sb, a, b):
            best = k
    return way[best] // c, way[best] % c


@njit(cache=True)
def _plan_rows(grid, cell, q, way, dirty, forgot, have_way, rows, ahead_m, wall_cost, turn_m):
    """Plan for each robot row in ``rows`` whose chart changed (``dirty``) or that is near its way
    point; writes ``way`` (F, m). Forgetting ends with an empty chart, on which there is always a way."""
    c = grid.shape[1]
    h = c // 2
    dist = np.empty((0, 0))  # the work arrays, made when the first robot plans
    prev = np.empty((0, 0), np.int64)
    closed = np.empty((0, 0), np.bool_)
    for r in range(len(rows)):
        i = rows[r]
        if cell[i] <= 0:
            continue
        w = cell[i]
        sa = min(max(int(np.floor(q[r, 0] / w)) + h, 0), c - 1)
        sb = min(max(int(np.floor(q[r, 1] / w)) + h, 0), c - 1)
        dx, dy = way[i, 0] - q[r, 0], way[i, 1] - q[r, 1]
        if not dirty[i] and dx * dx + dy * dy > (2 * w) ** 2:
            continue
        if dist.shape[0] == 0:
            dist = np.full((c, c), 1e30)
            prev = np.full((c, c), -1, np.int64)
            closed = np.zeros((c, c), np.bool_)
        ahead = max(ahead_m / w, 3.0)
        nrm = np.sqrt(dx * dx + dy * dy)
        ha, hb = (dx / nrm, dy / nrm) if nrm > 1e-9 and have_way[i] else (0.0, 0.0)
        tc = turn_m / w if nrm > 1e-9 and have_way[i] else 0.0
        ok, wa, wb, _ = _astar(grid[i], sa, sb, h, h, ahead, wall_cost, ha, hb, tc, dist, prev, closed)
        g = grid[i]
        if not ok:  # 1. forget the stalls
            for a in range(c):
                for b in range(c):
                    if g[a, b] == STUCK:
                        g[a, b] = OPEN
            ok, wa, wb, _ = _astar(g, sa, sb, h, h, ahead, wall_cost, ha, hb, tc, dist, prev, closed)
        if not ok:  # 2. forget the walls round where it stands (a corner mapped shut)
            for a in range(max(sa - 3, 0), min(sa + 4, c)):
                for b in range(max(sb - 3, 0), min(sb + 4, c)):
                    g[a, b] = OPEN
            ok, wa, wb, _ = _astar(g, sa, sb, h, h, ahead, wall_cost, ha, hb, tc, dist, prev, closed)
        if not ok:  # 3. forget the chart: it starts again from what it sees
            g[:, :] = OPEN
            forgot[i] += 1
            ok, wa, wb, _ = _astar(g, sa, sb, h, h, ahead, wall_cost, ha, hb, tc, dist, prev, closed)
        dirty[i] = False
        have_way[i] = ok
        if ok:
            if wa == h and wb == h:
                way[i, 0] = 0.0
                way[i, 1] = 0.0
            else:
                way[i, 0] = (wa - h + 0.5) * w
                way[i, 1] = (wb - h + 0.5) * w


def chart_update(mem: ChartMemory, rows, d: DecodedObs, q, psi, params: ChartParams, range_m: float,
                 step_m: float, body_m: float, crowded) -> np.ndarray:
    """Advance the charts of robots ``rows`` by one observation and return the body-frame vector
    to the point each heads for ``(m, 2)`` (the target's own vector ``rel_t`` when its way is
    open straight to it)."""
    c = params.cells
    new = (mem.cell[rows] <= 0) & d.has_t
    if new.any():
        r = rows[new]
        mem.cell[r] = np.maximum(max(params.min_cell_m, step_m),
                                 2 * (params.reach * d.dist[new] + params.range_reach * range_m) / c)
        mem.anchor[r] = q[new]
        mem.dirty[r] = True
    # what it sees: the dangerous breaks' closest points, and a little of each wall either side
    # (not past a break's end: the closest point of a break seen at its end is that end)
    rel = d.b_rel
    pts = q[:, None, :] + _rot(psi[:, None].repeat(rel.shape[1], 1).ravel(), rel.reshape(-1, 2)).reshape(rel.shape)
    nrm = _rot(psi[:, None].repeat(rel.shape[1], 1).ravel(), d.b_normal.reshape(-1, 2)).reshape(rel.shape)
    dist = np.sqrt(np.sum(rel * rel, axis=-1))
    unit = -rel / np.maximum(dist, 1e-9)[..., None]  # from the point toward the robot
    square = np.abs(np.sum(unit * d.b_normal, axis=-1)) > np.cos(np.radians(5.0))
    tang = np.stack([-nrm[..., 1], nrm[..., 0]], axis=-1)
    w = mem.cell[rows][:, None, None]
    ok = d.b_danger
    ext = [pts, pts - params.behind * w * nrm]  # the wall, and a cell behind it (no diagonal leak)
    oks = [ok, ok]
    for s in (-params.extend, params.extend):
        ext.append(pts + s * w * tang)
        oks.append(ok & square)
    # a wall driven along: each point joined to the nearest point seen last step within link cells
    # (closest points jump along a break of long edges, and a chart wall with a hole lets the way through)
    if mem.last_ok.shape[1] != ok.shape[1]:
        n_all = len(mem.cell)
        mem.last_pts, mem.last_ok = np.zeros((n_all, ok.shape[1], 2)), np.zeros((n_all, ok.shape[1]), bool)
    lp, lo = mem.last_pts[rows], mem.last_ok[rows]
    if ok.shape[1]:  # (no break slots: a scan alone)
        gap = np.sqrt(np.sum((pts[:, :, None, :] - lp[:, None, :, :]) ** 2, axis=-1))  # (m, K, K)
        gap = np.where(lo[:, None, :], gap, np.inf)
        j = np.argmin(gap, axis=-1)
        near = ok & (np.take_along_axis(gap, j[..., None], axis=-1)[..., 0] < params.link * w[..., 0])
        other = np.take_along_axis(lp, j[..., None].repeat(2, -1), axis=1)
        for f in (0.25, 0.5, 0.75):
            ext.append(pts + f * (other - pts))
            oks.append(near)
    mem.last_pts[rows], mem.last_ok[rows] = pts, ok
    if d.s_rel is not None and d.s_rel.shape[1]:  # the scan's hits: the wall, and a cell behind it
        k = d.s_rel.shape[1]
        turn = psi[:, None].repeat(k, 1).ravel()
        hits = q[:, None, :] + _rot(turn, d.s_rel.reshape(-1, 2)).reshape(d.s_rel.shape)
        # each beam's direction from its bearing, exact even for a hit 0 m away
        beam = _rot(turn, np.broadcast_to(d.s_dir, d.s_rel.shape).reshape(-1, 2)).reshape(d.s_rel.shape)
        ext += [hits, hits + params.behind * w * beam]
        oks += [d.s_hit, d.s_hit]
    at = np.concatenate(ext, axis=1)
    on = np.concatenate(oks, axis=1)
    # never the target's own cell
    h = c // 2
    cw = mem.cell[rows][:, None]
    tgt = (np.floor(at[..., 0] / cw) == 0) & (np.floor(at[..., 1] / cw) == 0)
    on = on & ~tgt
    rr = np.asarray(rows, np.int64)
    changed = _mark(mem.grid, mem.cell, rr, at.astype(np.float64), on)
    changed |= _mark_border(mem.grid, mem.cell, rr, pts.astype(np.float64), nrm.astype(np.float64),
                            d.b_border & d.b_danger)
    mem.dirty[rows] |= changed
    # stalls: a body length from the anchor resets the count
    moved = np.sqrt(np.sum((q - mem.anchor[rows]) ** 2, axis=-1)) > np.maximum(2 * body_m, 1.5 * mem.cell[rows])
    mem.anchor[rows] = np.where(moved[:, None], q, mem.anchor[rows])
    mem.stall[rows] = np.where(moved, 0, mem.stall[rows] + 1)
    limit = np.where(crowded, 2 * params.stall_steps, params.stall_steps)
    stuck = (mem.stall[rows] > limit) & d.has_t & (mem.cell[rows] > 0)
    if stuck.any():  # the straight way to the point it heads for is shut: mark it so
        r = rows[stuck]
        to = mem.way[r] - q[stuck]
        for f in (0.25, 0.5, 0.75, 1.0):
            p = q[stuck] + f * to
            a = np.clip(np.floor(p[:, 0] / mem.cell[r]).astype(np.int64) + h, 0, c - 1)
            b = np.clip(np.floor(p[:, 1] / mem.cell[r]).astype(np.int64) + h, 0, c - 1)
            ok = ~((a == h) & (b == h)) & (mem.grid[r, a, b] == OPEN)
            mem.grid[r[ok], a[ok], b[ok]] = STUCK
        mem.stall[r] = 0
        mem.dirty[r] = True
    _plan_rows(mem.grid, mem.cell, q.astype(np.float64), mem.way, mem.dirty, mem.forgot, mem.have_way,
               np.asarray(rows, np.int64), params.ahead_m, params.wall_cost, params.turn_m)
    way = mem.way[rows]
    at_t = (way[:, 0] == 0.0) & (way[:, 1] == 0.0)
    out = _rot(-psi, way - q)
    return np.where(at_t[:, None] | ~(mem.cell[rows] > 0)[:, None], d.rel_t, out)
