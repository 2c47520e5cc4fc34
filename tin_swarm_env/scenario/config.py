"""Scenario configuration: TOML files -> frozen dataclasses.

Every key maps onto one dataclass field; an unknown key, a wrong type, or a missing required
value raises :class:`ScenarioError` naming the file and the key (``[robots] cuont``).

Each table maps onto one dataclass, whose docstring lists its keys (the documentation's scenario
keys page is generated from those lists); every table and key is optional except
``[terrain] source``::

    (top level)    ScenarioConfig (name, task, max_cycles, seed) and description, the line
                   ``tin-swarm scenarios`` shows
    [terrain]      TerrainSpec
    [robots]       RobotsSpec and every RobotParams field
    [sensor]       SensorParams
    [battery]      BatteryParams
    [world]        WorldParams, less its robot/sensor/battery models and flat_size_m ([terrain] size_m)
    [targets]      EntitiesSpec: threats/targets, by positions or by a count drawn at each reset
    [assets]       EntitiesSpec less arrival_radius_m: what the swarm guards
    [rewards]      RewardWeights
    [observation]  ObservationSpec

A small file::

    name = "crossing"
    task = "goal"
    max_cycles = 400

    [terrain]
    source = "flat"
    size_m = [300.0, 300.0]

    [robots]
    count = 10
    spawn_region = [10.0, 10.0, 60.0, 60.0]

    [targets]
    positions = [[250.0, 250.0]]
"""

from __future__ import annotations

import dataclasses
import numbers
import os
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser from PyPI
    import tomli as tomllib

from ..errors import ParameterError, ScenarioError, check_fields, check_range
from ..world import BatteryParams, RobotParams, SensorParams, WorldParams
from .generators import ALL_FAMILIES, family_weights, validate_ranges
from ._reflect import MIRRORS

__all__ = ["ScenarioError", "TerrainSpec", "RobotsSpec", "EntitiesSpec", "RewardWeights", "ObservationSpec",
           "ScenarioConfig", "load_scenario", "scenario_from_dict", "SCENARIO_DIR", "list_scenarios",
           "MAX_ROBOTS", "scenario_file", "DEFAULT_K_SCAN"]

SCENARIO_DIR = Path(__file__).with_name("builtin")

MAX_ROBOTS = 100_000  # robots.count and n_robots: beyond this the per-robot arrays and names exhaust memory
# The terrain scan's beams in the default observation: 32, chosen by measurement. APF's chart search with 32 beams
# brings >= 97.5% of the robots in on every generated family (docs/figures/apf_scan32.md, apf_seeds100_scan32.md);
# research/sensing_bound.md compares beam counts. The scan costs about a fifth of the env's batched rate (env_scan.md).
DEFAULT_K_SCAN = 32
MAX_SLOTS = 256  # k_robots, k_targets, k_breaks, k_scan: observation slots (beams) per kind
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
    """The ``[terrain]`` table: where the terrain comes from.

    source          "procedural" | "sample" | "dem" | "tin" | "flat" | "generated"
    recipe          procedural recipe name (:mod:`tin_swarm_env.scenario.terrains`)
    path            DEM or TIN file (relative to the scenario file), or a sample DEM's name
    method          reduction of a DEM: "vip" | "greedy" | "delaunay" | "robot" | "trust" (these two: the
                    robots' max_slope_deg)
    max_vertices    vertex budget of the reduction; 0: not set
    max_error_m     vertical error the greedy reduction may leave
    size_m          (width, height) of a flat plane or a procedural terrain, m
    params          recipe parameters, e.g. ``{cell = 2.0}``
    families        generated: family names, or ``{name = weight}``; empty: the synthetic ones
                    (:data:`~tin_swarm_env.scenario.generators.ALL_FAMILIES`; ``realdem``, crops
                    of real DEMs, and ``bay`` and ``rough`` are drawn only where named)
    ranges          generated: per-family parameter ranges, ``{family = {parameter = [lo, hi] or choices}}``
    resample        generated: "reset" (a new terrain on every ``reset(seed)``) or "once" (one, from
                    the scenario's seed)
    mirror          "" (as built), "ns" (north-south flip), "ew" (east-west flip) or "both": the terrain
                    reflected across its middle (:mod:`tin_swarm_env.scenario.mirror`); the file's
                    positions are in the reflected frame (``mirror_scenario`` reflects them too)
    """

    source: str = "flat"
    recipe: str = ""
    path: str = ""
    method: str = "greedy"
    max_vertices: int = 0
    max_error_m: float = 0.5
    size_m: tuple[float, float] = (500.0, 500.0)
    params: dict = field(default_factory=dict)
    families: tuple[str, ...] | dict = ()
    ranges: dict = field(default_factory=dict)
    resample: str = "reset"
    mirror: str = ""

    def __post_init__(self):  # types normalised (lists -> tuples), then the values (see _check_terrain)
        if isinstance(self.families, (list, dict)) and not self.families:
            raise ParameterError("TerrainSpec.families is empty; name at least one family (leave it out for all)")
        _check_types(self)
        _check_terrain(self)


