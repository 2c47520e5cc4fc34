"""``tin-swarm train --resume``: a tiny training run is SIGKILLed in the middle of writing a
checkpoint, resumed, and finishes with a complete ``model.zip``, ``policy/`` and ``eval.csv``
whose evaluation history before the kill is kept; checkpoints are data: any damage to any file of a
real run directory is refused with one line naming the file and changes nothing, a pickle planted
in a checkpoint does not run, a checkpoint of another network or scenario is refused."""

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
import tin_swarm_env.training.checkpoint as C
import tin_swarm_env.training.sb3 as T

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


def test_resume_refuses_a_directory_that_is_not_a_run(tmp_path):
    from tin_swarm_env.apps.cli import main

    assert main(["train", "flat", "--resume", str(tmp_path / "nope")]) == 2
    assert main(["train", "flat", "--resume", str(tmp_path)]) == 2


# -- checkpoints are data ---------------------------------------------------------------------

TINY = dict(scenario="flat", n_robots=2, n_envs=1, max_cycles=20, total_timesteps=64, n_steps=32, batch_size=32,
            n_epochs=1, net_arch="8", eval_every=32, eval_episodes=1, checkpoint_every=32, progress_bar=False)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """A real run directory: args.json and two checkpoints (step_32, step_64) of a tiny PPO run."""
    pytest.importorskip("stable_baselines3")
    import tin_swarm_env.training.sb3 as T

    run = tmp_path_factory.mktemp("tiny") / "run"
    T.train(T.Args(**TINY, out_dir=str(run)))
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == ["step_32", "step_64"]
    return run


def _copy(run, dest):
    import shutil

    shutil.copytree(run, dest)
    return dest


def _snapshot(d):
    return {str(p.relative_to(d)): (p.read_bytes() if p.is_file() else None) for p in sorted(Path(d).rglob("*"))}


def _resume(run, *extra):
    """``tin-swarm train flat --resume RUN``: (exit status, stderr lines, stdout)."""
    import contextlib
    import io

    from tin_swarm_env.apps.cli import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        rc = main(["train", "flat", "--resume", str(run), *extra])
    return rc, err.getvalue().splitlines(), out.getvalue()


CKPT_FILES = ["args.json"] + [f"checkpoints/step_{n}/{f}" for n in (32, 64)
                              for f in ("state.json", "policy.npz", "optimizer.npz", "torch_rng.npy")]
# a value of another JSON kind than the one there: a number never replaces a number (an int for a float is fine)
_OTHER = {"number": ["x", [1], {"a": 1}, True, None], "str": [7, [1], {"a": 1}, True, None],
          "list": [7, "x", {"a": 1}, True, None], "dict": [7, "x", [1], True, None],
          "bool": [7, "x", [1], {"a": 1}, None], "null": [7, "x", [1], {"a": 1}, True]}
_NULL_OK = ("imitation", "env_rng[", "rng.python[2]")  # where null is allowed (those paths not swapped)


def _kind(v):
    return ("bool" if isinstance(v, bool) else "number" if isinstance(v, (int, float)) else "str" if isinstance(v, str)
            else "list" if isinstance(v, list) else "dict" if isinstance(v, dict) else "null")


def _paths(v, prefix=""):
    """Every place in a JSON value (lists: their first and last items), as (label, getter path)."""
    out = []
    items = v.items() if isinstance(v, dict) else ((i, x) for i, x in enumerate(v)) if isinstance(v, list) else ()
    items = list(items)
    if isinstance(v, list) and len(items) > 2:
        items = [items[0], items[-1]]
    for k, x in items:
        label = f"{prefix}.{k}" if isinstance(k, str) else f"{prefix}[{k}]"
        label = label.lstrip(".")
        out.append((label, (k,)))
        out += [(lab, (k, *path)) for lab, path in _paths(x, label)]
    return out


def _corrupt(path: Path, data):
    """Apply one drawn corruption to ``path``: random bytes, a truncation or (JSON) a value of another type."""
    raw = path.read_bytes()
    how = data.draw(__import__("hypothesis").strategies.sampled_from(
        ["bytes", "truncate", "swap"] if path.suffix == ".json" else ["bytes", "truncate"]), label="how")
    st = __import__("hypothesis").strategies
    if how == "bytes":
        path.write_bytes(data.draw(st.binary(max_size=2000), label="bytes"))
    elif how == "truncate":
        path.write_bytes(raw[:data.draw(st.integers(0, len(raw) - 1), label="keep")])
    else:
        doc = json.loads(raw)
        places = [(lab, p) for lab, p in _paths(doc)
                  if not lab.startswith(_NULL_OK) and lab not in ("trust_pickle",)]
        lab, where = data.draw(st.sampled_from(places), label="key")
        parent = doc
        for k in where[:-1]:
            parent = parent[k]
        parent[where[-1]] = data.draw(st.sampled_from(_OTHER[_kind(parent[where[-1]])]), label="value")
        path.write_text(json.dumps(doc))
    return how


