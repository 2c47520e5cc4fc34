"""The vector env: E copies of the swarm stepped by one call.

``tse.vector_env(scenario, n_envs=E, n_robots=N, seed=s)`` holds E copies of the parallel env's
swarm (each with its own terrain, targets, robots and episode clock) in flat arrays over the
``E * N`` robots, copy-major. One :meth:`VectorEnv.step` runs the world step, the distance to go,
the rewards, the sensing and the observations for every robot of every copy in a handful of
compiled passes, with no Python loop over copies or robots; only copies that end pay a reset.
**One step path**: they are the parallel env's own, which runs them as one copy: the world step
(:func:`~tin_swarm_env.world.step_kernel.step_copies`, ``World.step``'s), the sensing
(:func:`~tin_swarm_env.world.batch_kernels.sense_copies`, ``World.sense``'s), the step's bookkeeping
(:func:`~tin_swarm_env.env.reward.end_step`: distance to go, clocks and truncation, rewards,
terminations, arrived robots off the terrain) and the observation kernel
(:func:`~tin_swarm_env.env.observation.fill_observations`); ``tests/integration/test_one_step_path.py``
checks that each has its one set of callers.

**Copies.** ``scenario`` is one scenario (a name, path or
:class:`~tin_swarm_env.scenario.ScenarioConfig`) or a list of them: copy ``c`` plays
``scenario[c % len(scenario)]``. A generated scenario draws a new terrain per copy and per reset.
Every copy must have the same robot count, observation layout and the world parameters every
robot's step reads (``_SHARED_PARAMS``: body, speed, turn rate, sensor, battery, time step);
refused by name otherwise. The slope limit, the break angle, the terrain and the reward terms may
differ per scenario. Scenarios with mobile targets or assets are refused (their random walk
draws from each copy's generator every step); static assets are stepped like targets.

**Resets.** Each copy resets on its own when its episode ends (no robot of it is left: every one
terminated or was truncated at ``max_cycles``): the observations returned for that copy are the
new episode's, and ``infos["final_obs"][c]`` (with ``infos["_final"][c]`` True) holds the ended
episode's last observations. **Seeds**: every episode is reset with an explicit seed, drawn from
its copy's own generator, ``np.random.default_rng([seed, c])`` (:func:`copy_seed_stream`), so a
copy's episodes do not depend on when the other copies end, and the run is reproducible from one
seed. ``copy_seeds[c]`` is the seed copy ``c`` was last reset with, and copy ``c`` is, bit for bit,
``parallel_env(scenario_c, n_robots=N, ...).reset_arrays(seed=copy_seeds[c])`` stepped with the
same actions (``tests/env/test_vector.py``). :meth:`VectorEnv.reset_copy` resets one copy by hand
(a seed, and the parallel env's reset options to place robots and targets). With
``autoreset=False`` (the TorchRL env: its collector resets through ``"_reset"``), a copy that
ended stays ended (no live robot, zero observations and rewards) until :meth:`VectorEnv.reset_copy`;
then the observations of its last step are the ones returned (``final_obs`` stays zero) and
``_final[c]`` is True on every step until it is reset.

**Arrays.** ``reset()`` -> ``obs (E, N, d)`` float32. ``step(actions (E, N, 2))`` ->
``obs (E, N, d)``, ``rewards (E, N)`` float32, ``terminated``/``truncated (E, N)`` bool, ``infos``:
``reasons (E, N)`` int8 :class:`~tin_swarm_env.Reason` codes of this step, ``distance_to_go_m
(E, N)``, ``live (E, N)`` (robots still in their episode after the step and any reset),
``_final (E,)`` and ``final_obs (E, N, d)``. Robots no longer live read zero observations and
rewards, as in the parallel env; their actions are ignored. NaN/inf actions are refused naming
the copy and robot.
"""

from __future__ import annotations

import inspect
import numbers