@dataclass(frozen=True)
class RobotsSpec:
    """The ``[robots]`` table's swarm keys (the table also takes every
    :class:`~tin_swarm_env.world.RobotParams` field).

    count             how many robots
    spawn_region      ``[x0, y0, x1, y1]`` m where they start; default: the whole terrain
    min_separation_m  least distance between two robots at the start
    """

    count: int = 10
    spawn_region: tuple[float, float, float, float] | None = None
    min_separation_m: float = 2.0

    def __post_init__(self):
        _check_types(self)
        check_fields(self, {"count": {"lo": 1, "hi": MAX_ROBOTS, "integer": True}, "min_separation_m": _NONNEG})
        _check_region(self, "spawn_region")


@dataclass(frozen=True)
class EntitiesSpec:
    """Threats/targets or assets: fixed ``positions``, or ``count`` of them drawn at every reset
    from the reset seed inside ``region`` (m; default the whole terrain) on traversable ground,
    at least ``min_separation_m`` apart and reachable from the robots' spawn region
    (:func:`tin_swarm_env.scenario.build.place_entities`). Not both.

    positions         ``[[x, y], ...]`` m
    count             N > 0: N of them drawn from the reset seed (not with ``positions``)
    region            ``[x0, y0, x1, y1]`` m where counted ones are drawn; default: the whole terrain
    min_separation_m  least distance between counted ones
    mobile            whether they wander (a random walk, :class:`~tin_swarm_env.world.WorldParams`)
    standoff_m        targets: the containment task's ring radius (0 for the goal task); assets:
                      the guard ring the APF's asset field draws robots to
    arrival_radius_m  goal task: a robot this close to its target has arrived (targets only)
    """

    positions: tuple[tuple[float, float], ...] = ()
    count: int = 0
    region: tuple[float, float, float, float] | None = None
    min_separation_m: float = 10.0
    mobile: bool = False
    standoff_m: float = 0.0
    arrival_radius_m: float = 5.0

    def __post_init__(self):
        _check_types(self)
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
    """The ``[rewards]`` table: the weights of the per-robot reward (what each term pays for is
    :mod:`tin_swarm_env.env.reward`).

    progress          how the metres of progress are measured: "geodesic" (the shortest drivable
                      path) or "euclidean" (the straight line)
    progress_per_m    per metre gained toward the target (goal) or the standoff ring (containment)
    arrival           once, on reaching the target (goal task)
    on_ring_per_step  per step within ``ring_tolerance_m`` of the ring (containment)
    ring_tolerance_m  how near the ring counts as on it, m
    fall              once, on falling
    battery_empty     once, when the battery runs out
    collision         per robot touched this step
    energy_per_kj     per kJ drawn this step
    """

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
        _check_types(self)
        if self.progress not in ("geodesic", "euclidean"):
            raise ParameterError(f"RewardWeights.progress must be 'geodesic' or 'euclidean', got {self.progress!r}")
        check_fields(self, {f.name: (_NONNEG if f.name.endswith("_m") else _FINITE)
                            for f in dataclasses.fields(self) if f.type in (float, "float")})


