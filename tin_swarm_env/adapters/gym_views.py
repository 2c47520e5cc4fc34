"""Gymnasium views of the swarm: one learning robot, or the whole swarm as one agent.

Both are thin ``gymnasium.Env`` layers over the parallel environment's batched path
(:meth:`~tin_swarm_env.env.TinSwarmEnv.reset_arrays` / ``step_arrays``), so an episode through a
view is bit for bit the episode of the parallel env under the same seed and actions.

* :class:`TinSwarmSingleEnv` (``"tin_swarm/TinSwarmSingle-v0"``): robot 0 learns; the other
  robots (if any) are driven by a fixed policy (APF by default).
* :class:`TinSwarmCentralEnv` (``"tin_swarm/TinSwarmCentral-v0"``): one agent observes ``(n, d)``
  and commands ``(n, 2)``, for centralised controllers and for comparing them with
  decentralised ones.

**Time limit**: the parallel env truncates at the scenario's ``max_cycles`` (or the
``max_cycles`` argument); the views report that as ``truncated=True``. They are registered with
``max_episode_steps=None``: do not add Gymnasium's ``TimeLimit`` on top (a second, different
limit), pass ``max_cycles=`` instead.

**Seeding** (Gymnasium's way): ``reset(seed=s)`` seeds ``self.np_random`` and resets the parallel
env with the same ``s``; ``reset()`` without a seed resets it with the seed
``int(self.np_random.integers(2**63 - 1))`` (so a seeded first reset fixes every later episode,
whatever happened in between). Other policies that use
randomness (``others="random"``) are seeded from that per-episode seed.

:func:`register_gymnasium` registers both ids with entry-point strings (idempotent).
"""

from __future__ import annotations

import copy

import gymnasium
import numpy as np
from gymnasium import spaces

from .._registration import CENTRAL_ID, SINGLE_ID, register_gymnasium
from ..env.tin_swarm import TinSwarmEnv
from ..env.checks import ENV_ARGS, check_env_kwargs, check_seed, float_array
from ..errors import ArgumentError
from ..world.state import Reason

__all__ = ["SINGLE_ID", "CENTRAL_ID", "TinSwarmSingleEnv", "TinSwarmCentralEnv", "register_gymnasium",
           "reason_labels", "END_LABELS"]

TIMEOUT_LABEL = Reason.TIMEOUT.label
END_LABELS = tuple(r.label for r in Reason if r != Reason.NONE)  # every way a robot's episode ends
_LABEL_DTYPE = "<U16"  # fixed width so that vectorised infos never truncate a label
_REASON_LABELS = np.array([Reason(c).label for c in range(max(Reason) + 1)], dtype=_LABEL_DTYPE)  # code -> label


def reason_labels(codes, truncated) -> np.ndarray:
    """End-reason strings ``(n,)`` for reason ``codes (n,)`` (``step_arrays``'s) and
    ``truncated (n,)``: "arrived", "fell", "battery", "max_cycles" when truncated, "" otherwise.

    The one place reason codes become strings in this module."""
    out = _REASON_LABELS[np.asarray(codes, dtype=np.intp).reshape(-1)]
    out[np.asarray(truncated, dtype=bool).reshape(-1)] = TIMEOUT_LABEL
    return out


_METADATA = {"render_modes": list(TinSwarmEnv.metadata["render_modes"]),
             "render_fps": TinSwarmEnv.metadata["render_fps"]}


class _SwarmView(gymnasium.Env):
    """What both views share: the parallel env, seeding, liveness, rendering."""

    metadata = _METADATA

    def __init__(self, render_mode: str | None, env_kwargs: dict):
        check_env_kwargs(env_kwargs, f"{type(self).__name__}", tuple(a for a in ENV_ARGS if a != "render_mode"))
        self.parallel_env = TinSwarmEnv(render_mode=render_mode, **env_kwargs)
        self.metadata = copy.deepcopy(type(self).metadata)  # this instance's own (wrappers may write to it)
        self.render_mode = render_mode
        self.n = self.parallel_env.n
        self.max_cycles = self.parallel_env.max_cycles
        self._live = np.zeros(self.n, dtype=bool)  # robots whose episode has not ended
        self._obs = None  # (n, d) float32, the last observations of all robots

    def _reset_swarm(self, seed, options) -> int:
        """Seed ``np_random`` the Gymnasium way and reset the parallel env; returns its seed."""
        super().reset(seed=check_seed(seed))
        swarm_seed = int(seed) if seed is not None else int(self.np_random.integers(2**63 - 1))
        self._obs = self.parallel_env.reset_arrays(seed=swarm_seed, options=options)
        self._live[:] = True
        return swarm_seed

    def _step_swarm(self, actions):
        """Step the parallel env with ``actions (n, 2)``; updates liveness. Returns
        ``obs (n, d), rewards (n,), terminated (n,), truncated (n,), labels (n,)``."""
        obs, rewards, terminated, truncated, codes = self.parallel_env.step_arrays(actions)
        labels = reason_labels(codes, truncated)
        self._live &= ~(terminated | truncated)
        self._obs = obs
        return obs, rewards, terminated, truncated, labels

    def render(self):
        """The parallel env's frame (``render_mode="rgb_array"``: ``(H, W, 3)`` uint8)."""
        return self.parallel_env.render()

    def close(self):
        self.parallel_env.close()