import numpy as np
from gymnasium import spaces

from ..errors import ArgumentError, check_range
from ..world.batch_kernels import sense_copies
from ..world.pack import pack_one, pack_worlds
from ..world.sense_kernels import compact
from ..world.step_kernel import step_copies
from ..world.world import serial_if_small, step_scalars
from .checks import check_seed
from .field_pack import NO_FIELD, FieldPack, field_ids
from .observation import DZ_SCALE_M, NO_SCAN, OBS_SERIAL_BELOW, fill_observations, layout_offsets
from .reward import end_step
from .tin_swarm import TinSwarmEnv, live_actions

__all__ = ["VectorEnv", "vector_env", "MAX_COPIES", "copy_seed_stream", "CopyView"]

MAX_COPIES = 1 << 16


_NO_IDX = np.zeros(0, dtype=np.int64)


def copy_seed_stream(seed: int, c: int) -> np.random.Generator:
    """The generator copy ``c`` of a vector env made with ``seed`` draws its episodes' seeds from
    (``int(g.integers(0, 2**63 - 1))`` per reset)."""
    return np.random.default_rng([int(seed), int(c)])


# the world parameters the compiled passes read as one value for every copy; the others (the slope
# limit, the break angle, the flat plane's size) shape each world's own arrays, which the pack keeps per world
_SHARED_PARAMS = ("robot.radius_m", "robot.max_speed_mps", "robot.turn_rate_dps", "robot.max_climb_deg",
                  "sensor.range_m", "sensor.fov_deg", "sensor.height_m", "sensor.check_los", "sensor.max_candidates",
                  "battery.capacity_j", "battery.idle_w", "battery.sensing_w", "battery.drive_j_per_m",
                  "battery.climb_j_per_m", "dt_s", "entity_height_m")


def _param(params, dotted: str):
    v = params
    for part in dotted.split("."):
        v = getattr(v, part)
    return v


def _same(where: str, k: int, name: str, a, b) -> None:
    if a != b:
        raise ArgumentError(f"vector_env: scenario {k} ({where}) has {name} {a!r}, scenario 0 has {b!r}; every "
                            "copy must share it")


