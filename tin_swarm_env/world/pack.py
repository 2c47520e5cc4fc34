"""Many worlds' static arrays in one set of arrays: what the vector env's compiled passes read.

E copies of the swarm may stand on different terrains (a list of scenarios, or a generated
terrain drawn per copy and per reset). The compiled passes (:mod:`.batch_kernels`) run over every
robot of every copy at once, so they cannot take one terrain as an argument: they take a
:class:`WorldPack`, the distinct worlds' arrays concatenated, each world's indices shifted so
that they point into the concatenation (a triangle's vertices, its neighbours, the bucket grid's
triangles, the break grid's segments). A triangle walk started in world ``w``'s triangles never
leaves them (neighbours across worlds do not exist), so the walks of :mod:`.sense_kernels` and
:mod:`.locomotion` run unchanged on global indices; what a walk reads per world (the bucket grid's
origin, the edges for the brute-force line of sight, the tolerances) comes from
:func:`~.batch_kernels.terrain_of`, a view per world.

Copies on the same world share its arrays (one entry per distinct :class:`~.world.World`
object): E copies of jacksboro hold one jacksboro. The pack is rebuilt when the set of worlds
changes (a generated terrain's reset), in O(total size); generated terrains are a few hundred
triangles each.
"""

from __future__ import annotations

import functools

import numpy as np

from ..terrain import ANGLE
from .sense_kernels import deep_margin, terrain_arrays

__all__ = ["WorldPack", "pack_worlds", "join", "pack_one", "one_copy", "frozen"]


# the global arrays of a pack, in order, and what their values index (shifted on a join): "v" vertices,
# "t" triangles, "bt" bucket tris rows, "gi" break-grid items, "b" breaks; None: not an index
_GLOBAL = (("vx", None), ("vy", None), ("vz", None), ("tris", "v"), ("nbrs", "t"), ("grad", None),
           ("bstart", "bt"), ("btris", "t"), ("edges", "v"), ("border", None), ("steep", None),
           ("bax", None), ("bay", None), ("bbx", None), ("bby", None), ("gstart", "gi"), ("gitems", "b"),
           ("normals", None), ("drops", None), ("danger", None), ("ends", None),
           ("sin_slope", None), ("aspect_rad", None), ("slope_deg", None), ("aspect_deg", None))
# per-world scalars, and per-world offsets (W + 1,) into a global array of the given size key
_PER_WORLD = ("bx0", "by0", "binv", "bnx", "bny", "tol", "ztol", "ms", "margin", "gx0", "gy0", "ginv", "gnx", "gny")
_OFFSETS = (("bs_off", "bs"), ("e_off", "e"), ("tri_off", "t"), ("brk_off", "b"), ("gs_off", "gs"))
_SIZE_OF = {"v": "vx", "t": "tris", "bs": "bstart", "bt": "btris", "e": "edges", "b": "bax", "gs": "gstart",
            "gi": "gitems"}


