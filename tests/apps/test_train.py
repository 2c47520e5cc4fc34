"""Training (apps/train.py): the options' checks, the run directory's name, mirrored samples, and
tiny recurrent and mirror-symmetric runs that export policy files. Long training is never part of the suite."""

from __future__ import annotations

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.apps.evaluate import EVAL_SEED0
from tin_swarm_env.apps.train import Args, check_args, run_dir, scenarios_of
from tin_swarm_env.errors import ArgumentError


def test_timesteps_zero_without_imitation_is_refused():
    with pytest.raises(ArgumentError, match="untrained"):
        check_args(Args(total_timesteps=0))
    check_args(Args(total_timesteps=0, bc_episodes=1))  # imitation only: allowed
    with pytest.raises(ArgumentError, match="dagger"):
        check_args(Args(dagger_rounds=1))
    with pytest.raises(ArgumentError, match="recurrent"):
        check_args(Args(recurrent=True, bc_episodes=2))
    with pytest.raises(ArgumentError, match="dagger-beta"):
        check_args(Args(bc_episodes=1, dagger_beta=1.0))
    with pytest.raises(ArgumentError, match="seed"):
        check_args(Args(seed=EVAL_SEED0))


def test_head_acting_without_a_categorical_head_is_refused():
    with pytest.raises(ArgumentError, match="--head-acting sample is for --head categorical"):
        check_args(Args(bc_episodes=1, total_timesteps=0, head_acting="sample"))
    check_args(Args(bc_episodes=1, total_timesteps=0, head="categorical", head_acting="sample"))


def test_cli_train_refuses_timesteps_zero_before_any_work(tmp_path, capsys):
    from tin_swarm_env.apps.cli import main

    assert main(["train", "flat", "--timesteps", "0", "--out-dir", str(tmp_path / "r")]) == 2
    assert "untrained" in capsys.readouterr().err and not (tmp_path / "r").exists()


def test_run_directory_is_named_after_scenarios_and_seed():
    assert run_dir(Args(scenario="cliff_goal", seed=3)).as_posix() == "runs/ppo_cliff_goal_s3"
    assert run_dir(Args(scenario="cliff_goal, scenarios/valley.toml", bc_episodes=2, total_timesteps=0,
                        seed=1)).as_posix() == "runs/bc_cliff_goal+valley_s1"
    assert run_dir(Args(bc_episodes=2)).name == "bc_ppo_cliff_goal_s0"
    assert run_dir(Args(out_dir="x/y")).as_posix() == "x/y"
    assert scenarios_of(Args(scenario="a,,b ")) == ["a", "b"]
    with pytest.raises(ArgumentError):
        scenarios_of(Args(scenario=" , "))


def test_recurrent_training_runs_and_exports_a_recurrent_policy_file(tmp_path, capsys):
    pytest.importorskip("sb3_contrib")
    from tin_swarm_env.apps.train import train
    from tin_swarm_env.policies import load_policy
    from tin_swarm_env.policies.recurrent import RecurrentPolicy

    path = train(Args(scenario="flat", n_robots=2, n_envs=1, max_cycles=10, total_timesteps=32, n_steps=16,
                      batch_size=32, n_epochs=1, net_arch="16", recurrent=True, lstm_hidden=8, eval_every=0,
                      eval_episodes=1, out_dir=str(tmp_path / "r"), progress_bar=False, shield="safety_cut"))
    assert path.exists()
    env = tse.parallel_env(scenario="flat", n_robots=2)
    pol = load_policy(tmp_path / "r" / "policy", env)
    assert isinstance(pol, RecurrentPolicy) and pol.hidden_size == 8 and pol.shield == "safety_cut"
    assert "exported the pickle-free policy" in capsys.readouterr().out


def test_mirror_samples_add_the_mirror_image_of_every_sample():
    from tin_swarm_env.apps.imitation import Demos
    from tin_swarm_env.apps.train import fit_set
    from tin_swarm_env.env.observation import ObsLayout

    lay = ObsLayout()
    rng = np.random.default_rng(0)
    d = Demos(rng.uniform(-1, 1, (5, lay.size)).astype(np.float32), rng.uniform(-1, 1, (5, 2)).astype(np.float32),
              rng.normal(size=5).astype(np.float32), arrived=0.75, fell=0.1, episodes=3)
    m = d.mirrored(lay)
    np.testing.assert_array_equal(m.obs, d.obs * lay.mirror_signs())
    np.testing.assert_array_equal(m.actions, d.actions * [1, -1])
    np.testing.assert_array_equal(m.returns, d.returns)
    assert fit_set(d, Args(), lay) is d
    both = fit_set(d, Args(mirror_samples=True), lay)
    assert len(both) == 10 and (both.arrived, both.fell, both.episodes) == (0.75, 0.1, 3)
    np.testing.assert_array_equal(both.obs[5:], m.obs)


def test_symmetry_mirror_trains_imitates_and_exports_an_equivariant_policy(tmp_path):
    pytest.importorskip("torch")
    from tin_swarm_env.apps.train import train
    from tin_swarm_env.env.observation import mirror_action
    from tin_swarm_env.policies import load_policy

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


def test_teacher_option_is_checked_by_name_and_geodesic_refuses_mirrored_samples(capsys):
    from tin_swarm_env.apps.cli import main

    assert Args().teacher == "apf" and Args(teacher="geodesic").teacher == "geodesic"
    with pytest.raises(ArgumentError, match="--teacher must be one of.*got 'oracle'"):
        Args(teacher="oracle")
    assert main(["train", "cliff_goal", "--teacher", "oracle", "--bc-episodes", "1"]) == 2
    assert "--teacher must be one of apf, geodesic, apf_student, got 'oracle'" in capsys.readouterr().err
    with pytest.raises(ArgumentError, match="--mirror-samples cannot be combined with --teacher geodesic"):
        check_args(Args(teacher="geodesic", mirror_samples=True, bc_episodes=1))
    check_args(Args(teacher="geodesic", symmetry="mirror", bc_episodes=1))  # the way to get the symmetry
