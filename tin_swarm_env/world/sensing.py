"""Sensing, batched over all robots through spatial indexes (no all-pairs work).

A robot *sees* another robot, a threat/target or an asset when all of these hold:

* it is active (``Reason.NONE``; robots out of battery sense nothing but are still seen; fallen robots and
  robots the task took off the terrain (``Reason.ARRIVED``) are gone and are not seen);
* the horizontal distance is at most ``range_m``;
* the bearing relative to its heading lies within ``±fov_deg / 2``;
* with ``check_los``, the sight line from its sensor (ground + ``height_m``) to the other's
  sensor (robots) or to ``entity_height_m`` above the ground (entities) clears the TIN
  (exact walk, :meth:`~tin_swarm_env.terrain.Tin.line_of_sight`).

* it is among the observer's ``max_candidates`` nearest robots (or entities) within range: only
  those are checked for field of view and line of sight (a bound, documented in
  :class:`~tin_swarm_env.world.params.SensorParams`, that keeps memory and work at robots x
  ``max_candidates`` however densely robots are packed; the observations' K nearest visible
  slots need far fewer).

Candidates come from KD-trees (``scipy.spatial.cKDTree.query`` with ``k = max_candidates`` and
``distance_upper_bound = range_m``), so the work grows with robots x ``max_candidates``, not
robots².
Terrain breaks are sensed all round (the robot's scan of the terrain it stands on): every
break segment within ``range_m`` of the robot, found through a KD-tree over pieces of the
segments no longer than the range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from ..terrain.breaks import closest_on_segments

__all__ = ["Contacts", "BreakContacts", "SensorReadings", "BreakIndex", "sense", "nearest_k", "nearest_candidates"]


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


@dataclass
class Contacts:
    """Ordered (observer, target) pairs: observer i sees target j.

    observer (P,) int64, target (P,) int64, distance_m (P,), bearing_rad (P,) relative to the
    observer's heading, in [-pi, pi).
    """

    observer: np.ndarray
    target: np.ndarray
    distance_m: np.ndarray
    bearing_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.observer)

    def nearest(self, n: int, k: int):
        """``(target_idx (n, k) -1 if none, distance_m (n, k) inf, bearing_rad (n, k) 0)``,
        nearest first."""
        rows = nearest_k(self.observer, self.distance_m, n, k)
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
    """(robot, break) pairs within range: distance and the closest point of the segment."""

    observer: np.ndarray
    break_idx: np.ndarray
    distance_m: np.ndarray
    closest: np.ndarray  # (P, 2) m

    def __len__(self) -> int:
        return len(self.observer)

    def nearest(self, n: int, k: int):
        """``(break_idx (n, k), distance_m (n, k), closest (n, k, 2))``, nearest first; -1/inf/0
        where fewer breaks are in range."""
        rows = nearest_k(self.observer, self.distance_m, n, k)
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
    """KD-tree over pieces (no longer than ``piece_m``) of the break segments."""

    def __init__(self, breaks, piece_m: float):
        self.breaks = breaks
        a = breaks.segments[:, 0, :2]
        b = breaks.segments[:, 1, :2]
        L = np.hypot(*(b - a).T) if len(a) else np.zeros(0)
        n_pieces = np.maximum(np.ceil(L / piece_m), 1).astype(np.int64)
        seg = np.repeat(np.arange(len(a)), n_pieces)
        first = np.repeat(np.cumsum(n_pieces) - n_pieces, n_pieces)
        j = np.arange(len(seg)) - first
        t = (j + 0.5) / np.repeat(n_pieces, n_pieces)
        mid = a[seg] + t[:, None] * (b - a)[seg]
        self.piece_seg = seg
        self.half_len = float((L / n_pieces).max() / 2) if len(a) else 0.0
        self.tree = cKDTree(mid) if len(mid) else None
        self.a = a
        self.ab = b - a

    def query(self, xy, observers, range_m) -> BreakContacts:
        if self.tree is None or len(observers) == 0:
            z = np.zeros(0, dtype=np.int64)
            return BreakContacts(z, z, np.zeros(0), np.zeros((0, 2)))
        rt = cKDTree(xy[observers])
        m = rt.sparse_distance_matrix(self.tree, range_m + self.half_len + 1e-9, output_type="ndarray")
        obs = observers[m["i"]]
        seg = self.piece_seg[m["j"]]
        key = np.unique(obs * np.int64(len(self.a)) + seg)
        obs, seg = key // len(self.a), key % len(self.a)
        closest, d = closest_on_segments(xy[obs], self.a[seg], self.a[seg] + self.ab[seg])
        ok = d <= range_m
        return BreakContacts(obs[ok], seg[ok], d[ok], closest[ok])


def nearest_candidates(tree_xy, query_xy, range_m, k, *, query_idx, tree_idx=None, self_idx=None):
    """For each query point, its at most ``k`` nearest tree points within ``range_m`` (nearest
    first): ``(observer (P,), target (P,))`` int64, observers from ``query_idx (m,)``, targets
    from ``tree_idx (N,)`` (default: tree row numbers). With ``self_idx (m,)`` a target equal to
    the observer's own index is left out (and one more neighbour asked for). Memory O(m * k)."""
    n_tree = len(tree_xy)
    extra = 1 if self_idx is not None else 0
    kq = min(k + extra, n_tree)
    if kq == 0 or len(query_xy) == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z
    _, j = cKDTree(tree_xy).query(query_xy, k=kq, distance_upper_bound=range_m * (1 + 1e-9))
    j = np.asarray(j, dtype=np.int64).reshape(len(query_xy), kq)  # n_tree where fewer in range
    ok = j < n_tree
    tgt = np.where(ok, j, 0)
    if tree_idx is not None:
        tgt = tree_idx[tgt]
    if self_idx is not None:
        ok &= tgt != self_idx[:, None]
        ok &= np.cumsum(ok, axis=1) <= k  # self was not among them: keep k
    obs = np.broadcast_to(np.asarray(query_idx, dtype=np.int64)[:, None], ok.shape)
    return obs[ok], tgt[ok]


