"""tin_swarm_env: robot swarms on real terrain represented as a Triangulated Irregular Network.

Layers (imports flow downwards only): ``terrain`` (DEM -> TIN, geometry queries), ``world``
(robots, sensing, locomotion, battery), ``scenario`` (TOML -> config -> initial state), ``env``
(the PettingZoo parallel environment). See ``../shared/DESIGN.md`` for the full layout.

>>> import tin_swarm_env as tse
>>> env = tse.parallel_env(scenario="cliff_goal", n_robots=20)   # doctest: +SKIP
"""

from . import adapters, policies, scenario, terrain, tin_swarm_v0, world
from .env import TinSwarmEnv, env, parallel_env, raw_env
from .errors import (
    DemFormatError,
    MissingExtraError,
    TinFormatError,
    TinStructureError,
    TinSwarmError,
)

__version__ = "0.1.0"

ENV_ID = "tin_swarm/TinSwarm-v0"


def _register():
    import warnings

    import pettingzoo

    for kind, entry in (("parallel", "tin_swarm_env.tin_swarm_v0:parallel_env"),
                        ("aec", "tin_swarm_env.tin_swarm_v0:env")):
        registry = pettingzoo.parallel_registry if kind == "parallel" else pettingzoo.aec_registry
        if ENV_ID not in registry:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                pettingzoo.register(kind, ENV_ID, entry_point=entry)


_register()

__all__ = [
    "ENV_ID", "adapters", "DemFormatError", "MissingExtraError", "TinFormatError", "TinStructureError", "TinSwarmError",
    "TinSwarmEnv", "__version__", "env", "parallel_env", "raw_env", "policies", "scenario", "terrain",
    "tin_swarm_v0",
    "world",
]
