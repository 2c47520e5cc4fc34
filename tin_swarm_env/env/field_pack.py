"""Many copies' cost-to-go fields in one set of arrays, queried for every robot in one pass.

:class:`~tin_swarm_env.terrain.CostToGoStack` holds the fields of one TIN; the vector env's copies
stand on different TINs, so :class:`FieldPack` concatenates the distinct fields' own arrays with
per-field offsets (each field's indices stay local: the query takes views), and
:func:`distance_copies` measures every robot's distance to go on its field with the per-point
code of :func:`~tin_swarm_env.terrain._ctg_kernels.distance_stacked` (``best_distance``): the same bits.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..terrain._ctg_kernels import best_distance

__all__ = ["FieldPack", "distance_copies", "field_ids", "EUCLID", "NO_FIELD"]

NO_FIELD = -1  # a robot with no target: distance inf
EUCLID = -2  # a robot whose copy measures the straight line (euclidean progress, mobile targets)

# the per-field arrays and the size they are counted in: nodes, triangles, vertices, windows, wstart rows
_KIND = (("nx", "n"), ("ny", "n"), ("dist", "n"), ("tri_nodes", "t"), ("passable", "t"), ("goal_tri", "t"),
         ("tris", "t"), ("nbrs", "t"), ("vx", "v"), ("vy", "v"), ("twin", "v"), ("wstart", "s"), ("wgeo", "w"),
         ("wroot", "w"))


def _arrays(f) -> dict:
    c = np.ascontiguousarray
    return {"nx": c(f._nx, np.float64), "ny": c(f._ny, np.float64), "dist": c(f.node_distance, np.float64),
            "tri_nodes": c(f._tri_nodes, np.int64), "passable": c(f.passable, np.bool_),
            "goal_tri": c(f.goal_triangles, np.bool_), "tris": c(f._tris, np.int64),
            "nbrs": c(f.tin.neighbors, np.int64), "vx": c(f._vx, np.float64), "vy": c(f._vy, np.float64),
            "twin": c(f._twin, np.int64), "wstart": c(f._wstart, np.int64), "wgeo": c(f._wgeo, np.float64),
            "wroot": c(f._wroot, np.int64)}


class FieldPack:
    """The distinct :class:`~tin_swarm_env.terrain.CostToGo` fields, concatenated; ``index(f)``
    is a field's id. Appending a field costs one concatenation per array (O(total))."""

    def __init__(self, fields=()):
        self.fields: list = []
        self._where: dict = {}
        self.a = None
        self._buf: dict = {}  # per array: the buffer a holds a prefix of
        self.off = None
        self.scal = (np.zeros((0, 2)), np.zeros(0), np.zeros(0))  # goal xy, tolerance, eps
        self.extend(fields)

    def __len__(self) -> int:
        return len(self.fields)

    def index(self, f) -> int:
        return self._where[id(f)]

    def __contains__(self, f) -> bool:
        return id(f) in self._where

    def extend(self, fields) -> None:
        new = []
        for f in fields:
            if id(f) not in self._where and all(g is not f for g in new):
                new.append(f)
        if not new:
            return
        if self.fields and any(f._tri_nodes.shape[1] != self.fields[0]._tri_nodes.shape[1] for f in new):
            from ..errors import ArgumentError

            raise ArgumentError("vector env: the copies' cost-to-go fields have different steiner_per_edge")
        parts = [_arrays(f) for f in new]
        if self.a is None:
            self.a = {k: np.ascontiguousarray(np.concatenate([p[k] for p in parts])) for k, _ in _KIND}
            sizes = {s: [0] for s in "ntvsw"}
        else:  # appended in place into spare capacity (doubled when full): O(the new fields' size)
            for k, _ in _KIND:
                add = np.concatenate([p[k] for p in parts])
                n0, n1 = len(self.a[k]), len(self.a[k]) + len(add)
                b = self._buf.get(k)
                if b is None or len(b) < n1:
                    b = self._buf[k] = np.empty((max(2 * n0, n1),) + self.a[k].shape[1:], dtype=self.a[k].dtype)
                    b[:n0] = self.a[k]
                b[n0:n1] = add
                self.a[k] = b[:n1]
            sizes = {s: [int(self.off[s][-1])] for s in "ntvsw"}
        key = {"n": "nx", "t": "passable", "v": "vx", "s": "wstart", "w": "wroot"}
        for p in parts:
            for s in "ntvsw":
                sizes[s].append(sizes[s][-1] + len(p[key[s]]))
        if self.off is None:
            self.off = {s: np.array(v, dtype=np.int64) for s, v in sizes.items()}
        else:
            self.off = {s: np.concatenate([self.off[s], np.array(sizes[s][1:], dtype=np.int64)]) for s in "ntvsw"}
        for f in new:
            self._where[id(f)] = len(self.fields)
            self.fields.append(f)
        g, tol, eps = self.scal
        self.scal = (np.concatenate([g, np.array([f.goal_xy for f in new], dtype=np.float64).reshape(-1, 2)]),
                     np.concatenate([tol, [float(f.tin.tolerances[0]) for f in new]]),
                     np.concatenate([eps, [float(f._eps_m) for f in new]]))

    def kernel_args(self) -> tuple:
        a, o = self.a, self.off
        if a is None:
            z, zi = np.zeros(0), np.zeros(1, dtype=np.int64)
            i0, i3 = np.zeros(0, np.int64), np.zeros((0, 3), np.int64)
            return (z, z, z, np.zeros((0, 1), np.int64), np.zeros(0, bool), np.zeros(0, bool), i3, i3, z, z, i0, i0,
                    np.zeros((0, 7)), i0, zi, zi, zi, zi, zi, *self.scal)
        return (a["nx"], a["ny"], a["dist"], a["tri_nodes"], a["passable"], a["goal_tri"], a["tris"], a["nbrs"],
                a["vx"], a["vy"], a["twin"], a["wstart"], a["wgeo"], a["wroot"], o["n"], o["t"], o["v"], o["s"], o["w"],
                *self.scal)


