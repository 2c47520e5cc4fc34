"""``tin-swarm train --resume``: a tiny training run is SIGKILLed in the middle of writing a
checkpoint, resumed, and finishes with a complete ``model.zip``, ``policy/`` and ``eval.csv``
whose evaluation history before the kill is kept; the checkpoint directory logic on its own."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# the child trains 384 timesteps with a checkpoint every 128; in the middle of writing the second
# one (its model already in the .part directory, not yet renamed) it kills itself with SIGKILL
KILLED_RUN = """
import os, signal, sys
import tin_swarm_env.apps.checkpoint as C
import tin_swarm_env.apps.train as T

real, calls = C.write_checkpoint, []

def dying(out, model, vec, extra):
    calls.append(1)
    if len(calls) == 2:
        part = os.path.join(out, "checkpoints", ".step_256.part")
        os.makedirs(part)
        model.save(os.path.join(part, "model.zip"))
        os.kill(os.getpid(), signal.SIGKILL)
    return real(out, model, vec, extra)

C.write_checkpoint = dying  # train imports it from the module when it runs
T.train(T.Args(scenario="flat", n_robots=2, n_envs=1, max_cycles=20, total_timesteps=384, n_steps=32,
               batch_size=32, n_epochs=1, net_arch="8", eval_every=128, eval_episodes=1, checkpoint_every=128,
               out_dir=sys.argv[1], progress_bar=False))
"""


def _run(args, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, *args], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)


def test_a_killed_training_run_resumes_and_finishes_complete(tmp_path):
    pytest.importorskip("stable_baselines3")
    script = tmp_path / "killed_run.py"
    script.write_text(KILLED_RUN)
    run = tmp_path / "run"
    r = _run([str(script), str(run)], tmp_path)
    assert r.returncode == -signal.SIGKILL, r.stderr[-2000:]
    ckpts = sorted(p.name for p in (run / "checkpoints").iterdir())
    assert ckpts == [".step_256.part", "step_128"]  # the half-written one is not a checkpoint
    assert not (run / "model.zip").exists() and not (run / "eval.csv").exists()
    before = json.loads((run / "checkpoints" / "step_128" / "state.json").read_text())["eval_rows"]
    assert [row["timesteps"] for row in before] == [2, 128]

    r = _run(["-m", "tin_swarm_env.apps.cli", "train", "flat", "--resume", str(run)], tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "resuming" in r.stdout and "step_128" in r.stdout
    assert zipfile.ZipFile(run / "model.zip").testzip() is None
    with open(run / "eval.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(row["timesteps"]) for row in rows] == [2, 128, 256, 384]  # the history before the kill kept
    for old, new in zip(before, rows):
        assert float(new["return"]) == pytest.approx(old["return"], rel=1e-12)
    assert float(rows[2]["minutes"]) >= float(rows[1]["minutes"])  # the clock continues
    import tin_swarm_env as tse
    from tin_swarm_env.policies import load_policy

    env = tse.parallel_env(scenario="flat", n_robots=2, max_cycles=5)
    obs, _ = env.reset(seed=0)
    assert set(load_policy(run / "policy", env).act(obs)) == set(obs)
    assert not any(p.name.endswith(".part") for p in (run / "checkpoints").iterdir())
    assert json.loads((run / "model.json").read_text())["timesteps"] == 384


def test_last_checkpoint_skips_unfinished_and_damaged_ones(tmp_path):
    from tin_swarm_env.apps.checkpoint import last_checkpoint

    root = tmp_path / "checkpoints"
    assert last_checkpoint(tmp_path) is None
    for n, state in ((100, {"num_timesteps": 100}), (200, None), (300, {"num_timesteps": 300})):
        d = root / f"step_{n}"
        d.mkdir(parents=True)
        (d / "model.zip").write_bytes(b"")
        (d / "state.json").write_text(json.dumps(state) if state else "{not json")
    (root / "step_400").mkdir()  # no files: not complete
    (root / ".step_500.part").mkdir()
    path, state = last_checkpoint(tmp_path)
    assert path.name == "step_300" and state == {"num_timesteps": 300}
    assert not (root / ".step_500.part").exists()
    (root / "step_300" / "state.json").write_text("[")
    assert last_checkpoint(tmp_path)[0].name == "step_100"  # a damaged one: the one before it


def test_resume_refuses_a_directory_that_is_not_a_run(tmp_path):
    from tin_swarm_env.apps.cli import main

    assert main(["train", "flat", "--resume", str(tmp_path / "nope")]) == 2
    assert main(["train", "flat", "--resume", str(tmp_path)]) == 2