class VectorEnv:
    """E copies of the swarm stepped by one call (see the module docstring)."""

    metadata = {"name": "tin_swarm_v0_vector"}

    def __init__(self, scenario="cliff_goal", n_envs: int = 1, n_robots: int | None = None, seed: int | None = None,
                 autoreset: bool = True, **env_kwargs):
        check_range("vector_env", "n_envs", n_envs, 1, MAX_COPIES, integer=True, exc=ArgumentError)
        seed = check_seed(seed, "vector_env")
        if not isinstance(autoreset, bool):
            raise ArgumentError(f"vector_env: autoreset must be True or False, got {autoreset!r}")
        self.autoreset = autoreset
        known = set(inspect.signature(TinSwarmEnv.__init__).parameters) - {"self", "scenario", "n_robots"}
        unknown = sorted(set(env_kwargs) - known)
        if unknown:
            raise ArgumentError(f"vector_env: unknown argument {unknown[0]!r}; besides scenario, n_envs, n_robots, "
                                f"seed and autoreset it takes parallel_env's {sorted(known)}")
        if "render_mode" in env_kwargs and env_kwargs["render_mode"] is not None:
            raise ArgumentError("vector_env: render_mode is not supported (render a copy with parallel_env and "
                                "its copy_seeds)")
        scen = list(scenario) if isinstance(scenario, (list, tuple)) else [scenario]
        if not scen:
            raise ArgumentError("vector_env: scenario is an empty list")
        self._protos = [TinSwarmEnv(scenario=s, n_robots=n_robots, **env_kwargs) for s in scen]
        p0 = self._protos[0]
        from .reward import reward_params

        for k, p in enumerate(self._protos):
            name = p.config.name
            _same(name, k, "n_robots", p.n, p0.n)
            _same(name, k, "observation layout", p.layout, p0.layout)
            for key in _SHARED_PARAMS:
                _same(name, k, f"[world] {key}", _param(p.world.params, key), _param(p0.world.params, key))
            if p.config.targets.mobile or getattr(p.config.assets, "mobile", False):
                raise ArgumentError(f"vector_env: scenario {k} ({name}) has mobile targets or assets, which the "
                                    "vector env does not step; use parallel_env")
        E, N = int(n_envs), p0.n
        self.n_envs, self.n_robots, self.layout = E, N, p0.layout
        self.params = p0.world.params
        self.single_observation_space = spaces.Box(-1.0, 1.0, (self.layout.size,), np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.observation_space = spaces.Box(-1.0, 1.0, (E, N, self.layout.size), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (E, N, 2), np.float32)
        # each scenario's reward terms, one row per scenario of the mix (robots read their copy's)
        self._rws = np.array([reward_params(p.config) for p in self._protos], dtype=np.float64)
        self._M = max(max(p._target_slots for p in self._protos), 1)
        self._A = max(max(int(p.config.assets.n) for p in self._protos), 1)
        self.copy_scenario = np.arange(E) % len(scen)
        self.copy_seeds = np.zeros(E, dtype=np.int64)
        self._seed_streams(seed)
        R = E * N
        self._cop = np.repeat(np.arange(E, dtype=np.int64), N)
        self._scen_of_robot = np.repeat(self.copy_scenario, N).astype(np.int64)
        self._off = np.arange(E + 1, dtype=np.int64) * N
        z = np.zeros
        self._pos, self._head, self._h = z((R, 2)), z(R), z(R)
        self._tri = z(R, dtype=np.int64)  # local to the copy's TIN
        self._speed, self._batt, self._status = z(R), z(R), z(R, dtype=np.int8)
        self._coll = z(R, dtype=np.int64)
        self._live = z(R, dtype=bool)
        self._tglob = np.full(R, -1, dtype=np.int64)
        self._dist = np.full(R, np.inf)
        self._fid = np.full(R, NO_FIELD, dtype=np.int64)
        self._wor = z(R, dtype=np.int64)
        self._tri_off = z(R, dtype=np.int64)
        self._steps = z(E, dtype=np.int64)
        self._max_cycles = z(E, dtype=np.int64)
        # targets and assets: M (A) slots per copy, copy c's first k in use (the sensing's (eoff, use))
        self._tpos, self._tz, self._tuse = z((E * self._M, 2)), z(E * self._M), z(E * self._M, dtype=bool)
        self._apos, self._az, self._ause = z((E * self._A, 2)), z(E * self._A), z(E * self._A, dtype=bool)
        self._toff = np.arange(E + 1, dtype=np.int64) * self._M
        self._aoff = np.arange(E + 1, dtype=np.int64) * self._A
        self._worlds = [None] * E
        self._fields = [()] * E
        self._pack = None
        self._fpack = FieldPack()
        K = int(self.params.sensor.max_candidates)
        self._slots = [(np.empty((R, K), np.int64), np.empty((R, K)), np.empty((R, K), np.int8), z(R, np.int64))
                       for _ in range(3)]
        kb, ks = self.layout.k_breaks, self.layout.k_scan
        # what the observation reads of the break contacts, filled by the sensing pass each step (break_row): each
        # robot's kb nearest and its scan; no contact list is kept
        self._rows = (np.empty((R, kb), np.int64), np.empty((R, kb)), np.empty((R, kb, 2)), np.empty((R, ks)),
                      self.layout.scan_units())
        self._rows_start = np.arange(R + 1, dtype=np.int64) * kb
        P = self.params
        self._step_p = step_scalars(P)  # the scalars World._step passes to step_copies (one home)
        self._own_scale = (float(P.battery.capacity_j), float(P.robot.max_speed_mps), np.pi / 2, 90.0)
        self._ks = (self.layout.k_robots, self.layout.k_targets, self.layout.k_breaks, self.layout.k_assets,
                    self.layout.k_scan)
        self._started = False

    # -- resets ------------------------------------------------------------------------------
    def _seed_streams(self, seed) -> None:
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % (2 ** 63))
        self.base_seed = int(seed)  # the seed the copies' seed streams were made from
        self._gens = [copy_seed_stream(seed, c) for c in range(self.n_envs)]

    def _draw_seed(self, c: int) -> int:
        return int(self._gens[c].integers(0, 2 ** 63 - 1))

    def copy_rng_state(self, c: int) -> dict:
        """The state of copy ``c``'s seed generator (plain data, for checkpoints)."""
        return self._gens[c].bit_generator.state

    def set_copy_rng_state(self, c: int, state: dict) -> None:
        g = np.random.default_rng()
        try:
            g.bit_generator.state = state
        except (TypeError, ValueError, KeyError) as exc:
            raise ArgumentError(f"vector env copy {c}: rng_state is not a generator state ({exc})") from None
        self._gens[c] = g

    def reset(self, seed: int | None = None) -> np.ndarray:
        """Reset every copy; ``seed`` restarts the copies' seed generators (:func:`copy_seed_stream`),
        None continues them. Returns ``obs (E, N, d)``."""
        seed = check_seed(seed)
        if seed is not None:
            self._seed_streams(seed)
        obs = np.zeros((self.n_envs, self.n_robots, self.layout.size), dtype=np.float32)
        for c in range(self.n_envs):
            obs[c] = self._reset_copy(c, self._draw_seed(c), defer=True)
        self._repack()
        self._started = True
        return obs

    def reset_copy(self, c: int, seed: int | None = None, options: dict | None = None) -> np.ndarray:
        """Reset copy ``c`` alone (``seed`` None: the next of its stream), with the parallel env's
        reset ``options`` (``robot_positions``, ``headings``, ``target_positions``); returns its
        observations ``(N, d)``."""
        if not self._started:
            raise RuntimeError("call reset() before reset_copy()")
        check_range("reset_copy", "c", c, 0, self.n_envs - 1, integer=True, exc=ArgumentError)
        seed = check_seed(seed, "reset_copy")
        if seed is not None and seed >= 2 ** 63:
            raise ArgumentError(f"reset_copy(seed=...): seed must be < 2**63 (copy_seeds holds int64), got {seed}")
        return self._reset_copy(int(c), self._draw_seed(c) if seed is None else seed, options=options)

    def _reset_copy(self, c: int, seed: int, defer: bool = False, options: dict | None = None) -> np.ndarray:
        """Reset copy ``c`` with ``seed`` through its scenario's parallel env (the same code, so the
        same episode); returns its observations ``(N, d)``."""
        p = self._protos[self.copy_scenario[c]]
        obs = p.reset_arrays(seed=seed, options=options)
        s = p.world_state
        for ent, M, what in ((s.targets, self._M, "targets"), (s.assets, self._A, "assets")):
            if len(ent) > M:  # refused before anything of the copy is written: it stays as it was
                raise ArgumentError(f"vector_env: copy {c} would have {len(ent)} {what}, more than the {M} slots its "
                                    "scenario declares")
        self.copy_seeds[c] = seed
        N = self.n_robots
        rows = slice(c * N, (c + 1) * N)
        self._pos[rows] = s.positions
        self._head[rows] = s.headings
        self._tri[rows] = s.tri_idx
        self._h[rows] = s.heights
        self._speed[rows] = s.speeds
        self._batt[rows] = s.battery_j
        self._status[rows] = s.status
        self._coll[rows] = s.collisions
        self._live[rows] = True
        world = p.world
        for ent, M, pos, z, use in ((s.targets, self._M, self._tpos, self._tz, self._tuse),
                                    (s.assets, self._A, self._apos, self._az, self._ause)):
            k = len(ent)
            if k:
                pos[c * M:c * M + k] = ent.positions
                z[c * M:c * M + k] = world.tin.height_in(ent.positions, ent.tri_idx)
            use[c * M:(c + 1) * M] = False
            use[c * M:c * M + k] = True
        tidx = p.target_assignment
        self._tglob[rows] = np.where(tidx >= 0, c * self._M + tidx, -1)
        self._dist[rows] = p.distance_to_go()
        self._fields[c] = p._fields if p._fpack is not None else ()
        self._worlds[c] = world
        self._steps[c] = 0
        self._max_cycles[c] = p.max_cycles
        if not defer:
            self._place(c)
        return obs

    def _place(self, c: int) -> None:
        """Copy ``c``'s world and fields into the packs (appended when new), and its robots'
        world, triangle offset and field ids."""
        world = self._worlds[c]
        if self._pack is None or world not in self._pack:
            used = {id(w) for w in self._worlds}
            if self._pack is not None and len(self._pack.worlds) > 2 * len(used) + 8:
                self._repack()
                return
            if self._pack is None:
                self._pack = pack_one(world).copy()
            else:
                self._pack.append(world)  # in place, O(this world's size)
        self._fpack.extend(self._fields[c])
        if len(self._fpack) > 2 * sum(len(f) for f in self._fields) + 8:
            self._repack()
            return
        self._set_rows(c)

    def _set_rows(self, c: int) -> None:
        N = self.n_robots
        rows = slice(c * N, (c + 1) * N)
        w = self._pack.index(self._worlds[c])
        self._wor[rows] = w
        self._tri_off[rows] = self._pack.tri_off[w]
        t = self._tglob[rows] - c * self._M
        self._fid[rows] = field_ids(self._fpack, self._fields[c], np.where(self._tglob[rows] >= 0, t, -1))

    def _repack(self) -> None:
        """Rebuild both packs from the worlds and fields in use (drops the ended ones)."""
        seen, worlds = set(), []
        for w in self._worlds:
            if id(w) not in seen:
                seen.add(id(w))
                worlds.append(w)
        self._pack = pack_worlds(worlds).copy()  # a pack of its own, which append grows
        self._fpack = FieldPack([f for fs in self._fields for f in fs])
        for c in range(self.n_envs):
            self._set_rows(c)

    # -- step -------------------------------------------------------------------------------------
    def _check_actions(self, actions) -> np.ndarray:
        E, N = self.n_envs, self.n_robots
        try:
            raw = np.asarray(actions)
        except (TypeError, ValueError) as exc:
            raise ArgumentError(f"vector step(actions): not an array of numbers ({exc})") from None
        if raw.dtype.kind not in "fiu":
            raise ArgumentError(f"vector step(actions): actions must be real numbers, got dtype {raw.dtype}")
        a = raw.astype(np.float64)
        if a.shape != (E, N, 2):
            raise ArgumentError(f"vector step(actions): actions must have shape ({E}, {N}, 2), got {a.shape}")
        out, bad = live_actions(np.ascontiguousarray(a.reshape(E * N, 2)), self._live)
        if bad >= 0:
            raise ArgumentError(f"vector step(actions): copy {bad // N}, robot_{bad % N}: action "
                                f"{a.reshape(-1, 2)[bad].tolist()} is not finite")
        return out

    def step(self, actions):
        """One step of every copy: ``(obs, rewards, terminated, truncated, infos)`` (see the module
        docstring)."""
        if not self._started:
            raise RuntimeError("call reset() before step()")
        a = self._check_actions(actions)
        E, N = self.n_envs, self.n_robots
        with serial_if_small(E * N):
            obs, rew, term, trunc, why = self._step(a)
        live_after = self._live.reshape(E, N)
        done = ~live_after.any(axis=1)
        infos = {"reasons": why.reshape(E, N), "distance_to_go_m": self._dist.reshape(E, N).copy(),
                 "_final": done.copy()}
        obs = obs.reshape(E, N, -1)
        final = np.zeros_like(obs)
        if done.any() and self.autoreset:
            final[done] = obs[done]
            for c in np.flatnonzero(done).tolist():
                obs[c] = self._reset_copy(c, self._draw_seed(c))
                infos["distance_to_go_m"][c] = self._dist[c * N:(c + 1) * N]
        infos["final_obs"] = final
        infos["live"] = self._live.reshape(E, N).copy()
        return obs, rew.reshape(E, N), term.reshape(E, N), trunc.reshape(E, N), infos

    def _step(self, a: np.ndarray):
        pk = self._pack
        live = self._live
        tri_g = self._tri + self._tri_off
        (pos, tri_g, head, h, speeds, _, _, _, batt, energy, status, fell, emptied, coll, _) = step_copies(
            pk.T0, pk.steep, self._wor, self._cop, self._off, self._pos, tri_g, self._head, self._h, self._status,
            self._batt, a, self._step_p)
        tri = tri_g - self._tri_off
        dist, rew, term, why, trunc, live_after = end_step(
            self._rws, self._scen_of_robot, (self._fpack, self._fid), self._dist, pos, tri, self._tpos, self._tglob,
            live, energy, coll, fell, emptied, self._steps, self._max_cycles, self._cop, status)
        self._pos, self._tri, self._head, self._h, self._speed, self._batt, self._status = (
            pos, tri, head, h, speeds, batt, status)
        self._coll = self._coll + coll
        self._dist = dist
        obs = self._observe(tri_g, live)
        self._live = live_after
        return obs, rew, term, trunc, why

    def _observe(self, tri_g, live) -> np.ndarray:
        """Sense and encode every robot of every copy (robots not ``live`` read zeros)."""
        pk = self._pack
        P = self.params
        sp = P.sensor
        n = len(self._pos)
        px = np.ascontiguousarray(self._pos[:, 0])
        py = np.ascontiguousarray(self._pos[:, 1])
        for s in self._slots:
            s[3][:] = 0
        TG = ((np.ascontiguousarray(self._tpos[:, 0]), np.ascontiguousarray(self._tpos[:, 1]), self._tz, self._toff,
               self._tuse), self._slots[1])
        AS = ((np.ascontiguousarray(self._apos[:, 0]), np.ascontiguousarray(self._apos[:, 1]), self._az, self._aoff,
               self._ause), self._slots[2])
        _, (ro, rt, rd, rstart) = sense_copies(pk, self._wor, self._cop, self._off, px, py, self._head, tri_g,
                                               self._h, self._status, P, self._slots[0], TG, AS, rows=self._rows)
        tg = compact(*self._slots[1], px, py, self._head, TG[0][0], TG[0][1])
        at = compact(*self._slots[2], px, py, self._head, AS[0][0], AS[0][1])
        sin_slope, aspect_rad, slope_deg, _ = pk.tilt
        heading_compass = np.pi / 2 - self._head
        tilt = np.arcsin(sin_slope[tri_g] * np.sin(heading_compass - aspect_rad[tri_g]))
        own_n = (self._batt, self._speed, np.ascontiguousarray(tilt), np.ascontiguousarray(slope_deg[tri_g]))
        normals, drops, danger, ends = pk.OB
        bidx, bdist, bclosest, bscan, units = self._rows
        breaks = (self._rows_start, bidx.reshape(-1), bdist.reshape(-1), bclosest.reshape(-1, 2), normals, drops,
                  danger)
        scan = (self._rows_start, _NO_IDX, ends, units, bscan if self.layout.k_scan else NO_SCAN)
        obs = np.zeros((n, self.layout.size), dtype=np.float32)
        with serial_if_small(n, OBS_SERIAL_BELOW):
            fill_observations(obs, *layout_offsets(self.layout), self._ks, self._pos, self._head, self._h, own_n,
                              self._own_scale, pk.T0[5], tri_g, live, self._tglob, self._tpos, self._tz,
                              (rstart, rt, rd), (tg[4], tg[1], tg[2]), breaks, self._apos, (at[4], at[1], at[2]),
                              scan, float(sp.range_m), DZ_SCALE_M)
        return obs

    # -- views -----------------------------------------------------------------------------------
    @property
    def live_mask(self) -> np.ndarray:
        """``(E, N)`` bool, a copy: robots still in their copy's episode."""
        return self._live.reshape(self.n_envs, self.n_robots).copy()

    @property
    def steps(self) -> np.ndarray:
        """``(E,)`` steps taken in each copy's episode."""
        return self._steps.copy()

    def distance_to_go(self) -> np.ndarray:
        """``(E, N)`` m, each robot's distance to go (as the reward measures it)."""
        return self._dist.reshape(self.n_envs, self.n_robots).copy()

    def copies(self) -> list:
        """One :class:`CopyView` per copy."""
        return [CopyView(self, c) for c in range(self.n_envs)]

    def close(self) -> None:
        for p in self._protos:
            p.close()


