"""``tin-swarm train`` (apps/train.py): options refused before any work, and a resumed run given
another scenario than the one it was started with is refused, naming the file and the key."""

from __future__ import annotations

import json

import pytest

from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.train import Args, train_command
from tin_swarm_env.errors import CheckpointError


def test_cli_train_refuses_timesteps_zero_before_any_work(tmp_path, capsys):
    assert main(["train", "flat", "--timesteps", "0", "--out-dir", str(tmp_path / "r")]) == 2
    assert "untrained" in capsys.readouterr().err and not (tmp_path / "r").exists()


def test_resume_with_another_scenario_is_refused_before_any_work(tmp_path, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "args.json").write_text(json.dumps({"scenario": "ramp"}))
    with pytest.raises(CheckpointError, match=r"args.json: key 'scenario': found 'ramp', expected 'flat'"):
        train_command(Args(scenario="flat", resume=str(run)))
    assert main(["train", "flat", "--resume", str(run)]) == 2
    assert "key 'scenario': found 'ramp'" in capsys.readouterr().err
    assert sorted(p.name for p in run.iterdir()) == ["args.json"]  # nothing written