def _others_policy(others, penv):
    """The fixed policy of the non-learning robots: an object with ``act_batch``, or a name
    ("random" and "still" are resolved per episode, see :meth:`TinSwarmSingleEnv._others_actions`)."""
    if isinstance(others, str):
        if others == "apf":
            from ..policies import APFPolicy

            return APFPolicy(penv)
        if others in ("random", "still"):
            return others
        raise ArgumentError(f"others must be 'apf', 'random', 'still' or a policy with act_batch, got {others!r}")
    if not callable(getattr(others, "act_batch", None)):
        raise ArgumentError(f"others must be 'apf', 'random', 'still' or a policy with act_batch(obs), got {others!r}")
    return others


class TinSwarmSingleEnv(_SwarmView):
    """One learning robot (robot 0) of the swarm as a ``gymnasium.Env``.

    **Spaces**: one robot's observation ``Box(-1, 1, (d,), float32)`` and action
    ``Box(-1, 1, (2,), float32)`` of the parallel env (see
    :class:`~tin_swarm_env.env.TinSwarmEnv` for the layout).

    **Other robots** (``n_robots > 1``): ``others="apf"`` [default] drives them with
    :class:`~tin_swarm_env.policies.APFPolicy`, ``"random"`` with uniform random actions
    (seeded from the episode's seed), ``"still"`` with zero actions, or any object with
    ``act_batch(obs (n, d)) -> (n, 2)`` (called on every robot's observation; row 0 is replaced
    by the learner's action).

    **Step**: ``reward``, ``terminated`` and ``truncated`` are robot 0's; the episode ends when
    robot 0 terminates ("arrived", "fell", "battery") or is truncated at ``max_cycles``
    (``truncated=True``; registered with ``max_episode_steps=None``, do not add ``TimeLimit``).
    ``info["reason"]`` is set on the final step only, as in the parallel env: one of
    "arrived", "fell", "battery", "max_cycles".

    **Arguments**: ``others``, ``render_mode`` (None, "human", "rgb_array"), and every keyword of
    :class:`~tin_swarm_env.env.TinSwarmEnv` (``scenario``, ``n_robots``, ``max_cycles``,
    ``sensor_cones``, ``render_width``). ``reset(options=...)`` passes through to
    ``reset_arrays`` (``robot_positions``, ``headings``).
    """

    def __init__(self, others="apf", render_mode: str | None = None, **env_kwargs):
        super().__init__(render_mode, env_kwargs)
        penv = self.parallel_env
        a0 = penv.possible_agents[0]
        self.observation_space = copy.deepcopy(penv.observation_space(a0))
        self.action_space = copy.deepcopy(penv.action_space(a0))
        self.others = _others_policy(others, penv)
        self._random_others = None  # np.random.Generator for others="random", per episode

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        swarm_seed = self._reset_swarm(seed, options)
        if isinstance(self.others, str) and self.others == "random":
            self._random_others = np.random.default_rng(np.random.SeedSequence((swarm_seed, 1)))
        elif hasattr(self.others, "reset"):  # a policy with per-robot memory (APF) starts afresh
            self.others.reset()
        if self.render_mode == "human":
            self.render()
        return self._obs[0].copy(), {}

    def _others_actions(self) -> np.ndarray:
        """Actions ``(n, 2)`` float64 (a new array) of every robot under the others' policy;
        row 0 is the caller's to overwrite."""
        if self.n == 1 or (isinstance(self.others, str) and self.others == "still"):
            return np.zeros((self.n, 2))
        if isinstance(self.others, str) and self.others == "random":
            return self._random_others.uniform(-1, 1, (self.n, 2))
        acts = np.array(self.others.act_batch(self._obs), dtype=np.float64)
        if acts.shape != (self.n, 2):
            raise ArgumentError(f"others.act_batch must return shape ({self.n}, 2), got {acts.shape}")
        return acts

    def step(self, action):
        if self._obs is None or not self._live[0]:
            raise RuntimeError("call reset() before step() (robot 0's episode is over or not started)")
        a = float_array(action, "step(action)", (2,), finite=False)  # NaN: named as robot_0 by step_arrays
        actions = self._others_actions()
        actions[0] = a
        obs, rewards, terminated, truncated, labels = self._step_swarm(actions)
        info = {"reason": str(labels[0])} if terminated[0] or truncated[0] else {}
        if self.render_mode == "human":
            self.render()
        return obs[0].copy(), float(rewards[0]), bool(terminated[0]), bool(truncated[0]), info


