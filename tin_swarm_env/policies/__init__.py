"""Policies: observation -> action. They read observations, never world state."""

from .apf import APFPolicy, RandomPolicy, apf_forces

__all__ = ["APFPolicy", "RandomPolicy", "apf_forces"]
