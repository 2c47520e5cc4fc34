"""Layer 2: training adapters (SB3 VecEnv, RLlib env and PPO config, TorchRL env, BenchMARL task,
Gymnasium single-robot and centralised views). Heavy dependencies load lazily; a missing one
raises an error naming the extra to install."""

from .sb3 import make_sb3_vec_env

__all__ = ["make_sb3_vec_env", "TinSwarmVecEnv", "RLlibTinSwarmEnv", "rllib_env_creator", "ppo_config",
           "make_torchrl_env", "TinSwarmSingleEnv", "TinSwarmCentralEnv", "register_gymnasium"]


def __getattr__(name):
    if name == "TinSwarmVecEnv":
        from .sb3 import vec_class

        return vec_class()
    if name in ("RLlibTinSwarmEnv", "rllib_env_creator", "ppo_config"):
        from . import rllib

        return getattr(rllib, name)
    if name == "make_torchrl_env":
        from .torchrl import make_torchrl_env

        return make_torchrl_env
    if name in ("TinSwarmSingleEnv", "TinSwarmCentralEnv", "register_gymnasium"):
        from . import gym_views

        return getattr(gym_views, name)
    raise AttributeError(name)
