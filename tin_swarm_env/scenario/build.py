"""Scenario config -> terrain, :class:`~tin_swarm_env.world.World` and initial states.

A :class:`Stage` is what one episode is played on: the world, the targets, the spawn region and
one cost-to-go field per target (:func:`~tin_swarm_env.terrain.cost_to_go` over the triangles
no steeper than the robots' ``max_slope_deg``). :func:`build_stage` makes it from a scenario: for
a file-given terrain the TIN comes from a per-process cache and the fields from
:func:`target_field`'s; for ``[terrain] source = "generated"`` it draws a task from the
generators (:mod:`.generators`), meshes it once and keeps the draw only when every target can be
reached from the spawn region (the generator draws again otherwise).

Solvability: a target that cannot be reached from any point of the spawn region is a
ScenarioError at load naming the file and the target. "Any point of the region" is checked on
the triangles that meet it: those with a vertex inside and those holding one of a 33 x 33 grid of
sample points (a sliver triangle missed by both does not count).
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import json
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import terrain as T
from ..errors import ArgumentError, DemFormatError, PlacementError, ScenarioError, TinFormatError, TinStructureError
from ..world import World, WorldState, spawn_positions
from .config import ScenarioConfig
from ._reflect import dem_bounds, mirror_task, mirror_tin
from .terrains import make_dem

__all__ = ["Stage", "build_tin_for", "build_world", "build_stage", "target_field", "reaches_region",
           "initial_state", "assignments", "place_entities", "spawn_reachable"]


@functools.lru_cache(maxsize=16)
def _cached_tin(key: str):
    spec = json.loads(key)
    if spec["mirror"]:  # the reflection of the cached original (:mod:`.mirror`)
        tin = _cached_tin(json.dumps({**spec, "mirror": ""}, sort_keys=True))
        return None if tin is None else mirror_tin(tin, spec["mirror"])
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
        with _naming(f"{where} [terrain] path"):
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
        with _naming(f"{where} [terrain] path"):
            dem = T.load_dem(p)
            if isinstance(dem, T.Dem) and dem.n_nodata:
                dem = dem.fill_nodata()
    keys = ", ".join(f"{k} = {spec[k]!r}" for k in ("method", "max_vertices", "max_error_m") if spec[k])
    with _naming(f"{where} [terrain] ({keys})"):
        return _mesh(dem, spec["method"], spec["max_vertices"], spec["max_error_m"], spec.get("max_slope_deg"))


@contextlib.contextmanager
def _naming(where: str):
    """Re-raise a terrain error (a DEM or TIN file's, a reduction's argument) with the scenario file
    and its ``[terrain]`` keys in front: the same class, so callers catching it still do."""
    try:
        yield
    except (DemFormatError, TinFormatError, TinStructureError, ArgumentError) as exc:
        if str(exc).startswith(where):
            raise
        raise type(exc)(f"{where}: {exc}") from None


def _mesh(dem, method: str, max_vertices: int, max_error_m: float, max_slope_deg: float | None = None):
    """The TIN of a DEM as a scenario's ``[terrain]`` asks for it (the one place these keys are read);
    methods "robot" and "trust" keep the slope class at the robots' ``max_slope_deg``."""
    kw = {}
    if max_vertices:
        kw["max_vertices"] = max_vertices
    if method in ("greedy", "robot", "trust") and max_error_m:
        kw["max_error_m"] = max_error_m
    if method in ("robot", "trust"):
        kw["max_slope_deg"] = max_slope_deg
    return T.build_tin(dem, method=method, **kw)


def _file_stamp(path: Path) -> list[int] | None:
    """(modification time ns, size) of a terrain file, None when it does not exist."""
    try:
        st = path.stat()
    except OSError:
        return None
    return [st.st_mtime_ns, st.st_size]


def build_tin_for(cfg: ScenarioConfig):
    """The scenario's TIN (None for a flat plane), built once per process and reused while the
    DEM/TIN file it comes from keeps its modification time and size (an edited file is re-read);
    ``[terrain] mirror`` reflects it (:func:`~.mirror.mirror_tin`, over its own bounds)."""
    t = cfg.terrain
    base = Path(cfg.base_dir).resolve()
    stamp = _file_stamp(base / t.path) if t.source in ("dem", "tin") else None
    key = json.dumps({"source": t.source, "recipe": t.recipe, "path": t.path, "method": t.method,
                      "max_vertices": t.max_vertices, "max_error_m": t.max_error_m, "params": t.params,
                      "max_slope_deg": cfg.world.robot.max_slope_deg if t.method in ("robot", "trust") else None,
                      "mirror": t.mirror,
                      "_where": cfg.source, "_base": str(base), "_stamp": stamp}, sort_keys=True)
    return _cached_tin(key)


@dataclass(frozen=True, eq=False)
class Stage:
    """What an episode is played on.

    world          the :class:`~tin_swarm_env.world.World` (terrain, breaks, break index)
    targets        (m, 2) m, the targets' start positions
    spawn_region   (x0, y0, x1, y1) m or None (the whole terrain)
    fields         one :class:`~tin_swarm_env.terrain.CostToGo` per target (its start position)
    task           the :class:`~.generators.GeneratedTask` drawn (None for a file-given terrain)
    """

    world: World
    targets: np.ndarray
    spawn_region: tuple[float, float, float, float] | None
    fields: tuple
    task: object = None


