"""tin_swarm_env: robot swarms on real terrain represented as a Triangulated Irregular Network.

Layers (imports flow downwards only): ``terrain`` (DEM -> TIN, geometry queries), ``world``
(robots, sensing, locomotion, battery), ``scenario`` (TOML -> config -> initial state), ``env``
(the PettingZoo parallel environment and the vector env), ``adapters``/``policies``, ``training`` (the
training library: recipes, imitation, checkpoints, rollouts, evaluation rows; no CLI), ``apps`` (the
``tin-swarm`` commands only: run, eval, train, explore...). The documentation's contributing page (docs/contributing.md, "Layout") describes them.

The package root is lazy: it loads only :mod:`.errors`; ``tse.parallel_env``, ``tse.TinSwarmEnv``,
``tse.Reason`` and the subpackages load on first use, so ``import tin_swarm_env.terrain`` needs
numpy/scipy/numba only. ``tse.env`` is the :mod:`tin_swarm_env.env` subpackage; the AEC
constructor is ``tse.tin_swarm_v0.env()``. ``tin_swarm/TinSwarm-v0`` is registered with
PettingZoo when pettingzoo is imported, ``tin_swarm/TinSwarmSingle-v0`` and
``tin_swarm/TinSwarmCentral-v0`` with Gymnasium when gymnasium is imported (see :mod:`._registration`).

>>> import tin_swarm_env as tse
>>> env = tse.parallel_env(scenario="cliff_goal", n_robots=20)   # doctest: +SKIP
"""

import importlib
import os

# numba's OpenMP threads (GNU libgomp) wait for work between parallel kernels. Spinning long
# (libgomp's own default, or OMP_WAIT_POLICY=ACTIVE) made a 2-thread step ~8x slower than 1 thread
# when the other core was busy; sleeping at once (OMP_WAIT_POLICY=PASSIVE, this package's choice until
# 2026-11) pays a wake-up per kernel: 1.02 against 0.75 ms per world step at 1 000 robots on the idle
# 2-core machine. A short spin has both: 0.75 ms idle, and with three such 2-thread processes on the 2
# cores 1.9 ms against passive's 2.0 (bench/world.py's setup). Unless the user chose either variable.
if "OMP_WAIT_POLICY" not in os.environ and "GOMP_SPINCOUNT" not in os.environ:
    os.environ["GOMP_SPINCOUNT"] = "1000"

from ._registration import ENV_ID, register_gymnasium, register_pettingzoo  # noqa: E402
from .errors import (  # noqa: E402
    DemFormatError,
    MissingExtraError,
    TinFormatError,
    TinStructureError,
    TinSwarmError,
)

__version__ = "0.1.0"

_SUBPACKAGES = ("adapters", "apps", "env", "policies", "scenario", "terrain", "tin_swarm_v0", "training", "world")
_LAZY = {"TinSwarmEnv": "env.tin_swarm", "parallel_env": "env.tin_swarm", "raw_env": "env.tin_swarm",
         "Reason": "world.state", "vector_env": "env.vector", "VectorEnv": "env.vector"}


def __getattr__(name):
    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    if name in _LAZY:
        value = getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_SUBPACKAGES) | set(_LAZY))


register_pettingzoo()
register_gymnasium()

__all__ = [
    "ENV_ID", "DemFormatError", "MissingExtraError", "Reason", "TinFormatError", "TinStructureError", "TinSwarmError",
    "TinSwarmEnv", "VectorEnv", "__version__", "adapters", "apps", "env", "parallel_env", "policies", "raw_env",
    "scenario", "vector_env", "terrain", "tin_swarm_v0", "training", "world",
]
