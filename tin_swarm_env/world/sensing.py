"""Sensing, batched over all robots through compiled uniform grids (no all-pairs work).

A robot *sees* another robot, a threat/target or an asset when all of these hold:

* it is active (``Reason.NONE``; robots out of battery sense nothing but are still seen; fallen robots and
  robots the task took off the terrain (``Reason.ARRIVED``) are gone and are not seen);
* the horizontal distance is at most ``range_m``;
* the bearing relative to its heading lies within ``±fov_deg / 2``;
* with ``check_los``, the sight line from its sensor (ground + ``height_m``) to the other's
  sensor (robots) or to ``entity_height_m`` above the ground (entities) clears the TIN
  (exact walk, :meth:`~tin_swarm_env.terrain.Tin.line_of_sight`).

* it is among the observer's ``max_candidates`` nearest robots (or entities) within range
  (ties: the lower index): only those are checked for field of view and line of sight (a
  bound, documented in :class:`~tin_swarm_env.world.params.SensorParams`, that keeps memory and
  work at robots x ``max_candidates`` however densely robots are packed; the observations' K
  nearest visible slots need far fewer).

Candidates come from a uniform grid of cell side ``range_m / 2`` (a 5 x 5 block per query) rebuilt
every call in O(n) (:mod:`.grid`); the per-observer work (candidates, field of view, line of sight, breaks) runs
in numba ``prange`` loops over observers (:func:`~.batch_kernels.sense_copies`, the vector env's
passes, here on one copy; the per-observer code is :mod:`.sense_kernels`), bit-identical for any thread
count (``NUMBA_NUM_THREADS`` / ``numba.set_num_threads``). Terrain breaks are sensed all round
(the robot's scan of the terrain it stands on): every break segment within ``range_m`` of the
robot, found through a static grid whose cells list the segments that can lie within range.
Contacts are ordered by observer, then distance (ties: lower index).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from numba import njit

from . import sense_kernels as SK
from .batch_kernels import sense_copies
from .pack import one_copy, pack_one

__all__ = ["Contacts", "BreakContacts", "SensorReadings", "BreakIndex", "sense", "nearest_k"]


@njit(cache=True)
def _nearest_k(observer, key, n, k):
    out = np.full((n, k), -1, dtype=np.int64)
    best = np.full((n, k), np.inf)
    for p in range(observer.shape[0]):
        i = observer[p]
        v = key[p]
        if v >= best[i, k - 1]:
            continue  # not better than the k-th (ties keep the earlier row)
        j = k - 1
        while j > 0 and best[i, j - 1] > v:
            best[i, j] = best[i, j - 1]
            out[i, j] = out[i, j - 1]
            j -= 1
        best[i, j] = v
        out[i, j] = p
    return out


def nearest_k(observer, key, n, k):
    """Row positions of the ``k`` smallest ``key`` per observer: ``(n, k)`` int64, -1 where
    fewer exist, nearest first. Ties keep the input order (stable). One pass with a sorted
    k-buffer per observer (numba): O(pairs * k)."""
    if len(observer) == 0 or k == 0:
        return np.full((n, k), -1, dtype=np.int64)
    return _nearest_k(np.ascontiguousarray(observer, dtype=np.int64),
                      np.ascontiguousarray(key, dtype=np.float64), int(n), int(k))


def nearest_k_reference(observer, key, n, k):
    """:func:`nearest_k` by a stable sort (the plain reference)."""
    out = np.full((n, k), -1, dtype=np.int64)
    if len(observer) == 0 or k == 0:
        return out
    order = np.lexsort((key, observer))
    obs = observer[order]
    starts = np.searchsorted(obs, np.arange(n))
    rank = np.arange(len(obs)) - starts[obs]
    keep = rank < k
    out[obs[keep], rank[keep]] = order[keep]
    return out


@njit(cache=True)
def _first_k(start, n, k):
    """Rows ``start[i]:start[i+1]`` (already nearest first) -> ``(n, k)`` of the first k row
    positions, -1 where fewer."""
    out = np.full((n, k), -1, dtype=np.int64)
    for i in range(n):
        m = min(start[i + 1] - start[i], k)
        for s in range(m):
            out[i, s] = start[i] + s
    return out


@njit(cache=True)
def _gather_first_k(start, target, dist, extra, n, k):
    """The CSR fast path of ``nearest``: ``(target (n, k) -1, dist (n, k) inf, extra (n, k, ...)
    0)`` from rows ``start[i]:start[i+1]`` already nearest first; ``extra`` is ``(P,)`` (bearings)
    or ``(P, 2)`` (closest points)."""
    idx = np.full((n, k), -1, dtype=np.int64)
    d = np.full((n, k), np.inf)
    ex = np.zeros((n, k) + extra.shape[1:])
    for i in range(n):
        m = min(start[i + 1] - start[i], k)
        for s in range(m):
            p = start[i] + s
            idx[i, s] = target[p]
            d[i, s] = dist[p]
            ex[i, s] = extra[p]
    return idx, d, ex


def _rows(obj, n, k):
    """Row positions of each observer's k nearest contacts (CSR fast path when known)."""
    if obj.start is not None and len(obj.start) == n + 1:
        return _first_k(obj.start, n, k) if k else np.full((n, 0), -1, dtype=np.int64)
    return nearest_k(obj.observer, obj.distance_m, n, k)


