"""Policies by name, for the commands and the training library: ``"apf"`` (APF with its default
search, the chart search), ``"apf-bug"`` (APF with the bug search, a weaker baseline), ``"apf-chart"``
(the same as ``"apf"``, kept as a name), ``"random"``, ``"geodesic"`` (the map-knowing
reference), a pickle-free policy directory, or (only with ``trust_pickle``) a saved Stable-Baselines3 ``.zip``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import ArgumentError, MissingExtraError

__all__ = ["make_policy", "check_policy_spec", "policy_scenario", "SB3Policy", "POLICY_NAMES"]

POLICY_NAMES = ("apf", "apf-bug", "apf-chart", "random", "geodesic")

_PICKLE_WHY = ("an SB3 .zip is a pickle: loading it runs any code the file holds, so load only files you "
               "made or trust")


def check_policy_spec(spec: str, trust_pickle: bool = False, option: str = "--policy") -> str:
    """Check a policy spec before any slow work starts; returns a name of :data:`POLICY_NAMES`, ``"dir"``
    (a pickle-free policy directory, or its policy.json) or ``"sb3"`` (a .zip, only when
    ``trust_pickle``). Names are case-insensitive. Anything else raises :class:`ArgumentError`
    naming ``option`` and listing what it accepts."""
    s = str(spec).strip()
    if s.lower() in POLICY_NAMES:
        return s.lower()
    p = Path(os.fspath(s))
    if p.is_dir() or (p.name == "policy.json" and p.is_file()):
        return "dir"
    if p.is_file() and p.suffix.lower() == ".zip":
        if not trust_pickle:
            raise ArgumentError(f"{option} {s}: refusing to load an SB3 .zip without --trust-pickle ({_PICKLE_WHY}); "
                                "or export it once to a pickle-free policy directory "
                                "(tin_swarm_env.adapters.sb3.export_sb3_policy) and pass that")
        return "sb3"
    what = "is not a policy directory or an SB3 .zip" if p.exists() else "no such file or directory"
    raise ArgumentError(f"{option} {s!r}: {what}; give {', '.join(POLICY_NAMES)} (any case), a policy directory "
                        "(policy.json + weights.npz), or an SB3 .zip with --trust-pickle")


def make_policy(env, policy: str, fields=None, seed: int | None = None, trust_pickle: bool = False):
    """``"apf"`` / ``"apf-chart"`` or ``"apf-bug"`` (with the APF ``fields``, default all; the chart
    search, APF's default, or the bug search), ``"random"`` (seeded), a pickle-free
    policy directory (:func:`~tin_swarm_env.policies.load_policy`) or, with ``trust_pickle``, a
    saved SB3 model ``.zip``: an object with ``act_batch(obs (n, d)) -> (n, 2)``."""
    from ..policies import APFPolicy, RandomPolicy, load_policy
    from ..world.fields import FIELDS

    kind = check_policy_spec(policy, trust_pickle)
    if kind in ("apf", "apf-bug", "apf-chart"):
        return APFPolicy(env, fields=tuple(fields) if fields else FIELDS, search="bug" if kind == "apf-bug" else "chart")
    if kind == "random":
        return RandomPolicy(env, seed=seed)
    if kind == "geodesic":  # the map-knowing reference
        from ..policies import GeodesicPolicy

        return GeodesicPolicy(env)
    if kind == "dir":
        return load_policy(policy, env)
    return SB3Policy.load(policy)


def policy_scenario(scenario, policy: str, trust_pickle: bool = False):
    """The scenario (a name, a file or a :class:`~tin_swarm_env.scenario.ScenarioConfig`) the policy
    ``policy`` runs on: for a policy directory, ``scenario`` with the observation layout the policy
    was trained on (:func:`~tin_swarm_env.policies.policy_layout`, so that a policy trained on an
    older default layout still runs); for a built-in name or an SB3 ``.zip``, ``scenario`` as given."""
    from ..policies import policy_layout
    from ..scenario import ScenarioConfig, load_scenario

    if check_policy_spec(policy, trust_pickle) != "dir":
        return scenario
    cfg = scenario if isinstance(scenario, ScenarioConfig) else load_scenario(scenario)
    return cfg.with_layout(policy_layout(policy))


class SB3Policy:
    """An SB3 model as a shared, deterministic policy over batched observations."""

    def __init__(self, model):
        self.model = model

    @classmethod
    def load(cls, path) -> SB3Policy:
        """Load a trusted SB3 ``.zip`` (it is unpickled: it can run code)."""
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