@dataclass(frozen=True)
class ObservationSpec:
    """The ``[observation]`` table: slot counts of the observation (the only place they are written;
    :class:`~tin_swarm_env.env.observation.ObsLayout` is built from it).

    k_robots    slots for the nearest visible robots
    k_targets   slots for the nearest visible threats/targets
    k_breaks    slots for the nearest terrain breaks in range
    k_assets    slots for the nearest visible assets; not set: ``DEFAULT_K_ASSETS`` when the scenario
                has assets, else 0 (:meth:`~tin_swarm_env.env.observation.ObsLayout.from_spec`)
    k_scan      beams of the terrain scan (0: no scan part): the range to the first dangerous break
                along each of ``k_scan`` bearings all round; default :data:`DEFAULT_K_SCAN`
    """

    k_robots: int = 4
    k_targets: int = 2
    k_breaks: int = 3
    k_assets: int | None = None
    k_scan: int = DEFAULT_K_SCAN

    def __post_init__(self):
        _check_types(self)
        check_fields(self, {k: {"lo": 0, "hi": MAX_SLOTS, "integer": True} for k in ("k_robots", "k_targets",
                                                                                    "k_breaks", "k_scan")})
        if self.k_assets is not None:
            check_range("ObservationSpec", "k_assets", self.k_assets, 0, MAX_SLOTS, integer=True)


@dataclass(frozen=True)
class ScenarioConfig:
    """A whole scenario; its top-level keys:

    name        the scenario's name (default: the file's stem)
    task        "goal" (reach an assigned target) or "containment" (surround threats at a standoff)
    max_cycles  episode length in steps (truncation)
    seed        the seed of ``reset()`` called without one, and of a terrain drawn once
                (``resample = "once"``; not set: 0)
    """

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
        for key, cls in _PARTS.items():
            if not isinstance(getattr(self, key), cls):
                raise ScenarioError(f"ScenarioConfig.{key} must be a {cls.__name__}, got {type(getattr(self, key)).__name__} "
                                    f"{getattr(self, key)!r:.60}")
        _check_types(self, skip=tuple(_PARTS))
        check_range("ScenarioConfig", "max_cycles", self.max_cycles, 1, MAX_CYCLES, integer=True, exc=ScenarioError)
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
        if self.terrain.source == "generated":
            _check_generated(self)

    def replace(self, **kw) -> ScenarioConfig:
        return dataclasses.replace(self, **kw)

    def with_families(self, families) -> ScenarioConfig:
        """This scenario with its generated terrain drawn from ``families`` only (names, or
        ``{name: weight}``); checked like ``[terrain] families``."""
        fam = dict(families) if isinstance(families, dict) else tuple(families)
        if not fam:  # (an empty tuple in a TerrainSpec means every family: not what a restriction asks)
            raise ScenarioError("ScenarioConfig.with_families: no families given; name at least one")
        return self.replace(terrain=dataclasses.replace(self.terrain, families=fam))

    def with_layout(self, layout) -> ScenarioConfig:
        """This scenario with the ``[observation]`` slot counts of ``layout`` (an
        :class:`~tin_swarm_env.env.observation.ObsLayout`, or anything with its ``k_robots``,
        ``k_targets``, ``k_breaks``, ``k_assets`` and ``k_scan``): how a policy file trained on another
        layout gets the env it runs on (:func:`~tin_swarm_env.policies.policy_layout`)."""
        try:
            obs = ObservationSpec(*(int(getattr(layout, k)) for k in ("k_robots", "k_targets", "k_breaks",
                                                                     "k_assets", "k_scan")))
        except (AttributeError, TypeError, ValueError) as exc:
            raise ScenarioError(f"ScenarioConfig.with_layout: {layout!r} is not an observation layout ({exc})") from None
        return self.replace(observation=obs)


_PARTS = {"terrain": TerrainSpec, "robots": RobotsSpec, "world": WorldParams, "targets": EntitiesSpec,
          "assets": EntitiesSpec, "rewards": RewardWeights, "observation": ObservationSpec}


MAX_SCENARIO_BYTES = 1_000_000  # a scenario file is a few hundred bytes of settings; refuse megabytes unread
MAX_FLAT_AREA_M2 = 1e10  # a flat plane up to 100 km x 100 km: spawn and sensing grids scale with the area
MIN_TIN_VERTICES = 4  # [terrain] max_vertices, when set: build_tin's own least (the corners)
MAX_CYCLES = 10_000_000  # steps per episode: far beyond any task; keeps step counters and budgets sane

# which [terrain] keys each source reads (any other key set away from its default is an error, not ignored);
# every source reads these too
COMMON_TERRAIN_KEYS = ("source", "mirror")
SOURCE_KEYS = {
    "flat": ("size_m",),
    "procedural": ("recipe", "params", "method", "max_vertices", "max_error_m"),
    "sample": ("path", "method", "max_vertices", "max_error_m"),
    "dem": ("path", "method", "max_vertices", "max_error_m"),
    "tin": ("path",),
    "generated": ("families", "ranges", "resample", "method", "max_vertices", "max_error_m"),
}


