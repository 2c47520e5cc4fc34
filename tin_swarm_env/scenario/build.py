"""Scenario config -> terrain, :class:`~tin_swarm_env.world.World` and initial states."""

from __future__ import annotations

import functools
import json
import weakref
from pathlib import Path

import numpy as np

from .. import terrain as T
from ..world import World, WorldState, spawn_positions
from ..errors import ArgumentError, PlacementError, ScenarioError
from .config import ScenarioConfig
from .terrains import make_dem

__all__ = ["build_tin_for", "build_world", "initial_state", "assignments", "place_entities", "spawn_reachable"]


@functools.lru_cache(maxsize=16)
def _cached_tin(key: str):
    spec = json.loads(key)
    where = spec.pop("_where")
    base = Path(spec.pop("_base"))
    spec.pop("_stamp")
    src = spec["source"]
    if src == "flat":
        return None
    if src == "tin":
        p = base / spec["path"]
        if not p.exists():
            raise ScenarioError(f"{where} [terrain] path: TIN file {str(p)!r} does not exist")
        return T.load_tin(p)
    if src == "procedural":
        dem = make_dem(spec["recipe"], spec["params"], f"{where} [terrain]")
    elif src == "sample":
        try:
            dem = T.sample_dem(spec["path"] or "jacksboro")
        except ValueError as exc:
            raise ScenarioError(f"{where} [terrain] path: {exc}") from None
    else:
        p = base / spec["path"]
        if not p.exists():
            raise ScenarioError(f"{where} [terrain] path: DEM file {str(p)!r} does not exist")
        dem = T.load_dem(p)
        if isinstance(dem, T.Dem) and dem.n_nodata:
            dem = dem.fill_nodata()
    kw = {}
    if spec["max_vertices"]:
        kw["max_vertices"] = spec["max_vertices"]
    if spec["method"] == "greedy" and spec["max_error_m"]:
        kw["max_error_m"] = spec["max_error_m"]
    return T.build_tin(dem, method=spec["method"], **kw)


def _file_stamp(path: Path) -> list[int] | None:
    """(modification time ns, size) of a terrain file, None when it does not exist."""
    try:
        st = path.stat()
    except OSError:
        return None
    return [st.st_mtime_ns, st.st_size]


def build_tin_for(cfg: ScenarioConfig):
    """The scenario's TIN (None for a flat plane), built once per process and reused while the
    DEM/TIN file it comes from keeps its modification time and size (an edited file is re-read)."""
    t = cfg.terrain
    base = Path(cfg.base_dir).resolve()
    stamp = _file_stamp(base / t.path) if t.source in ("dem", "tin") else None
    key = json.dumps({"source": t.source, "recipe": t.recipe, "path": t.path, "method": t.method,
                      "max_vertices": t.max_vertices, "max_error_m": t.max_error_m, "params": t.params,
                      "_where": cfg.source, "_base": str(base), "_stamp": stamp}, sort_keys=True)
    return _cached_tin(key)


def build_world(cfg: ScenarioConfig) -> World:
    """The scenario's world; its targets and assets are checked to stand on traversable ground
    (a ScenarioError names the file, the table and the position's index), and counted ones to
    have room in their region (one trial draw)."""
    world = World(build_tin_for(cfg), cfg.world)
    for what, spec in (("targets", cfg.targets), ("assets", cfg.assets)):
        try:
            world.check_placement(_positions(spec), f"{cfg.source} [{what}] positions[{{i}}]")
            place_entities(world, spec, np.random.default_rng(0), spawn_region=cfg.robots.spawn_region,
                           label=f"{cfg.source} [{what}]")
        except PlacementError as exc:
            raise ScenarioError(str(exc)) from None
    return world


_REACHABLE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # world -> {spawn region: (T,) bool}


