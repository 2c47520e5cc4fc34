"""A training run's configuration (training/config.py): the checks across options, the options
checked by name, the run directory's name, the network widths, and a resumed run's arguments."""

from __future__ import annotations

import json

import pytest

from tin_swarm_env.errors import ArgumentError, CheckpointError
from tin_swarm_env.training.config import Args, check_args, net_arch, resumed, run_dir, scenarios_of
from tin_swarm_env.training.evaluation import EVAL_SEED0


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


def test_run_directory_is_named_after_scenarios_and_seed():
    assert run_dir(Args(scenario="cliff_goal", seed=3)).as_posix() == "runs/ppo_cliff_goal_s3"
    assert run_dir(Args(scenario="cliff_goal, scenarios/valley.toml", bc_episodes=2, total_timesteps=0,
                        seed=1)).as_posix() == "runs/bc_cliff_goal+valley_s1"
    assert run_dir(Args(bc_episodes=2)).name == "bc_ppo_cliff_goal_s0"
    assert run_dir(Args(out_dir="x/y")).as_posix() == "x/y"
    assert scenarios_of(Args(scenario="a,,b ")) == ["a", "b"]
    with pytest.raises(ArgumentError):
        scenarios_of(Args(scenario=" , "))


def test_teacher_option_is_checked_by_name_and_geodesic_refuses_mirrored_samples(capsys):
    from tin_swarm_env.apps.cli import main

    assert Args().teacher == "apf" and Args(teacher="geodesic").teacher == "geodesic"
    with pytest.raises(ArgumentError, match="--teacher must be one of.*got 'oracle'"):
        Args(teacher="oracle")
    assert main(["train", "cliff_goal", "--teacher", "oracle", "--bc-episodes", "1"]) == 2
    assert "--teacher must be one of apf, apf_bug, geodesic, apf_student, got 'oracle'" in capsys.readouterr().err
    with pytest.raises(ArgumentError, match="--mirror-samples cannot be combined with --teacher geodesic"):
        check_args(Args(teacher="geodesic", mirror_samples=True, bc_episodes=1))
    check_args(Args(teacher="geodesic", symmetry="mirror", bc_episodes=1))  # the way to get the symmetry


def test_net_arch_reads_widths_and_refuses_bad_ones():
    assert net_arch("64,64") == [64, 64] and net_arch(" 8 ") == [8]
    for bad in ("", "a,b", "0", "64,,x"):
        with pytest.raises(ArgumentError, match="--net-arch"):
            net_arch(bad)
    with pytest.raises(ArgumentError, match="--net-arch"):
        Args(net_arch="64,-1")


def test_a_resumed_run_takes_every_argument_it_was_started_with(tmp_path):
    from tin_swarm_env.training.checkpoint import ARGS_FILE

    run = tmp_path / "run"
    run.mkdir()
    saved = {k: v for k, v in Args(scenario="flat", n_robots=3, seed=5).__dict__.items() if k != "trust_pickle"}
    (run / ARGS_FILE).write_text(json.dumps(saved))
    new, where = resumed(Args(resume=str(run), n_robots=7, trust_pickle=True))
    assert where == run and (new.scenario, new.n_robots, new.seed) == ("flat", 3, 5)
    assert new.out_dir == str(run) and new.resume == "" and new.trust_pickle is True
    (run / ARGS_FILE).write_text(json.dumps({**saved, "colour": "red"}))
    with pytest.raises(CheckpointError, match="key 'colour': found an unknown argument"):
        resumed(Args(resume=str(run)))
