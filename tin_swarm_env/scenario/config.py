"""Scenario configuration: TOML files -> frozen dataclasses.

Every key maps onto one dataclass field; an unknown key, a wrong type, or a missing required
value raises :class:`ScenarioError` naming the file and the key (``[robots] cuont``).

Layout of a scenario file (every table and key optional except ``terrain.source``)::

    name = "cliff_goal"
    task = "goal"                 # "goal" (reach an assigned target) or "containment"
    max_cycles = 400
    seed = 0

    [terrain]
    source = "procedural"         # "procedural" | "sample" | "dem" | "tin" | "flat" | "generated"
    recipe = "cliff_goal"         # procedural recipe name (see scenario/terrains.py)
    path = ""                     # DEM/TIN file (relative to the scenario file) or sample name
    method = "greedy"             # reduction for a DEM: "vip" | "greedy" | "delaunay"
    max_vertices = 0              # 0: not set
    max_error_m = 0.5
    size_m = [500.0, 500.0]       # flat plane / procedural extent
    params = {}                   # recipe parameters
    # source = "generated" (seeded task generators, scenario/generators.py):
    families = ["canyon", "fork"]  # or {canyon = 2, mesa = 1}: weights; default all (generators.ALL_FAMILIES)
    ranges = {}                   # per-family parameter ranges, e.g. {canyon = {cliff_m = [8, 12]}}
    resample = "reset"            # "reset": a new terrain on every reset(seed); "once": one, from seed

    [robots]
    count = 20
    spawn_region = [x0, y0, x1, y1]  # m; default: the whole terrain
    min_separation_m = 2.0
    # any RobotParams field: radius_m, max_speed_mps, turn_rate_dps, max_slope_deg, max_climb_deg

    [sensor]     # SensorParams fields
    [battery]    # BatteryParams fields
    [world]      # dt_s, entity_height_m, entity_speed_mps, entity_turn_sd_deg, break_angle_deg

    [targets]    # threats/targets: positions, or count (+ region) drawn by the reset seed
    positions = [[x, y], ...]
    count = 0                     # N > 0: N targets drawn from reset(seed) (not with positions)
    region = [x0, y0, x1, y1]     # m, where counted ones are drawn; default: the whole terrain
    min_separation_m = 10.0       # between counted ones
    mobile = false
    standoff_m = 0.0              # containment: ring radius; goal: 0
    arrival_radius_m = 5.0

    [assets]     # things the swarm guards (positions or count/region/min_separation_m, as targets)
    positions = [[x, y], ...]
    mobile = false
    standoff_m = 0.0              # the guard ring's radius (the APF's asset field)

    [rewards]    # RewardWeights fields; progress = "geodesic" | "euclidean"
    [observation]  # k_robots, k_targets, k_breaks, k_assets
"""

from __future__ import annotations

import dataclasses
import os
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser from PyPI
    import tomli as tomllib

from ..errors import ParameterError, ScenarioError, check_fields, check_range
from ..world import BatteryParams, RobotParams, SensorParams, WorldParams
from .generators import ALL_FAMILIES, family_weights, validate_ranges

__all__ = ["ScenarioError", "TerrainSpec", "RobotsSpec", "EntitiesSpec", "RewardWeights", "ObservationSpec",
           "ScenarioConfig", "load_scenario", "scenario_from_dict", "SCENARIO_DIR", "list_scenarios",
           "MAX_ROBOTS", "scenario_file"]

SCENARIO_DIR = Path(__file__).with_name("builtin")

MAX_ROBOTS = 100_000  # robots.count and n_robots: beyond this the per-robot arrays and names exhaust memory
MAX_SLOTS = 256  # k_robots, k_targets, k_breaks: observation slots per kind
MAX_ENTITIES = 10_000  # targets/assets count drawn per reset
_POS = {"lo": 0, "lo_open": True}  # check_range limits: a finite number > 0
_NONNEG = {"lo": 0}  # >= 0
_FINITE: dict = {}  # any finite number


