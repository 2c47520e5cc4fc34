"""Ray RLlib adapter: a corrected ``ParallelPettingZooEnv`` for tin_swarm_v0.

RLlib's own ``ParallelPettingZooEnv`` (ray 2.60) freezes ``agents`` at construction in set
order (so it never shrinks as robots die, and its order changes from run to run), passes an
argument to ``render()`` that PettingZoo's ``render`` does not take, and ends an episode only
when *all* robots reported in a step are terminated (or all truncated), which misses a last step
where one robot arrives while the others hit the time limit. This subclass keeps ``agents`` in
``possible_agents`` order and in step with the environment, renders, and ends the episode
exactly when no robot is left.
"""

from __future__ import annotations

from ..errors import require

__all__ = ["RLlibTinSwarmEnv", "rllib_env_creator", "ENV_NAME"]  # noqa: F822 (lazy, see __getattr__)

ENV_NAME = "tin_swarm_v0"

_CLASS = None


def _cls():
    global _CLASS
    if _CLASS is not None:
        return _CLASS
    require("ray.rllib", "rllib", "The RLlib adapter")
    import gymnasium as gym
    from ray.rllib.env.multi_agent_env import MultiAgentEnv
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    from ..env import parallel_env

    class RLlibTinSwarmEnv(ParallelPettingZooEnv):
        """``RLlibTinSwarmEnv(config)``: ``config`` holds :func:`tin_swarm_env.parallel_env`'s
        keyword arguments (``scenario``, ``n_robots``, ``max_cycles``, ``render_mode``...)."""

        def __init__(self, config=None):
            MultiAgentEnv.__init__(self)
            self.par_env = parallel_env(**dict(config or {}))
            self.possible_agents = list(self.par_env.possible_agents)
            self.agents = list(self.possible_agents)
            self._agent_ids = set(self.possible_agents)
            self.render_mode = self.par_env.render_mode
            obs_sp = self.par_env.observation_space(self.possible_agents[0])
            act_sp = self.par_env.action_space(self.possible_agents[0])
            self.observation_spaces = {a: obs_sp for a in self.possible_agents}
            self.action_spaces = {a: act_sp for a in self.possible_agents}
            self.observation_space = gym.spaces.Dict(self.observation_spaces)
            self.action_space = gym.spaces.Dict(self.action_spaces)

        def reset(self, *, seed=None, options=None):
            obs, infos = self.par_env.reset(seed=seed, options=options)
            self.agents = list(self.par_env.agents)
            return obs, infos or {}

        def step(self, action_dict):
            obs, rew, term, trunc, infos = self.par_env.step(action_dict)
            self.agents = list(self.par_env.agents)
            over = not self.agents
            term["__all__"] = over and all(term.values())
            trunc["__all__"] = over and not term["__all__"]
            return obs, rew, term, trunc, infos

        def render(self):
            return self.par_env.render()

    _CLASS = RLlibTinSwarmEnv
    return RLlibTinSwarmEnv


def rllib_env_creator(config):
    """For ``ray.tune.registry.register_env(ENV_NAME, rllib_env_creator)``."""
    return _cls()(config)


def __getattr__(name):
    if name == "RLlibTinSwarmEnv":
        return _cls()
    raise AttributeError(name)
