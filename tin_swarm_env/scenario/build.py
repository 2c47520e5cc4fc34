"""Scenario config -> terrain, :class:`~tin_swarm_env.world.World` and initial states."""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np

from .. import terrain as T
from ..world import World, WorldState, spawn_positions
from .config import ScenarioConfig, ScenarioError
from .terrains import make_dem

__all__ = ["build_tin_for", "build_world", "initial_state", "assignments"]


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
    world = World(build_tin_for(cfg), cfg.world)
    _check_entities(world, cfg)
    return world


def _check_entities(world: World, cfg: ScenarioConfig):
    for what, spec in (("targets", cfg.targets), ("assets", cfg.assets)):
        if not spec.positions:
            continue
        p = np.asarray(spec.positions, dtype=float)
        tri = world.tin.locate(p)
        for i in range(len(p)):  # a handful of entities, checked once per scenario
            if tri[i] < 0:
                raise ScenarioError(f"{cfg.source} [{what}] positions[{i}] = {p[i].tolist()} lies outside the "
                                    f"terrain (bounds {tuple(round(b, 1) for b in world.tin.bounds)})")
            if world.steep[tri[i]]:
                raise ScenarioError(f"{cfg.source} [{what}] positions[{i}] = {p[i].tolist()} lies inside a "
                                    f"too-steep (cliff) triangle ({world.tin.slope_deg[tri[i]]:.0f} deg)")


def initial_state(world: World, cfg: ScenarioConfig, rng: np.random.Generator, n_robots: int) -> WorldState:
    """Robots spawned uniformly (from ``rng``) in the spawn region on traversable ground,
    targets and assets where the scenario puts them."""
    pos = spawn_positions(world.tin, world.steep, n_robots, rng, region=cfg.robots.spawn_region,
                          min_separation_m=cfg.robots.min_separation_m)
    tg = np.asarray(cfg.targets.positions, dtype=float).reshape(-1, 2) if cfg.targets.positions else None
    at = np.asarray(cfg.assets.positions, dtype=float).reshape(-1, 2) if cfg.assets.positions else None
    return world.reset(rng, pos, targets=tg, targets_mobile=cfg.targets.mobile, assets=at,
                       assets_mobile=cfg.assets.mobile)


def assignments(n_robots: int, n_targets: int) -> np.ndarray:
    """Robot i's assigned target: ``i mod n_targets`` (-1 when there are none)."""
    if n_targets == 0:
        return np.full(n_robots, -1, dtype=np.int64)
    return np.arange(n_robots, dtype=np.int64) % n_targets