def _check_region(spec, key: str) -> None:
    """Raise :class:`ParameterError` unless ``spec.<key>`` is None or ``[x0, y0, x1, y1]`` (m), finite,
    with x0 < x1 and y0 < y1 (the one check behind every region of a scenario)."""
    region = getattr(spec, key)
    if region is None:
        return
    where = type(spec).__name__
    for i, v in enumerate(region):
        check_range(where, f"{key}[{i}]", v)
    if len(region) != 4 or not (region[0] < region[2] and region[1] < region[3]):
        raise ParameterError(f"{where}.{key} must be [x0, y0, x1, y1] with x0 < x1 and y0 < y1, got {list(region)}")


@dataclass(frozen=True)
class TerrainSpec:
    source: str = "flat"
    recipe: str = ""
    path: str = ""
    method: str = "greedy"
    max_vertices: int = 0
    max_error_m: float = 0.5
    size_m: tuple[float, float] = (500.0, 500.0)
    params: dict = field(default_factory=dict)
    families: tuple[str, ...] | dict = ()  # generated: family names or {name: weight}; () = all
    ranges: dict = field(default_factory=dict)  # generated: {family: {parameter: [lo, hi] | choices}}
    resample: str = "reset"  # generated: "reset" (new terrain every reset(seed)) or "once"

    def __post_init__(self):  # validation only (see _check_terrain)
        _check_terrain(self)


@dataclass(frozen=True)
class RobotsSpec:
    count: int = 10
    spawn_region: tuple[float, float, float, float] | None = None
    min_separation_m: float = 2.0

    def __post_init__(self):
        check_fields(self, {"count": {"lo": 1, "hi": MAX_ROBOTS, "integer": True}, "min_separation_m": _NONNEG})
        _check_region(self, "spawn_region")


@dataclass(frozen=True)
class EntitiesSpec:
    """Threats/targets or assets: fixed ``positions``, or ``count`` of them drawn at every reset
    from the reset seed inside ``region`` (m; default the whole terrain) on traversable ground,
    at least ``min_separation_m`` apart and reachable from the robots' spawn region
    (:func:`tin_swarm_env.scenario.build.place_entities`). Not both."""

    positions: tuple[tuple[float, float], ...] = ()
    count: int = 0
    region: tuple[float, float, float, float] | None = None
    min_separation_m: float = 10.0
    mobile: bool = False
    standoff_m: float = 0.0
    arrival_radius_m: float = 5.0

    def __post_init__(self):
        check_fields(self, {"count": {"lo": 0, "hi": MAX_ENTITIES, "integer": True}, "standoff_m": _NONNEG,
                            "arrival_radius_m": _POS, "min_separation_m": _NONNEG})
        for i, xy in enumerate(self.positions):
            for j, v in enumerate(xy):
                check_range("EntitiesSpec", f"positions[{i}][{j}]", v)
        if self.count and self.positions:
            raise ParameterError("EntitiesSpec: give 'positions' or 'count', not both")
        _check_region(self, "region")

    @property
    def n(self) -> int:
        """How many there are: ``count`` or the number of ``positions``."""
        return self.count or len(self.positions)


@dataclass(frozen=True)
class RewardWeights:
    """Per-robot reward = progress_per_m * (metres gained toward the goal or standoff ring)
    + arrival (once, goal task) + on_ring_per_step (containment, within ring_tolerance_m)
    + fall (once) + battery_empty (once) + collision * (robots touched this step)
    + energy_per_kj * (kJ drawn this step).

    ``progress`` says how the metres are measured: "geodesic" (default) by the length of the
    shortest drivable path (:func:`~tin_swarm_env.terrain.cost_to_go` over the triangles no
    steeper than the robots' ``max_slope_deg``), "euclidean" by the straight line (see
    :mod:`tin_swarm_env.env.reward`)."""

    progress: str = "geodesic"
    progress_per_m: float = 1.0
    arrival: float = 10.0
    on_ring_per_step: float = 0.1
    ring_tolerance_m: float = 2.0
    fall: float = -100.0
    battery_empty: float = -5.0
    collision: float = -1.0
    energy_per_kj: float = -1.0

    def __post_init__(self):
        if self.progress not in ("geodesic", "euclidean"):
            raise ParameterError(f"RewardWeights.progress must be 'geodesic' or 'euclidean', got {self.progress!r}")
        check_fields(self, {f.name: (_NONNEG if f.name.endswith("_m") else _FINITE)
                            for f in dataclasses.fields(self) if f.type in (float, "float")})


