"""PufferLib 3 adapter: the vector env as a native ``pufferlib.PufferEnv``.

    from tin_swarm_env.adapters.puffer import make_puffer_env
    env = make_puffer_env("generated", n_envs=256, n_robots=16, seed=0)   # num_agents = 4 096
    obs, infos = env.reset()
    obs, rewards, terminals, truncations, infos = env.step(actions)      # actions (num_agents, 2)

* Every robot of every copy is one PufferLib agent (``num_agents = n_envs * n_robots``, agent
  ``c * n_robots + i`` is robot ``i`` of copy ``c``), stepped by the vector env in one call; the
  env writes into PufferLib's shared buffers (``observations``, ``rewards``, ``terminals``,
  ``truncations``, ``masks``) in place, so it runs under ``pufferlib.vector``'s ``PufferEnv``
  (native), ``Serial`` and ``Multiprocessing`` backends and feeds ``pufferlib.pufferl.PuffeRL``.
* Episodes as in PufferLib's native envs: a robot reports ``terminals``/``truncations`` once, at
  the step it ends; a copy that ended resets in place (the observations of that step are its new
  episode's). A robot that ended while its copy goes on is frozen until its copy resets: zero
  observation and reward, ``masks`` False (from the step after it ended), its actions ignored.
  ``infos`` is a list with one dict per step in which robots ended:
  ``{"arrived", "fell", "battery", "max_cycles"}`` shares of the robots that ended.
* Seeds: ``reset(seed)`` restarts the copies' seed streams (the vector env's ``copy_seeds``).

``agents/train_puffer.py`` trains PufferLib's PPO (``pufferl.PuffeRL``) on it. Needs the
``pufferlib-core`` package (3.0.x: ``pip install 'tin_swarm_env[puffer]'``). Its compiled extension
(``pufferlib._C``, the advantage kernel PuffeRL imports) is built against CUDA torch and does not
load beside the CPU-only torch; :func:`use_cpu_advantage` then registers the same kernel
(``pufferlib::compute_puff_advantage``, PufferLib's ``puff_advantage_row``: V-trace-clipped GAE)
written in torch for the CPU, so ``pufferl`` imports and trains.
"""

from __future__ import annotations

import numpy as np

from ..errors import require

__all__ = ["make_puffer_env", "puffer_env_class", "use_cpu_advantage", "puff_advantage"]

_CLASS = None


def make_puffer_env(scenario="cliff_goal", n_envs: int = 1, n_robots: int | None = None, seed: int | None = None,
                    buf=None, shield: str = "none", reward_scale: float = 1.0, prior: str = "none", **env_kwargs):
    """A native ``pufferlib.PufferEnv`` over ``tse.vector_env(scenario, n_envs, n_robots, seed,
    **env_kwargs)`` (module docstring); ``buf``: PufferLib's shared buffers (its backends pass them).
    ``shield="safety_cut"`` filters the actions as a policy file's shield does (the SB3 VecEnv's
    option); ``reward_scale`` multiplies every reward (PuffeRL clips rewards to ``[-1, 1]``: at 1.0 a
    fall's -100 and an arrival's +10 would read as -1 and +1). ``prior="apf"``: the actions are a
    residual policy's corrections, added to the default APF's commands before the clip and the shield
    (:mod:`tin_swarm_env.policies.residual`; APF's memory of a copy is forgotten when it resets, and
    robot ``i`` of every copy has the side preference of robot ``i`` of an episode of its own:
    :func:`~tin_swarm_env.policies.residual.side_rows`)."""
    return puffer_env_class()(scenario, n_envs=n_envs, n_robots=n_robots, seed=seed, buf=buf, shield=shield,
                              reward_scale=reward_scale, prior=prior, **env_kwargs)


def puff_advantage(values, rewards, dones, importance, advantages, gamma, lam, rho_clip, c_clip) -> None:
    """PufferLib's ``puff_advantage`` (``extensions/pufferlib.cpp``) in torch, into ``advantages``
    ``(rows, horizon)`` float32: per row, backwards from ``horizon - 2``, ``delta = rho (r[t+1] + gamma
    v[t+1] (1 - d[t+1]) - v[t])`` and ``A[t] = delta + gamma lam c A[t+1] (1 - d[t+1])``, with
    ``rho``/``c`` the importance ratio clipped at ``rho_clip``/``c_clip``; every row at once."""
    import torch

    horizon = values.shape[1]
    last = torch.zeros(values.shape[0], dtype=values.dtype, device=values.device)
    for t in range(horizon - 2, -1, -1):
        nonterminal = 1.0 - dones[:, t + 1]
        rho = torch.clamp(importance[:, t], max=rho_clip)
        c = torch.clamp(importance[:, t], max=c_clip)
        delta = rho * (rewards[:, t + 1] + gamma * values[:, t + 1] * nonterminal - values[:, t])
        last = delta + gamma * lam * c * last * nonterminal
        advantages[:, t] = last


_CPU_LIB = None


