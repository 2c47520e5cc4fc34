"""Policies by name for the apps: ``"apf"``, ``"random"`` or a saved Stable-Baselines3 model."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MissingExtraError

__all__ = ["make_policy", "SB3Policy"]


def make_policy(env, policy: str, fields=None, seed: int | None = None):
    """``"apf"`` (with the APF ``fields``, default all), ``"random"`` (seeded), a pickle-free
    policy directory (:func:`~tin_swarm_env.policies.load_policy`) or a path to a saved SB3 model
    (``.zip``): an object with ``act_batch(obs (n, d)) -> (n, 2)``."""
    from ..policies import APFPolicy, RandomPolicy
    from ..world.fields import FIELDS

    if policy == "apf":
        return APFPolicy(env, fields=tuple(fields) if fields else FIELDS)
    if policy == "random":
        return RandomPolicy(env, seed=seed)
    if Path(policy).is_dir() or Path(policy).name == "policy.json":  # a pickle-free policy file
        from ..policies import load_policy

        return load_policy(policy, env)
    return SB3Policy.load(policy)


class SB3Policy:
    """An SB3 model as a shared, deterministic policy over batched observations."""

    def __init__(self, model):
        self.model = model

    @classmethod
    def load(cls, path) -> SB3Policy:
        try:
            from stable_baselines3 import PPO
        except ImportError as exc:
            raise MissingExtraError(
                f"loading the learned policy {str(path)!r} needs stable-baselines3; install it with: "
                "pip install 'tin_swarm_env[train]'") from exc
        return cls(PPO.load(path, device="cpu"))

    def act_batch(self, obs):
        a, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(a, dtype=np.float32)