def _check_terrain(t: TerrainSpec) -> None:
    """A [terrain] table: its source, the keys that source reads, the method, the numbers and, for
    a generated terrain, the families, ranges and resample (recipe parameters are checked by
    make_dem)."""
    from ..terrain.build import METHODS

    if t.source not in SOURCE_KEYS:
        raise ParameterError(f"TerrainSpec.source must be one of {', '.join(SOURCE_KEYS)}, got {t.source!r}")
    defaults = TerrainSpec.__dataclass_fields__
    for key, f in defaults.items():
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        if key not in COMMON_TERRAIN_KEYS and key not in SOURCE_KEYS[t.source] and getattr(t, key) != default:
            raise ParameterError(f"TerrainSpec.{key} does not apply to source = {t.source!r} (it reads "
                                 f"{', '.join(SOURCE_KEYS[t.source]) or 'no other key'}); remove it")
    if t.mirror not in MIRRORS:
        raise ParameterError(f"TerrainSpec.mirror must be one of {', '.join(map(repr, MIRRORS))}, got {t.mirror!r}")
    if t.method not in METHODS:
        raise ParameterError(f"TerrainSpec.method must be one of {', '.join(METHODS)}, got {t.method!r}")
    check_fields(t, {"max_vertices": {"lo": 0, "integer": True}, "max_error_m": _NONNEG})
    if 0 < t.max_vertices < MIN_TIN_VERTICES:
        raise ParameterError(f"TerrainSpec.max_vertices must be 0 (not set) or at least {MIN_TIN_VERTICES} (a TIN's "
                             f"four corners), got {t.max_vertices}")
    if len(t.size_m) != 2:
        raise ParameterError(f"TerrainSpec.size_m must be (width, height), got {t.size_m!r}")
    for i, v in enumerate(t.size_m):
        check_range("TerrainSpec", f"size_m[{i}]", v, 0, lo_open=True)
    if t.size_m[0] * t.size_m[1] > MAX_FLAT_AREA_M2:
        raise ParameterError(f"TerrainSpec.size_m {list(t.size_m)}: a flat plane of at most {MAX_FLAT_AREA_M2:.0e} "
                             "m^2 (robots' spawn and sensing grids scale with the area)")
    if t.source == "generated":
        if isinstance(t.families, dict):
            for k, w in t.families.items():
                check_range("TerrainSpec", f"families[{k!r}]", w, 0)
        names, _ = family_weights(t.families or ALL_FAMILIES, "TerrainSpec.families")
        validate_ranges(t.ranges, names, "ranges")
        if t.resample not in ("reset", "once"):
            raise ParameterError(f"'resample' must be 'reset' or 'once', got {t.resample!r}")


def _check_types(obj, skip: tuple = ()) -> None:
    """Each field of dataclass ``obj`` against its annotated type, as a scenario file's key is
    (:func:`_typed`; lists become tuples), so a config built in code gets the file's checks."""
    hints = typing.get_type_hints(type(obj))
    where = type(obj).__name__
    for f in dataclasses.fields(obj):
        if f.name not in skip:
            object.__setattr__(obj, f.name, _typed(where, f.name, getattr(obj, f.name), hints[f.name], ParameterError))


# -- parsing ------------------------------------------------------------------------------------

_ROBOT_KEYS = {f.name for f in dataclasses.fields(RobotParams)}
_RSPEC_KEYS = {f.name for f in dataclasses.fields(RobotsSpec)}
# [world] takes WorldParams' own settings: not the robot/sensor/battery models (their own tables)
# nor flat_size_m (the [terrain] table's size_m)
_WORLD_KEYS = {f.name for f in dataclasses.fields(WorldParams)} - {"robot", "sensor", "battery", "flat_size_m"}
_TOP_KEYS = {f.name for f in dataclasses.fields(ScenarioConfig)} - {"world", "base_dir", "source"} | {
    "sensor", "battery", "world", "description"}


