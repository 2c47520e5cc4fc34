"""RandomPolicy: uniform random body-frame velocities (a floor for the tables)."""

from __future__ import annotations

import numpy as np

from .base import act_dict

__all__ = ["RandomPolicy"]


class RandomPolicy:
    """Uniform random body-frame velocities in ``[-1, 1]^2`` from its own generator
    (``np.random.default_rng(seed)``); ``env`` is accepted for the common signature and unused."""

    def __init__(self, env=None, seed: int | None = None):
        self.rng = np.random.default_rng(seed)

    def act_batch(self, obs) -> np.ndarray:
        return self.rng.uniform(-1, 1, (len(obs), 2)).astype(np.float32)

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs)