class CopyView:
    """Copy ``c`` of a :class:`VectorEnv` seen as one env: its scenario's ``config``, ``layout``
    and ``max_cycles``, its ``steps``, ``live_mask``, ``world``/``tin``, its seed generator's
    ``rng_state`` (read and set), ``reset_arrays(seed, options)`` (:meth:`VectorEnv.reset_copy`)
    and ``distance_to_go()``. The adapters hand these out where one env per copy is expected."""

    def __init__(self, vec: VectorEnv, c: int):
        self._vec, self._c = vec, c
        self._proto = vec._protos[vec.copy_scenario[c]]

    config = property(lambda self: self._proto.config)
    layout = property(lambda self: self._proto.layout)
    n = property(lambda self: self._vec.n_robots)
    possible_agents = property(lambda self: self._proto.possible_agents)
    max_cycles = property(lambda self: int(self._vec._max_cycles[self._c]))
    steps = property(lambda self: int(self._vec._steps[self._c]))
    world = property(lambda self: self._vec._worlds[self._c])
    tin = property(lambda self: self._vec._worlds[self._c].tin)
    render_mode = None

    def observation_space(self, agent=None):
        return self._vec.single_observation_space

    def action_space(self, agent=None):
        return self._vec.single_action_space

    @property
    def live_mask(self) -> np.ndarray:
        return self._vec.live_mask[self._c]

    def distance_to_go(self) -> np.ndarray:
        return self._vec.distance_to_go()[self._c]

    @property
    def rng_state(self) -> dict:
        return self._vec.copy_rng_state(self._c)

    @rng_state.setter
    def rng_state(self, state: dict) -> None:
        self._vec.set_copy_rng_state(self._c, state)

    def reset_arrays(self, seed: int | None = None, options: dict | None = None) -> np.ndarray:
        return self._vec.reset_copy(self._c, seed, options)

    def render(self):
        return None

    def close(self) -> None:
        pass


def vector_env(scenario="cliff_goal", n_envs: int = 1, n_robots: int | None = None, seed: int | None = None,
               **env_kwargs) -> VectorEnv:
    """E copies of the swarm stepped by one call (:class:`VectorEnv`); ``env_kwargs`` go to each
    copy's :class:`~tin_swarm_env.env.tin_swarm.TinSwarmEnv` (``max_cycles``...)."""
    if isinstance(n_envs, bool) or not isinstance(n_envs, numbers.Integral):
        raise ArgumentError(f"vector_env: n_envs must be an integer >= 1, got {n_envs!r}")
    return VectorEnv(scenario, n_envs=n_envs, n_robots=n_robots, seed=seed, **env_kwargs)