class _OnFirstRead:
    """A dataclass field that may be given as a function of no arguments instead of a value:
    the function runs on the field's first read and its result is kept (:func:`sense` hands
    the robot contacts' bearings over this way; the env's observations never read them). No
    default: the field stays required."""

    def __set_name__(self, owner, name):
        self.slot = "_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            raise AttributeError(self.slot)  # (what dataclasses reads as "no default")
        v = obj.__dict__[self.slot]
        if callable(v):
            v = obj.__dict__[self.slot] = v()
        return v

    def __set__(self, obj, value):
        obj.__dict__[self.slot] = value


@dataclass
class Contacts:
    """Ordered (observer, target) pairs: observer i sees target j.

    observer (P,) int64, target (P,) int64, distance_m (P,), bearing_rad (P,) relative to the
    observer's heading, in [-pi, pi) (given as an array, or as a function returning it, run
    when first read). ``start (n + 1,)`` (optional): when the pairs are grouped by observer,
    nearest first, observer i's are ``start[i]:start[i + 1]``.
    """

    observer: np.ndarray
    target: np.ndarray
    distance_m: np.ndarray
    bearing_rad: np.ndarray = _OnFirstRead()
    start: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.observer)

    def __getstate__(self):
        self.bearing_rad  # noqa: B018 (computed now: a pickle holds arrays, not the function)
        return self.__dict__

    def nearest(self, n: int, k: int):
        """``(target_idx (n, k) -1 if none, distance_m (n, k) inf, bearing_rad (n, k) 0)``,
        nearest first."""
        if self.start is not None and len(self.start) == n + 1:
            return _gather_first_k(self.start, self.target, self.distance_m, self.bearing_rad, n, k)
        rows = _rows(self, n, k)
        ok = rows >= 0
        r = np.where(ok, rows, 0)
        idx = np.where(ok, self.target[r] if len(self) else -1, -1)
        dist = np.where(ok, self.distance_m[r] if len(self) else np.inf, np.inf)
        bear = np.where(ok, self.bearing_rad[r] if len(self) else 0.0, 0.0)
        return idx, dist, bear

    def as_set(self) -> set:
        return set(zip(self.observer.tolist(), self.target.tolist()))


@dataclass
class BreakContacts:
    """(robot, break) pairs within range: distance and the closest point of the segment;
    ``start`` as in :class:`Contacts`."""

    observer: np.ndarray
    break_idx: np.ndarray
    distance_m: np.ndarray
    closest: np.ndarray  # (P, 2) m
    start: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.observer)

    def nearest(self, n: int, k: int):
        """``(break_idx (n, k), distance_m (n, k), closest (n, k, 2))``, nearest first; -1/inf/0
        where fewer breaks are in range."""
        if self.start is not None and len(self.start) == n + 1:
            return _gather_first_k(self.start, self.break_idx, self.distance_m, self.closest, n, k)
        rows = _rows(self, n, k)
        ok = rows >= 0
        r = np.where(ok, rows, 0)
        if len(self) == 0:
            return np.full((n, k), -1), np.full((n, k), np.inf), np.zeros((n, k, 2))
        return (np.where(ok, self.break_idx[r], -1), np.where(ok, self.distance_m[r], np.inf),
                np.where(ok[..., None], self.closest[r], 0.0))

    def as_set(self) -> set:
        return set(zip(self.observer.tolist(), self.break_idx.tolist()))


@dataclass
class SensorReadings:
    robots: Contacts
    targets: Contacts
    assets: Contacts
    breaks: BreakContacts
    tilt_rad: np.ndarray  # (n,) thesis 3.1 sensor tilt
    slope_deg: np.ndarray  # (n,) slope of the triangle under each robot
    aspect_deg: np.ndarray  # (n,) its aspect (-1 flat)


