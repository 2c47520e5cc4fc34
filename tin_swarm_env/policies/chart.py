"""The chart search of :class:`~tin_swarm_env.policies.APFPolicy` (``search="chart"``): each robot
keeps a coarse chart of the dangerous breaks it has seen and heads along the shortest way to its
target on that chart, taking unseen ground as open (planning under the free-space assumption,
as D* and its kin do). The rule, and why it terminates, is written once, in the
:mod:`tin_swarm_env.policies.apf` module docstring. A step's chart work (marking, stalls, the
decision to plan, the A* over each robot's own chart, the point it heads for) is one compiled
pass over all robot rows (:func:`chart_update`), its blocks of rows run side by side on numba's
threads (a robot's step touches its own memory only, so the same bits on any number); the numpy
version of its marks is the reference of ``tests/policies/test_chart.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numba import njit, prange

from ..errors import ArgumentError
from .base import DecodedObs, check_positive_fields

__all__ = ["ChartMemory", "ChartParams", "ROUTE_PER_CELL", "chart_update", "plan", "robot_side"]

OPEN, WALL, STUCK = 0, 1, 2  # chart cell values: not seen blocked, a dangerous break seen there, a stall there
SEEN = 4  # a bit on an open cell: a scan beam passed over it (ChartParams.unseen_gap)
SHUT = 3  # the mask of the value (OPEN, WALL or STUCK) under the SEEN bit
PINCH_ONE_CELL = 1.5  # _pinched's width that leaves out gaps one cell wide, across a diagonal too
_SQRT2 = 2.0 ** 0.5


MAX_CHART_CELLS = 2048  # ChartParams.cells: a chart is cells^2 bytes per robot (4 MiB at 2048; 200 robots 800 MiB)
ROUTE_PER_CELL = 2  # a robot keeps the first ROUTE_PER_CELL * cells cells of its planned way (ChartMemory.route)


@dataclass(frozen=True)
class ChartParams:
    """Constants of the chart search (the module docstring of :mod:`tin_swarm_env.policies.apf`
    says what each does).

    cells           the chart is ``cells x cells``, centred on the target (4 ..
                    :data:`MAX_CHART_CELLS`: one byte a cell, per robot)
    reach           its half-width is ``reach`` times the robot's distance to go at its first step
                    plus ``range_reach`` sensor ranges
    range_reach
    min_cell_m      cells are at least this wide (and at least one step at top speed); a coarser chart
                    (3 m, or 256 cells) brings more of the generated forks' robots in and far fewer of
                    ``realdem``'s (``research/side_tradeoff_cell3.md``, ``_cells256.md``)
    ahead_m         the robot heads for the farthest point of its planned way within this (and within
                    its sensor range) that it sees in a straight line on its chart
    stall_steps     a robot that has not got two body lengths (or 1.5 cells) from where it was this
                    many steps ago (twice as many with robots near) marks the straight way to the
                    point it heads for as shut (so that it plans another way)
    wall_cost       a step into a cell beside a shut cell costs this many cells more (the way keeps
                    off the walls)
    extend          a break point seen square on (not at its end) shuts the chart this many cells
                    either side of it along the break as well
    inset           a break point (a scan hit) shuts the cell this many cells beyond it (away from
                    its safe side; a hit: on along the beam), not the cell that holds it: at 0.5 a
                    cell is shut only where most of it lies beyond the break, so a gap between two
                    breaks is charted about as wide as it is (shutting the cell that holds each
                    point charted it a cell narrower on average); ``behind`` counts from there
    turn_m          a way that sets off against the way the robot was heading costs up to this much
                    more (it keeps to its way unless another is this much shorter: no dithering
                    between two ways of about the same length as the chart grows)
    behind          the cell this many cells behind each break point (away from its safe side) is
                    shut too: a wall two cells thick leaks no diagonal way through its holes
    link            a break point within this many cells of one seen last step shuts the cells
                    between them too (a wall driven along leaves no holes on the chart)
    pinch_cells     (with ``unseen_gap`` 0 only) a cell between two shut cells on opposite sides (a gap
                    charted one cell wide) is left out of the plan (step 5 crosses it at a wall's price)
                    on a chart whose cells are fine enough that a pass (``SafetyShield.pass_m``: 3 body diameters)
                    is at least this many cells wide: such a gap is narrower than a pass, most often
                    a hole between two sightings of one wall; on a coarser chart it may be a real pass
                    (real hillside has passes narrower than ``pass_m``: at 1.5 the rule shut them on
                    most ``realdem`` charts, 85.5 % arrived against 93.8 % at 2.5)
    break_decay_m   the break field's decay length under the chart search, in place of
                    :attr:`FieldParams.break_decay_m <tin_swarm_env.world.fields.FieldParams>` (which
                    the bug search keeps): the planned way keeps off the walls (``wall_cost``), so the
                    field is a cushion at the wall; one reaching further pushes a robot back out of
                    a funnel narrower than a few body lengths (``realdem``: 66.9 % arrived at 2.5 m,
                    85.5 % at 0.5 m, 0 falls either way)
    side_cost       robot ``i`` prefers one side of the line from where it started (its first step) to
                    its target, the right or the left (:func:`robot_side`: the robots of each target
                    split about evenly): a step onto a cell whose centre lies more than ``side_margin``
                    cells over on the other side costs ``1 + side_cost`` times its length. Where a wall
                    blocks the straight way, the robots of one target split between its two ends instead
                    of all trying the end that looks nearer first; a robot keeps to its side unless the
                    other way is shorter even with its stretch beyond the margin priced so, and a side
                    found shut is left at once. jacksboro, 1 800 steps: 71.0-72.5 % of all robots in
                    without it (``docs/figures/apf_noside.md``), 82.5 % with it (``docs/figures/apf.md``);
                    the price is paid where the side a robot does not prefer is the short one and its own
                    has dead ends (generated forks: 97.7 % without it, 97.0 % with it; at 1.0, 96.6 %,
                    half the robots of a seed sometimes lost in the pockets of theirs). 0: no preference
                    (the same steps as before it, bit for bit)
    side_margin     cells on either side of that line that cost no more (a way that keeps near the line,
                    as on open ground, pays nothing)
    side_leave_m    a robot whose new plan is longer than what was left of its last by more than this
                    (its side's way led into a dead end, or round a wall longer than it looked) has no side
                    from then on (not told where either way is cut at ``ROUTE_PER_CELL`` x ``cells``
                    cells: its length is not known). 0 (the default): it keeps its side. Not the default
                    because it does not meet both of the bars it trades
                    (``research/side_tradeoff_leave60.md``, ``_leave300.md``): at 60 m generated forks
                    bring 97.4 % in over three held-out sets (96.6 % without it; 94.8 % on one of them),
                    but jacksboro by 1 800 steps falls to 72.5-77.0 % (82.5 % without it); at 300 m forks
                    are as without it and jacksboro is at 73.5-78.5 %: there a plan grows as much on the
                    right side as on the wrong one
    unseen_gap      a gap in the charted walls narrower than this many passes (``SafetyShield.pass_m``) is
                    left out of the plan (crossed at a wall's price, as ``pinch_cells``' gaps, whose rule
                    it replaces) unless a scan beam has passed over it: every open cell a beam passes
                    over is marked seen. The holes between a wall's sightings are then walls while a
                    narrow pass seen through is not, on a chart of any cell size. At 1 (the default)
                    generated forks bring 98.8 / 97.1 / 98.0 % in on three held-out sets
                    (``docs/figures/apf.md``, ``apf_seeds100.md``, ``apf_seeds200_fork.md``; 97.0 / 96.1 /
                    96.8 % at 0) and ``realdem`` 94.3 / 93.5 % on two (92.3 / 90.6 % at 0); jacksboro as
                    at 0. 0: off (the one-cell rule of ``pinch_cells``; the default before it). Known
                    gaps: a robot keeps its way until its chart changes near it, so a gap seen since does
                    not make it plan again by itself (planning again then was tried: fork 98.9 / 96.8 /
                    98.0 %, realdem 94.2 / 93.1 %, no gain); what the beams' marks cost: the
                    ``unseen_gap = 0`` row of ``docs/figures/apf_speed.md``
    """

    cells: int = 512
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
    inset: float = 0.5
    pinch_cells: float = 2.5
    break_decay_m: float = 0.5
    side_cost: float = 0.75
    side_margin: float = 2.0
    side_leave_m: float = 0.0
    unseen_gap: float = 1.0

    def __post_init__(self):  # the chart is cells x cells bytes per robot: at most MAX_CHART_CELLS a side
        check_positive_fields(self, {"cells": {"lo": 4, "lo_open": False, "hi": MAX_CHART_CELLS},
                                     "stall_steps": {"hi": 10**9}, "inset": {"lo_open": False, "hi": 1.0},
                                     "side_cost": {"lo_open": False}, "side_margin": {"lo_open": False},
                                     "side_leave_m": {"lo_open": False}, "unseen_gap": {"lo_open": False}})


_ROW_FIELDS = ("grid", "cell", "way", "dirty", "anchor", "stall", "forgot", "last_pts", "last_ok", "have_way",
               "route", "route_shut", "route_len", "route_at", "way_at", "plans", "walled", "home")


@dataclass
class ChartMemory:
    """What each robot keeps (``n`` rows; its heading ``psi`` in its own frame ``F`` is the odometry
    of :func:`~tin_swarm_env.policies.bug.odometry`, kept in the bug memory beside this one):

    grid       (n, C, C) uint8   its chart, centred on its target in ``F``: 0 open (or not sensed),
                                 1 a wall (a dangerous break seen there), 2 stuck (it stalled there);
                                 bit 4 (``SEEN``) on an open cell a scan beam passed over
                                 (``ChartParams.unseen_gap``): the value is ``grid & SHUT``
    cell       (n,)      m       the chart's cell width (0: no chart yet)
    way        (n, 2)    m       the point it heads for, in ``F`` relative to the target
    dirty      (n,)      bool    it must plan afresh (no way yet, or it stalled)
    anchor     (n, 2)    m       where it was when the stall count started
    stall      (n,)      int     steps since it was last far enough from ``anchor``
    forgot     (n,)      int     times it forgot its whole chart (no way on it)
    last_pts   (n, K, 2) m       the break points it saw last step, in ``F`` (``last_ok``: which were
    last_ok    (n, K)    bool    dangerous), joined to this step's (``ChartParams.link``)
    have_way   (n,)      bool    ``way`` holds a planned point (its direction counts in ``turn_m``)
    route      (n, L)    int32   its planned way, start first, as flat cell indices ``a C + b``: the
                                 first ``L = ROUTE_PER_CELL C`` cells of it (a longer way is cut there)
    route_shut (n, L)    uint8   shut cells among each route cell's 3 x 3 block when it planned
    route_len  (n,)      int     cells held in ``route`` (0: none)
    route_at   (n,)      int     the route cell it is at (within a cell of it)
    way_at     (n,)      int     the route cell it heads for (``way``)
    plans      (n,)      int     times it has run the A* (a count for the benchmark and tests)
    walled     (n,)      bool    its last way crossed a shut cell (no way over open cells): its next
                                 plan first floods from the target (:func:`_walled_in`)
    home       (n, 2)    m       where it was at its first step, in ``F`` relative to the target (the
                                 line of :attr:`ChartParams.side_cost`); (0, 0) once it has left its
                                 side (:attr:`ChartParams.side_leave_m`): no side preference

    Bytes per robot: ``C^2 + 5 ROUTE_PER_CELL C + 17 K + 107`` (the chart, the route, the rest):
    68 254 at 256 cells and 3 break slots (66.7 KiB; the route is 2.5 KiB of it), 267 422 at the
    default 512 (261 KiB). Besides, for all robots together: one set of A* work arrays for each of
    numba's threads (``work``: ``17 C^2`` bytes a set, 1.06 MiB at 256 cells, 4.25 MiB at 512, made at
    the first plan) and the heap of each search under way.
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
    route: np.ndarray
    route_shut: np.ndarray
    route_len: np.ndarray
    route_at: np.ndarray
    way_at: np.ndarray
    plans: np.ndarray
    walled: np.ndarray
    home: np.ndarray
    work: tuple | None = None

    @classmethod
    def empty(cls, n: int, cells: int, k: int = 0) -> ChartMemory:
        L = ROUTE_PER_CELL * cells
        return cls(grid=np.zeros((n, cells, cells), np.uint8), cell=np.zeros(n), way=np.zeros((n, 2)),
                   dirty=np.ones(n, bool), anchor=np.zeros((n, 2)), stall=np.zeros(n, np.int64),
                   forgot=np.zeros(n, np.int64),
                   last_pts=np.zeros((n, k, 2)), last_ok=np.zeros((n, k), bool), have_way=np.zeros(n, bool),
                   route=np.zeros((n, L), np.int32), route_shut=np.zeros((n, L), np.uint8),
                   route_len=np.zeros(n, np.int64), route_at=np.zeros(n, np.int64), way_at=np.zeros(n, np.int64),
                   plans=np.zeros(n, np.int64), walled=np.zeros(n, bool), home=np.zeros((n, 2)))

    def grow(self, n: int) -> ChartMemory:
        have = len(self.cell)
        if n <= have:
            return self
        e = ChartMemory.empty(n - have, self.grid.shape[1], self.last_ok.shape[1])
        return ChartMemory(**{f: np.concatenate([getattr(self, f), getattr(e, f)]) for f in _ROW_FIELDS},
                           work=self.work)

    def work_arrays(self) -> tuple:
        """The A* work arrays ``(dist, prev, closed)``, ``(T, C, C)`` each: one set for each of the
        ``T`` runs of :func:`_chart_rows` (``T``: numba's thread count; made again only when it grows)."""
        t = max(1, int(numba.get_num_threads()))
        if self.work is None or self.work[0].shape[0] < t:
            c = self.grid.shape[1]
            self.work = (np.full((t, c, c), 1e30), np.full((t, c, c), -1, np.int32), np.zeros((t, c, c), np.bool_))
        return self.work


@njit(cache=True)
def _border_one(g, w, px, py, nx, ny):
    """The terrain is a rectangle: a border point ``(px, py)`` with its normal ``(nx, ny)`` (toward
    the terrain) closes the whole half-plane beyond it on chart ``g`` (cells ``w`` wide). True where
    a cell changed."""
    c = g.shape[0]
    h = c // 2
    a = int(np.floor((px - 2 * w * nx) / w)) + h
    b = int(np.floor((py - 2 * w * ny) / w)) + h
    if 0 <= a < c and 0 <= b < c and (g[a, b] & SHUT) == WALL:
        return False  # this side is closed already
    changed = False
    for a in range(c):
        x = (a - h + 0.5) * w - px
        for b in range(c):
            if x * nx + ((b - h + 0.5) * w - py) * ny < -0.5 * w and (g[a, b] & SHUT) != WALL:
                g[a, b] = WALL
                changed = True
    return changed


@njit(cache=True)
def _mark_border(grid, cell, rows, pts, nrm, ok):
    """:func:`_border_one` for border points ``pts (m, K, 2)`` with their normals ``nrm`` (``ok (m, K)``)
    on the charts of robots ``rows (m,)``. True where a cell changed."""
    n, m = ok.shape
    changed = np.zeros(n, np.bool_)
    for r in range(n):
        i = rows[r]
        if cell[i] <= 0:
            continue
        for k in range(m):
            if ok[r, k] and _border_one(grid[i], cell[i], pts[r, k, 0], pts[r, k, 1], nrm[r, k, 0], nrm[r, k, 1]):
                changed[r] = True
    return changed


@njit(cache=True, inline="always")
def _wall_at(g, w, x, y):
    """Chart ``g`` (cells ``w`` wide, centred on the target) shuts the cell of point ``(x, y)``
    (never the target's own cell; a point off the chart is ignored). True where the cell changed."""
    fa, fb = np.floor(x / w), np.floor(y / w)
    if fa == 0 and fb == 0:
        return False
    c = g.shape[0]
    a, b = int(fa) + c // 2, int(fb) + c // 2
    if 0 <= a < c and 0 <= b < c and (g[a, b] & SHUT) == OPEN:  # a stuck cell stays stuck (step 5)
        g[a, b] = WALL
        return True
    return False


@njit(cache=True)
def _mark_row(g, w, qx, qy, cs, sn, rel, nrm_b, danger, border, lp, lo, s_rel, s_dir, s_hit, prm):
    """One robot's marks (apf docstring, chart search step 1) on its chart ``g`` (cells ``w`` wide;
    ``w <= 0``: no chart, nothing marked): at ``q``, heading ``(cs, sn) = (cos, sin) psi``, it sees
    break slots ``rel, nrm_b (K, 2)`` (body frame), ``danger``, ``border (K,)``, and scan hits
    ``s_rel (K_s, 2)`` along ``s_dir`` (``s_hit``); ``lp, lo``: last step's points in ``F``, replaced
    by this step's. ``prm``: behind, extend, link, cos(5 deg), inset (0 if left out) and the widest gap
    left out of the plan unless seen, in metres (0 if left out): where it is wider than a cell, scan beams
    mark the open cells they pass over (:func:`_mark_seen`; elsewhere no gap is left out, and the marks
    would change nothing). True where a cell changed."""
    behind, extend, link, cos_sq = prm[0], prm[1], prm[2], prm[3]
    inset = prm[4] if prm.shape[0] > 4 else 0.0
    seen = prm.shape[0] > 5 and _unseen_pinch(prm[5], w) > 0.0  # only where a gap can be left out
    k = rel.shape[0]
    pts = np.empty((k, 2))
    nrm = np.empty((k, 2))
    for j in range(k):
        pts[j, 0] = qx + (cs * rel[j, 0] - sn * rel[j, 1])
        pts[j, 1] = qy + (sn * rel[j, 0] + cs * rel[j, 1])
        nrm[j, 0] = cs * nrm_b[j, 0] - sn * nrm_b[j, 1]
        nrm[j, 1] = sn * nrm_b[j, 0] + cs * nrm_b[j, 1]
    changed = False
    if w > 0:
        for j in range(k):
            if not danger[j]:
                continue
            nx, ny = nrm[j, 0], nrm[j, 1]
            px, py = pts[j, 0] - inset * w * nx, pts[j, 1] - inset * w * ny  # the mark: inset cells beyond it
            changed |= _wall_at(g, w, px, py)
            t = behind * w  # the cell behind it: a wall two cells thick
            changed |= _wall_at(g, w, px - t * nx, py - t * ny)
            d = np.sqrt(rel[j, 0] * rel[j, 0] + rel[j, 1] * rel[j, 1])
            ux, uy = -rel[j, 0] / max(d, 1e-9), -rel[j, 1] / max(d, 1e-9)
            if abs(ux * nrm_b[j, 0] + uy * nrm_b[j, 1]) > cos_sq:  # seen square on: a little either side
                for s in (-extend, extend):
                    t = s * w
                    changed |= _wall_at(g, w, px + t * -ny, py + t * nx)
            best, jb = np.inf, -1  # joined to the nearest point seen last step within link cells
            for i in range(lp.shape[0]):
                if lo[i]:
                    ex, ey = pts[j, 0] - lp[i, 0], pts[j, 1] - lp[i, 1]
                    e = np.sqrt(ex * ex + ey * ey)
                    if e < best:
                        best, jb = e, i
            if jb >= 0 and best < link * w:
                for f in (0.25, 0.5, 0.75):  # (inset as this point's mark)
                    changed |= _wall_at(g, w, px + f * (lp[jb, 0] - pts[j, 0]), py + f * (lp[jb, 1] - pts[j, 1]))
        for j in range(s_rel.shape[0]):  # the scan's hits: the wall, and a cell behind it
            if not s_hit[j]:
                continue
            hx = qx + (cs * s_rel[j, 0] - sn * s_rel[j, 1])
            hy = qy + (sn * s_rel[j, 0] + cs * s_rel[j, 1])
            bx = cs * s_dir[j, 0] - sn * s_dir[j, 1]
            by = sn * s_dir[j, 0] + cs * s_dir[j, 1]
            t = inset * w
            changed |= _wall_at(g, w, hx + t * bx, hy + t * by)
            t = (inset + behind) * w
            changed |= _wall_at(g, w, hx + t * bx, hy + t * by)
        if seen:
            _mark_seen(g, w, qx, qy, cs, sn, s_rel, s_dir)
        for j in range(k):  # the border closes the half-plane beyond it
            if border[j] and danger[j]:
                changed |= _border_one(g, w, pts[j, 0], pts[j, 1], nrm[j, 0], nrm[j, 1])
    lp[:, :] = pts
    lo[:] = danger
    return changed


@njit(cache=True, inline="always")
def _unseen_pinch(gap_m, w):
    """The width in cells below which :func:`_pinched` leaves an unseen gap out, on a chart of cells ``w`` wide,
    for gaps narrower than ``gap_m`` metres (``ChartParams.unseen_gap`` passes): 0 (none) where ``gap_m <= w``,
    since a gap between shut cells spans at least one cell, and on a chart not yet sized (``w <= 0``). The plan
    reads it (:func:`_plan_way`), and the beams mark cells seen only where it is not 0 (:func:`_mark_row`)."""
    return gap_m / w if gap_m > w > 0.0 else 0.0


@njit(cache=True, inline="always")
def _mark_seen(g, w, qx, qy, cs, sn, s_rel, s_dir):
    """Every open cell a scan beam passed over, from half a cell out to a cell short of where it ends
    (its hit, or the range), gets the ``SEEN`` bit (beam ``j``: from ``q`` along ``s_dir[j]`` turned by
    the heading ``(cs, sn)``, ``|s_rel[j]|`` long). Each cell the segment enters is visited once, in
    order along it (a grid walk: the next cell is the one whose edge the segment crosses first; through a
    corner, the diagonal one). A segment that starts on an edge starts in the cell on the side it goes. A
    position or length that is not a finite number marks nothing."""
    c = g.shape[0]
    h = c // 2
    for j in range(s_rel.shape[0]):
        bx = cs * s_dir[j, 0] - sn * s_dir[j, 1]
        by = sn * s_dir[j, 0] + cs * s_dir[j, 1]
        end = np.sqrt(s_rel[j, 0] * s_rel[j, 0] + s_rel[j, 1] * s_rel[j, 1]) / w - 1.0  # in cells
        t = 0.5
        x, y = qx / w + h + t * bx, qy / w + h + t * by
        if not (t < end and abs(x) < 1e9 and abs(y) < 1e9):  # nothing to mark (NaN: nothing either)
            continue
        a = int(np.floor(x)) if bx >= 0.0 else int(np.ceil(x)) - 1
        b = int(np.floor(y)) if by >= 0.0 else int(np.ceil(y)) - 1
        sa = 1 if bx > 0.0 else (-1 if bx < 0.0 else 0)
        sb = 1 if by > 0.0 else (-1 if by < 0.0 else 0)
        da = 1.0 / abs(bx) if sa != 0 else np.inf  # t from one edge to the next
        db = 1.0 / abs(by) if sb != 0 else np.inf
        ta = t + ((a + 1 - x) if sa > 0 else (x - a)) * da if sa != 0 else np.inf  # t at the next edge
        tb = t + ((b + 1 - y) if sb > 0 else (y - b)) * db if sb != 0 else np.inf
        while True:
            if 0 <= a < c and 0 <= b < c:
                if g[a, b] == OPEN:
                    g[a, b] = SEEN
            elif (a < 0 and sa <= 0) or (a >= c and sa >= 0) or (b < 0 and sb <= 0) or (b >= c and sb >= 0):
                break  # off the chart and not coming back
            if ta < tb:
                t, ta, a = ta, ta + da, a + sa
            elif tb < ta:
                t, tb, b = tb, tb + db, b + sb
            else:  # through a corner
                t, ta, tb, a, b = ta, ta + da, tb + db, a + sa, b + sb
            if t >= end:
                break


@njit(cache=True)
def _stall_row(g, w, qx, qy, way, anchor, stall, limit, body_m, has_t):
    """Stalls (chart search step 4): a robot not ``max(2 body_m, 1.5 w)`` from ``anchor`` for more
    than ``limit`` steps marks ``STUCK`` the cells (open or wall) at 1/4, 1/2, 3/4 and all of the
    straight way to ``way``. Returns ``(stall count, stuck)``; ``anchor (2,)`` is updated in place."""
    dx, dy = qx - anchor[0], qy - anchor[1]
    if np.sqrt(dx * dx + dy * dy) > max(2 * body_m, 1.5 * w):
        anchor[0], anchor[1] = qx, qy
        stall = 0
    else:
        stall += 1
    if not (stall > limit and has_t and w > 0):
        return stall, False
    c = g.shape[0]
    h = c // 2
    tx, ty = way[0] - qx, way[1] - qy
    for f in (0.25, 0.5, 0.75, 1.0):
        a = min(max(int(np.floor((qx + f * tx) / w)) + h, 0), c - 1)
        b = min(max(int(np.floor((qy + f * ty) / w)) + h, 0), c - 1)
        if not (a == h and b == h) and (g[a, b] & SHUT) != STUCK:  # a wall it drove into too (step 5)
            g[a, b] = STUCK
    return 0, True


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
            if (g[a + sa, b] & SHUT) != 0 or (g[a, b + sb] & SHUT) != 0:
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
        if (g[a, b] & SHUT) != 0:
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
    first cell), and the way's cost (inf: none). ``wall_cost`` must be ``>= 0`` (the search skips a
    neighbour whose cost before that price cannot improve; :class:`ChartParams` takes ``> 0``)."""
    if not wall_cost >= 0.0:
        raise ArgumentError("plan: wall_cost must be a number >= 0")
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
    found, cost, touched, nt = _search(g, sa, sb, ta, tb, wall_cost, ha, hb, turn, dist, prev, closed)
    wa, wb = sa, sb
    if found:
        n = _way_length(prev, c, sa, sb, ta, tb)
        route = np.empty(n, np.int32)
        _store_way(g, prev, sa, sb, ta, tb, n, route, np.empty(n, np.uint8))
        k = _pick_way(g, route, n, 0, sa, sb, ahead)
        wa, wb = route[k] // c, route[k] % c
    _reset(dist, prev, closed, touched, nt, c)
    return found, wa, wb, cost


@njit(cache=True)
def _search(g, sa, sb, ta, tb, wall_cost, ha, hb, turn, dist, prev, closed, cross=0.0, pinch=0.0, side_cost=0.0,
            ux=0.0, uy=0.0, margin=0.0):
    """The A* of :func:`plan` on the work arrays of :func:`_astar`, which it leaves filled (``prev``
    holds the way): ``(found, cost, touched, nt)``, the first ``nt`` of ``touched`` the flat indices
    of the cells it set (for :func:`_reset`). ``cross > 0``: wall cells may be entered too, each
    for ``cross`` more, and so may a diagonal step past one (stuck cells stay shut): the way through
    the fewest walls (chart search step 5). ``pinch`` > 0: an open cell (not the target's) in a gap
    narrower than ``pinch`` cells that no beam has passed over (:func:`_pinched`) counts as a wall."""
    c = g.shape[0]
    INF = 1e30
    cap = 4 * c + 64  # small at first, then doubled as it fills: one search often touches few cells
    heap_k = np.empty(cap)
    heap_v = np.empty(cap, np.int64)
    touched = np.empty(cap, np.int64)
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
                if na < 0 or nb < 0 or na >= c or nb >= c or closed[na, nb]:
                    continue
                v = g[na, nb] & SHUT
                if v == STUCK or (v == WALL and cross <= 0.0):
                    continue
                diag = da != 0 and db != 0
                step = s2 if diag else 1.0
                cw = False
                if diag:  # no corner cut between shut cells (through walls: at a price)
                    c1, c2 = g[a + da, b] & SHUT, g[a, b + db] & SHUT
                    if c1 == STUCK or c2 == STUCK or (cross <= 0.0 and (c1 != 0 or c2 != 0)):
                        continue
                    cw = c1 == WALL or c2 == WALL
                far = side_cost * step if side_cost > 0.0 and _across(ux, uy, na - ta, nb - tb) < -margin else 0.0
                nd = _step_cost(dist[a, b], step, v == WALL, cross, cw, a == sa and b == sb, turn, da, db, ha, hb, far)
                if nd >= dist[na, nb]:
                    continue  # no better whatever is added below (wall_cost > 0; rounding is monotone)
                if pinch and v == OPEN and not (na == ta and nb == tb) and _pinched(g, na, nb, pinch):
                    if cross <= 0.0:  # a gap narrower than a pass, not seen through: a wall
                        continue
                    nd = _step_cost(dist[a, b], step, True, cross, cw, a == sa and b == sb, turn, da, db, ha, hb,
                                    far)
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
    return found, (dist[ta, tb] if found else np.inf), touched, nt


_GOLDEN = (5.0 ** 0.5 - 1.0) / 2.0  # robot_side's step


@njit(cache=True, inline="always")
def robot_side(i):
    """Which side of its way robot ``i`` prefers (:attr:`ChartParams.side_cost`): ``1.0`` the right
    (facing its target), ``-1.0`` the left; the right when the fractional part of ``i`` times
    ``(sqrt 5 - 1) / 2`` is below one half. A low-discrepancy split: the robots of any one target
    (robot ``i`` goes to target ``i`` mod the target count) split about evenly between the two sides,
    whatever the count (within 4 robots of even at 200 robots and up to 4 targets)."""
    return 1.0 if (i * _GOLDEN) % 1.0 < 0.5 else -1.0


@njit(cache=True, inline="always")
def _across(ux, uy, da, db):
    """How far (cells) the centre of the cell ``(da, db)`` cells from the target's lies to the left
    of the unit direction ``(ux, uy)`` (negative: to its right); the target lies at its cell's
    corner (chart cells are ``[k w, (k + 1) w)`` from it)."""
    return ux * (db + 0.5) - uy * (da + 0.5)


@njit(cache=True, inline="always")
def _step_cost(d0, step, into_wall, cross, corner_wall, from_start, turn, da, db, ha, hb, far=0.0):
    """What a step of :func:`_search` costs up to its cell's wall price, the terms added in one fixed
    order (so the same bits wherever it is computed): the step's length, ``cross`` into a wall cell
    and past a wall corner, the turn from the start, and ``far`` (the price of a step on the side
    the robot does not prefer, :attr:`ChartParams.side_cost`)."""
    nd = d0 + step
    if into_wall:
        nd += cross
    if corner_wall:
        nd += cross
    if from_start and turn > 0:  # leaving the start against the way it was going
        nd += turn * 0.5 * (1.0 - (da * ha + db * hb) / step)
    if far > 0.0:
        nd += far
    return nd


@njit(cache=True)
def _reset(dist, prev, closed, touched, nt, c):
    """Leave the work arrays as :func:`_search` found them (only the ``nt`` cells it touched)."""
    for k in range(nt):
        v = touched[k]
        dist[v // c, v % c] = 1e30
        prev[v // c, v % c] = -1
        closed[v // c, v % c] = False


@njit(cache=True, inline="always")
def _pinched(g, a, b, pinch):
    """Cell (a, b) of chart ``g`` lies in a gap between shut cells on opposite sides (north and south,
    east and west, or across a diagonal) narrower than ``pinch`` cells (a diagonal's cells count sqrt 2
    each; :data:`PINCH_ONE_CELL`: a gap one cell wide), and no scan beam has passed over it (``SEEN``).
    Cells on the chart's edge never do."""
    c = g.shape[0]
    if a <= 0 or b <= 0 or a >= c - 1 or b >= c - 1 or (g[a, b] & SEEN) != 0:
        return False
    k = int(pinch)  # the most cells a gap narrower than pinch can span
    for da, db, f in ((1, 0, 1.0), (0, 1, 1.0), (1, 1, _SQRT2), (1, -1, _SQRT2)):
        d1 = _to_shut(g, a, b, da, db, k + 1)
        if d1 <= k and (d1 + _to_shut(g, a, b, -da, -db, k + 1) - 1) * f < pinch:
            return True
    return False


@njit(cache=True, inline="always")
def _to_shut(g, a, b, da, db, lim):
    """Steps from cell (a, b) of chart ``g`` along (da, db) to the first shut cell, or ``lim`` (none
    nearer, or the chart's edge first)."""
    c = g.shape[0]
    for t in range(1, lim):
        x, y = a + t * da, b + t * db
        if x < 0 or y < 0 or x >= c or y >= c:
            return lim
        if (g[x, y] & SHUT) != 0:
            return t
    return lim


@njit(cache=True, inline="always")
def _beside_wall(g, a, b):
    """A non-open cell among the 8 neighbours of cell (a, b) (or the cell itself) of chart ``g``."""
    return _shut_near(g, a, b) > 0


@njit(cache=True, inline="always")
def _shut_near(g, a, b):
    """How many of the 3 x 3 cells round cell (a, b) of chart ``g`` (itself included) are not open."""
    c = g.shape[0]
    n = 0
    for ea in range(-1, 2):
        for eb in range(-1, 2):
            xa, xb = a + ea, b + eb
            if 0 <= xa < c and 0 <= xb < c and (g[xa, xb] & SHUT) != 0:
                n += 1
    return n


@njit(cache=True, inline="always")
def _doubled(arr, n):
    """A copy of ``arr``'s first ``n`` entries in an array twice as long (the rest unset)."""
    out = np.empty(2 * n, arr.dtype)
    out[:n] = arr[:n]
    return out


@njit(cache=True)
def _way_length(prev, c, sa, sb, ta, tb):
    """Cells on the way :func:`_search` found from (sa, sb) to (ta, tb), both ends included."""
    n = 1
    v = ta * c + tb
    while v != sa * c + sb:
        v = prev[v // c, v % c]
        n += 1
    return n


@njit(cache=True)
def _store_way(g, prev, sa, sb, ta, tb, n, route, shut):
    """Write the way :func:`_search` found (``n`` cells, :func:`_way_length`) into ``route``, start
    first, as flat indices, and into ``shut`` the shut cells of each one's 3 x 3 block on chart ``g``;
    a way longer than ``route`` is cut there. Returns the cells written."""
    c = g.shape[0]
    v = ta * c + tb
    for k in range(n - 1, -1, -1):
        if k < len(route):
            route[k] = v
            shut[k] = _shut_near(g, v // c, v % c)
        if k > 0:
            v = prev[v // c, v % c]
    return min(n, len(route))


@njit(cache=True)
def _pick_way(g, route, n, at, sa, sb, ahead):
    """The point to head for from cell (sa, sb), at cell ``at`` of ``route`` (``n`` cells): the
    index of its farthest cell after ``at`` within ``ahead`` cells of (sa, sb) (straight-line
    distance) that is in a straight open line from it on chart ``g`` (at least the next cell;
    ``at`` itself at the way's end)."""
    c = g.shape[0]
    best = at
    for k in range(at + 1, n):
        a, b = route[k] // c, route[k] % c
        if (a - sa) ** 2 + (b - sb) ** 2 > ahead * ahead and k > at + 1:
            break
        if k == at + 1 or _clear(g, sa, sb, a, b):
            best = k
    return best


@njit(cache=True)
def _route_open(g, route, shut, at, n):
    """No cell on or beside ``route[at:n]`` has been shut on chart ``g`` since it was planned (its
    3 x 3 blocks hold no more shut cells than ``shut`` says): the rest of the way costs what it did."""
    c = g.shape[0]
    for k in range(at, n):
        if _shut_near(g, route[k] // c, route[k] % c) > shut[k]:
            return False
    return True


@njit(cache=True)
def _crosses(g, route, n, pinch):
    """A cell of ``route[1:n]`` (after its start) is shut on chart ``g``, or (``pinch`` > 0) lies in a gap
    :func:`_pinched` leaves out, but the target's (the way went through the fewest walls)."""
    c = g.shape[0]
    h = c // 2
    for k in range(1, n):
        a, b = route[k] // c, route[k] % c
        if (g[a, b] & SHUT) != OPEN or (pinch and not (a == h and b == h) and _pinched(g, a, b, pinch)):
            return True
    return False


@njit(cache=True)
def _locate(route, lo, hi, sa, sb, c):
    """The cell of ``route[lo:hi + 1]`` nearest cell (sa, sb) (Chebyshev distance; the last of
    equals): ``(index, distance)``."""
    best, bd = lo, 1 << 30
    for k in range(lo, hi + 1):
        d = max(abs(route[k] // c - sa), abs(route[k] % c - sb))
        if d <= bd:
            best, bd = k, d
    return best, bd


@njit(cache=True)
def _walled_in(g, sa, sb, ta, tb, pinch, budget, seen):
    """True when the A* over open cells of :func:`_search` (``cross`` 0, ``pinch``) from cell
    (sa, sb) would not reach cell (ta, tb): a flood from (ta, tb) over the cells that search may
    enter (its steps taken backwards: the same cells, the same corners) closes within ``budget``
    cells without meeting (sa, sb). False when it meets it or outgrows the budget (then nothing is
    known). ``seen (C, C)`` all False, left so (the A*'s ``closed``)."""
    c = g.shape[0]
    if sa == ta and sb == tb:
        return False
    if (g[ta, tb] & SHUT) != OPEN:
        return True
    queue = np.empty(min(budget, 4 * c + 64), np.int64)
    queue[0] = ta * c + tb
    seen[ta, tb] = True
    head, nq = 0, 1
    met = False
    while head < nq and not met:
        v = queue[head]
        head += 1
        a, b = v // c, v % c
        for da in range(-1, 2):
            for db in range(-1, 2):
                na, nb = a + da, b + db
                if (da == 0 and db == 0) or na < 0 or nb < 0 or na >= c or nb >= c or seen[na, nb]:
                    continue
                if da != 0 and db != 0 and ((g[a + da, b] & SHUT) != 0 or (g[a, b + db] & SHUT) != 0):
                    continue  # no corner cut, either way
                if na == sa and nb == sb:
                    met = True
                    break
                if (g[na, nb] & SHUT) != OPEN or (pinch and _pinched(g, na, nb, pinch)):
                    continue
                if nq == budget:
                    met = True  # outgrew the budget: nothing known
                    break
                if nq == len(queue):
                    queue = _doubled(queue, nq)
                seen[na, nb] = True
                queue[nq] = na * c + nb
                nq += 1
            if met:
                break
    for k in range(nq):
        seen[queue[k] // c, queue[k] % c] = False
    return not met


@njit(cache=True)
def _plan_row(g, sa, sb, ahead, wall_cost, ha, hb, tc, dist, prev, closed, route, shut, pinch=0.0, flood=0,
              side_cost=0.0, ux=0.0, uy=0.0, margin=0.0):
    """Plan on chart ``g`` from cell (sa, sb) to the target's cell (chart search steps 2 and 5):
    A* over open cells (``pinch`` > 0: but gaps :func:`_pinched` leaves out); if there is no way, the
    way through the fewest walls (each wall cell entered costs a chart's width in cells, stuck cells
    stay shut), then that again after forgetting its stuck cells, then on a forgotten chart (on
    which there is always a way). Stores the way in ``route``/``shut`` (:func:`_store_way`).
    Returns ``(found, cells stored, index of the point to head for, forgot the whole chart)``.
    ``flood > 0``: first a flood of at most that many cells from the target (:func:`_walled_in`);
    if it shows no way over open cells, the A* over open cells is not run (the same answer, without
    the search over every cell the robot can reach)."""
    c = g.shape[0]
    h = c // 2
    for attempt in range(4):
        cross = 0.0 if attempt == 0 else float(c)
        if attempt == 0 and flood > 0 and _walled_in(g, sa, sb, h, h, pinch, flood, closed):
            continue
        if attempt == 2:  # forget the stalls
            for a in range(c):
                for b in range(c):
                    if (g[a, b] & SHUT) == STUCK:
                        g[a, b] = OPEN
        elif attempt == 3:  # forget the chart: it starts again from what it sees
            g[:, :] = OPEN
        found, _, touched, nt = _search(g, sa, sb, h, h, wall_cost, ha, hb, tc, dist, prev, closed, cross, pinch,
                                        side_cost, ux, uy, margin)
        n = 0
        if found:
            n = _store_way(g, prev, sa, sb, h, h, _way_length(prev, c, sa, sb, h, h), route, shut)
        _reset(dist, prev, closed, touched, nt, c)
        if found:
            return True, n, _pick_way(g, route, n, 0, sa, sb, ahead), attempt == 3
    return False, 0, 0, True


@njit(cache=True, inline="always")
def _start(qx, qy, w, c, ahead_m):
    """The chart cell ``(sa, sb)`` of a robot at ``(qx, qy)`` (cells ``w`` wide, ``c`` a side, clipped to
    the chart) and how many cells ahead it looks for the point it heads for."""
    h = c // 2
    return (min(max(int(np.floor(qx / w)) + h, 0), c - 1), min(max(int(np.floor(qy / w)) + h, 0), c - 1),
            max(ahead_m / w, 3.0))


@njit(cache=True)
def _next_way(i, g, w, qx, qy, changed, m_route, m_shut, m_len, m_at, m_way_at, way, dirty, prm):
    """Robot ``i``'s way after this step's marks (chart search step 2, its chart ``g`` cells ``w``
    wide; ``changed``: a cell of it was shut this step). It plans afresh (A*) when it has no way,
    stalled, was more than a cell off its way, or a cell on or beside the rest of its way was shut
    (its way cut at ``ROUTE_PER_CELL C`` cells: any cell, or near the cut); else, within two cells
    of the point it heads for (or at it), or with its target within ``ahead`` cells (so that a
    target in a straight open line is headed for itself, and its stand-off rules), it picks the next
    one along its way. True if it must plan: the plan is :func:`_plan_way`'s (the pass over the
    robots that plan, :func:`_chart_rows`)."""
    ahead_m = prm[0]
    c = g.shape[0]
    h = c // 2
    sa, sb, ahead = _start(qx, qy, w, c, ahead_m)
    route, shut, n, at = m_route[i], m_shut[i], m_len[i], m_at[i]
    need = dirty[i] or n == 0
    if not need:
        at, off = _locate(route, at, min(n - 1, m_way_at[i] + 2), sa, sb, c)
        m_at[i] = at
        cut = route[n - 1] != h * c + h
        need = off > 1 or (changed and (cut or not _route_open(g, route, shut, at, n))) or (
            cut and n - at <= ahead + 2)
    if need:
        return True
    dx, dy = way[i, 0] - qx, way[i, 1] - qy
    if dx * dx + dy * dy <= (2 * w) ** 2 or at >= m_way_at[i] or qx * qx + qy * qy <= (ahead * w) ** 2:
        m_way_at[i] = _pick_way(g, route, n, at, sa, sb, ahead)
        _set_way(i, w, c, route, m_len, m_way_at, way)
    return False


@njit(cache=True)
def _plan_way(i, g, w, qx, qy, m_route, m_shut, m_len, m_at, m_way_at, way, dirty, have_way, forgot, work, prm,
              walled, home):
    """Robot ``i``'s plan when :func:`_next_way` says it must (A*, :func:`_plan_row`, on the work arrays
    ``work``), and the point it heads for on the new way. A robot whose last way crossed a shut cell
    (``walled``) floods from the target before it plans (:func:`_plan_row`'s ``flood``: the same way,
    found sooner where the target is walled in on its chart)."""
    ahead_m, wall_cost, turn_m, pinch_m = prm[0], prm[1], prm[2], prm[4]
    c = g.shape[0]
    sa, sb, ahead = _start(qx, qy, w, c, ahead_m)
    route, shut = m_route[i], m_shut[i]
    dx, dy = way[i, 0] - qx, way[i, 1] - qy
    nrm = np.sqrt(dx * dx + dy * dy)
    ha, hb = (dx / nrm, dy / nrm) if nrm > 1e-9 and have_way[i] else (0.0, 0.0)
    tc = turn_m / w if nrm > 1e-9 and have_way[i] else 0.0
    # gaps narrower than unseen_gap passes, or (a fine chart) one cell wide, are left out (_pinched)
    pinch = _unseen_pinch(prm[8], w) if prm[8] > 0.0 else (PINCH_ONE_CELL if 0.0 < w <= pinch_m else 0.0)
    flood = c * c // 4 if walled[i] else 0
    side_cost = prm[5]
    hx, hy = home[i, 0], home[i, 1]
    hn = np.sqrt(hx * hx + hy * hy)
    sgn = robot_side(i if i >= 0 else i + home.shape[0])
    ux, uy = (sgn * hx / hn, sgn * hy / hn) if hn > 1e-9 else (0.0, 0.0)
    goal = (c // 2) * c + c // 2
    # cells left on the way it had (-1: none, or one cut at ROUTE_PER_CELL C cells: its length is not known)
    left = m_len[i] - m_at[i] if have_way[i] and m_len[i] > 0 and route[m_len[i] - 1] == goal else -1
    ok, n, k, fg = _plan_row(g, sa, sb, ahead, wall_cost, ha, hb, tc, work[0], work[1], work[2], route, shut,
                             pinch, flood, side_cost if hn > 1e-9 else 0.0, ux, uy, prm[6])
    if prm[7] > 0.0 and hn > 1e-9 and left >= 0 and ok and n > 0 and route[n - 1] == goal and (
            n - left) * w > prm[7]:
        home[i, 0], home[i, 1] = 0.0, 0.0  # its side led into a dead end: no side from now on
    walled[i] = ok and _crosses(g, route, n, pinch)
    forgot[i] += fg
    dirty[i] = False
    have_way[i] = ok
    m_len[i], m_at[i], m_way_at[i] = n, 0, k
    _set_way(i, w, c, route, m_len, m_way_at, way)


@njit(cache=True, inline="always")
def _set_way(i, w, c, route, m_len, m_way_at, way):
    """Robot ``i`` heads for route cell ``m_way_at[i]`` (its centre; the target itself at its cell)."""
    if m_len[i] > 0:
        h = c // 2
        v = route[m_way_at[i]]
        if v == h * c + h:
            way[i, 0] = 0.0
            way[i, 1] = 0.0
        else:
            way[i, 0] = (v // c - h + 0.5) * w
            way[i, 1] = (v % c - h + 0.5) * w


@njit(cache=True, inline="always")
def _mark_prm(prm):
    """The constants :func:`_mark_row` reads, from :func:`_prm`'s: behind, extend, link, cos(5 deg), inset and
    the widest gap left out unless seen, in metres (``ChartParams.unseen_gap`` passes; 0: off)."""
    return np.array([prm[4], prm[5], prm[6], prm[7], prm[13], prm[18]])


@njit(cache=True, parallel=True)
def _chart_rows(mem, work, rows, q, cs, sn, has_t, dist_t, crowded, b_rel, b_normal, b_danger, b_border,
                s_rel, s_dir, s_hit, prm):
    """:func:`chart_update`'s compiled pass over robot rows ``rows (m,)`` (the memory ``mem``: the
    arrays of :data:`_ROW_FIELDS`, in order; ``work``: ``T`` sets of A* work arrays, ``(T, C, C)`` each;
    ``prm``: :func:`_prm`), in two passes of ``T`` runs side by side: the marks, stalls and the
    decision to plan of every robot (run ``t``: the ``t``-th of ``T`` blocks of rows), then the plans
    of those that must (run ``t``: the ``t``-th block of them, on work set ``t``). A robot's step reads
    and writes its own memory only (``rows`` holds no robot twice), in the order the one-robot pass
    took, and a work set is left as found after each plan, so the same bits whatever ``T``
    (:func:`chart_update` takes rows that name a robot twice one after another,
    :func:`_chart_rows_serial`)."""
    grid, cell, way, dirty, anchor, stall, forgot, last_pts, last_ok, have_way = mem[:10]
    route, shut, route_len, route_at, way_at, plans, walled, home = mem[10:]
    mark_prm = _mark_prm(prm)
    T = work[0].shape[0]
    m = len(rows)
    needs = np.zeros(m, np.bool_)
    for t in prange(T):
        for r in range(t * m // T, (t + 1) * m // T):
            needs[r] = _chart_row(r, rows[r], mem, q, cs, sn, has_t, dist_t, crowded, b_rel, b_normal, b_danger,
                                  b_border, s_rel, s_dir, s_hit, prm, mark_prm)
    todo = np.flatnonzero(needs)
    P = len(todo)
    for t in prange(T):
        wk = (work[0][t], work[1][t], work[2][t])
        for k in range(t * P // T, (t + 1) * P // T):
            r = todo[k]
            i = rows[r]
            _plan_way(i, grid[i], cell[i], q[r, 0], q[r, 1], route, shut, route_len, route_at, way_at, way, dirty,
                      have_way, forgot, wk, prm[10:19], walled, home)
            plans[i] += 1


@njit(cache=True)
def _chart_rows_serial(mem, work, rows, q, cs, sn, has_t, dist_t, crowded, b_rel, b_normal, b_danger, b_border,
                       s_rel, s_dir, s_hit, prm):
    """:func:`_chart_rows` one row after another, each robot's plan made before the next row is taken: rows
    that name a robot twice (work set 0)."""
    grid, cell, way, dirty, anchor, stall, forgot, last_pts, last_ok, have_way = mem[:10]
    route, shut, route_len, route_at, way_at, plans, walled, home = mem[10:]
    mark_prm = _mark_prm(prm)
    wk = (work[0][0], work[1][0], work[2][0])
    for r in range(len(rows)):
        i = rows[r]
        if _chart_row(r, i, mem, q, cs, sn, has_t, dist_t, crowded, b_rel, b_normal, b_danger, b_border, s_rel,
                      s_dir, s_hit, prm, mark_prm):
            _plan_way(i, grid[i], cell[i], q[r, 0], q[r, 1], route, shut, route_len, route_at, way_at, way, dirty,
                      have_way, forgot, wk, prm[10:19], walled, home)
            plans[i] += 1


@njit(cache=True)
def _chart_row(r, i, mem, q, cs, sn, has_t, dist_t, crowded, b_rel, b_normal, b_danger, b_border, s_rel, s_dir,
               s_hit, prm, mark_prm):
    """One robot's step of :func:`_chart_rows` up to its plan: row ``r`` of the step's inputs, robot ``i``
    of the memory. True if it must plan (:func:`_next_way`)."""
    grid, cell, way, dirty, anchor, stall, forgot, last_pts, last_ok, have_way = mem[:10]
    route, shut, route_len, route_at, way_at, plans, walled, home = mem[10:]
    c = grid.shape[1]
    qx, qy = q[r, 0], q[r, 1]
    if cell[i] <= 0 and has_t[r]:  # its first step: a chart centred on its target
        cell[i] = max(prm[0], 2 * (prm[1] * dist_t[r] + prm[2] * prm[3]) / c)
        anchor[i, 0], anchor[i, 1] = qx, qy
        home[i, 0], home[i, 1] = qx, qy
        dirty[i] = True
    w = cell[i]
    g = grid[i]
    changed = _mark_row(g, w, qx, qy, cs[r], sn[r], b_rel[r], b_normal[r], b_danger[r], b_border[r],
                        last_pts[i], last_ok[i], s_rel[r], s_dir, s_hit[r], mark_prm)
    limit = 2 * prm[8] if crowded[r] else prm[8]
    stall[i], stuck = _stall_row(g, w, qx, qy, way[i], anchor[i], stall[i], limit, prm[9], has_t[r])
    if stuck:
        dirty[i] = True
    if w <= 0 or not has_t[r]:  # no chart, or no target: no way to plan
        return False
    return _next_way(i, g, w, qx, qy, changed, route, shut, route_len, route_at, way_at, way, dirty, prm[10:15])


def _prm(params: ChartParams, range_m: float, step_m: float, body_m: float, pass_m: float = 0.0) -> np.ndarray:
    """The constants :func:`_chart_rows` reads, in its order (index 14: the widest cell at which gaps
    one cell wide are left out of the plan, ``ChartParams.pinch_cells``, 0: none; then ``side_cost``,
    ``side_margin``, ``side_leave_m`` and the widest unseen gap left out, ``ChartParams.unseen_gap`` passes
    in metres, 0: off)."""
    return np.array([max(params.min_cell_m, step_m), params.reach, params.range_reach, range_m,
                     params.behind, params.extend, params.link, np.cos(np.radians(5.0)),
                     params.stall_steps, body_m, params.ahead_m, params.wall_cost, params.turn_m, params.inset,
                     pass_m / params.pinch_cells, params.side_cost, params.side_margin, params.side_leave_m,
                     params.unseen_gap * pass_m],
                    np.float64)


def _rot(psi, v):
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1)


def _f64(a, shape=None):
    return np.ascontiguousarray(a if shape is None else np.reshape(a, shape), dtype=np.float64)


def chart_update(mem: ChartMemory, rows, d: DecodedObs, q, psi, params: ChartParams, range_m: float,
                 step_m: float, body_m: float, crowded, standoff_m: float = 0.0, pass_m: float = 0.0) -> np.ndarray:
    """Advance the charts of robots ``rows`` by one observation and return the body-frame vector
    to the point each heads for ``(m, 2)`` (the target's own vector ``rel_t`` when its way is
    open straight to it, or when that point lies within ``standoff_m`` of the target: the ring
    around a threat is the target field's to hold, never a point inside it). ``pass_m``: the
    narrowest gap the robot drives through (``SafetyShield.pass_m``; 0: every open cell may be
    planned through, ``ChartParams.pinch_cells``; it turns ``ChartParams.unseen_gap`` off too). One compiled
    pass over the rows
    (:func:`_chart_rows`)."""
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    m, k = len(rows), d.b_rel.shape[1]
    if mem.last_ok.shape[1] != k:
        n_all = len(mem.cell)
        mem.last_pts, mem.last_ok = np.zeros((n_all, k, 2)), np.zeros((n_all, k), bool)
    if d.s_rel is not None and d.s_rel.shape[1]:  # the scan's hits (K_s, 2) beams
        s_rel, s_hit, s_dir = _f64(d.s_rel), np.ascontiguousarray(d.s_hit, bool), _f64(d.s_dir, (-1, 2))
    else:
        s_rel, s_hit, s_dir = np.zeros((m, 0, 2)), np.zeros((m, 0), bool), np.zeros((0, 2))
    psi = np.asarray(psi, dtype=np.float64)
    # rows in increasing order name each robot once; others may name one twice (or from the end): in order
    serial = m > 1 and not (rows[1:] > rows[:-1]).all() and (len(np.unique(rows)) != m or rows.min() < 0)
    (_chart_rows_serial if serial else _chart_rows)(
        tuple(getattr(mem, f) for f in _ROW_FIELDS), mem.work_arrays(), rows, _f64(q), np.cos(psi), np.sin(psi),
        np.ascontiguousarray(d.has_t, bool), _f64(d.dist), np.ascontiguousarray(crowded, bool), _f64(d.b_rel),
        _f64(d.b_normal), np.ascontiguousarray(d.b_danger, bool), np.ascontiguousarray(d.b_border, bool), s_rel,
        s_dir, s_hit, _prm(params, range_m, step_m, body_m, pass_m))
    way = mem.way[rows]
    at_t = ((way[:, 0] == 0.0) & (way[:, 1] == 0.0)) | (np.sum(way * way, axis=-1) < standoff_m ** 2)
    out = _rot(-psi, way - q)
    return np.where(at_t[:, None] | ~(mem.cell[rows] > 0)[:, None], d.rel_t, out)