@dataclass(frozen=True)
class ObservationSpec:
    """Slot counts of the observation (the only place they are written;
    :class:`~tin_swarm_env.env.observation.ObsLayout` is built from it)."""

    k_robots: int = 4
    k_targets: int = 2
    k_breaks: int = 3
    k_assets: int | None = None  # None: 2 when the scenario has assets, else 0 (ObsLayout.from_spec)

    def __post_init__(self):
        check_fields(self, {k: {"lo": 0, "hi": MAX_SLOTS, "integer": True} for k in ("k_robots", "k_targets",
                                                                                    "k_breaks")})


@dataclass(frozen=True)
class ScenarioConfig:
    name: str = "custom"
    task: str = "goal"
    max_cycles: int = 400
    seed: int | None = None
    terrain: TerrainSpec = field(default_factory=TerrainSpec)
    robots: RobotsSpec = field(default_factory=RobotsSpec)
    world: WorldParams = field(default_factory=WorldParams)
    targets: EntitiesSpec = field(default_factory=EntitiesSpec)
    assets: EntitiesSpec = field(default_factory=EntitiesSpec)
    rewards: RewardWeights = field(default_factory=RewardWeights)
    observation: ObservationSpec = field(default_factory=ObservationSpec)
    base_dir: str = "."  # where relative terrain paths are resolved
    source: str = "<dict>"  # the file it came from, for messages

    def __post_init__(self):
        if self.task not in ("goal", "containment"):
            raise ScenarioError(f"scenario {self.name!r}: task must be 'goal' or 'containment', got {self.task!r}")
        if not (isinstance(self.max_cycles, int) and self.max_cycles > 0):
            raise ScenarioError(
                f"scenario {self.name!r}: max_cycles must be a positive integer, got {self.max_cycles!r}")
        if self.seed is not None:
            check_range("ScenarioConfig", "seed", self.seed, 0, integer=True, exc=ScenarioError)
        cand, obs = self.world.sensor.max_candidates, self.observation
        if cand < max(obs.k_robots, obs.k_targets):
            raise ScenarioError(f"scenario {self.name!r}: sensor.max_candidates ({cand}) must be >= "
                                f"observation.k_robots ({obs.k_robots}) and k_targets ({obs.k_targets})")
        if self.robots.count < 1:
            raise ScenarioError(f"scenario {self.name!r}: robots.count must be >= 1, got {self.robots.count}")
        if self.task == "goal" and self.targets.n == 0 and self.terrain.source != "generated":
            raise ScenarioError(f"scenario {self.name!r}: the goal task needs at least one target (positions or count)")

    def replace(self, **kw) -> ScenarioConfig:
        return dataclasses.replace(self, **kw)


def _check_terrain(t: TerrainSpec) -> None:
    """The numbers of a [terrain] table (recipe parameters are checked by make_dem)."""
    check_fields(t, {"max_vertices": {"lo": 0, "integer": True}, "max_error_m": _NONNEG})
    if len(t.size_m) != 2:
        raise ParameterError(f"TerrainSpec.size_m must be (width, height), got {t.size_m!r}")
    for i, v in enumerate(t.size_m):
        check_range("TerrainSpec", f"size_m[{i}]", v, 0, lo_open=True)


# -- parsing ------------------------------------------------------------------------------------

_ROBOT_KEYS = {f.name for f in dataclasses.fields(RobotParams)}
_RSPEC_KEYS = {f.name for f in dataclasses.fields(RobotsSpec)}
# [world] takes WorldParams' own settings: not the robot/sensor/battery models (their own tables)
# nor flat_size_m (the [terrain] table's size_m)
_WORLD_KEYS = {f.name for f in dataclasses.fields(WorldParams)} - {"robot", "sensor", "battery", "flat_size_m"}
_TOP_KEYS = {f.name for f in dataclasses.fields(ScenarioConfig)} - {"world", "base_dir", "source"} | {
    "sensor", "battery", "world", "description"}