class TinSwarmCentralEnv(_SwarmView):
    """The whole swarm as one agent (a centralised controller) as a ``gymnasium.Env``.

    **Spaces**: observation ``Box(-1, 1, (n, d), float32)`` (row ``i`` is robot ``i``'s
    observation of the parallel env), action ``Box(-1, 1, (n, 2), float32)``.

    **Done robots**: a robot whose episode ended reads its last observation on the step it ends
    and zeros after; its action rows are ignored (any finite or non-finite value).

    **Reward**: ``reward="sum"`` [default] the sum of every robot's reward this step, or
    ``"mean"`` that sum over ``n`` (robots that are done contribute 0).

    **Episode end**: ``terminated`` when every robot has terminated (arrived, fell, battery);
    ``truncated`` when the step count reaches ``max_cycles`` with a robot still running (it is
    not ``TimeLimit``'s: registered with ``max_episode_steps=None``, do not add it twice).

    **Info** (reset and every step): ``"reasons"``: ``(n,)`` object array of str (object, not a
    numpy str dtype, so that Gymnasium's checker and vector infos take it), each robot's end reason so far
    ("" while it runs; "arrived", "fell", "battery", "max_cycles"); ``"counts"``: ``{"live": int,
    "arrived": int, ...}``, robots running and robots ended per reason.

    **Arguments**: ``reward``, ``render_mode`` and every keyword of
    :class:`~tin_swarm_env.env.TinSwarmEnv`.
    """

    def __init__(self, reward: str = "sum", render_mode: str | None = None, **env_kwargs):
        if reward not in ("sum", "mean"):
            raise ArgumentError(f"reward must be 'sum' or 'mean', got {reward!r}")
        super().__init__(render_mode, env_kwargs)
        penv = self.parallel_env
        a0 = penv.possible_agents[0]
        obs1, act1 = penv.observation_space(a0), penv.action_space(a0)
        self.observation_space = spaces.Box(np.tile(obs1.low, (self.n, 1)), np.tile(obs1.high, (self.n, 1)),
                                            dtype=obs1.dtype)
        self.action_space = spaces.Box(np.tile(act1.low, (self.n, 1)), np.tile(act1.high, (self.n, 1)),
                                       dtype=act1.dtype)
        self.reward_mode = reward
        self._ended = np.full(self.n, "", dtype=object)  # (n,) str, end reason so far, "" while running

    def _info(self) -> dict:
        counts = {"live": int(self._live.sum())}
        counts.update({k: int(np.count_nonzero(self._ended == k)) for k in END_LABELS})
        return {"reasons": self._ended.copy(), "counts": counts}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._reset_swarm(seed, options)
        self._ended[:] = ""
        if self.render_mode == "human":
            self.render()
        return self._obs, self._info()

    def step(self, action):
        if self._obs is None or not self._live.any():
            raise RuntimeError("call reset() before step() (every robot's episode is over or not started)")
        a = float_array(action, "step(action)", (self.n, 2), finite=False)
        live_before = self._live.copy()
        a = np.where(live_before[:, None], a, 0.0)  # done robots' actions are ignored, even NaN
        obs, rewards, terminated, truncated, labels = self._step_swarm(a)
        ended_now = live_before & ~self._live
        self._ended[ended_now] = labels[ended_now].astype(object)
        total = float(np.sum(rewards, dtype=np.float64))
        reward = total if self.reward_mode == "sum" else total / self.n
        all_done = not self._live.any()
        trunc = bool(truncated.any())
        if self.render_mode == "human":
            self.render()
        return obs, reward, all_done and not trunc, trunc, self._info()