def test_any_damage_to_any_checkpoint_file_is_one_line_naming_it_and_changes_nothing(tiny_run):
    import tempfile

    from hypothesis import given, settings
    from hypothesis import strategies as st

    @settings(max_examples=40, deadline=None, derandomize=True)
    @given(rel=st.sampled_from(CKPT_FILES), data=st.data())
    def check(rel, data):
        with tempfile.TemporaryDirectory() as d:
            run = _copy(tiny_run, Path(d) / "run")
            _corrupt(run / rel, data)
            (run / "checkpoints" / ".step_96.part").mkdir()  # an unfinished one: kept, as everything else
            before = _snapshot(run)
            rc, err, _ = _resume(run)
            assert rc == 2, err
            assert len(err) == 1 and "Traceback" not in err[0], err
            assert str(run / rel) in err[0], (rel, err)
            assert _snapshot(run) == before

    check()


def _payload_pickle(marker: Path) -> bytes:
    import pickle

    return pickle.dumps(_Marker(marker))


def test_a_pickle_planted_in_a_checkpoint_does_not_run(tiny_run, tmp_path):
    import base64
    import zipfile

    import numpy as np

    marker = tmp_path / "PWNED"
    payload = _payload_pickle(marker)
    # 1. the network file of the checkpoint: an object array (np.save pickles it)
    run = _copy(tiny_run, tmp_path / "a")
    ck = run / "checkpoints" / "step_64"
    with open(ck / "policy.npz", "wb") as fh:
        np.savez(fh, log_std=np.array([_Marker(marker), 1], dtype=object))
    assert not marker.exists()
    before = _snapshot(run)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1 and str(ck / "policy.npz") in err[0], err
    assert not marker.exists() and _snapshot(run) == before
    np.load(ck / "policy.npz", allow_pickle=True)["log_std"]  # the control: unpickled, the payload runs
    assert marker.exists()
    marker.unlink()

    # 2. an older version's checkpoint: an SB3 model.zip whose data carries a pickle
    run = _copy(tiny_run, tmp_path / "b")
    for n in (32, 64):
        ck = run / "checkpoints" / f"step_{n}"
        (ck / "policy.npz").unlink()
        (ck / "optimizer.npz").unlink()
        st = json.loads((ck / "state.json").read_text())
        for k in ("format", "version", "n_updates", "run"):
            del st[k]
        (ck / "state.json").write_text(json.dumps(st))
        data = {"policy_class": {":type:": "<class 'abc.ABCMeta'>",
                                 ":serialized:": base64.b64encode(payload).decode()}}
        with zipfile.ZipFile(ck / "model.zip", "w") as zf:
            zf.writestr("data", json.dumps(data))
    before = _snapshot(run)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1, err
    assert str(run / "checkpoints" / "step_32" / "model.zip") in err[0] and "--trust-pickle" in err[0]
    assert not marker.exists() and _snapshot(run) == before
    _resume(run, "--trust-pickle")  # the control: with --trust-pickle SB3 unpickles it (and the payload runs)
    assert marker.exists()