class WorldPack:
    """The distinct worlds' arrays, concatenated (``W`` worlds).

    ``a`` maps names to arrays: the global ones of ``_GLOBAL`` (the terrain arrays of
    :func:`~.sense_kernels.terrain_arrays`, ``steep``, the break segments and each world's break
    grid, the observation's break arrays, the tilt tables), the per-world scalars ``(W,)`` and the
    per-world offsets ``(W + 1,)`` (world w's triangles are ``tri_off[w]:tri_off[w + 1]``).
    :attr:`T0`, :attr:`B`, :attr:`OB` and :attr:`tilt` are the tuples the kernels read.
    """

    def __init__(self, worlds: tuple, a: dict):
        self.worlds = worlds
        self.a = {k: frozen(v) for k, v in a.items()}
        self._where = {id(w): k for k, w in enumerate(worlds)}

    def index(self, world) -> int:
        """The pack's index of ``world`` (KeyError if it is not in the pack)."""
        return self._where[id(world)]

    def __contains__(self, world) -> bool:
        return id(world) in self._where

    @property
    def T0(self) -> tuple:
        a = self.a
        return (a["vx"], a["vy"], a["vz"], a["tris"], a["nbrs"], a["grad"], a["bstart"], a["btris"], a["edges"],
                a["border"], a["bx0"], a["by0"], a["binv"], a["bnx"], a["bny"], a["tol"], a["ztol"], a["ms"],
                a["bs_off"], a["e_off"])

    @property
    def B(self) -> tuple:
        a = self.a
        return (a["bax"], a["bay"], a["bbx"], a["bby"], a["gx0"], a["gy0"], a["ginv"], a["gnx"], a["gny"],
                a["gstart"], a["gitems"], a["gs_off"], a["brk_off"])

    @property
    def OB(self) -> tuple:
        a = self.a
        return a["normals"], a["drops"], a["danger"], a["ends"]

    @property
    def tilt(self) -> tuple:
        a = self.a
        return a["sin_slope"], a["aspect_rad"], a["slope_deg"], a["aspect_deg"]

    @property
    def steep(self) -> np.ndarray:
        return self.a["steep"]

    @property
    def margin(self) -> np.ndarray:
        return self.a["margin"]

    @property
    def tri_off(self) -> np.ndarray:
        return self.a["tri_off"]

    @property
    def brk_off(self) -> np.ndarray:
        return self.a["brk_off"]

    @property
    def nbytes(self) -> int:
        return int(sum(v.nbytes for v in self.a.values()))

    def copy(self) -> WorldPack:
        """A pack of its own (its arrays copied): one that :meth:`append` may grow."""
        return WorldPack(self.worlds, {k: v.copy() for k, v in self.a.items()})

    def append(self, world) -> None:
        """Add ``world`` at the end, in place, in O(its size): each global array keeps spare
        capacity (doubled when full), so a copy's reset does not copy the other worlds' arrays.
        (Only on a pack of its own: :meth:`copy` one from :func:`pack_worlds`.)"""
        new = pack_one(world)
        size = {k: len(self.a[name]) for k, name in _SIZE_OF.items()}
        buf = self.__dict__.setdefault("_buf", {})
        for name, key in _GLOBAL:
            v = new.a[name]
            if key is not None and size[key]:
                v = np.where(v >= 0, v + size[key], v) if name == "nbrs" else v + size[key]
            n0 = len(self.a[name])
            n1 = n0 + len(v)
            b = buf.get(name)
            if b is None or len(b) < n1:
                grown = np.empty((max(2 * n0, n1, 16),) + self.a[name].shape[1:], dtype=self.a[name].dtype)
                grown[:n0] = self.a[name]
                b = buf[name] = grown
            b[n0:n1] = v
            self.a[name] = frozen(b[:n1])
        for name in _PER_WORLD:
            self.a[name] = frozen(np.concatenate([self.a[name], new.a[name]]))
        for name, key in _OFFSETS:
            self.a[name] = frozen(np.concatenate([self.a[name], new.a[name][1:] + size[key]]).astype(np.int64))
        self.worlds = self.worlds + (world,)
        self._where[id(world)] = len(self.worlds) - 1


def frozen(v: np.ndarray) -> np.ndarray:
    """A read-only view of ``v``. Every array of a pack is one, whichever way the pack was built (one world's
    arrays, some of them the TIN's own read-only ones; a join's concatenations; an append's buffers), so the
    compiled passes see the same array types from the env and the vector env and compile once (numba types a
    read-only array apart from a writable one: each difference is another compilation of the whole pass)."""
    v = v.view()
    v.flags.writeable = False
    return v


@functools.lru_cache(maxsize=8)
def one_copy(n: int) -> tuple:
    """``(wor, cop, off)`` of ``n`` robots on world 0 of a pack, all in copy 0: how a single
    :class:`~.world.World` calls the passes over copies (:func:`~.step_kernel.step_copies`,
    :func:`~.batch_kernels.sense_copies`). Read only (kept per ``n``)."""
    z = np.zeros(n, dtype=np.int64)
    return z, z, np.array([0, n], dtype=np.int64)


