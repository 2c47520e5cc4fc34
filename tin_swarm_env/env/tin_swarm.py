"""The PettingZoo parallel environment ``tin_swarm_v0``."""

from __future__ import annotations

import numbers

import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle
from numba import njit
from pettingzoo import ParallelEnv

from ..errors import ArgumentError, check_range
from ..scenario import (
    ScenarioConfig,
    Stage,
    assignments,
    build_stage,
    initial_state,
    load_scenario,
    place_entities,
    target_field,
)
from ..scenario.config import MAX_ROBOTS
from ..world import Reason, World
from ..world.pack import one_copy
from ..world.world import serial_if_small
from .checks import actions_from_dict, check_options, check_scenario_arg, check_seed, float_array
from .field_pack import FieldPack, field_ids
from .observation import ObsLayout, build_observations
from .reward import end_step, measure, reward_params

__all__ = ["TinSwarmEnv", "parallel_env", "raw_env", "env", "RENDER_WIDTH_PX", "DEFAULT_RENDER_WIDTH_PX"]


_NO_FIELDS = FieldPack()  # every distance the straight line (read only)
RENDER_WIDTH_PX = (64, 4096)  # the frame widths render() draws
DEFAULT_RENDER_WIDTH_PX = 640  # render_width when none is given (also the CLI's frame width, apps.media.GIF_WIDTH_PX)

_REASON_LABEL = {int(r): r.label for r in Reason}  # Reason code -> infos[agent]["reason"]


@njit(cache=True)
def live_actions(a, live):
    """``(np.where(live[:, None], a, 0.0), i)`` with ``i`` the first robot whose row there is not
    finite (-1: none), in one pass."""
    n = a.shape[0]
    out = np.empty((n, 2))
    bad = -1
    for i in range(n):
        u = a[i, 0] if live[i] else 0.0
        v = a[i, 1] if live[i] else 0.0
        out[i, 0] = u
        out[i, 1] = v
        if bad < 0 and not (np.isfinite(u) and np.isfinite(v)):
            bad = i
    return out, bad


def _check_args(n_robots, max_cycles, render_width) -> None:
    """The constructor's numbers: ArgumentError naming the argument (an integer in range)."""
    if n_robots is not None:
        check_range("TinSwarmEnv", "n_robots", n_robots, 1, MAX_ROBOTS, integer=True, exc=ArgumentError)
    if max_cycles is not None:
        check_range("TinSwarmEnv", "max_cycles", max_cycles, 1, integer=True, exc=ArgumentError)
    check_range("TinSwarmEnv", "render_width", render_width, *RENDER_WIDTH_PX, integer=True, exc=ArgumentError)


