"""Layer 2: the PettingZoo parallel environment (the only layer importing pettingzoo/gymnasium)."""

from .observation import ObsLayout
from .tin_swarm import TinSwarmEnv, env, parallel_env, raw_env

__all__ = ["ObsLayout", "TinSwarmEnv", "env", "parallel_env", "raw_env"]
