"""Policies: observation -> action. They read observations, never world state, except
:class:`GeodesicPolicy`, the map-knowing reference. :mod:`~tin_swarm_env.policies.base` holds what
they share (the :class:`Policy` protocol, the decoded observation, the safety shield)."""

from .apf import APFPolicy, apf_forces
from .base import DecodedObs, Policy, SafetyShield, decode, safety_cut, unwrap_env
from .geodesic import GeodesicPolicy
from .learned import MLPPolicy, ShieldedPolicy, load_policy, policy_layout, save_policy
from .random import RandomPolicy
from .recurrent import RecurrentPolicy

__all__ = ["APFPolicy", "RandomPolicy", "GeodesicPolicy", "apf_forces", "MLPPolicy", "ShieldedPolicy", "load_policy", "policy_layout",
           "save_policy", "Policy", "DecodedObs", "decode", "SafetyShield", "safety_cut", "unwrap_env",
           "RecurrentPolicy"]