def spawn_reachable(world: World, spawn_region=None) -> np.ndarray:
    """``(T,)`` bool: traversable triangles from which some point of the spawn region (m;
    None: the whole terrain) can be reached by a drivable path. Drivable connection is
    symmetric, so these are the triangles a target may stand on and be reached from there:
    the union of :meth:`~tin_swarm_env.terrain.CostToGo.triangle_reachable` from the traversable
    points of a 5 x 5 lattice over the region (one field per connected piece it touches;
    cached per world and region)."""
    cache = _REACHABLE.setdefault(world, {})
    key = None if spawn_region is None else tuple(float(v) for v in spawn_region)
    if key in cache:
        return cache[key]
    tin, passable = world.tin, ~world.steep
    x0, y0, x1, y1 = tin.bounds if key is None else key
    gx, gy = np.meshgrid(np.linspace(x0, x1, 5), np.linspace(y0, y1, 5))
    pts = np.column_stack([gx.ravel(), gy.ravel()])
    pts = pts + 1e-6 * np.sign(np.array([(x0 + x1) / 2, (y0 + y1) / 2]) - pts)  # just inside the border
    tri = tin.locate(pts)
    out = np.zeros(tin.n_triangles, dtype=bool)
    for p, t in zip(pts, tri):
        if t >= 0 and passable[t] and not out[t]:
            out |= T.cost_to_go(tin, p, passable, steiner_per_edge=0, any_angle=False).triangle_reachable()
    cache[key] = out
    return out


def place_entities(world: World, spec, rng: np.random.Generator, *, spawn_region=None,
                   label: str = "entities") -> np.ndarray:
    """``(m, 2)`` positions of an entities table: its ``positions``, or ``spec.count`` points drawn
    from ``rng`` uniformly in ``spec.region`` (default the terrain's bounds), each on a
    traversable triangle from which the spawn region can be reached (:func:`spawn_reachable`:
    the task is solvable), at least ``spec.min_separation_m`` apart (batched rejection
    sampling, :func:`~tin_swarm_env.world.spawn_positions`). Draws nothing from ``rng`` for a
    positions list. A PlacementError names ``label`` when the region has no room."""
    if not spec.count:
        return _positions(spec)
    blocked = world.steep | ~spawn_reachable(world, spawn_region)
    try:
        return spawn_positions(world.tin, blocked, spec.count, rng, region=spec.region,
                               min_separation_m=spec.min_separation_m)
    except (PlacementError, ArgumentError) as exc:
        where = list(spec.region) if spec.region else "the whole terrain"
        raise PlacementError(f"{label}: cannot place count = {spec.count} in region {where} on traversable "
                             f"ground reachable from the robots' spawn region, {spec.min_separation_m} m apart "
                             f"({exc})") from None


def _positions(spec) -> np.ndarray:
    """``(m, 2)`` positions of an entities table (``(0, 2)`` when it has none)."""
    return np.asarray(spec.positions, dtype=float).reshape(-1, 2)


def initial_state(world: World, cfg: ScenarioConfig, rng: np.random.Generator, n_robots: int, *,
                  robot_positions=None, headings=None, target_positions=None) -> WorldState:
    """The generator: robots spawned uniformly (from ``rng``) in the spawn region on traversable
    ground, then targets and assets where the scenario puts them or, for a ``count``, drawn
    from ``rng`` (:func:`place_entities`). ``robot_positions (n, 2)`` (with
    optional ``headings (n,)``) and ``target_positions (m, 2)`` replace the spawned robots and
    the scenario's targets (the env's reset options); a position off traversable ground raises
    a PlacementError naming it."""
    if robot_positions is None:
        if headings is not None:
            raise ArgumentError("headings need robot_positions")
        pos = spawn_positions(world.tin, world.steep, n_robots, rng, region=cfg.robots.spawn_region,
                              min_separation_m=cfg.robots.min_separation_m)
    else:
        pos = np.asarray(robot_positions, dtype=np.float64)
        if pos.shape != (n_robots, 2):
            raise ArgumentError(f"robot_positions must have shape ({n_robots}, 2), got {pos.shape}")
    tg, at = _entity_positions(world, cfg, rng, target_positions)
    return world.reset(rng, pos, headings, targets=tg, targets_mobile=cfg.targets.mobile, assets=at,
                       assets_mobile=cfg.assets.mobile)


def _entity_positions(world, cfg, rng, target_positions=None):
    """``(targets (m, 2), assets (k, 2))`` for a reset: ``target_positions`` when given."""
    region = cfg.robots.spawn_region
    if target_positions is None:
        tg = place_entities(world, cfg.targets, rng, spawn_region=region, label=f"{cfg.source} [targets]")
    else:
        tg = np.asarray(target_positions, float).reshape(-1, 2)
    at = place_entities(world, cfg.assets, rng, spawn_region=region, label=f"{cfg.source} [assets]")
    return tg, at


def assignments(n_robots: int, n_targets: int) -> np.ndarray:
    """Robot i's assigned target: ``i mod n_targets`` (-1 when there are none)."""
    if n_targets == 0:
        return np.full(n_robots, -1, dtype=np.int64)
    return np.arange(n_robots, dtype=np.int64) % n_targets