_FIELDS: collections.OrderedDict = collections.OrderedDict()  # (id(tin), max_slope_deg, x, y) -> CostToGo
_FIELDS_MAX = 64


def target_field(world: World, goal_xy):
    """The cost-to-go field of ``goal_xy`` (2,) m over ``world``'s passable triangles
    (``~world.steep``), from a small per-process cache (the last 64 fields; a hit must be for the
    very same TIN object), so scenarios whose TIN is cached build each field once per process."""
    g = np.asarray(goal_xy, dtype=np.float64).reshape(2)
    key = (id(world.tin), float(world.params.robot.max_slope_deg), float(g[0]), float(g[1]))
    f = _FIELDS.get(key)
    if f is None or f.tin is not world.tin:
        f = T.cost_to_go(world.tin, g, ~world.steep)
        _FIELDS[key] = f
        if len(_FIELDS) > _FIELDS_MAX:
            _FIELDS.popitem(last=False)
    else:
        _FIELDS.move_to_end(key)
    return f


def _region_triangles(tin, region) -> np.ndarray:
    """Indices of the triangles that meet the rectangle ``region`` (see the module docstring):
    the one sampling of "a point of the region" that :func:`reaches_region` and
    :func:`spawn_reachable` share."""
    x0, y0, x1, y1 = tin.bounds if region is None else region
    v = tin.vertices
    inside = (v[:, 0] >= x0) & (v[:, 0] <= x1) & (v[:, 1] >= y0) & (v[:, 1] <= y1)
    by_vertex = np.flatnonzero(inside[tin.triangles].any(axis=1))
    gx, gy = np.meshgrid(np.linspace(x0, x1, 33), np.linspace(y0, y1, 33))
    by_sample = tin.locate(np.column_stack([gx.ravel(), gy.ravel()]))
    return np.union1d(by_vertex, by_sample[by_sample >= 0])


def reaches_region(field, region) -> bool:
    """Whether ``field``'s goal can be reached from some point of ``region`` (x0, y0, x1, y1) m
    (None: anywhere on the TIN)."""
    return bool(field.triangle_reachable()[_region_triangles(field.tin, region)].any())


def _check_solvable(stage: Stage, where: str, max_slope_deg: float) -> None:
    for k, f in enumerate(stage.fields):
        if not reaches_region(f, stage.spawn_region):
            region = "the whole terrain" if stage.spawn_region is None else f"spawn_region {list(stage.spawn_region)}"
            raise ScenarioError(f"{where} [targets] positions[{k}] {stage.targets[k].tolist()}: cannot be reached "
                                f"from any point of {region} over ground no steeper than {max_slope_deg} deg")


def build_stage(cfg: ScenarioConfig, rng: np.random.Generator | None = None) -> Stage:
    """The scenario's :class:`Stage`. Targets and assets must stand on traversable ground and
    every target must be reachable from the spawn region (a ScenarioError names the file, the
    table and the position's index). A generated terrain is drawn from ``rng`` (default: from the
    scenario's seed, 0 when it has none)."""
    if cfg.terrain.source == "generated":
        return _generated_stage(cfg, np.random.default_rng(cfg.seed or 0) if rng is None else rng)
    world = World(build_tin_for(cfg), cfg.world)
    for what, spec in (("targets", cfg.targets), ("assets", cfg.assets)):
        try:
            world.check_placement(_positions(spec), f"{cfg.source} [{what}] positions[{{i}}]")
            place_entities(world, spec, np.random.default_rng(0), spawn_region=cfg.robots.spawn_region,
                           label=f"{cfg.source} [{what}]")
        except PlacementError as exc:
            raise ScenarioError(str(exc)) from None
    targets = _positions(cfg.targets)
    stage = Stage(world, targets, cfg.robots.spawn_region, tuple(target_field(world, t) for t in targets))
    _check_solvable(stage, cfg.source, cfg.world.robot.max_slope_deg)
    return stage


def _generated_stage(cfg: ScenarioConfig, rng: np.random.Generator) -> Stage:
    """Draw a solvable generated task; the TIN and fields made by the check are the ones kept. A task
    that draws the robots' slope limit (``params["max_slope_deg"]``, realdem) is meshed and its world
    built with that limit; one that promises a detour (``detour_min``) is kept only if its field keeps it."""
    from .generators import ALL_FAMILIES, generate

    t = cfg.terrain
    max_slope = cfg.world.robot.max_slope_deg
    made = {}

    def solvable(drawn) -> bool:  # meshed as drawn, then reflected with its task when [terrain] mirror asks
        slope = float(drawn.params.get("max_slope_deg", max_slope))  # realdem draws the robots' limit per task
        tin = mirror_tin(_mesh(drawn.dem, t.method, t.max_vertices, t.max_error_m, slope), t.mirror,
                         dem_bounds(drawn.dem))
        task = mirror_task(drawn, t.mirror)
        world = World(tin, cfg.world if slope == max_slope else dataclasses.replace(
            cfg.world, robot=dataclasses.replace(cfg.world.robot, max_slope_deg=slope)))
        fields = tuple(T.cost_to_go(world.tin, g, ~world.steep) for g in task.targets)
        made["drawn"], made["task"], made["world"], made["fields"] = drawn, task, world, fields
        return all(reaches_region(f, task.spawn_region) and _detour_holds(f, task) for f in fields)

    drawn = generate(rng, t.families or ALL_FAMILIES, t.ranges, max_slope_deg=max_slope, solvable=solvable,
                     where=f"{cfg.source} [terrain]")
    assert made["drawn"] is drawn  # generate returns the draw the check accepted last
    task = made["task"]
    return Stage(made["world"], np.asarray(task.targets, dtype=float).reshape(-1, 2), task.spawn_region,
                 made["fields"], task)