def _typed(where: str, key: str, value, t):
    """Check ``value`` against the (resolved) type ``t`` of a dataclass field: float, int, bool,
    str, dict, ``X | None``, ``tuple[float, ...n]`` and ``tuple[tuple[float, float], ...]``."""
    origin, args = typing.get_origin(t), typing.get_args(t)
    if origin in (typing.Union, types.UnionType) and type(None) in args:
        inner = [a for a in args if a is not type(None)]
        return None if value is None else _typed(where, key, value, inner[0])
    if t is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(f"{where}: '{key}' must be a number, got {value!r}")
        return float(value)
    if t in (int, bool, str):
        kind = {int: "an integer", bool: "true or false", str: "a string"}[t]
        if not isinstance(value, t) or (t is int and isinstance(value, bool)):
            raise ScenarioError(f"{where}: '{key}' must be {kind}, got {value!r}")
        return value
    if t is dict or origin is dict:
        if not isinstance(value, dict):
            raise ScenarioError(f"{where}: '{key}' must be a table, got {value!r}")
        return dict(value)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        if not isinstance(value, list):
            raise ScenarioError(f"{where}: '{key}' must be a list of [x, y] pairs, got {value!r}")
        return tuple(_typed(where, f"{key}[{i}]", v, args[0]) for i, v in enumerate(value))
    if origin is tuple and all(a is float for a in args):
        return _floats(where, key, value, len(args))
    raise TypeError(f"{where}: no check for the type {t!r} of '{key}'")  # a new field type: add it here


def _floats(where, key, value, n):
    if not isinstance(value, (list, tuple)) or len(value) != n or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        raise ScenarioError(f"{where}: '{key}' must be a list of {n} numbers, got {value!r}")
    return tuple(float(v) for v in value)


def _build(cls, table: dict, where: str, allowed: set | None = None, **extra):
    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: must be a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    allowed = set(hints) if allowed is None else allowed
    kw = dict(extra)
    for k, v in table.items():
        if k not in allowed:
            raise ScenarioError(f"{where}: unknown key '{k}' (known: {', '.join(sorted(allowed))})")
        kw[k] = _typed(where, k, v, hints[k])
    try:
        return cls(**kw)
    except ScenarioError:
        raise
    except (TypeError, ValueError) as exc:
        raise ScenarioError(f"{where}: {exc}") from None


def scenario_from_dict(d: dict, source: str = "<dict>", base_dir: str = ".") -> ScenarioConfig:
    """Build a :class:`ScenarioConfig` from a parsed TOML document (``source`` names it in errors)."""
    for k in d:
        if k not in _TOP_KEYS:
            raise ScenarioError(f"{source}: unknown key '{k}' (known: {', '.join(sorted(_TOP_KEYS))})")
    robots_t = dict(d.get("robots", {}))
    robot_params = {k: robots_t.pop(k) for k in list(robots_t) if k in _ROBOT_KEYS}
    robot = _build(RobotParams, robot_params, f"{source} [robots]")
    rspec = _build(RobotsSpec, robots_t, f"{source} [robots]", allowed=_RSPEC_KEYS)
    sensor = _build(SensorParams, d.get("sensor", {}), f"{source} [sensor]")
    battery = _build(BatteryParams, d.get("battery", {}), f"{source} [battery]")
    terrain_t, families = d.get("terrain", {}), ()
    if isinstance(terrain_t, dict) and "families" in terrain_t:  # a list or a table: checked by _families
        terrain_t = dict(terrain_t)
        families = _families(terrain_t.pop("families"), f"{source} [terrain]")
    terrain = _build(TerrainSpec, terrain_t, f"{source} [terrain]", families=families)
    if terrain.source not in _SOURCES:
        raise ScenarioError(f"{source} [terrain]: 'source' must be {', '.join(_SOURCES)}, got {terrain.source!r}")
    world = _build(WorldParams, d.get("world", {}), f"{source} [world]", allowed=_WORLD_KEYS,
                   robot=robot, sensor=sensor, battery=battery, flat_size_m=terrain.size_m)
    targets = _build(EntitiesSpec, d.get("targets", {}), f"{source} [targets]")
    assets = _build(EntitiesSpec, d.get("assets", {}), f"{source} [assets]",
                    allowed={"positions", "count", "region", "min_separation_m", "mobile", "standoff_m"})
    rewards = _build(RewardWeights, d.get("rewards", {}), f"{source} [rewards]")
    obs = _build(ObservationSpec, d.get("observation", {}), f"{source} [observation]")
    if terrain.source == "generated":
        _check_generated(terrain, rspec, targets, d.get("task", "goal"), source)
    hints = typing.get_type_hints(ScenarioConfig)
    top = {k: _typed(source, k, d[k], hints[k]) for k in ("name", "task", "max_cycles", "seed") if k in d}
    try:
        return ScenarioConfig(terrain=terrain, robots=rspec, world=world, targets=targets, assets=assets,
                              rewards=rewards, observation=obs, base_dir=base_dir, source=source, **top)
    except ScenarioError as exc:
        raise ScenarioError(f"{source}: {exc}") from None