def _bearing(dx, dy, heading):
    return (np.arctan2(dy, dx) - heading + np.pi) % (2 * np.pi) - np.pi


def _in_fov(bearing, fov_deg):
    return np.abs(bearing) <= np.radians(fov_deg) / 2 + 1e-12


def _contacts(obs, tgt, dx, dy, headings, fov_deg):
    d = np.hypot(dx, dy)
    b = _bearing(dx, dy, headings[obs])
    ok = _in_fov(b, fov_deg)
    return Contacts(obs[ok], tgt[ok], d[ok], b[ok])


def sense(tin, break_index: BreakIndex, state, params) -> SensorReadings:
    """What every robot senses in ``state`` (see the module docstring)."""
    sp = params.sensor
    r = sp.range_m
    pos, head = state.positions, state.headings
    present = np.flatnonzero(state.present)
    act_idx = np.flatnonzero(state.active)
    sensor_z = state.heights + sp.height_m
    robots = _sense_robots(tin, state, present, act_idx, sensor_z, sp)
    targets = _sense_entities(tin, state.targets, pos, head, sensor_z, state.tri_idx, act_idx, params)
    assets = _sense_entities(tin, state.assets, pos, head, sensor_z, state.tri_idx, act_idx, params)
    breaks = break_index.query(pos, act_idx, r)
    tri = state.tri_idx
    return SensorReadings(robots=robots, targets=targets, assets=assets, breaks=breaks,
                          tilt_rad=tin.sensor_tilt_in(tri, head), slope_deg=tin.slope_deg[tri],
                          aspect_deg=tin.aspect_deg[tri])


def _sense_robots(tin, state, present, act_idx, sensor_z, sp) -> Contacts:
    """Each active observer's nearest present robots in range, within FOV, in sight."""
    pos, n = state.positions, state.n_robots
    if len(present) < 2 or len(act_idx) == 0:
        z = np.zeros(0, dtype=np.int64)
        return Contacts(z, z, np.zeros(0), np.zeros(0))
    obs, tgt = nearest_candidates(pos[present], pos[act_idx], sp.range_m, sp.max_candidates, self_idx=act_idx,
                                  tree_idx=present, query_idx=act_idx)
    dx, dy = pos[tgt, 0] - pos[obs, 0], pos[tgt, 1] - pos[obs, 1]
    in_range = np.hypot(dx, dy) <= sp.range_m
    robots = _contacts(obs[in_range], tgt[in_range], dx[in_range], dy[in_range], state.headings, sp.fov_deg)
    del obs, tgt, dx, dy, in_range
    if sp.check_los and len(robots):
        # sight is symmetric: test each unordered pair once
        lo, hi = np.minimum(robots.observer, robots.target), np.maximum(robots.observer, robots.target)
        key, inv = np.unique(lo * np.int64(n) + hi, return_inverse=True)
        del lo, hi
        a_i, b_i = key // n, key % n
        A = np.column_stack([pos[a_i], sensor_z[a_i]])
        B = np.column_stack([pos[b_i], sensor_z[b_i]])
        vis = tin.line_of_sight(A, B, hint=state.tri_idx[a_i])[inv.ravel()]
        robots = Contacts(robots.observer[vis], robots.target[vis], robots.distance_m[vis], robots.bearing_rad[vis])
    return robots


def _sense_entities(tin, ent, pos, head, sensor_z, tri_idx, act_idx, params) -> Contacts:
    sp = params.sensor
    empty = Contacts(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))
    if len(ent) == 0 or len(act_idx) == 0:
        return empty
    obs, tgt = nearest_candidates(ent.positions, pos[act_idx], sp.range_m, sp.max_candidates,
                                  query_idx=act_idx)
    dx = ent.positions[tgt, 0] - pos[obs, 0]
    dy = ent.positions[tgt, 1] - pos[obs, 1]
    in_range = np.hypot(dx, dy) <= sp.range_m
    c = _contacts(obs[in_range], tgt[in_range], dx[in_range], dy[in_range], head, sp.fov_deg)
    if sp.check_los and len(c):
        ez = tin.height_in(ent.positions[c.target], ent.tri_idx[c.target]) + params.entity_height_m
        A = np.column_stack([pos[c.observer], sensor_z[c.observer]])
        B = np.column_stack([ent.positions[c.target], ez])
        vis = tin.line_of_sight(A, B, hint=tri_idx[c.observer])
        c = Contacts(c.observer[vis], c.target[vis], c.distance_m[vis], c.bearing_rad[vis])
    # order by observer then distance, for stable downstream use
    o = np.lexsort((c.distance_m, c.observer))
    return Contacts(c.observer[o], c.target[o], c.distance_m[o], c.bearing_rad[o])