CHUNKS = 16  # runs of robots _distance_copies shares among the threads (as distance_stacked's)


@njit(cache=True)
def _distance_run(lo, hi, nx, ny, dist, tri_nodes, passable, goal_tri, tris, nbrs, vx, vy, twin, wstart, wgeo, wroot,
                  on, ot, ov, os_, ow, gxy, tol, eps, fid, pos, tri, tpos, tglob, out):
    """Robots ``lo:hi`` of :func:`_distance_copies`: a field's views are taken when the field changes
    (a copy's robots are consecutive and share their fields), not per robot."""
    cur = -1
    nx_f, ny_f, d_f, wg_f = nx[0:0], ny[0:0], dist[0:0], wgeo[0:0]
    tn_f, pa_f, gt_f, tr_f, nb_f = tri_nodes[0:0], passable[0:0], goal_tri[0:0], tris[0:0], nbrs[0:0]
    vx_f, vy_f, tw_f, ws_f, wr_f = vx[0:0], vy[0:0], twin[0:0], wstart[0:0], wroot[0:0]
    for i in range(lo, hi):
        f = fid[i]
        if f == EUCLID:
            k = tglob[i]
            out[i] = np.hypot(tpos[k, 0] - pos[i, 0], tpos[k, 1] - pos[i, 1])
            continue
        out[i] = np.inf
        t = tri[i]
        if f < 0 or t < 0:
            continue
        if f != cur:
            cur = f
            a0, a1 = on[f], on[f + 1]
            t0, t1 = ot[f], ot[f + 1]
            v0, v1 = ov[f], ov[f + 1]
            w0, w1 = ow[f], ow[f + 1]
            nx_f, ny_f, d_f = nx[a0:a1], ny[a0:a1], dist[a0:a1]
            tn_f, pa_f, gt_f, tr_f, nb_f = tri_nodes[t0:t1], passable[t0:t1], goal_tri[t0:t1], tris[t0:t1], nbrs[t0:t1]
            vx_f, vy_f, tw_f = vx[v0:v1], vy[v0:v1], twin[v0:v1]
            ws_f, wg_f, wr_f = wstart[os_[f]:os_[f + 1]], wgeo[w0:w1], wroot[w0:w1]
        out[i] = best_distance(nx_f, ny_f, d_f, tn_f, pa_f, gt_f, gxy[f, 0], gxy[f, 1], vx_f, vy_f, tr_f, nb_f, ws_f,
                               wg_f, wr_f, pos[i, 0], pos[i, 1], t, tol[f], eps[f], tw_f)[0]


@njit(cache=True, parallel=True)
def _distance_copies(nx, ny, dist, tri_nodes, passable, goal_tri, tris, nbrs, vx, vy, twin, wstart, wgeo, wroot,
                     on, ot, ov, os_, ow, gxy, tol, eps, fid, pos, tri, tpos, tglob, out):
    n = pos.shape[0]
    C = CHUNKS if n >= CHUNKS else 1
    for c in prange(C):  # every robot's value is computed alone: the same bits on any thread count
        _distance_run(c * n // C, (c + 1) * n // C, nx, ny, dist, tri_nodes, passable, goal_tri, tris, nbrs, vx, vy,
                      twin, wstart, wgeo, wroot, on, ot, ov, os_, ow, gxy, tol, eps, fid, pos, tri, tpos, tglob, out)
    return out


def distance_copies(pack: FieldPack, fid, pos, tri_local, tpos, tglob, out) -> np.ndarray:
    """``out (n,)`` m: robot i's distance to go on field ``fid[i]`` (:data:`EUCLID`: the straight
    line to target ``tglob[i]`` of ``tpos``; :data:`NO_FIELD`: inf), ``tri_local`` its
    triangle in its own TIN (-1: inf). The one distance-to-go pass of the env and the vector env
    (:func:`~.reward.end_step`)."""
    return _distance_copies(*pack.kernel_args(), fid, pos, tri_local, tpos, tglob, out)


def field_ids(pack: FieldPack, fields, target_idx) -> np.ndarray:
    """``(n,)`` the ``fid`` of :func:`distance_copies` for robots assigned ``target_idx`` (-1: none)
    among targets whose fields are ``fields`` (in ``pack``; empty: every target measured by the
    straight line, :data:`EUCLID`)."""
    t = np.asarray(target_idx, dtype=np.int64)
    if len(fields):
        ids = np.array([pack.index(f) for f in fields], dtype=np.int64)
        return np.where(t >= 0, ids[np.maximum(t, 0)], NO_FIELD).astype(np.int64)
    return np.where(t >= 0, EUCLID, NO_FIELD).astype(np.int64)