class _Marker:
    """Unpickling it creates the file ``marker`` (the stand-in for any code a pickle can run)."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_a_checkpoint_of_another_network_or_scenario_is_refused_naming_file_key_found_expected(tiny_run, tmp_path):
    import numpy as np

    # args.json says 16 units, the checkpoints were built with 8
    run = _copy(tiny_run, tmp_path / "a")
    a = json.loads((run / "args.json").read_text())
    (run / "args.json").write_text(json.dumps({**a, "net_arch": "16"}))
    before = _snapshot(run)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1
    assert str(run / "checkpoints" / "step_32" / "state.json") in err[0] and "'run.net_arch'" in err[0]
    assert "found [8]" in err[0] and "expected [16]" in err[0]
    assert _snapshot(run) == before
    # the run info edited to match as well: the tensors' shapes still do not
    for n in (32, 64):
        p = run / "checkpoints" / f"step_{n}" / "state.json"
        st = json.loads(p.read_text())
        st["run"]["net_arch"] = [16]
        p.write_text(json.dumps(st))
    before = _snapshot(run)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1
    assert str(run / "checkpoints" / "step_32" / "policy.npz") in err[0]
    assert "found float32 (2, 8)" in err[0] and "expected float32 (2, 16)" in err[0]
    assert _snapshot(run) == before
    # another scenario than the run's
    import contextlib
    import io

    from tin_swarm_env.apps.cli import main

    e = io.StringIO()
    with contextlib.redirect_stderr(e):
        assert main(["train", "ramp", "--resume", str(tiny_run)]) == 2
    assert "args.json" in e.getvalue() and "'scenario'" in e.getvalue() and "'flat'" in e.getvalue()
    # a policy tensor of the right shape but another dtype
    run = _copy(tiny_run, tmp_path / "b")
    p = run / "checkpoints" / "step_64" / "policy.npz"
    arrays = dict(np.load(p))
    arrays["log_std"] = arrays["log_std"].astype(np.float64)
    np.savez(p, **arrays)
    rc, err, _ = _resume(run)
    assert rc == 2 and str(p) in err[0] and "log_std" in err[0] and "float64" in err[0]


def test_json_nested_too_deep_is_refused_before_parsing(tiny_run, tmp_path):
    run = _copy(tiny_run, tmp_path / "a")
    p = run / "checkpoints" / "step_64" / "state.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1 and str(p) in err[0] and "nested 100000 levels" in err[0]


@pytest.mark.parametrize("rel", CKPT_FILES)
def test_a_missing_file_is_named_and_nothing_changes(tiny_run, tmp_path, rel):
    run = _copy(tiny_run, tmp_path / "a")
    (run / rel).unlink()
    before = _snapshot(run)
    rc, err, _ = _resume(run)
    assert rc == 2 and len(err) == 1 and (str(run / rel) in err[0] or "no args.json" in err[0]), err
    assert _snapshot(run) == before


def test_checkpoints_that_is_a_file_is_refused(tiny_run, tmp_path):
    import shutil

    run = _copy(tiny_run, tmp_path / "a")
    shutil.rmtree(run / "checkpoints")
    (run / "checkpoints").write_text("x")
    rc, err, _ = _resume(run)
    assert rc == 2 and str(run / "checkpoints") in err[0] and "not a directory" in err[0], err
    assert (run / "checkpoints").read_text() == "x"


def _swaps(doc):
    """Every (label, document with the value at label replaced by one of another JSON kind)."""
    import copy

    for lab, where in _paths(doc):
        if lab.startswith(_NULL_OK):
            continue
        parent = doc
        for k in where[:-1]:
            parent = parent[k]
        for v in _OTHER[_kind(parent[where[-1]])]:
            new = copy.deepcopy(doc)
            p = new
            for k in where[:-1]:
                p = p[k]
            p[where[-1]] = v
            yield f"{lab}={json.dumps(v)}", new


def test_every_key_of_state_json_swapped_for_another_type_is_refused_naming_it(tiny_run):
    """Not drawn at random: every place in a real state.json, each replaced by a value of every other
    JSON kind, is refused by the schema check with the file and a key on the way to it."""
    import tin_swarm_env.training.config as T
    from tin_swarm_env import parallel_env
    from tin_swarm_env.errors import CheckpointError
    from tin_swarm_env.training.checkpoint import check_state

    p = tiny_run / "checkpoints" / "step_64" / "state.json"
    doc = json.loads(p.read_text())
    args = T.Args(**TINY)
    info = T.run_info(args, parallel_env(scenario="flat", n_robots=2).layout, 1)
    check_state(p, doc, 64, 1, info)  # the real one passes
    n = 0
    for lab, new in _swaps(doc):
        with pytest.raises(CheckpointError) as ei:
            check_state(p, new, 64, 1, info)
        msg = str(ei.value)
        assert msg.startswith(f"{p}: ") and "\n" not in msg, (lab, msg)
        top = lab.split("=")[0].split(".")[0].split("[")[0]
        assert f"'{top}" in msg or "refuses" in msg, (lab, msg)
        n += 1
    assert n > 100


def test_every_key_of_args_json_swapped_for_another_type_is_refused_naming_it(tiny_run, tmp_path):
    import tin_swarm_env.training.config as T
    from tin_swarm_env.errors import CheckpointError
    from tin_swarm_env.options import option_name

    doc = json.loads((tiny_run / "args.json").read_text())
    run = tmp_path / "run"
    run.mkdir()
    for lab, new in _swaps(doc):
        (run / "args.json").write_text(json.dumps(new))
        with pytest.raises(CheckpointError) as ei:
            T.resumed(T.Args(resume=str(run)))
        key = lab.split("=")[0]
        assert str(run / "args.json") in str(ei.value), (lab, ei.value)
        assert f"'{key}'" in str(ei.value) or option_name(key) in str(ei.value), (lab, ei.value)
