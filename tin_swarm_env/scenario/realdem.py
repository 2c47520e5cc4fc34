"""The ``realdem`` generated family: random crops of the real DEMs bundled with matplotlib.

A draw takes a square crop ``crop_cells`` source cells wide (along the coarser axis) at a random
place of ``dem`` (``"jacksboro"``: the Jacksboro fault, ~75 x 93 m cells; ``"topobathy"``:
Vancouver Island with its sea floor, 2 arc-minute cells, ~2.4 km; :func:`~tin_swarm_env.terrain.sample_dem`),
resamples it (cubic spline) onto the family's square grid ``size_m`` wide at ``cell_m``, and
scales the heights by the same factor as the horizontal extent (``size_m`` over the crop's side
in metres), so every slope angle of the crop is kept. The grid is then turned by ``orient``, one
of the eight symmetries of the square (:data:`ORIENTS`: flips of either axis, transposes, quarter
turns), so the family is not tuned to one orientation of the real hillsides.

The robots' ``max_slope_deg`` is drawn per task, not taken from the scenario: the crop is meshed
as the generated scenario meshes it (:data:`MESH`, the greedy 0.5 m TIN) and the limit is the
area-weighted ``1 - steep_frac`` quantile of its triangles' slopes, so ``steep_frac`` of the ground
is hillside too steep to drive (no cliff: real slopes). A limit outside :data:`SLOPE_LIMITS_DEG`
(a flat crop of the sea floor) rejects the crop. The task's ``params["max_slope_deg"]`` is the
drawn limit; the scenario builder gives the robots that limit on this task.

Spawn and target are placed on that TIN with :func:`~tin_swarm_env.terrain.cost_to_go` over its
drivable triangles: the target on drivable ground with ``TARGET_CLEAR_M`` of it clear, the spawn
region's centre where the drivable way to the target is at least ``detour_min`` times the straight
line (so the straight line crosses ground too steep to drive), the straight line at least
``MIN_STRAIGHT_FRAC`` of the map and the way at most ``MAX_PATH_FRAC`` of it (an episode of 1 000
steps at 1 m per step has room for it), and at least ``SPAWN_REACHABLE_FRAC`` of the spawn region
(sampled 9 x 9) able to reach the target. So every task is solvable by construction (the cost-to-go
is finite from the spawn centre) and a detour; the scenario builder checks both again on its own
TIN. ``rng`` draws the crop's place and the candidate targets and spawn centres: up to
:data:`CROP_TRIES` crops, :data:`TARGET_TRIES` targets each, :data:`SPAWN_CANDIDATES` spawn centres
per target; when none fits, :class:`~.generators.NoFitError` says why (``generate`` draws the
parameters again, at most ``max_tries`` times, then names the last misfit).

``detour_side`` is the side of the straight line (seen from the spawn looking at the target) where
the drivable way strays furthest from it, traced along the cost-to-go's direction field.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import ndimage

from .. import terrain as T

__all__ = ["crop_heights", "orient_grid", "steep_quantile_deg", "place", "route_side", "source_cell_m", "source_extent_m",
           "ORIENTS", "SOURCES", "MESH", "SLOPE_LIMITS_DEG"]

SOURCES = ("jacksboro", "topobathy")  # terrain.sample_dem names
ORIENTS = ("none", "flip_x", "flip_y", "rot180", "transpose", "rot90", "rot270", "anti_transpose")
MESH = {"method": "greedy", "max_error_m": 0.5}  # the generated scenario's [terrain] method and max_error_m
SLOPE_LIMITS_DEG = (2.0, 40.0)  # a drawn max_slope_deg outside these rejects the crop (max_climb_deg is 45)
CROP_TRIES, TARGET_TRIES, SPAWN_CANDIDATES = 12, 6, 160
MIN_STRAIGHT_FRAC = 0.35  # spawn centre to target, straight, at least this share of size_m
MAX_PATH_FRAC = 1.6  # the drivable way at most this share of size_m
SPAWN_REACHABLE_FRAC = 0.5  # of the spawn region's 9 x 9 sample points, this share at least reach the target
TARGET_CLEAR_M = 3.0  # the target and 8 points this far round it stand on drivable triangles
SPLINE_MARGIN = 2.0  # source cells kept between a crop and the DEM's edge (the cubic spline's reach)


@functools.lru_cache(maxsize=len(SOURCES))
def _source(name: str):
    """``(dem, spline coefficients)`` of a bundled DEM, loaded once per process."""
    dem = T.sample_dem(name)
    coef = ndimage.spline_filter(dem.z, order=3)
    coef.setflags(write=False)
    return dem, coef


def source_extent_m(name: str) -> np.ndarray:
    """``(2,)`` m: the east-west and north-south extent of bundled DEM ``name``'s cell centres."""
    dem, _ = _source(name)
    return np.array([dem.x[-1] - dem.x[0], dem.y[-1] - dem.y[0]])


def source_cell_m(name: str) -> float:
    """The coarser cell side of bundled DEM ``name``, m (a crop's ``crop_cells`` count these)."""
    dem, _ = _source(name)
    return float(max(dem.x[1] - dem.x[0], dem.y[1] - dem.y[0]))


