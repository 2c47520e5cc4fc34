"""The policy research/teacher_geodesic.md evaluates, committed under agents/models/geodesic_mirror: small
pickle-free data that records its teacher and symmetry, loads on the core install and turns both ways alike."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.training.policy_factory import policy_scenario
from tin_swarm_env.env.observation import mirror_action
from tin_swarm_env.policies import load_policy

D = Path(__file__).resolve().parents[2] / "agents" / "models" / "geodesic_mirror"


def test_geodesic_teacher_model_is_small_mirror_equivariant_data():
    assert sorted(p.name for p in D.iterdir()) == ["policy.json", "weights.npz"]
    assert sum(p.stat().st_size for p in D.iterdir()) < 2**20
    meta = json.loads((D / "policy.json").read_text())
    args = meta["training"]["args"]
    assert meta["training"]["imitation"]["teacher"] == args["teacher"] == "geodesic"
    assert meta["symmetry"] == args["symmetry"] == "mirror" and meta["shield"] == "safety_cut"
    env = tse.parallel_env(scenario=policy_scenario("cliff_goal", str(D)), n_robots=4)
    pol = load_policy(D, env)
    o = np.random.default_rng(2).uniform(-1, 1, (200, env.layout.size))
    np.testing.assert_array_equal(pol.net_batch(env.layout.mirror(o)), mirror_action(pol.net_batch(o)))