class BreakIndex:
    """A static grid over the break segments: each cell (side ``>= piece_m / 2``, ``piece_m`` the
    sensor range) lists every segment that can lie within ``piece_m`` of a point in it
    (:func:`~.sense_kernels.break_grid`), over the bounds given (the TIN's)."""

    def __init__(self, breaks, piece_m: float, bounds=None):
        self.breaks = breaks
        seg = breaks.segments
        self.ax, self.ay = (np.ascontiguousarray(seg[:, 0, c]) for c in (0, 1))
        self.bx, self.by = (np.ascontiguousarray(seg[:, 1, c]) for c in (0, 1))
        self.range_m = float(piece_m)
        if bounds is None:
            xy = seg[..., :2].reshape(-1, 2)
            bounds = (*xy.min(axis=0), *xy.max(axis=0)) if len(xy) else (0.0, 0.0, 1.0, 1.0)
        self.grid = SK.break_grid(self.ax, self.ay, self.bx, self.by, self.range_m, *map(float, bounds))


def _empty_contacts(n) -> Contacts:
    z = np.zeros(0, dtype=np.int64)
    return Contacts(z, z, np.zeros(0), np.zeros(0), np.zeros(n + 1, dtype=np.int64))


_SCRATCH = threading.local()  # per thread: slot buffers reused across calls (never returned to callers)


def _slots(n, k, which):
    """``(idx, dist, vis, cnt)``: per observer K candidate slots (only ``[:cnt]`` is read;
    ``cnt`` zeroed here, the kernels write every slot they later read). Reused across calls
    of the same thread and size: no allocation per step."""
    cache = getattr(_SCRATCH, "slots", None)
    if cache is None:
        cache = _SCRATCH.slots = {}
    key = (n, k, which)
    buf = cache.get(key)
    if buf is None:
        if len(cache) > 12:
            cache.clear()
        buf = cache[key] = (np.empty((n, k), dtype=np.int64), np.empty((n, k)), np.empty((n, k), dtype=np.int8),
                            np.empty(n, dtype=np.int64))
    buf[3][:] = 0
    return buf


_NO_ENTITIES = (np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(2, dtype=np.int64), np.zeros(0, dtype=np.bool_))


def _entities(tin, ent):
    """``(ex, ey, ez, off, use)`` of the entities as :func:`~.batch_kernels.sense_copies` reads them
    (one copy; ez: their ground heights)."""
    m = len(ent)
    if m == 0:
        return _NO_ENTITIES
    ex = np.ascontiguousarray(ent.positions[:, 0])
    ey = np.ascontiguousarray(ent.positions[:, 1])
    return ex, ey, tin.height_in(ent.positions, ent.tri_idx), np.array([0, m], dtype=np.int64), np.ones(m, np.bool_)


def sense(world, state) -> SensorReadings:
    """What every robot of ``world`` senses in ``state`` (see the module docstring): the vector env's
    two parallel passes (:func:`~.batch_kernels.sense_copies`) on the world's pack, as one copy."""
    tin = world.tin
    bi = world.break_index
    r = float(world.params.sensor.range_m)
    if r > bi.range_m:
        raise ValueError(f"BreakIndex built for range {bi.range_m} m, asked for {r} m")
    n = state.n_robots
    k = int(world.params.sensor.max_candidates)
    x = np.ascontiguousarray(state.positions[:, 0])
    y = np.ascontiguousarray(state.positions[:, 1])
    head = np.ascontiguousarray(state.headings, dtype=np.float64)
    tri = np.ascontiguousarray(state.tri_idx, dtype=np.int64)
    TE, AE = _entities(tin, state.targets), _entities(tin, state.assets)
    TG = (TE, _slots(n, k, 1))
    AS = (AE, _slots(n, k, 2))
    wor, cop, off = one_copy(n)
    brk, (ro, rt, rd, rs) = sense_copies(pack_one(world), wor, cop, off, x, y, head, tri, state.heights,
                                         state.status, world.params, _slots(n, k, 0), TG, AS)
    h0 = head.copy()  # (the state's own array may be changed before the bearings are read)
    robots = Contacts(ro, rt, rd, lambda: SK.bearings(ro, rt, x, y, h0, x, y), rs)
    targets = Contacts(*SK.compact(*TG[1], x, y, head, TE[0], TE[1])) if len(state.targets) else _empty_contacts(n)
    assets = Contacts(*SK.compact(*AS[1], x, y, head, AE[0], AE[1])) if len(state.assets) else _empty_contacts(n)
    return SensorReadings(robots=robots, targets=targets, assets=assets, breaks=BreakContacts(*brk),
                          tilt_rad=tin.sensor_tilt_in(tri, head), slope_deg=tin.slope_deg[tri],
                          aspect_deg=tin.aspect_deg[tri])
