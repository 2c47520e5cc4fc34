"""SB3 training (training/sb3.py): tiny recurrent and mirror-symmetric runs that export policy files.
Long training is never part of the suite."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.training.config import Args, check_args


def test_recurrent_training_runs_and_exports_a_recurrent_policy_file(tmp_path, capsys):
    pytest.importorskip("sb3_contrib")
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.recurrent import RecurrentPolicy
    from tin_swarm_env.training.sb3 import train

    path = train(Args(scenario="flat", n_robots=2, n_envs=1, max_cycles=10, total_timesteps=32, n_steps=16,
                      batch_size=32, n_epochs=1, net_arch="16", recurrent=True, lstm_hidden=8, eval_every=0,
                      eval_episodes=1, out_dir=str(tmp_path / "r"), progress_bar=False, shield="safety_cut"))
    assert path.exists()
    env = tse.parallel_env(scenario="flat", n_robots=2)
    pol = load_policy(tmp_path / "r" / "policy", env)
    assert isinstance(pol, RecurrentPolicy) and pol.hidden_size == 8 and pol.shield == "safety_cut"
    assert "exported the pickle-free policy" in capsys.readouterr().out


def test_symmetry_mirror_trains_imitates_and_exports_an_equivariant_policy(tmp_path):
    pytest.importorskip("torch")
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.training.sb3 import train

    with pytest.raises(ArgumentError, match="--symmetry must be one of"):
        check_args(Args(symmetry="left"))
    with pytest.raises(ArgumentError, match="--symmetry mirror is for the MLP"):
        check_args(Args(symmetry="mirror", recurrent=True))
    train(Args(scenario="cliff_goal", n_robots=3, n_envs=1, max_cycles=15, total_timesteps=48, n_steps=16,
               batch_size=48, n_epochs=1, net_arch="16", bc_episodes=1, bc_epochs=2, value_epochs=1, eval_every=0,
               eval_episodes=1, symmetry="mirror", out_dir=str(tmp_path / "m"), progress_bar=False))
    env = tse.parallel_env(scenario="cliff_goal", n_robots=3)
    for stage in ("policy_imitation", "policy"):
        pol = load_policy(tmp_path / "m" / stage, env)
        assert pol.symmetry == "mirror"
        o = np.random.default_rng(0).uniform(-1, 1, (50, env.layout.size)).astype(np.float32)
        np.testing.assert_array_equal(pol.act_batch(env.layout.mirror(o)), mirror_action(pol.act_batch(o)))


