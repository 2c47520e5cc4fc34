"""Policies: observation -> action. They read observations, never world state."""

from .apf import APFPolicy, RandomPolicy, apf_forces
from .learned import MLPPolicy, load_policy, save_policy

__all__ = ["APFPolicy", "RandomPolicy", "apf_forces", "MLPPolicy", "load_policy", "save_policy"]