def _typed(where: str, key: str, value, t, exc=ScenarioError):
    """Check ``value`` against the (resolved) type ``t`` of a dataclass field: float, int, bool,
    str, dict, ``X | None``, ``A | B``, ``tuple[float, ...n]``, ``tuple[X, ...]``; returns it
    normalised (numpy numbers -> Python, lists -> tuples). ``exc`` is raised, naming the key."""
    origin, args = typing.get_origin(t), typing.get_args(t)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        for a in inner[:-1]:  # the first alternative that fits (e.g. a list of names, else a table)
            try:
                return _typed(where, key, value, a, exc)
            except exc:
                pass
        return _typed(where, key, value, inner[-1], exc)
    if t is float:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise exc(f"{_name(where, key, exc)} must be a number, got {_short(value)}")
        return float(value)
    if t is int:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
            raise exc(f"{_name(where, key, exc)} must be an integer, got {_short(value)}")
        return int(value)
    if t in (bool, str):
        kind = {bool: "true or false", str: "a string"}[t]
        if not isinstance(value, (t, np.bool_) if t is bool else t):
            raise exc(f"{_name(where, key, exc)} must be {kind}, got {_short(value)}")
        return t(value)
    if t is dict or origin is dict:
        if not isinstance(value, dict):
            raise exc(f"{_name(where, key, exc)} must be a table, got {_short(value)}")
        return dict(value)
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        if not isinstance(value, (list, tuple)):
            what = "[x, y] pairs" if typing.get_origin(args[0]) is tuple else "names" if args[0] is str else "values"
            raise exc(f"{_name(where, key, exc)} must be a list of {what}, got {_short(value)}")
        return tuple(_typed(where, f"{key}[{i}]", v, args[0], exc) for i, v in enumerate(value))
    if origin is tuple and all(a is float for a in args):
        return _floats(where, key, value, len(args), exc)
    raise TypeError(f"{where}: no check for the type {t!r} of '{key}'")  # a new field type: add it here


def _name(where: str, key: str, exc) -> str:
    """How a message names a key: ``file [table]: 'key'`` (a scenario file) or ``Class.key`` (code)."""
    return f"{where}.{key}" if exc is ParameterError else f"{where}: '{key}'"


def _short(value) -> str:
    """``repr(value)``, cut to 80 characters (a message stays one readable line)."""
    r = repr(value)
    return r if len(r) <= 80 else r[:77] + "..."


def _floats(where, key, value, n, exc=ScenarioError):
    if not isinstance(value, (list, tuple)) or len(value) != n or not all(
            isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in value):
        raise exc(f"{_name(where, key, exc)} must be a list of {n} numbers, got {_short(value)}")
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
    except (TypeError, ValueError) as exc:
        msg = str(exc)
        raise ScenarioError(f"{where}{' ' if msg.startswith(('ranges', '[')) else ': '}{msg}") from None


def scenario_from_dict(d: dict, source: str = "<dict>", base_dir: str = ".") -> ScenarioConfig:
    """Build a :class:`ScenarioConfig` from a parsed TOML document (``source`` names it in errors)."""
    for k in d:
        if k not in _TOP_KEYS:
            raise ScenarioError(f"{source}: unknown key '{k}' (known: {', '.join(sorted(_TOP_KEYS))})")
    for k in ("terrain", "robots", "sensor", "battery", "world", "targets", "assets", "rewards", "observation"):
        if k in d and not isinstance(d[k], dict):
            raise ScenarioError(f"{source}: '{k}' must be a table ([{k}] followed by its keys), got {_short(d[k])}")
    robots_t = dict(d.get("robots", {}))
    robot_params = {k: robots_t.pop(k) for k in list(robots_t) if k in _ROBOT_KEYS}
    robot = _build(RobotParams, robot_params, f"{source} [robots]")
    rspec = _build(RobotsSpec, robots_t, f"{source} [robots]", allowed=_RSPEC_KEYS)
    sensor = _build(SensorParams, d.get("sensor", {}), f"{source} [sensor]")
    battery = _build(BatteryParams, d.get("battery", {}), f"{source} [battery]")
    terrain_t, families = dict(d.get("terrain", {})), ()
    src = terrain_t.get("source", "flat")
    if src not in SOURCE_KEYS:
        raise ScenarioError(f"{source} [terrain]: 'source' must be one of {', '.join(SOURCE_KEYS)}, got {_short(src)}")
    for k in terrain_t:
        if k not in COMMON_TERRAIN_KEYS and k in TerrainSpec.__dataclass_fields__ and k not in SOURCE_KEYS[src]:
            raise ScenarioError(f"{source} [terrain]: '{k}' does not apply to source = {src!r} (it reads "
                                f"{', '.join(SOURCE_KEYS[src]) or 'no other key'}); remove it")
    if "families" in terrain_t:  # a list or a table: checked by _families
        families = _families(terrain_t.pop("families"), f"{source} [terrain]")
    terrain = _build(TerrainSpec, terrain_t, f"{source} [terrain]", families=families)
    world = _build(WorldParams, d.get("world", {}), f"{source} [world]", allowed=_WORLD_KEYS,
                   robot=robot, sensor=sensor, battery=battery, flat_size_m=terrain.size_m)
    targets = _build(EntitiesSpec, d.get("targets", {}), f"{source} [targets]")
    assets = _build(EntitiesSpec, d.get("assets", {}), f"{source} [assets]",
                    allowed={"positions", "count", "region", "min_separation_m", "mobile", "standoff_m"})
    rewards = _build(RewardWeights, d.get("rewards", {}), f"{source} [rewards]")
    obs = _build(ObservationSpec, d.get("observation", {}), f"{source} [observation]")
    hints = typing.get_type_hints(ScenarioConfig)
    top = {k: _typed(source, k, d[k], hints[k]) for k in ("name", "task", "max_cycles", "seed") if k in d}
    try:
        return ScenarioConfig(terrain=terrain, robots=rspec, world=world, targets=targets, assets=assets,
                              rewards=rewards, observation=obs, base_dir=base_dir, source=source, **top)
    except ScenarioError as exc:
        msg = str(exc)
        raise ScenarioError(f"{source}{' ' if msg.startswith('[') else ': '}{msg}") from None


