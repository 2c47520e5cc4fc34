"""Training checkpoints that survive SIGKILL, and what ``tin-swarm train SCENARIO --resume DIR`` reads.

A run directory holds ``args.json`` (the run's arguments, written before any work) and
``checkpoints/step_<N>/`` directories, each complete or absent: a checkpoint is written into
``checkpoints/.step_<N>.part/`` and renamed into place (one atomic ``rename``), so a run killed at
any moment leaves its last complete checkpoint and at most a ``.part`` directory, which is ignored
and removed on resume. A checkpoint holds

* ``model.zip``: the SB3 model with its optimiser state and step counter (``num_timesteps``);
* ``state.json``: the evaluation history so far (the rows of ``eval.csv``), the wall-clock minutes
  spent, the next evaluation's step, the imitation summary, the Python and numpy global RNG states
  and every environment copy's generator state;
* ``torch_rng.npy``: torch's CPU RNG state (plain bytes; no pickle anywhere).

There is no observation or reward normaliser in this training loop (observations are already
scaled to [-1, 1]), so there is none to save. On resume the model is loaded, the RNGs restored,
and every environment copy starts a new episode from its restored generator (an episode cut by
the kill is not replayed). At most one checkpoint interval (``--checkpoint-every`` timesteps) of
work is lost; the last two checkpoints are kept.
"""

from __future__ import annotations

import json
import os
import random
import shutil
from pathlib import Path

import numpy as np

from ..errors import ArgumentError

__all__ = ["ARGS_FILE", "write_args", "read_args", "write_checkpoint", "last_checkpoint", "restore_rng"]

ARGS_FILE = "args.json"
KEEP = 2  # complete checkpoints kept


def _atomic_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.part")
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def write_args(out: Path, args_dict: dict) -> None:
    """``out/args.json``, atomically (what ``--resume`` restarts from when no checkpoint exists)."""
    _atomic_text(out / ARGS_FILE, json.dumps(args_dict, indent=1))


def read_args(run: Path) -> dict:
    """The saved arguments of the run directory ``run`` (ArgumentError naming ``--resume`` if none)."""
    p = run / ARGS_FILE
    if not run.is_dir():
        raise ArgumentError(f"--resume {run}: no such run directory")
    if not p.is_file():
        raise ArgumentError(f"--resume {run}: no {ARGS_FILE} in it (not a run directory of tin-swarm train)")
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ArgumentError(f"--resume {p}: cannot be read ({exc})") from None
    if not isinstance(d, dict):
        raise ArgumentError(f"--resume {p}: not a JSON object of arguments")
    return d


def _rng_state() -> dict:
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    py = random.getstate()
    return {"numpy": [kind, keys.tolist(), int(pos), int(has_gauss), float(gauss)],
            "python": [py[0], list(py[1]), py[2]]}


def write_checkpoint(out: Path, model, vec, extra: dict) -> Path:
    """Write ``out/checkpoints/step_<N>/`` for ``model`` (N = its ``num_timesteps``) atomically,
    then keep only the last :data:`KEEP`. ``extra`` goes into ``state.json``."""
    import torch

    root = out / "checkpoints"
    root.mkdir(parents=True, exist_ok=True)
    n = int(model.num_timesteps)
    final = root / f"step_{n}"
    tmp = root / f".step_{n}.part"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    model.save(tmp / "model.zip")
    np.save(tmp / "torch_rng.npy", torch.get_rng_state().numpy())
    envs = [e.rng_state for e in vec.envs]
    state = {"num_timesteps": n, "rng": _rng_state(), "env_rng": envs, **extra}
    with open(tmp / "state.json", "w", encoding="utf-8") as fh:
        json.dump(state, fh, indent=1)
        fh.flush()
        os.fsync(fh.fileno())
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)  # the checkpoint exists whole, or not at all
    for old in _complete(root)[:-KEEP]:
        shutil.rmtree(old, ignore_errors=True)
    return final


def _complete(root: Path) -> list[Path]:
    """Complete checkpoint directories under ``root``, oldest first."""
    out = []
    for p in root.glob("step_*"):
        tail = p.name[5:]
        if p.is_dir() and tail.isdigit() and (p / "state.json").is_file() and (p / "model.zip").is_file():
            out.append((int(tail), p))
    return [p for _, p in sorted(out)]


def last_checkpoint(run: Path) -> tuple[Path, dict] | None:
    """``(directory, state)`` of the run's last complete checkpoint (None if there is none);
    unfinished ``.part`` directories are removed."""
    root = run / "checkpoints"
    if not root.is_dir():
        return None
    for part in root.glob(".step_*.part"):
        if part.is_dir():
            shutil.rmtree(part, ignore_errors=True)
        else:
            part.unlink(missing_ok=True)
    for p in reversed(_complete(root)):
        try:
            return p, json.loads((p / "state.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue  # damaged by something other than a kill: try the one before
    return None


def restore_rng(ckpt: Path, state: dict, vec) -> None:
    """Put back the RNG states saved in ``ckpt`` (torch, numpy, Python, each environment copy's)."""
    import torch

    torch.set_rng_state(torch.from_numpy(np.load(ckpt / "torch_rng.npy", allow_pickle=False)))
    kind, keys, pos, has_gauss, gauss = state["rng"]["numpy"]
    np.random.set_state((kind, np.asarray(keys, dtype=np.uint32), pos, has_gauss, gauss))
    v, internal, g = state["rng"]["python"]
    random.setstate((v, tuple(internal), g))
    for e, s in zip(vec.envs, state.get("env_rng") or [], strict=False):
        if s is not None:
            e.rng_state = s
    vec.seed(None)  # the next reset continues each copy's restored generator, not its first seed
