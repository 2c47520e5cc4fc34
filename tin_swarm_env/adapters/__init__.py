"""Layer 2: training adapters (SB3 VecEnv, RLlib env). Heavy dependencies load lazily; a
missing one raises an error naming the extra to install."""

from .sb3 import make_sb3_vec_env

__all__ = ["make_sb3_vec_env", "TinSwarmVecEnv", "RLlibTinSwarmEnv", "rllib_env_creator"]


def __getattr__(name):
    if name == "TinSwarmVecEnv":
        from .sb3 import _vec_class

        return _vec_class()
    if name in ("RLlibTinSwarmEnv", "rllib_env_creator"):
        from . import rllib

        return getattr(rllib, name)
    raise AttributeError(name)