def _families(value, where):
    """``[terrain] families``: a list of names (a tuple) or a table of weights (a dict); empty is
    an error (leave the key out for all families)."""
    if isinstance(value, (list, dict)) and not value:
        raise ScenarioError(f"{where}: 'families' is empty; name at least one family (leave the key out for all)")
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return tuple(value)
    if isinstance(value, dict):
        for k, w in value.items():
            if isinstance(w, bool) or not isinstance(w, (int, float)):
                raise ScenarioError(f"{where}: families.{k} must be a number (a weight), got {_short(w)}")
        return dict(value)
    raise ScenarioError(f"{where}: 'families' must be a list of family names or a table of weights, got {value!r}")


def _check_generated(cfg: ScenarioConfig) -> None:
    """A generated terrain brings its own target and spawn region (its families, ranges and
    ``resample`` are checked by :class:`TerrainSpec`)."""
    if cfg.task != "goal":
        raise ScenarioError(f"[terrain] a generated terrain is a goal task; 'task' must be 'goal', got {cfg.task!r}")
    if cfg.targets.positions or cfg.targets.count:
        raise ScenarioError("[targets] 'positions' and 'count' must be empty with a generated terrain "
                            "(the generator places the target)")
    if cfg.robots.spawn_region is not None:
        raise ScenarioError("[robots] 'spawn_region' must not be set with a generated terrain "
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
    """A built-in scenario by name (``"cliff_goal"``) or a TOML file by path. A bare name (no
    ``.toml``, no directory) of a built-in scenario is the built-in one, whatever lies in the working
    directory under that name (``./ramp``, ``./flat/``); write ``./ramp.toml`` for a file."""
    s = os.fspath(name_or_path)
    p = Path(s)
    bare = not (s.endswith(".toml") or os.sep in s or "/" in s)
    if bare and ((SCENARIO_DIR / f"{s}.toml").is_file() or not p.exists()):
        p = scenario_file(s)
    if not p.exists():
        raise ScenarioError(f"{p}: no such scenario file")
    if not p.is_file():
        raise ScenarioError(f"{p}: is a directory, not a scenario (.toml) file")
    if p.stat().st_size > MAX_SCENARIO_BYTES:
        raise ScenarioError(f"{p}: {p.stat().st_size:,} bytes; a scenario file has at most {MAX_SCENARIO_BYTES:,} "
                            "(terrain data goes in its own file, named by [terrain] path)")
    try:
        text = p.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        line = p.read_bytes()[:exc.start].count(b"\n") + 1
        raise ScenarioError(f"{p}: line {line}: not UTF-8 text (byte {exc.object[exc.start]:#04x}); save the file as "
                            "UTF-8") from None
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{p}: not valid TOML ({exc})") from None
    if not isinstance(d.get("description", ""), str):
        raise ScenarioError(f"{p}: 'description' must be a string, got {_short(d['description'])}")
    d.setdefault("name", p.stem)
    return scenario_from_dict(d, source=str(p), base_dir=str(p.parent))
