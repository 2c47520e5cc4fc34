"""Layer 2: the PettingZoo parallel environment (the only layer importing pettingzoo/gymnasium)."""

from ..world.state import Reason
from .observation import ObsLayout
from .tin_swarm import TinSwarmEnv, env, parallel_env, raw_env

__all__ = ["ObsLayout", "Reason", "TinSwarmEnv", "env", "parallel_env", "raw_env"]