class TinSwarmEnv(ParallelEnv, EzPickle):
    """A swarm of ground robots on real terrain stored as a Triangulated Irregular Network.

    Robots drive over a TIN (a reduced real DEM, a procedural thesis scenario, or a flat
    plane), sense each other, threats/targets and terrain breaks with a range-, field-of-view-
    and line-of-sight-limited sensor, and must not drive down into too-steep triangles (cliffs
    are fatal). The scenario (``scenario=``, a built-in name or a TOML path) fixes the terrain,
    the robot, sensor and battery models, the targets, the task and the reward weights.

    **Agents**: ``robot_0 … robot_{n-1}``; a robot leaves ``agents`` the step after it is
    reported terminated or truncated.

    **Observation**: an identical ``Box(-1, 1, (d,), float32)`` for every robot, egocentric (body
    frame x forward / y left, distances over the sensor range), read through the named slices of
    ``env.layout`` (an :class:`~tin_swarm_env.env.observation.ObsLayout`); the module docstring of
    :mod:`tin_swarm_env.env.observation` is its table. Robots no longer in ``agents`` read all zeros.

    **Assets** (``[assets]``: positions, or a count drawn by the reset seed like targets): what
    the swarm protects. Robots sense them like threats (range, field of view, line of sight) in
    the ``assets`` part of the observation; the APF's asset field
    (:func:`~tin_swarm_env.world.fields.asset_field`) draws each robot that sees an asset to the
    guard ring of radius ``[assets] standoff_m`` around the nearest one, so with threats the
    swarm stays near and between the assets and the threats. The rewards do not count assets.

    **Action**: ``Box(-1, 1, (2,), float32)``: commanded velocity in the body frame as a
    fraction of max speed. Out-of-range values are clipped (then to norm 1); NaN/inf raise
    ValueError naming the agent, and so does an unknown agent key; a live agent missing from
    the action dict gets the zero action (it stands still).

    **Rewards**: per robot, weighted by the scenario's ``[rewards]``
    (:class:`~tin_swarm_env.scenario.RewardWeights`); what each term pays for, and how progress is
    measured (along the shortest drivable path by default), is the module docstring of
    :mod:`tin_swarm_env.env.reward`. ``infos[agent]["distance_to_go_m"]`` is the distance the reward
    uses, for every live agent at reset and after every step; :meth:`distance_to_go` gives it for all
    robots as an array.

    **Solvability**: a target that cannot be reached from any point of the spawn region is a
    ScenarioError at construction (naming the file and the target); robots are spawned only where
    their assigned target can be reached.

    **Generated terrains** (``[terrain] source = "generated"``, e.g. ``scenario="generated"``):
    each :meth:`reset` with ``resample = "reset"`` draws a new solvable task (terrain, spawn
    region, one target) from the episode's generator, so the same seed gives the same terrain bit
    for bit; ``resample = "once"`` draws one at construction from the scenario's seed. The world
    (``tin``, ``world``) is replaced on resample; the spaces (and ``state_space``) never change.
    ``task`` is the current :class:`~tin_swarm_env.scenario.generators.GeneratedTask`.

    **Termination**: "arrived" (goal task, within ``arrival_radius_m``; the robot then leaves
    the terrain: it is no longer seen and does not block the robots behind it), "fell" (drove down
    into a too-steep triangle), "battery" (charge ran out); the reason is in
    ``infos[agent]["reason"]``. **Truncation**: every live robot when the step count reaches
    ``max_cycles`` (read at step time, so it may be changed between steps), reason
    "max_cycles". The codes are :class:`~tin_swarm_env.Reason` (``.label`` is the string).

    **Arguments**

    - ``scenario``: a built-in name (``tin_swarm_env.scenario.list_scenarios()``), a TOML path, or a
      :class:`~tin_swarm_env.scenario.ScenarioConfig` ["cliff_goal"]
    - ``n_robots``: overrides the scenario's robot count
    - ``max_cycles``: overrides the scenario's episode length
    - ``render_mode``: None, "human" (matplotlib window) or "rgb_array" (HxWx3 uint8)
    - ``sensor_cones``: draw each robot's field of view when rendering [False]
    - ``render_width``: width of rendered frames in pixels [``DEFAULT_RENDER_WIDTH_PX``]
    - ``render_decorations``: a title strip (scenario, step, robots arrived / fell / battery-empty /
      active, on the last frame timed out), a legend, a scale bar and a height colour bar on rendered
      frames [True] (:mod:`~tin_swarm_env.env.viewer`); False for bare frames (training videos)

    ``state()`` (for centralised critics): per robot x, y (scaled to the terrain's bounds), cos
    and sin of the heading, battery fraction and an active flag; per target x, y.

    **Batched path**: :meth:`reset_arrays` / :meth:`step_arrays` do the same on arrays over all
    ``n`` robots (``obs (n, d)``, ``actions (n, 2)``), without per-agent dicts; the dict API is
    a thin layer over them.

    **Read-only views** (for apps and plots; policies read observations only): ``tin`` (the
    current :class:`~tin_swarm_env.terrain.Tin`; it changes on reset with a generated terrain),
    ``world``, ``task``, ``world_state``, ``live_mask``, ``target_assignment``,
    ``target_fields``, ``steps``, ``sensed()``, ``distance_to_go()``.
    Reset options place robots and targets: ``robot_positions (n, 2)``, ``headings (n,)``,
    ``target_positions (m, 2)``.

    **Version history**: v0 (0.1.0): first release.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "name": "tin_swarm_v0", "is_parallelizable": True,
                "render_fps": 10}

    def __init__(self, scenario: str | ScenarioConfig = "cliff_goal", n_robots: int | None = None,
                 max_cycles: int | None = None, render_mode: str | None = None, sensor_cones: bool = False,
                 render_width: int = DEFAULT_RENDER_WIDTH_PX, render_decorations: bool = True):
        EzPickle.__init__(self, scenario=scenario, n_robots=n_robots, max_cycles=max_cycles,
                          render_mode=render_mode, sensor_cones=sensor_cones, render_width=render_width,
                          render_decorations=render_decorations)
        check_scenario_arg(scenario, ScenarioConfig)
        _check_args(n_robots, max_cycles, render_width)
        cfg = scenario if isinstance(scenario, ScenarioConfig) else load_scenario(scenario)
        if n_robots is not None:
            cfg = cfg.replace(robots=type(cfg.robots)(count=int(n_robots), spawn_region=cfg.robots.spawn_region,
                                                      min_separation_m=cfg.robots.min_separation_m))
        if max_cycles is not None:
            cfg = cfg.replace(max_cycles=int(max_cycles))
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ArgumentError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.config = cfg
        self.max_cycles = cfg.max_cycles
        self.render_mode = render_mode
        self._stage: Stage = build_stage(cfg)
        self._world: World = self._stage.world
        if cfg.rewards.progress == "geodesic" and cfg.targets.mobile and len(self._stage.targets):
            import warnings

            warnings.warn(f"{cfg.source}: mobile targets: progress and distance_to_go_m use the straight-line "
                          "distance (a cost-to-go field is built for static targets only)", stacklevel=2)
        self.n = cfg.robots.count
        self.possible_agents = [f"robot_{i}" for i in range(self.n)]
        self.agent_name_mapping = {a: i for i, a in enumerate(self.possible_agents)}
        self.layout = ObsLayout.from_spec(cfg.observation, n_assets=cfg.assets.n)
        self._obs_space = spaces.Box(-1.0, 1.0, (self.layout.size,), np.float32)
        self._act_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self._target_slots = max(cfg.targets.n, len(self._stage.targets))  # a generated task always has 1
        self.state_space = spaces.Box(-1.0, 1.0, (6 * self.n + 2 * self._target_slots,), np.float32)
        self._sensor_cones = sensor_cones
        self._render_width = render_width
        self._render_decorations = bool(render_decorations)
        self._viewer = None
        self._np_random = None
        self.agents: list[str] = []
        self._wstate = None  # WorldState; set by reset
        self._live = np.zeros(self.n, dtype=bool)
        self._target_idx = np.full(self.n, -1, dtype=np.int64)
        self._readings = None
        self._steps = np.zeros(1, dtype=np.int64)  # steps taken in the episode (one copy's clock, end_step's)
        self._fields: tuple = ()  # one CostToGo per target of the episode
        self._fpack = None  # FieldPack of _fields where progress is geodesic (one query a step), else None
        self._fid = np.full(self.n, -1, dtype=np.int64)  # each robot's field in _fpack (field_pack.field_ids)
        self._rws = None  # (1, 11) reward.reward_params(config), set at reset
        self._dist = np.full(self.n, np.inf)  # (n,) m, distance to go after the last reset/step

    # -- read-only views for apps, policies' tests and plots ------------------------------------
    @property
    def world(self) -> World:
        """The static world (terrain, breaks, parameters)."""
        return self._world

    @property
    def tin(self):
        """The current :class:`~tin_swarm_env.terrain.Tin` (a generated terrain's changes on reset)."""
        return self._world.tin

    @property
    def task(self):
        """The current generated task (:class:`~tin_swarm_env.scenario.generators.GeneratedTask`;
        None unless ``[terrain] source = "generated"``)."""
        return self._stage.task

    @property
    def target_fields(self) -> tuple:
        """One :class:`~tin_swarm_env.terrain.CostToGo` per target of this episode (at its
        start position); empty before reset."""
        return self._fields

    def distance_to_go(self) -> np.ndarray:
        """``(n,)`` m, a copy: each robot's distance to go to its assigned target as the reward
        measures it (geodesic or straight-line, see the class docstring) at its current position;
        ``inf`` where it cannot be reached or no target is assigned."""
        return self._dist.copy()

    @property
    def world_state(self):
        """The current :class:`~tin_swarm_env.world.WorldState` (None before reset). Read it, never
        change it: the env replaces it every step; place robots and targets with reset options."""
        return self._wstate

    @property
    def live_mask(self) -> np.ndarray:
        """``(n,)`` bool, a copy: robots still in the episode (in ``agents``)."""
        return self._live.copy()

    @property
    def target_assignment(self) -> np.ndarray:
        """``(n,)`` int64, a copy: each robot's assigned target index (-1: none)."""
        return self._target_idx.copy()

    @property
    def rng_state(self) -> dict | None:
        """The state of the episode generator (``np.random.Generator.bit_generator.state``, plain
        data; None before the first reset). Setting it makes the next ``reset(seed=None)`` continue
        from there (training checkpoints save and restore it)."""
        return None if self._np_random is None else self._np_random.bit_generator.state

    @rng_state.setter
    def rng_state(self, state: dict) -> None:
        g = np.random.default_rng()
        try:
            g.bit_generator.state = state
        except (TypeError, ValueError, KeyError) as exc:
            raise ArgumentError(f"rng_state: not a generator state ({exc})") from None
        self._np_random = g

    @property
    def steps(self) -> int:
        """Steps taken in this episode."""
        return int(self._steps[0])

    def sensed(self):
        """What every robot senses now (:class:`~tin_swarm_env.world.SensorReadings`; read-only)."""
        return self._readings

    # -- spaces ----------------------------------------------------------------------------
    def observation_space(self, agent):
        return self._obs_space

    def action_space(self, agent):
        return self._act_space

    # -- batched path -----------------------------------------------------------------------
    def reset_arrays(self, seed: int | None = None, options: dict | None = None) -> np.ndarray:
        """Reset and return observations ``(n, d)`` float32 for all robots. ``options`` may place
        things: ``{"robot_positions": (n, 2), "headings": (n,), "target_positions": (m, 2)}``
        (metres; headings in radians counter-clockwise from east, only with robot_positions);
        otherwise robots spawn at random in the scenario's spawn region and targets stand where
        the scenario puts them. Robots are assigned targets ``i mod m`` either way."""
        seed = check_seed(seed)
        options = check_options(options, ("robot_positions", "headings", "target_positions"))
        if "robot_positions" in options:
            options["robot_positions"] = float_array(options["robot_positions"], "options['robot_positions']",
                                                     (self.n, 2))
        if "headings" in options:
            options["headings"] = float_array(options["headings"], "options['headings']", (self.n,))
        if "target_positions" in options:
            tp = options["target_positions"]
            if isinstance(tp, (list, tuple, np.ndarray)) and len(tp) == 2 and all(
                    isinstance(v, numbers.Real) for v in tp):
                tp = [tp]  # one [x, y] pair
            if isinstance(tp, (list, tuple)) and len(tp) == 0:
                tp = np.zeros((0, 2))  # an empty list: no target (a shape numpy cannot tell from [])
            options["target_positions"] = float_array(tp, "options['target_positions']", (-1, 2))
            if not len(options["target_positions"]) and self.config.task == "goal":
                raise ArgumentError(f"reset(options['target_positions']): an empty list, but {self.config.name!r} "
                                    "is a goal task, which needs at least one target (leave the option out to keep "
                                    "the scenario's targets)")
        if seed is not None or self._np_random is None:
            s = seed if seed is not None else self.config.seed
            self._np_random = np.random.default_rng(s)
        if "headings" in options and "robot_positions" not in options:
            raise ArgumentError("options['headings'] needs options['robot_positions']")
        cfg = self.config
        if cfg.terrain.source == "generated" and cfg.terrain.resample == "reset":
            self._set_stage(build_stage(cfg, self._np_random))
        targets = self._stage.targets
        if "target_positions" in options:
            targets, _ = self._world.check_placement(options["target_positions"], "target {i}")
        elif cfg.targets.count:  # drawn by this reset's generator, before the robots (they spawn where
            # theirs is reachable)
            targets = place_entities(self._world, cfg.targets, self._np_random, spawn_region=self._stage.spawn_region,
                                     label=f"{cfg.source} [targets]")
        self._fields = tuple(self._field(t) for t in targets)
        geodesic = self.config.rewards.progress == "geodesic" and not self.config.targets.mobile
        self._set_fields(self._fields if geodesic else ())
        self._rws = np.array([reward_params(cfg)], dtype=np.float64)  # the reward terms as the step's kernel reads
        reach = np.array([f.triangle_reachable() for f in self._fields]) if len(self._fields) else None
        self._wstate = initial_state(self._world, cfg, self._np_random, self.n, target_positions=targets,
                                     spawn_region=self._stage.spawn_region, reachable=reach,
                                     **{k: options[k] for k in ("robot_positions", "headings") if k in options})
        self._target_idx = assignments(self.n, len(self._wstate.targets))
        self._fid = field_ids(self._fpack, self._fields if self._fpack is not None else (), self._target_idx)
        self._dist = self._measure(self._wstate)
        self._live = np.ones(self.n, dtype=bool)
        self._steps = np.zeros(1, dtype=np.int64)
        self._readings = self._world.sense(self._wstate)
        return build_observations(self._world, self._wstate, self._readings, self._target_idx, self._live,
                                  self.layout)

    def _set_stage(self, stage: Stage) -> None:
        """Play on a new stage (a resampled generated terrain); the viewer is made anew."""
        self._stage, self._world = stage, stage.world
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None

    def _field(self, xy):
        """The cost-to-go field of a target standing at ``xy``: the stage's own, else the cache."""
        for t, f in zip(self._stage.targets, self._stage.fields, strict=True):
            if t[0] == xy[0] and t[1] == xy[1]:
                return f
        return target_field(self._world, xy)

    def _set_fields(self, fields) -> None:
        """The episode's fields as the distance pass reads them: a :class:`~.field_pack.FieldPack` of
        ``fields`` (kept while they are the same fields: a static task's every reset), or none
        (every distance the straight line)."""
        if not fields:
            self._fpack = None
        elif self._fpack is None or any(f not in self._fpack for f in fields) or len(self._fpack) > len(fields):
            self._fpack = FieldPack(fields)

    def _measure(self, state) -> np.ndarray:
        """Distance to go ``(n,)`` m of every robot in ``state`` (the reward's metric): the vector env's
        pass (:func:`~tin_swarm_env.env.reward.measure`), the same bits as
        :func:`~tin_swarm_env.env.reward.distance_to_go` (tests check both)."""
        return measure(self._distance_fields(), state.positions, state.tri_idx, state.targets.positions,
                       self._target_idx)

    def _distance_fields(self) -> tuple:
        return (self._fpack if self._fpack is not None else _NO_FIELDS), self._fid

    def step_arrays(self, actions) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """One step for all robots: ``actions (n, 2)`` (rows of robots no longer live are
        ignored). Returns ``obs (n, d)``, ``rewards (n,)``, ``terminated (n,)``, ``truncated (n,)``
        and ``reasons (n,)`` int8 :class:`~tin_swarm_env.Reason` codes (ARRIVED, FELL, BATTERY for
        terminated robots, TIMEOUT for truncated ones, NONE otherwise), all for this step; robots
        already gone read zeros/False. Robots that end this step are not live on the next."""
        if self._wstate is None:
            raise RuntimeError("call reset() before step()")
        a, i = live_actions(float_array(actions, "step_arrays(actions)", (self.n, 2), finite=False), self._live)
        if i >= 0:
            raise ArgumentError(f"step_arrays(actions): the action of {self.possible_agents[i]} is not finite: "
                                f"{a[i].tolist()}")
        with serial_if_small(self.n):  # one thread for a small swarm, as the world's own kernels
            return self._step_arrays(a)

    def _step_arrays(self, a: np.ndarray):
        new, events = self._world._step(self._wstate, a)  # a: checked by step_arrays (live_actions)
        live = self._live
        _, one, _ = one_copy(self.n)  # this env is copy 0 of one, as the vector env's bookkeeping reads it
        dist, rewards, terminated, reasons, truncated, live_after = end_step(
            self._rws, one, self._distance_fields(), self._dist, new.positions, new.tri_idx, new.targets.positions,
            self._target_idx, live, events.energy_j, events.collisions, events.fell, events.emptied, self._steps,
            np.array([self.max_cycles], dtype=np.int64), one, new.status)  # arrived robots leave the terrain
        self._dist = dist
        self._wstate = new
        self._readings = self._world.sense(new)
        obs = build_observations(self._world, new, self._readings, self._target_idx, live, self.layout)
        self._live = live_after
        return obs, rewards, terminated, truncated, reasons

    # -- dict API -----------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        obs = self.reset_arrays(seed, options)
        self.agents = self.possible_agents[:]
        infos = {a: {"distance_to_go_m": float(self._dist[i])} for i, a in enumerate(self.agents)}
        return {a: obs[i] for i, a in enumerate(self.possible_agents)}, infos

    def step(self, actions: dict):
        if self._wstate is None:
            raise RuntimeError("call reset() before step()")
        arr = actions_from_dict(actions, self.agent_name_mapping, self._live, f"robot_0..robot_{self.n - 1}")
        live_before = np.flatnonzero(self._live)
        obs, rew, term, trunc, reasons = self.step_arrays(arr)
        names = self.possible_agents
        live = [names[i] for i in live_before.tolist()]  # dicts built from whole-array conversions
        observations = dict(zip(live, obs[live_before]))
        rewards = dict(zip(live, rew[live_before].tolist()))
        terminations = dict(zip(live, term[live_before].tolist()))
        truncations = dict(zip(live, trunc[live_before].tolist()))
        infos = {a: {"distance_to_go_m": d, "reason": _REASON_LABEL[r]} if r else {"distance_to_go_m": d}
                 for a, d, r in zip(live, self._dist[live_before].tolist(), reasons[live_before].tolist())}
        self.agents = [names[i] for i in np.flatnonzero(self._live).tolist()]
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    # -- state, rendering -------------------------------------------------------------------
    def state(self) -> np.ndarray:
        """``state_space`` vector: per robot (x, y) scaled to the terrain's bounds, cos/sin of the
        heading, battery fraction, active flag; then per target slot its scaled (x, y). The slots
        are the scenario's target count; a reset with fewer ``target_positions`` leaves the rest
        0, one with more raises an ArgumentError (the space is fixed at construction)."""
        s = self._wstate
        if s is None:
            raise RuntimeError("call reset() before state()")
        if len(s.targets) > self._target_slots:
            raise ArgumentError(f"state(): this episode has {len(s.targets)} targets (reset option "
                                f"'target_positions'), but state_space holds {self._target_slots}")
        x0, y0, x1, y1 = self.tin.bounds
        span = np.array([x1 - x0, y1 - y0])
        p = (s.positions - [x0, y0]) / span
        robots = np.column_stack([p, np.cos(s.headings), np.sin(s.headings),
                                  s.battery_j / self.config.world.battery.capacity_j, s.active])
        t = np.zeros((self._target_slots, 2))
        t[:len(s.targets)] = (s.targets.positions - [x0, y0]) / span
        return np.clip(np.concatenate([robots.ravel(), t.ravel()]), -1, 1).astype(np.float32)

    def render(self):
        if self.render_mode is None:
            import gymnasium

            gymnasium.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self._wstate is None:
            raise RuntimeError("call reset() before render()")
        if self._viewer is None:
            from .viewer import Viewer

            self._viewer = Viewer(self._world, width_px=self._render_width, sensor_cones=self._sensor_cones,
                                  decorations=self._render_decorations, name=self.config.name)
            if self.render_mode == "human":
                _warn_if_no_display()  # once per viewer
        img = self._viewer.frame(self._wstate, final=not self._live.any())  # last frame: active = timed out
        if self.render_mode == "rgb_array":
            return img
        self._viewer.show(img)
        return None

    def close(self):
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None


def _warn_if_no_display() -> None:
    """render_mode="human" draws into a matplotlib window; without a display (no DISPLAY or
    WAYLAND_DISPLAY on Linux, or a non-interactive backend such as Agg) nothing would appear:
    say so (a one-line gymnasium warning)."""
    import os
    import sys

    import matplotlib

    backend = matplotlib.get_backend().lower()
    headless = sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    if headless or backend in ("agg", "pdf", "ps", "svg", "cairo", "template"):
        import gymnasium

        gymnasium.logger.warn(f"render_mode='human' but there is no display (matplotlib backend {backend!r}"
                              f"{', no DISPLAY' if headless else ''}): no window will open; use "
                              "render_mode='rgb_array' and save the frames instead")


def parallel_env(scenario: str | ScenarioConfig = "cliff_goal", n_robots: int | None = None,
                 max_cycles: int | None = None, render_mode: str | None = None, sensor_cones: bool = False,
                 render_width: int = DEFAULT_RENDER_WIDTH_PX, render_decorations: bool = True) -> TinSwarmEnv:
    """The parallel environment (see :class:`TinSwarmEnv` for the arguments)."""
    return TinSwarmEnv(scenario=scenario, n_robots=n_robots, max_cycles=max_cycles, render_mode=render_mode,
                       sensor_cones=sensor_cones, render_width=render_width, render_decorations=render_decorations)


def raw_env(**kwargs):
    """The AEC version, unwrapped (PettingZoo's ``parallel_to_aec_wrapper``)."""
    from pettingzoo.utils.conversions import parallel_to_aec_wrapper

    return parallel_to_aec_wrapper(parallel_env(**kwargs))


def env(**kwargs):
    """The AEC version with PettingZoo's order-enforcing checks (``parallel_to_aec``)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(**kwargs))
