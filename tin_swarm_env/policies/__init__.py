"""Policies: observation -> action. They read observations, never world state, except
:class:`GeodesicPolicy`, the map-knowing reference."""

from .apf import APFPolicy, RandomPolicy, apf_forces
from .geodesic import GeodesicPolicy
from .learned import MLPPolicy, ShieldedPolicy, load_policy, save_policy

__all__ = ["APFPolicy", "RandomPolicy", "GeodesicPolicy", "apf_forces", "MLPPolicy", "ShieldedPolicy", "load_policy",
           "save_policy"]