def pack_one(world) -> WorldPack:
    """The pack of one world (cached on the world: its arrays never change; built anew if its
    ``break_index`` was replaced, which the sensing reads)."""
    got = world.__dict__.get("_world_pack")
    bi = world.break_index
    if got is not None and got[0] is bi:
        return got[1]
    T = terrain_arrays(world.tin)
    f64, i64 = np.float64, np.int64
    g = bi.grid
    sin_slope, aspect_rad = world.tin._tilt_tables
    c = np.ascontiguousarray
    a = {"vx": c(T[0], f64), "vy": c(T[1], f64), "vz": c(T[2], f64), "tris": c(T[3], i64), "nbrs": c(T[4], i64),
         "grad": c(T[5], f64), "bstart": c(T[6], i64), "btris": c(T[7], i64), "edges": c(T[13], i64).reshape(-1, 2),
         "border": c(T[14], np.bool_), "steep": c(world.steep, np.bool_),
         "bax": c(bi.ax, f64), "bay": c(bi.ay, f64), "bbx": c(bi.bx, f64), "bby": c(bi.by, f64),  # what sensing reads
         "gstart": c(g[5], i64), "gitems": c(g[6], i64),
         "normals": c(world.breaks.normals.reshape(-1, 2), f64), "drops": c(world.breaks.drops_m.reshape(-1), f64),
         "danger": c((world.breaks.kinds != ANGLE).astype(f64)),
         "ends": c(np.column_stack([bi.ax, bi.ay, bi.bx, bi.by]), f64),  # bax.. side by side (break_row reads it)
         "sin_slope": c(sin_slope, f64), "aspect_rad": c(aspect_rad, f64), "slope_deg": c(world.tin.slope_deg, f64),
         "aspect_deg": c(world.tin.aspect_deg, f64)}
    for name, v, dt in (("bx0", T[8], f64), ("by0", T[9], f64), ("binv", T[10], f64), ("bnx", T[11], i64),
                        ("bny", T[12], i64), ("tol", T[15], f64), ("ztol", T[16], f64), ("ms", T[17], i64),
                        ("margin", deep_margin(world.tin), f64), ("gx0", g[0], f64), ("gy0", g[1], f64),
                        ("ginv", g[2], f64), ("gnx", g[3], i64), ("gny", g[4], i64)):
        a[name] = np.array([v], dtype=dt)
    for name, key in _OFFSETS:
        a[name] = np.array([0, len(a[_SIZE_OF[key]])], dtype=i64)
    p = WorldPack((world,), a)
    world.__dict__["_world_pack"] = (bi, p)
    return p


def join(packs) -> WorldPack:
    """One pack of several (their worlds in order), index arrays shifted: O(total size), one
    concatenation per array."""
    packs = list(packs)
    if len(packs) == 1:
        return packs[0]
    size = {k: np.concatenate([[0], np.cumsum([len(p.a[name]) for p in packs])]).astype(np.int64)
            for k, name in _SIZE_OF.items()}
    a = {}
    for name, key in _GLOBAL:
        parts = []
        for k, p in enumerate(packs):
            v = p.a[name]
            if key is not None and size[key][k]:
                v = np.where(v >= 0, v + size[key][k], v) if name in ("nbrs",) else v + size[key][k]
            parts.append(v)
        a[name] = np.ascontiguousarray(np.concatenate(parts))
    for name in _PER_WORLD:
        a[name] = np.concatenate([p.a[name] for p in packs])
    for name, key in _OFFSETS:
        a[name] = np.concatenate([packs[0].a[name]] + [p.a[name][1:] + size[key][k] for k, p in enumerate(packs)
                                                       if k > 0]).astype(np.int64)
    return WorldPack(tuple(w for p in packs for w in p.worlds), a)


def pack_worlds(worlds) -> WorldPack:
    """The :class:`WorldPack` of ``worlds`` (distinct :class:`~.world.World` objects)."""
    return join([pack_one(w) for w in worlds])