def _detour_holds(field, task) -> bool:
    """Whether the drivable way from the task's spawn centre to ``field``'s goal is at least
    ``task.detour_min`` times the straight line (always, for a task that promises none)."""
    if task.detour_min <= 1.0:
        return True
    way = float(field.distance_at(task.spawn_centre[None])[0])
    return bool(np.isfinite(way) and way >= task.detour_min * float(np.hypot(*(field.goal_xy - task.spawn_centre))))


def build_world(cfg: ScenarioConfig) -> World:
    """The scenario's world (:func:`build_stage`'s, with the same checks)."""
    return build_stage(cfg).world


_REACHABLE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # world -> {spawn region: (T,) bool}


def spawn_reachable(world: World, spawn_region=None) -> np.ndarray:
    """``(T,)`` bool: traversable triangles from which some point of the spawn region (m;
    None: the whole terrain) can be reached by a drivable path. Drivable connection is
    symmetric, so these are the triangles a target may stand on and be reached from there:
    the union of :meth:`~tin_swarm_env.terrain.CostToGo.triangle_reachable` from the traversable
    triangles that meet the region (:func:`_region_triangles`, the sampling :func:`reaches_region`
    uses; one field per connected piece they touch; cached per world and region)."""
    cache = _REACHABLE.setdefault(world, {})
    key = None if spawn_region is None else tuple(float(v) for v in spawn_region)
    if key in cache:
        return cache[key]
    tin, passable = world.tin, ~world.steep
    centroids = tin.vertices[tin.triangles, :2].mean(axis=1)  # (T, 2): a point of each triangle
    out = np.zeros(tin.n_triangles, dtype=bool)
    for t in _region_triangles(tin, key):
        if passable[t] and not out[t]:  # all of a triangle's points reach the same places
            out |= T.cost_to_go(tin, centroids[t], passable, steiner_per_edge=0, any_angle=False).triangle_reachable()
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
                  robot_positions=None, headings=None, target_positions=None, spawn_region=None,
                  reachable=None) -> WorldState:
    """The generator: robots spawned uniformly (from ``rng``) in the spawn region on traversable
    ground, then targets and assets where the scenario puts them or, for a ``count``, drawn
    from ``rng`` (:func:`place_entities`). ``robot_positions (n, 2)`` (with
    optional ``headings (n,)``) and ``target_positions (m, 2)`` replace the spawned robots and
    the scenario's targets (the env's reset options); a position off traversable ground raises
    a PlacementError naming it. ``spawn_region`` replaces the scenario's (a generated task's);
    ``reachable (m, T)`` bool, per target the triangles it can be reached from: robot ``i``
    spawns only where its assigned target (:func:`assignments`) can be reached."""
    region = cfg.robots.spawn_region if spawn_region is None else spawn_region
    if robot_positions is None:
        if headings is not None:
            raise ArgumentError("headings need robot_positions")
        groups = None
        if reachable is not None and len(reachable):
            groups = assignments(n_robots, len(reachable))
        try:
            pos = spawn_positions(world.tin, world.steep, n_robots, rng, region=region,
                                  min_separation_m=cfg.robots.min_separation_m,
                                  allowed=reachable if groups is not None else None, groups=groups)
        except PlacementError as e:  # say which knobs make room
            raise PlacementError(f"{e}: place fewer robots (n_robots), widen the spawn region ([robots] "
                                 "spawn_region; a generated terrain's: [terrain] ranges spawn_m) or lower "
                                 "[robots] min_separation_m") from None
    else:
        pos = np.asarray(robot_positions, dtype=np.float64)
        if pos.shape != (n_robots, 2):
            raise ArgumentError(f"robot_positions must have shape ({n_robots}, 2), got {pos.shape}")
    tg, at = _entity_positions(world, cfg, rng, region, target_positions)
    return world.reset(rng, pos, headings, targets=tg, targets_mobile=cfg.targets.mobile, assets=at,
                       assets_mobile=cfg.assets.mobile)


def _entity_positions(world, cfg, rng, region, target_positions=None):
    """``(targets (m, 2), assets (k, 2))`` for a reset: ``target_positions`` when given; counted
    ones reachable from the spawn ``region`` the robots use (a generated task's own)."""
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
