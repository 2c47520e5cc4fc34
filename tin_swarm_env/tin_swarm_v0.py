"""Versioned entry point: ``from tin_swarm_env import tin_swarm_v0; tin_swarm_v0.parallel_env()``."""

from .env.tin_swarm import TinSwarmEnv, env, parallel_env, raw_env

__all__ = ["TinSwarmEnv", "env", "parallel_env", "raw_env"]
