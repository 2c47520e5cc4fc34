"""Mirror images of scenarios: the terrain and the task reflected across the terrain's middle.

A policy that prefers one side (it learned to go round cliffs to the left) does well on a map and
badly on its mirror image; the standard evaluation suite (:mod:`tin_swarm_env.training.suite`) plays
every map both ways. The reflections (``axis``):

====== ==================================================================================
axis   what is reflected, over the terrain's bounds ``(xmin, ymin, xmax, ymax)``
====== ==================================================================================
""     nothing (the terrain as built)
ns     the north-south flip: ``y -> ymin + ymax - y`` (north becomes south)
ew     the east-west flip: ``x -> xmin + xmax - x``
both   both flips (a half turn about the middle)
====== ==================================================================================

The bounds are the TIN's (its vertices' extent), a flat plane's ``[0, width] x [0, height]``, or a
generated task's DEM grid. The terrain is reflected after meshing, triangle for triangle, so the
mirrored terrain's elevation and slope at the mirrored point equal the original's (to rounding;
not a re-meshed flipped DEM, whose triangles could differ). A single flip swaps the robots'
left and right: a pass on the left of the way to the target becomes a pass on the right.

- ``[terrain] mirror = "ns"`` in a scenario reflects its terrain (a generated terrain: each drawn
  task, its spawn region and target with it); the file's own positions and regions are read as
  they stand, in the reflected frame.
- :func:`mirror_scenario` makes the mirror image of a whole scenario: that key (two flips on one
  axis cancel) and every position and region of the file reflected, so the task is the mirror
  image too.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import ArgumentError
from ._reflect import (MIRRORS, axis_flips, compose, dem_bounds, mirror_dem, mirror_task, mirror_tin, reflect_region,
                       reflect_xy)
from .build import build_tin_for

__all__ = ["MIRRORS", "compose", "reflect_xy", "reflect_region", "mirror_tin", "mirror_dem", "mirror_task",
           "dem_bounds", "terrain_bounds", "mirror_scenario"]


def terrain_bounds(cfg) -> tuple[float, float, float, float]:
    """The bounds a scenario's mirror is taken over: its flat plane's ``(0, 0, width, height)`` or
    its TIN's (built, or taken from the per-process cache). A generated terrain has none (each
    drawn task is reflected over its own grid): ArgumentError."""
    src = cfg.terrain.source
    if src == "generated":
        raise ArgumentError(f"{cfg.source}: a generated terrain has no fixed bounds (each task is reflected over "
                            "its own grid)")
    if src == "flat":
        w, h = cfg.terrain.size_m
        return 0.0, 0.0, float(w), float(h)
    return build_tin_for(cfg).bounds


def _entities(spec, axis, bounds):
    pos = tuple(tuple(float(v) for v in p) for p in reflect_xy(np.reshape(np.asarray(spec.positions, float), (-1, 2)),
                                                                 axis, bounds)) if spec.positions else ()
    return dataclasses.replace(spec, positions=pos, region=reflect_region(spec.region, axis, bounds))


def mirror_scenario(cfg, axis: str = "ns"):
    """The mirror image of a :class:`~tin_swarm_env.scenario.ScenarioConfig`: its terrain reflected
    (``[terrain] mirror`` composed with ``axis``) and its robots' spawn region, targets and assets
    (positions and regions) reflected over the same bounds (:func:`terrain_bounds`), so the task is
    the mirror image. The name gains ``" (mirror AXIS)"``."""
    axis_flips(axis)
    t = cfg.terrain
    new_t = dataclasses.replace(t, mirror=compose(t.mirror, axis))
    if t.source == "generated" or not any(axis_flips(axis)):
        robots, targets, assets = cfg.robots, cfg.targets, cfg.assets
    else:
        b = terrain_bounds(cfg)
        robots = dataclasses.replace(cfg.robots, spawn_region=reflect_region(cfg.robots.spawn_region, axis, b))
        targets, assets = _entities(cfg.targets, axis, b), _entities(cfg.assets, axis, b)
    name = cfg.name + (f" (mirror {axis})" if axis else "")
    return cfg.replace(name=name, terrain=new_t, robots=robots, targets=targets, assets=assets)
