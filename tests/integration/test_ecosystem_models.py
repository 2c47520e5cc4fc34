"""The BenchMARL, RLlib and PufferLib policies docs/figures/ecosystem_training.md evaluates, committed under agents/models:
small pickle-free data that loads on the core install for the scenario they were trained on, recording the
library, the run's budget and the export check (numpy against the library's own actions), and acting as the
recorded network says (layer sizes, squash)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.training.policy_factory import policy_scenario
from tin_swarm_env.policies import load_policy

ROOT = Path(__file__).resolve().parents[2]
MODELS = {"mappo_benchmarl": ("benchmarl", "tanh"), "ppo_rllib": ("rllib", "clip"), "ppo_puffer": ("pufferlib", "clip"),
          "mappo_benchmarl_vec": ("benchmarl", "tanh")}
SHIELDED = {"ppo_puffer", "mappo_benchmarl_vec"}  # files with the safety shield (PufferLib trained behind it)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_committed_model_is_small_checked_data(name):
    d = ROOT / "agents" / "models" / name
    assert sorted(p.name for p in d.iterdir()) == ["policy.json", "weights.npz"]
    assert sum(p.stat().st_size for p in d.iterdir()) < 4 * 2**20
    meta = json.loads((d / "policy.json").read_text())
    library, squash = MODELS[name]
    t = meta["training"]
    assert t["library"] == library and t["action_squash"].startswith(squash)
    assert 0 < t["minutes"] <= 31 and t["args"]["max_minutes"] <= 30  # the wall-clock budget of the run
    assert (meta.get("shield", "none") == "safety_cut") == (name in SHIELDED)
    scenario = str(ROOT / meta["scenario"]) if "/" in meta["scenario"] else meta["scenario"]  # a recipe's TOML
    env = tse.parallel_env(scenario=policy_scenario(scenario, str(d)), n_robots=4)  # the layout it was trained on
    pol = load_policy(d, env)
    sizes = meta["network"]["layer_sizes"]
    assert sizes[0] == env.observation_space("robot_0").shape[0] and sizes[-1] == 2
    assert (sizes[-2:] == [2, 2]) == (squash == "tanh")  # tanh: the identity layer after the network's tanh
    obs, _ = env.reset(seed=1)
    a = pol.act_batch(np.stack(list(obs.values())))
    assert a.shape == (4, 2) and np.isfinite(a).all() and (np.abs(a) <= 1).all()
