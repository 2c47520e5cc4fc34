"""Registrations with PettingZoo (and Gymnasium) without importing them at package import.

``import tin_swarm_env`` must not load pettingzoo or gymnasium (``import tin_swarm_env.terrain``
needs numpy/scipy/numba only), yet ``pettingzoo.make("parallel", "tin_swarm/TinSwarm-v0")`` must
work after it. So the ids are registered with entry-point *strings* (the env module loads only
when an env is made), and at the right time: at once when the registry's module is already
imported, otherwise by a small post-import hook: :func:`_on_import` puts a finder on
``sys.meta_path`` that wraps the module's loader and runs the callbacks right after the module
has executed (the first ``import pettingzoo`` anywhere), then steps aside.
"""

from __future__ import annotations

import importlib.abc
import sys
import threading
import warnings

__all__ = ["ENV_ID", "SINGLE_ID", "CENTRAL_ID", "register_pettingzoo", "register_gymnasium", "_on_import"]

ENV_ID = "tin_swarm/TinSwarm-v0"
SINGLE_ID = "tin_swarm/TinSwarmSingle-v0"
CENTRAL_ID = "tin_swarm/TinSwarmCentral-v0"

_PENDING: dict[str, list] = {}
_LOCK = threading.RLock()


def _on_import(module_name: str, callback) -> None:
    """Call ``callback(module)`` once ``module_name`` is imported: now if it already is, else
    right after its first import finishes."""
    with _LOCK:
        mod = sys.modules.get(module_name)
        if mod is not None and getattr(getattr(mod, "__spec__", None), "_initializing", False) is False:
            callback(mod)
            return
        _PENDING.setdefault(module_name, []).append(callback)
        if not any(isinstance(f, _PostImportFinder) for f in sys.meta_path):
            sys.meta_path.insert(0, _PostImportFinder())


def _run_pending(module_name: str, module) -> None:
    with _LOCK:
        callbacks = _PENDING.pop(module_name, [])
        if not _PENDING:
            sys.meta_path[:] = [f for f in sys.meta_path if not isinstance(f, _PostImportFinder)]
    for cb in callbacks:
        cb(module)


class _PostImportFinder(importlib.abc.MetaPathFinder):
    """Finds nothing itself: for a watched module it asks the other finders and wraps the loader."""

    def find_spec(self, fullname, path, target=None):
        if fullname not in _PENDING:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                break
        else:
            return None
        if spec.loader is not None and hasattr(spec.loader, "exec_module"):
            spec.loader = _PostImportLoader(spec.loader, fullname)
        return spec


class _PostImportLoader(importlib.abc.Loader):
    """The module's own loader, then the callbacks."""

    def __init__(self, inner, name):
        self._inner, self._name = inner, name

    def create_module(self, spec):
        return self._inner.create_module(spec)

    def exec_module(self, module):
        module.__loader__ = self._inner
        self._inner.exec_module(module)
        _run_pending(self._name, module)

    def __getattr__(self, attr):  # get_resource_reader, is_package, get_code...
        return getattr(self._inner, attr)


def _register_pettingzoo(pettingzoo) -> None:
    if not hasattr(pettingzoo, "register"):  # pettingzoo < 1.27 has no environment registry
        return
    for kind, entry in (("parallel", "tin_swarm_env.tin_swarm_v0:parallel_env"),
                        ("aec", "tin_swarm_env.tin_swarm_v0:env")):
        registry = pettingzoo.parallel_registry if kind == "parallel" else pettingzoo.aec_registry
        if ENV_ID not in registry:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                pettingzoo.register(kind, ENV_ID, entry_point=entry)


def register_pettingzoo() -> None:
    """Register ``tin_swarm/TinSwarm-v0`` (parallel and AEC) with PettingZoo, now or on its import."""
    _on_import("pettingzoo", _register_pettingzoo)


def _register_gymnasium(gymnasium) -> None:
    for env_id, cls in ((SINGLE_ID, "TinSwarmSingleEnv"), (CENTRAL_ID, "TinSwarmCentralEnv")):
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=f"tin_swarm_env.adapters.gym_views:{cls}",
                               max_episode_steps=None, nondeterministic=False)


def register_gymnasium() -> None:
    """Register ``"tin_swarm/TinSwarmSingle-v0"`` and ``"tin_swarm/TinSwarmCentral-v0"`` with
    Gymnasium (entry-point strings; ``max_episode_steps=None``: the env truncates itself at
    ``max_cycles``), now or on gymnasium's import. Calling it again does nothing."""
    _on_import("gymnasium", _register_gymnasium)