_SOURCES = ("procedural", "sample", "dem", "tin", "flat", "generated")


def _families(value, where):
    """``[terrain] families``: a list of names (a tuple) or a table of weights (a dict)."""
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return tuple(value)
    if isinstance(value, dict):
        return dict(value)
    raise ScenarioError(f"{where}: 'families' must be a list of family names or a table of weights, got {value!r}")


def _check_generated(terrain: TerrainSpec, robots: RobotsSpec, targets: EntitiesSpec, task, source):
    """A generated terrain brings its own target and spawn region; its families, ranges and
    ``resample`` are checked here, at load, so that errors name the file."""
    where = f"{source} [terrain]"
    names, _ = family_weights(terrain.families or ALL_FAMILIES, where)
    validate_ranges(terrain.ranges, names, f"{where} ranges")
    if terrain.resample not in ("reset", "once"):
        raise ScenarioError(f"{where}: 'resample' must be 'reset' or 'once', got {terrain.resample!r}")
    if task != "goal":
        raise ScenarioError(f"{where}: a generated terrain is a goal task; 'task' must be 'goal', got {task!r}")
    if targets.positions or targets.count:
        raise ScenarioError(f"{source} [targets]: 'positions' and 'count' must be empty with a generated terrain "
                            "(the generator places the target)")
    if robots.spawn_region is not None:
        raise ScenarioError(f"{source} [robots]: 'spawn_region' must not be set with a generated terrain "
                            "(the generator draws it)")


def list_scenarios() -> dict[str, str]:
    """Built-in scenario names -> their one-line description."""
    out = {}
    for p in sorted(SCENARIO_DIR.glob("*.toml")):
        with open(p, "rb") as fh:
            out[p.stem] = tomllib.load(fh).get("description", "")
    return out


def scenario_file(name: str) -> Path:
    """The TOML file of the built-in scenario ``name`` (ScenarioError listing the names if none)."""
    p = SCENARIO_DIR / f"{name}.toml"
    if os.sep in name or "/" in name or not p.is_file():
        raise ScenarioError(f"unknown scenario {name!r}; built-in: {', '.join(sorted(list_scenarios()))}, "
                            "or give a path to a .toml file")
    return p


def load_scenario(name_or_path) -> ScenarioConfig:
    """A built-in scenario by name (``"cliff_goal"``) or a TOML file by path."""
    s = os.fspath(name_or_path)
    p = Path(s)
    if not (s.endswith(".toml") or os.sep in s or p.exists()):
        p = scenario_file(s)
    if not p.exists():
        raise ScenarioError(f"{p}: no such scenario file")
    try:
        with open(p, "rb") as fh:
            d = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: not valid TOML ({exc})") from None
    d.setdefault("name", p.stem)
    return scenario_from_dict(d, source=str(p), base_dir=str(p.parent))