def use_cpu_advantage() -> bool:
    """Make ``pufferlib.pufferl`` importable without CUDA: when ``pufferlib._C`` does not load,
    register :func:`puff_advantage` as the op ``pufferlib::compute_puff_advantage`` (CPU) and stand
    an empty module in for ``pufferlib._C``. Returns True when it did; False when the extension
    loads (nothing is changed)."""
    global _CPU_LIB
    import sys
    import types

    require("pufferlib", "puffer", "The PufferLib adapter")
    try:
        from pufferlib import _C  # noqa: F401
        return False
    except ImportError:
        pass
    if _CPU_LIB is None:
        import torch

        lib = torch.library.Library("pufferlib", "DEF")
        lib.define("compute_puff_advantage(Tensor(a!) values, Tensor(b!) rewards, Tensor(c!) dones, "
                   "Tensor(d!) importance, Tensor(e!) advantages, float gamma, float lambda, float rho_clip, "
                   "float c_clip) -> ()")
        lib.impl("compute_puff_advantage", puff_advantage, "CPU")
        _CPU_LIB = lib
        sys.modules["pufferlib._C"] = types.ModuleType("pufferlib._C")
    return True


def puffer_env_class():
    """The ``TinSwarmPufferEnv`` class, made on first use (it derives from ``pufferlib.PufferEnv``)."""
    global _CLASS
    if _CLASS is not None:
        return _CLASS
    require("pufferlib", "puffer", "The PufferLib adapter")
    import pufferlib
    import pufferlib.spaces  # noqa: F401

    from ..env.vector import VectorEnv
    from ..policies.residual import add_prior, side_rows
    from ..world.state import Reason

    labels = {int(r): r.label for r in Reason if r != Reason.NONE}

    class TinSwarmPufferEnv(pufferlib.PufferEnv):
        """The vector env as a native PufferLib env (module docstring)."""

        def __init__(self, scenario="cliff_goal", n_envs=1, n_robots=None, seed=None, buf=None, shield="none",
                     reward_scale=1.0, prior="none", **env_kwargs):
            from ..errors import ArgumentError, check_range
            from ..policies.base import make_shield
            from ..policies.learned import SHIELDS
            from ..policies.residual import PRIORS, make_prior

            if shield not in SHIELDS:
                raise ArgumentError(f"make_puffer_env: shield must be one of {list(SHIELDS)}, got {shield!r}")
            check_range("make_puffer_env", "reward_scale", reward_scale, 0, lo_open=True, exc=ArgumentError)
            self.vec = VectorEnv(scenario, n_envs=n_envs, n_robots=n_robots, seed=seed, **env_kwargs)
            self.reward_scale = np.float32(reward_scale)
            self._shield = make_shield(shield, self.vec._protos[0])
            if prior not in PRIORS:
                raise ArgumentError(f"make_puffer_env: prior must be one of {list(PRIORS)}, got {prior!r}")
            self._prior = make_prior(prior, self.vec._protos[0], "make_puffer_env")
            self._prior_act = None  # the prior's commands on the current observations
            self._rows = side_rows(self.vec.n_envs, self.vec.n_robots)  # the prior's memory row of each agent
            self.single_observation_space = self.vec.single_observation_space
            self.single_action_space = self.vec.single_action_space
            self.num_agents = self.vec.n_envs * self.vec.n_robots
            self.agents_per_batch = self.num_agents  # one batch of every agent (PuffeRL's recurrent state's rows)
            self.render_mode = None
            super().__init__(buf)

        def reset(self, seed=None):
            obs = self.vec.reset(seed=None if seed is None else int(seed))
            self.observations[:] = obs.reshape(self.num_agents, -1)
            self.rewards[:] = 0
            self.terminals[:] = False
            self.truncations[:] = False
            self.masks[:] = True
            if self._prior is not None:
                self._prior.reset()
                self._prior_act = self._prior(self.observations, self._rows)
            return self.observations, []

        def step(self, actions):
            v = self.vec
            live_before = v._live.copy()
            a = np.asarray(actions, dtype=np.float64).reshape(v.n_envs * v.n_robots, 2)
            if self._prior is not None:  # a residual: the correction plus the prior's command
                a = add_prior(self._prior_act, a)
            if self._shield is not None:  # it reads the observations the actions were chosen from
                a = self._shield(a, self.observations)
            if self._prior is not None:
                self._prior.driven(a, self._rows)
            a = a.reshape(v.n_envs, v.n_robots, 2)
            obs, rew, term, trunc, info = v.step(a)
            final = np.repeat(info["_final"], v.n_robots)
            term, trunc = term.reshape(-1), trunc.reshape(-1)
            ended = term | trunc
            # a copy that ended shows its new episode (PufferLib's native envs reset in place); a robot that ended
            # while its copy goes on reads zeros from now until its copy resets
            self.observations[:] = np.where((ended & ~final)[:, None], np.float32(0.0),
                                            obs.reshape(self.num_agents, -1))
            self.rewards[:] = rew.reshape(-1) * self.reward_scale
            self.terminals[:] = term
            self.truncations[:] = trunc
            self.masks[:] = live_before
            if self._prior is not None:  # a copy that reset starts its robots' memories afresh
                self._prior.forget(self._rows[final])
                self._prior_act = self._prior(self.observations, self._rows)
            infos = []
            if ended.any():
                why = info["reasons"].reshape(-1)[ended]
                infos.append({lab: float(np.mean(why == code)) for code, lab in labels.items()})
            return self.observations, self.rewards, self.terminals, self.truncations, infos

        def close(self):
            self.vec.close()

    TinSwarmPufferEnv.__qualname__ = "TinSwarmPufferEnv"
    _CLASS = TinSwarmPufferEnv
    return TinSwarmPufferEnv
