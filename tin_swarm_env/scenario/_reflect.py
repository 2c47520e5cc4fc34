"""The reflections behind :mod:`tin_swarm_env.scenario.mirror` (whose docstring says what they
are): points, rectangles, TINs, grids and generated tasks, below the stage builder (``build.py``
applies them; ``mirror.py`` builds on ``build.py``)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import ArgumentError
from ..terrain import Dem, Tin

__all__ = ["MIRRORS", "compose", "reflect_xy", "reflect_region", "mirror_tin", "mirror_dem", "mirror_task",
           "dem_bounds", "axis_flips"]

MIRRORS = ("", "ns", "ew", "both")
_FLIPS = {"": (False, False), "ns": (False, True), "ew": (True, False), "both": (True, True)}  # (x, y) reflected


def axis_flips(axis: str) -> tuple[bool, bool]:
    if axis not in _FLIPS:
        raise ArgumentError(f"mirror axis must be one of {', '.join(repr(m) for m in MIRRORS)}, got {axis!r}")
    return _FLIPS[axis]


def compose(a: str, b: str) -> str:
    """The reflection ``a`` then ``b`` as one: ``compose("ns", "ns") == ""``, ``compose("ns", "ew") == "both"``."""
    fa, fb = axis_flips(a), axis_flips(b)
    f = (fa[0] != fb[0], fa[1] != fb[1])
    return next(k for k, v in _FLIPS.items() if v == f)


def reflect_xy(xy, axis: str, bounds) -> np.ndarray:
    """``(..., 2)`` points reflected by ``axis`` over ``bounds`` ``(xmin, ymin, xmax, ymax)`` m."""
    fx, fy = axis_flips(axis)
    out = np.array(xy, dtype=np.float64)
    if out.shape[-1:] != (2,):
        raise ArgumentError(f"reflect_xy: points must have shape (..., 2), got {out.shape}")
    x0, y0, x1, y1 = (float(b) for b in bounds)
    if fx:
        out[..., 0] = (x0 + x1) - out[..., 0]
    if fy:
        out[..., 1] = (y0 + y1) - out[..., 1]
    return out


def reflect_region(region, axis: str, bounds):
    """A rectangle ``(x0, y0, x1, y1)`` reflected (still ``x0 < x1``, ``y0 < y1``); None stays None."""
    if region is None:
        return None
    a = reflect_xy(np.reshape(np.asarray(region, dtype=np.float64), (2, 2)), axis, bounds)
    lo, hi = a.min(axis=0), a.max(axis=0)
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def mirror_tin(tin: Tin, axis: str, bounds=None) -> Tin:
    """The TIN reflected by ``axis`` over ``bounds`` (default: its own): the same triangles with
    reflected vertices (the :class:`~tin_swarm_env.terrain.Tin` constructor turns them back
    counter-clockwise). ``axis=""`` returns ``tin`` itself."""
    if not any(axis_flips(axis)):
        return tin
    v = np.array(tin.vertices, dtype=np.float64)
    v[:, :2] = reflect_xy(v[:, :2], axis, tin.bounds if bounds is None else bounds)
    return Tin(v, np.array(tin.triangles), source=f"{tin.source} (mirror {axis})")


def mirror_dem(dem: Dem, axis: str) -> Dem:
    """The grid reflected by ``axis`` over its own extent (rows and/or columns reversed; the
    coordinates stay, so ``z`` at ``(x, y)`` is the original's at the reflected point)."""
    fx, fy = axis_flips(axis)
    z = dem.z[::-1] if fy else dem.z
    z = z[:, ::-1] if fx else z
    return Dem(z, dem.x, dem.y, source=f"{dem.source} (mirror {axis})") if (fx or fy) else dem


def dem_bounds(dem: Dem) -> tuple[float, float, float, float]:
    """``(xmin, ymin, xmax, ymax)`` of a grid's cell centres."""
    return float(dem.x[0]), float(dem.y[0]), float(dem.x[-1]), float(dem.y[-1])


_SWAP = {"left": "right", "right": "left"}


def mirror_task(task, axis: str):
    """A :class:`~tin_swarm_env.scenario.generators.GeneratedTask` reflected by ``axis`` over its
    DEM's extent: the grid, spawn region, targets, passes and dead ends; a single flip swaps
    ``detour_side`` left/right. ``params`` and ``seed`` stay the drawn ones
    (:func:`~tin_swarm_env.scenario.generators.replay` rebuilds the original)."""
    fx, fy = axis_flips(axis)
    if not (fx or fy):
        return task
    b = dem_bounds(task.dem)
    side = _SWAP.get(task.detour_side, task.detour_side) if fx != fy else task.detour_side

    def frozen(a):
        a = reflect_xy(np.asarray(a, dtype=np.float64).reshape(-1, 2), axis, b).reshape(np.shape(a))
        a.setflags(write=False)
        return a

    return dataclasses.replace(task, dem=mirror_dem(task.dem, axis), spawn_region=reflect_region(task.spawn_region,
                               axis, b), targets=frozen(task.targets), passes=frozen(task.passes),
                               dead_ends=frozen(task.dead_ends), detour_side=side)