def orient_grid(z: np.ndarray, orient: str) -> np.ndarray:
    """``z`` (n, n), row 0 south, turned by one of :data:`ORIENTS`: ``flip_x`` mirrors east-west,
    ``flip_y`` north-south, ``transpose`` swaps x and y, ``rot90`` turns counter-clockwise."""
    ops = {"none": lambda a: a, "flip_x": lambda a: a[:, ::-1], "flip_y": lambda a: a[::-1],
           "rot180": lambda a: a[::-1, ::-1], "transpose": lambda a: a.T, "rot90": lambda a: a[::-1].T,
           "rot270": lambda a: a.T[::-1], "anti_transpose": lambda a: a[::-1, ::-1].T}
    return np.ascontiguousarray(ops[orient](z))


def crop_heights(name: str, origin_m, crop_cells: float, size_m: float, cell_m: float,
                 orient: str = "none") -> tuple[np.ndarray, np.ndarray]:
    """``(x (n,) m, z (n, n) m)``: the square crop of bundled DEM ``name`` whose south-west corner
    lies ``origin_m`` (2,) m from its south-west cell centre, ``crop_cells`` coarser cells wide,
    resampled onto ``n = round(size_m / cell_m) + 1`` points per side ``cell_m`` apart, heights
    times ``size_m / crop side`` (slopes kept) less their minimum, turned by ``orient``."""
    dem, coef = _source(name)
    side_m = crop_cells * source_cell_m(name)
    n = int(round(size_m / cell_m)) + 1
    x = np.arange(n) * cell_m
    scale = x[-1] / side_m  # map metres per crop metre (the last point is the crop's far edge)
    cols = (origin_m[0] + x / scale) / (dem.x[1] - dem.x[0])
    rows = (origin_m[1] + x / scale) / (dem.y[1] - dem.y[0])
    z = ndimage.map_coordinates(coef, np.meshgrid(rows, cols, indexing="ij"), order=3, prefilter=False) * scale
    return x, orient_grid(z - z.min(), orient)


def steep_quantile_deg(tin, steep_frac: float) -> float:
    """The slope (deg) above which ``steep_frac`` of ``tin``'s area lies (area-weighted quantile)."""
    v = tin.vertices[tin.triangles, :2]  # (T, 3, 2)
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    order = np.argsort(tin.slope_deg, kind="stable")
    cum = np.cumsum(area[order]) / area.sum()
    k = min(int(np.searchsorted(cum, 1.0 - steep_frac)), len(order) - 1)
    return float(tin.slope_deg[order[k]])


def _clear(tin, passable, pts, radius_m):
    """``(k,)`` bool: each point of ``pts`` (k, 2) and 8 points ``radius_m`` round it on drivable triangles."""
    a = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    ring = np.concatenate([[[0.0, 0.0]], radius_m * np.column_stack([np.cos(a), np.sin(a)])])  # (9, 2)
    t = tin.locate((pts[:, None, :] + ring[None]).reshape(-1, 2)).reshape(len(pts), 9)
    return np.all((t >= 0) & passable[np.maximum(t, 0)], axis=1)


def place(rng, tin, passable, spawn_m: float, detour_min: float, margin_m: float):
    """``(spawn centre (2,), target (2,), detour side)`` on ``tin``'s ``passable`` triangles as the
    module docstring says, ``margin_m`` clear of the map edge, or None when no try fits."""
    size = tin.bounds[2] - tin.bounds[0]
    s, lo_s = spawn_m, margin_m + spawn_m / 2
    g = np.linspace(-s / 2, s / 2, 9)
    square = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)  # (81, 2) the spawn region's sample points
    for _ in range(TARGET_TRIES):
        cands = tin.bounds[0] + rng.uniform(margin_m + TARGET_CLEAR_M, size - margin_m - TARGET_CLEAR_M, (32, 2))
        spawns = tin.bounds[0] + rng.uniform(lo_s, size - lo_s, (SPAWN_CANDIDATES, 2))
        ok = _clear(tin, passable, cands, TARGET_CLEAR_M)
        if not ok.any():
            continue
        target = cands[np.argmax(ok)]
        field = T.cost_to_go(tin, target, passable)
        way = field.distance_at(spawns)
        line = np.hypot(*(spawns - target).T)
        good = (np.isfinite(way) & (line >= MIN_STRAIGHT_FRAC * size) & (way >= detour_min * line)
                & (way <= MAX_PATH_FRAC * size))
        idx = np.flatnonzero(good)
        if not len(idx):
            continue
        reach = np.isfinite(field.distance_at((spawns[idx, None, :] + square[None]).reshape(-1, 2)))
        share = reach.reshape(len(idx), -1).mean(axis=1)
        fits = idx[share >= SPAWN_REACHABLE_FRAC]
        if len(fits):
            spawn = spawns[fits[0]]
            return spawn, target, route_side(field, spawn, target, float(way[fits[0]]))
    return None


def route_side(field, spawn, target, way_m: float, steps: int = 64) -> str:
    """'left' / 'right': the side of the straight line ``spawn -> target`` (looking at the target)
    where the drivable way from ``spawn`` strays furthest from it, traced along ``field``'s first
    legs in ``steps`` steps of ``way_m / steps``; 'none' when the trace cannot leave ``spawn``."""
    h = way_m / steps
    pts, pos = [], np.asarray(spawn, dtype=np.float64)
    for _ in range(steps):
        d = field.direction_at(pos[None])[0]
        if not np.any(d):
            break
        pos = pos + h * d
        pts.append(pos)
    if not pts:
        return "none"
    pts, d = np.asarray(pts), np.asarray(target) - spawn
    cross = d[0] * (pts[:, 1] - spawn[1]) - d[1] * (pts[:, 0] - spawn[0])
    return "left" if cross[int(np.argmax(np.abs(cross)))] > 0 else "right"
