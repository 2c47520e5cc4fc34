"""Training checkpoints that survive SIGKILL, and what ``tin-swarm train SCENARIO --resume DIR`` reads.

A run directory holds ``args.json`` (the run's arguments, written before any work) and
``checkpoints/step_<N>/`` directories, each complete or absent: a checkpoint is written into
``checkpoints/.step_<N>.part/`` and renamed into place (one atomic ``rename``), so a run killed at
any moment leaves its last complete checkpoint and at most a ``.part`` directory, which is ignored
and removed once a resume has checked everything else. A checkpoint is data, never code (no
pickle anywhere):

* ``policy.npz``: the network's tensors (the SB3 policy's ``state_dict``: weights, biases, the
  exploration ``log_std``), one array each;
* ``optimizer.npz``: the Adam optimiser's per-parameter state (``state.<i>.step``,
  ``state.<i>.exp_avg``, ``state.<i>.exp_avg_sq``); its hyperparameters come from the arguments;
* ``state.json``: the step counter, the evaluation history so far (the rows of ``eval.csv``), the
  wall-clock minutes spent, the next evaluation's step, the imitation summary, the Python and numpy
  global RNG states, every environment copy's generator state and ``run``: what the network was
  built for (scenario, robots, copies, observation layout, network widths, policy kind);
* ``torch_rng.npy``: torch's CPU RNG state (plain bytes).

Resuming reads every file of every checkpoint and checks it before anything is built or written:
each file's size, a JSON file's nesting depth before it is parsed, every key of ``state.json``
(type, range, length) and of ``args.json`` (the :class:`~tin_swarm_env.training.config.Args` checks),
``run`` against the run being resumed, each array's dtype and shape (from its header, before it is
read) against the network the arguments build, and that every number is finite. Anything wrong is
one :class:`~tin_swarm_env.errors.CheckpointError` naming the file, the key, what was found and what
was expected; then nothing is removed or replaced (a damaged checkpoint is never overwritten by a
run that restarted without it). A checkpoint written by an older version holds an SB3
``model.zip`` instead of the two ``.npz`` files: that is a pickle (loading it runs any code it
holds), refused unless ``--trust-pickle`` is given.

There is no observation or reward normaliser in this training loop (observations are already
scaled to [-1, 1]), so there is none to save. On resume the network and optimiser are rebuilt from
the arguments and filled from the files, the RNGs restored, and every environment copy starts a new
episode from its restored generator (an episode cut by the kill is not replayed). At most one
checkpoint interval (``--checkpoint-every`` timesteps) of work is lost; the last two checkpoints
are kept.
"""

from __future__ import annotations

import errno
import json
import math
import os
import random
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from .._safe_json import read_json
from ..errors import CheckpointError, OutputError

__all__ = ["ARGS_FILE", "STATE_FILE", "POLICY_FILE", "OPTIMIZER_FILE", "TORCH_RNG_FILE", "LEGACY_MODEL", "FORMAT",
           "Checkpoint", "write_args", "read_args", "write_checkpoint", "read_checkpoints", "last_checkpoint",
           "check_against_model", "restore", "restore_rng", "remove_unfinished"]

ARGS_FILE = "args.json"
STATE_FILE = "state.json"
POLICY_FILE = "policy.npz"
OPTIMIZER_FILE = "optimizer.npz"
TORCH_RNG_FILE = "torch_rng.npy"
LEGACY_MODEL = "model.zip"  # the SB3 pickle older versions wrote (--trust-pickle)
FORMAT, VERSION = "tin_swarm_env.checkpoint", 1
KEEP = 2  # complete checkpoints kept
MAX_ARGS_BYTES = 1 << 20
MAX_STATE_BYTES = 64 << 20
MAX_ARRAY_BYTES = 1 << 30  # all arrays of one .npz file
MAX_EVAL_ROWS = 100_000
MAX_STEPS = 1 << 53  # timesteps, updates, evaluation steps: what a float64 counts exactly
_OPT_KEYS = ("step", "exp_avg", "exp_avg_sq")


def _short(v) -> str:
    s = json.dumps(v) if isinstance(v, (dict, list, str, int, float, bool, type(None))) else repr(v)
    return s if len(s) <= 60 else s[:57] + "..."


def _bad(path, key: str, found, expected: str):
    raise CheckpointError(f"{path}: key {key!r}: found {found}, expected {expected}")


def _kind(v) -> str:
    return {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "a list",
            dict: "an object", type(None): "null"}.get(type(v), type(v).__name__)


def _int(path, key, v, lo=0, hi=MAX_STEPS):
    if not isinstance(v, int) or isinstance(v, bool) or not lo <= v <= hi:
        _bad(path, key, f"{_kind(v)} {_short(v)}", f"an integer in {lo}..{hi}")
    return v


def _num(path, key, v, lo=-math.inf, hi=math.inf):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and lo <= v <= hi
    if not ok:
        rng = f" in {lo:g}..{hi:g}" if math.isfinite(lo) or math.isfinite(hi) else ""
        _bad(path, key, f"{_kind(v)} {_short(v)}", f"a finite number{rng}")
    return v


def _typed(path, key, v, t, what: str):
    if not isinstance(v, t) or isinstance(v, bool) and t is not bool:
        _bad(path, key, f"{_kind(v)} {_short(v)}", what)
    return v


def _keys(path, key, d: dict, required, optional=()):
    missing = [k for k in required if k not in d]
    if missing:
        _bad(path, f"{key}.{missing[0]}" if key else missing[0], "nothing (missing)", "the key to be there")
    extra = sorted(set(d) - set(required) - set(optional))
    if extra:
        _bad(path, f"{key}.{extra[0]}" if key else extra[0], "an unknown key", f"only {sorted(required)}")


# -- args.json --------------------------------------------------------------------------------

def write_args(out: Path, args_dict: dict) -> None:
    """``out/args.json``, atomically (what ``--resume`` restarts from when no checkpoint exists)."""
    with atomic_path(Path(out) / ARGS_FILE) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        json.dump(args_dict, fh, indent=1, allow_nan=False)
        fh.flush()
        os.fsync(fh.fileno())


def read_args(run: Path) -> dict:
    """The saved arguments of the run directory ``run`` as a JSON object (size and depth checked
    before parsing); :class:`CheckpointError` naming the file otherwise. The values are checked by
    the caller (:class:`~tin_swarm_env.training.config.Args`)."""
    run = Path(run)
    p = run / ARGS_FILE
    if not run.is_dir():
        raise CheckpointError(f"--resume {run}: no such run directory")
    if not p.exists():
        raise CheckpointError(f"--resume {run}: no {ARGS_FILE} in it (not a run directory of tin-swarm train)")
    d = read_json(p, max_bytes=MAX_ARGS_BYTES, exc=CheckpointError)
    if not isinstance(d, dict):
        _bad(p, "", _kind(d), "a JSON object of arguments")
    return d


# -- state.json --------------------------------------------------------------------------------

def _rng_state() -> dict:
    kind, keys, pos, has_gauss, gauss = np.random.get_state()
    py = random.getstate()
    return {"numpy": [kind, keys.tolist(), int(pos), int(has_gauss), float(gauss)],
            "python": [py[0], list(py[1]), py[2]]}


def _check_rng(path, rng):
    _typed(path, "rng", rng, dict, "an object")
    _keys(path, "rng", rng, ("numpy", "python"))
    npy, py = rng["numpy"], rng["python"]
    if not isinstance(npy, list) or len(npy) != 5:
        _bad(path, "rng.numpy", f"{_kind(npy)} {_short(npy)}", "a list of 5 (kind, keys, pos, has_gauss, gauss)")
    if npy[0] != "MT19937":
        _bad(path, "rng.numpy[0]", _short(npy[0]), '"MT19937"')
    if not isinstance(npy[1], list) or len(npy[1]) != 624:
        _bad(path, "rng.numpy[1]", _kind(npy[1]), "a list of 624 integers")
    for v in npy[1]:
        _int(path, "rng.numpy[1]", v, 0, 2 ** 32 - 1)
    _int(path, "rng.numpy[2]", npy[2], 0, 624)
    _int(path, "rng.numpy[3]", npy[3], 0, 1)
    _num(path, "rng.numpy[4]", npy[4])
    if not isinstance(py, list) or len(py) != 3:
        _bad(path, "rng.python", f"{_kind(py)} {_short(py)}", "a list of 3 (version, state, gauss_next)")
    _int(path, "rng.python[0]", py[0], 3, 3)
    if not isinstance(py[1], list) or len(py[1]) != 625:
        _bad(path, "rng.python[1]", _kind(py[1]), "a list of 625 integers")
    for v in py[1][:624]:
        _int(path, "rng.python[1]", v, 0, 2 ** 32 - 1)
    _int(path, "rng.python[1][624]", py[1][624], 0, 624)
    if py[2] is not None:
        _num(path, "rng.python[2]", py[2])
    saved_np, saved_py = np.random.get_state(), random.getstate()
    try:  # what the generators themselves accept (then put back as they were)
        np.random.set_state((npy[0], np.asarray(npy[1], dtype=np.uint32), npy[2], npy[3], npy[4]))
        random.setstate((py[0], tuple(py[1]), py[2]))
    except (TypeError, ValueError, OverflowError) as exc:
        _bad(path, "rng", f"a state the generator refuses ({exc})", "a saved generator state")
    finally:
        np.random.set_state(saved_np)
        random.setstate(saved_py)


def _check_env_rng(path, env_rng, n_copies: int):
    if not isinstance(env_rng, list) or len(env_rng) != n_copies:
        n = f"a list of {len(env_rng)}" if isinstance(env_rng, list) else f"{_kind(env_rng)} {_short(env_rng)}"
        _bad(path, "env_rng", n, f"a list of {n_copies} (one per environment copy of this run)")
    for i, s in enumerate(env_rng):
        if s is None:
            continue
        key = f"env_rng[{i}]"
        _typed(path, key, s, dict, "null or a generator state object")
        _keys(path, key, s, ("bit_generator", "state", "has_uint32", "uinteger"))
        if s["bit_generator"] != "PCG64":
            _bad(path, f"{key}.bit_generator", _short(s["bit_generator"]), '"PCG64"')
        _typed(path, f"{key}.state", s["state"], dict, "an object")
        _keys(path, f"{key}.state", s["state"], ("state", "inc"))
        for k in ("state", "inc"):
            _int(path, f"{key}.state.{k}", s["state"][k], 0, 2 ** 128 - 1)
        _int(path, f"{key}.has_uint32", s["has_uint32"], 0, 1)
        _int(path, f"{key}.uinteger", s["uinteger"], 0, 2 ** 32 - 1)
        try:
            np.random.default_rng().bit_generator.state = s
        except (TypeError, ValueError, KeyError) as exc:
            _bad(path, key, f"a state the generator refuses ({exc})", "a PCG64 state")


_ROW = ("timesteps", "minutes", "return", "arrived", "fell")


def _check_rows(path, rows, n: int):
    if not isinstance(rows, list) or len(rows) > MAX_EVAL_ROWS:
        _bad(path, "eval_rows", f"{_kind(rows)}" + (f" of {len(rows)}" if isinstance(rows, list) else ""),
             f"a list of at most {MAX_EVAL_ROWS} rows")
    last = -1
    for i, r in enumerate(rows):
        key = f"eval_rows[{i}]"
        _typed(path, key, r, dict, f"an object with keys {list(_ROW)}")
        _keys(path, key, r, _ROW)
        t = _int(path, f"{key}.timesteps", r["timesteps"], 0, n)
        if t < last:
            _bad(path, f"{key}.timesteps", t, f"at least {last} (rows in order)")
        last = t
        _num(path, f"{key}.minutes", r["minutes"], 0)
        _num(path, f"{key}.return", r["return"])
        _num(path, f"{key}.arrived", r["arrived"], 0, 1)
        _num(path, f"{key}.fell", r["fell"], 0, 1)


def _check_run(path, got, expected: dict):
    _typed(path, "run", got, dict, "an object")
    _keys(path, "run", got, tuple(expected))
    for k, v in expected.items():  # compared as JSON text: true is not 1, 1.0 is not 1
        if json.dumps(got[k], sort_keys=True) != json.dumps(v, sort_keys=True):
            _bad(path, f"run.{k}", _short(got[k]), f"{_short(v)} (the run being resumed)")


def check_state(path, st, n: int, n_copies: int, run_info: dict | None) -> dict:
    """Every key of a checkpoint's ``state.json`` (``st``, in directory ``step_<n>``): type,
    range, length; ``run`` equal to ``run_info`` (None: an older checkpoint, which has no
    ``format``, ``version``, ``n_updates`` or ``run``). Returns ``st``; CheckpointError otherwise."""
    _typed(path, "", st, dict, "a JSON object")
    base = ("num_timesteps", "rng", "env_rng", "eval_rows", "minutes", "next_eval", "imitation")
    _keys(path, "", st, base + (("format", "version", "n_updates", "run") if run_info is not None else ()))
    if run_info is not None:
        if st["format"] != FORMAT:
            _bad(path, "format", _short(st["format"]), f'"{FORMAT}"')
        _int(path, "version", st["version"], VERSION, VERSION)
        _int(path, "n_updates", st["n_updates"])
        _check_run(path, st["run"], run_info)
    if _int(path, "num_timesteps", st["num_timesteps"]) != n:
        _bad(path, "num_timesteps", st["num_timesteps"], f"{n} (the directory's step_{n})")
    _int(path, "next_eval", st["next_eval"])
    _num(path, "minutes", st["minutes"], 0, 1e9)
    if st["imitation"] is not None:
        _typed(path, "imitation", st["imitation"], dict, "null or an object")
    _check_rows(path, st["eval_rows"], n)
    _check_rng(path, st["rng"])
    _check_env_rng(path, st["env_rng"], n_copies)
    return st


# -- arrays -----------------------------------------------------------------------------------

def _npy_header(fh, path, key):
    """``(shape, dtype)`` from a ``.npy`` stream's header (nothing else read)."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(fh)
        shape, fortran, dtype = (fmt.read_array_header_1_0(fh) if version == (1, 0) else
                                 fmt.read_array_header_2_0(fh))
    except (ValueError, OSError, EOFError, SyntaxError, TypeError) as exc:
        raise CheckpointError(f"{path}: array {key!r}: not a .npy array header ({exc})") from None
    if dtype.kind not in "fiub" or dtype.hasobject:
        _bad(path, key, f"dtype {dtype}", "numbers (no objects: nothing is unpickled)")
    if any(d > MAX_ARRAY_BYTES for d in shape):
        _bad(path, key, f"shape {shape}", f"at most {MAX_ARRAY_BYTES:,} elements")
    return tuple(shape), dtype


def _read_npz(path: Path) -> dict:
    """The arrays of ``.npz`` file ``path``: every member's header checked (numbers only, at most
    :data:`MAX_ARRAY_BYTES` in all) before it is read, pickles refused, every value finite."""
    if not path.is_file():
        raise CheckpointError(f"{path}: {'is a directory' if path.is_dir() else 'is missing'}")
    try:
        if path.stat().st_size > MAX_ARRAY_BYTES:
            raise CheckpointError(f"{path}: more than {MAX_ARRAY_BYTES:,} bytes")
        out, total = {}, 0
        with zipfile.ZipFile(path) as zf:
            names = zf.namelist()
            if len(names) != len(set(names)):
                raise CheckpointError(f"{path}: an array name occurs twice")
            for name in names:
                if not name.endswith(".npy"):
                    _bad(path, name, "a member that is not a .npy array", "only .npy arrays")
                key = name[:-4]
                with zf.open(name) as fh:
                    shape, dtype = _npy_header(fh, path, key)
                total += int(np.prod(shape, dtype=np.float64)) * dtype.itemsize
                if total > MAX_ARRAY_BYTES:
                    raise CheckpointError(f"{path}: arrays of more than {MAX_ARRAY_BYTES:,} bytes")
            with np.load(path, allow_pickle=False) as z:
                for key in z.files:
                    a = z[key]
                    if a.dtype.kind == "f" and not np.isfinite(a).all():
                        _bad(path, key, "NaN or inf", "finite numbers")
                    out[key] = a
        return out
    except CheckpointError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError, RuntimeError, NotImplementedError) as exc:
        raise CheckpointError(f"{path}: not a readable .npz of arrays ({exc})") from None


def _read_torch_rng(path: Path) -> np.ndarray:
    import torch

    expected = tuple(torch.get_rng_state().shape)
    if not path.is_file():
        raise CheckpointError(f"{path}: {'is a directory' if path.is_dir() else 'is missing'}")
    try:
        with open(path, "rb") as fh:
            shape, dtype = _npy_header(fh, path, "torch_rng")
            if dtype != np.uint8 or shape != expected:
                _bad(path, "torch_rng", f"{dtype} {shape}", f"uint8 {expected}")
        a = np.load(path, allow_pickle=False)
    except CheckpointError:
        raise
    except (OSError, ValueError, EOFError) as exc:
        raise CheckpointError(f"{path}: not a readable .npy array ({exc})") from None
    saved = torch.get_rng_state()
    try:
        torch.set_rng_state(torch.from_numpy(a.copy()))
    except (RuntimeError, ValueError, TypeError) as exc:
        raise CheckpointError(f"{path}: a state torch refuses ({exc})") from None
    finally:
        torch.set_rng_state(saved)
    return a


# -- writing ---------------------------------------------------------------------------------

def _save_npz(path: Path, arrays: dict) -> None:
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
        fh.flush()
        os.fsync(fh.fileno())


def _optimizer_arrays(model) -> dict:
    out = {}
    for i, s in model.policy.optimizer.state_dict()["state"].items():
        for k in _OPT_KEYS:
            if k in s:
                out[f"state.{i}.{k}"] = s[k].detach().cpu().numpy()
    return out


def write_checkpoint(out: Path, model, vec, extra: dict) -> Path:
    """Write ``out/checkpoints/step_<N>/`` for ``model`` (N = its ``num_timesteps``) atomically,
    then keep only the last :data:`KEEP`. ``extra`` goes into ``state.json`` (``run``: what the
    network was built for, and the training history)."""
    import torch

    root = Path(out) / "checkpoints"
    root.mkdir(parents=True, exist_ok=True)
    n = int(model.num_timesteps)
    final = root / f"step_{n}"
    tmp = root / f".step_{n}.part"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    name = POLICY_FILE
    try:
        _save_npz(tmp / POLICY_FILE, {k: v.detach().cpu().numpy() for k, v in model.policy.state_dict().items()})
        name = OPTIMIZER_FILE
        _save_npz(tmp / OPTIMIZER_FILE, _optimizer_arrays(model))
        name = TORCH_RNG_FILE
        with open(tmp / TORCH_RNG_FILE, "wb") as fh:
            np.save(fh, torch.get_rng_state().numpy())
        envs = [e.rng_state for e in vec.envs]
        state = {"format": FORMAT, "version": VERSION, "num_timesteps": n, "n_updates": int(model._n_updates),
                 "rng": _rng_state(), "env_rng": envs, **extra}
        name = STATE_FILE
        with open(tmp / STATE_FILE, "w", encoding="utf-8") as fh:
            json.dump(state, fh, indent=1, allow_nan=False)
            fh.flush()
            os.fsync(fh.fileno())
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError):
            raise OutputError(exc.errno or errno.EIO, f"{exc.strerror or exc}; the checkpoint was not written (the "
                              "earlier ones are unchanged)", str(final / name)) from exc
        raise
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)  # the checkpoint exists whole, or not at all
    for old in _steps(root)[:-KEEP]:
        shutil.rmtree(old, ignore_errors=True)
    return final


# -- reading ----------------------------------------------------------------------------------

@dataclass
class Checkpoint:
    """One checked checkpoint: its directory, ``state.json`` and arrays (``legacy``: an older
    version's, whose model is the SB3 pickle ``model.zip``; its arrays are then None)."""

    path: Path
    state: dict
    policy: dict | None
    optimizer: dict | None
    torch_rng: np.ndarray
    legacy: bool = False


def _steps(root: Path) -> list[Path]:
    """The ``step_<N>`` entries under ``root``, by N."""
    out = []
    for p in root.iterdir() if root.is_dir() else ():
        tail = p.name[5:]
        if p.name.startswith("step_") and tail.isdigit():
            out.append((int(tail), p))
    return [p for _, p in sorted(out)]


def read_checkpoints(run: Path, *, n_copies: int, run_info: dict, trust_pickle: bool = False) -> list[Checkpoint]:
    """Every checkpoint of run directory ``run``, oldest first, each file read and checked
    (module docstring); CheckpointError naming the file at the first problem. Nothing is changed
    on disk (unfinished ``.part`` directories: :func:`remove_unfinished`, once the resume goes on)."""
    out = []
    root = Path(run) / "checkpoints"
    if root.exists() and not root.is_dir():
        raise CheckpointError(f"{root}: not a directory of checkpoints (a file of that name)")
    for p in _steps(root):
        if not p.is_dir():
            raise CheckpointError(f"{p}: not a checkpoint directory (a file of that name)")
        n = int(p.name[5:])
        legacy = not (p / POLICY_FILE).exists() and (p / LEGACY_MODEL).exists()
        state = read_json(p / STATE_FILE, max_bytes=MAX_STATE_BYTES, exc=CheckpointError)
        check_state(p / STATE_FILE, state, n, n_copies, None if legacy else run_info)
        rng = _read_torch_rng(p / TORCH_RNG_FILE)
        if legacy:
            if not trust_pickle:
                raise CheckpointError(f"{p / LEGACY_MODEL}: an SB3 model file from an older version, a pickle "
                                      "(loading it runs any code it holds); refused without --trust-pickle")
            if not zipfile.is_zipfile(p / LEGACY_MODEL):
                raise CheckpointError(f"{p / LEGACY_MODEL}: not a readable SB3 model (zip) file")
            out.append(Checkpoint(p, state, None, None, rng, legacy=True))
            continue
        pol, opt = _read_npz(p / POLICY_FILE), _read_npz(p / OPTIMIZER_FILE)
        out.append(Checkpoint(p, state, pol, opt, rng))
    return out


def last_checkpoint(run: Path, *, n_copies: int, run_info: dict, trust_pickle: bool = False) -> Checkpoint | None:
    """The last of :func:`read_checkpoints` (None: there is none; any damaged one: CheckpointError)."""
    cks = read_checkpoints(run, n_copies=n_copies, run_info=run_info, trust_pickle=trust_pickle)
    return cks[-1] if cks else None


def check_against_model(ck: Checkpoint, model) -> None:
    """Each array of ``ck`` has the name, dtype and shape of the tensor of ``model.policy`` (and
    of its optimiser's state) it fills; CheckpointError naming the file and key otherwise."""
    if ck.legacy:
        return
    want = {k: v for k, v in model.policy.state_dict().items()}
    path = ck.path / POLICY_FILE
    for k in sorted(set(want) | set(ck.policy)):
        if k not in ck.policy:
            _bad(path, k, "nothing (missing)", f"an array of shape {tuple(want[k].shape)}")
        if k not in want:
            _bad(path, k, f"an array of shape {ck.policy[k].shape}", "no such tensor in this run's network")
        a, t = ck.policy[k], want[k]
        if tuple(a.shape) != tuple(t.shape) or str(a.dtype) != str(t.dtype).replace("torch.", ""):
            _bad(path, k, f"{a.dtype} {a.shape}", f"{str(t.dtype).replace('torch.', '')} {tuple(t.shape)} "
                 "(the network the run's arguments build)")
    params = [p for g in model.policy.optimizer.param_groups for p in g["params"]]
    path = ck.path / OPTIMIZER_FILE
    seen = {}
    for key, a in ck.optimizer.items():
        parts = key.split(".")
        if len(parts) != 3 or parts[0] != "state" or not parts[1].isdigit() or parts[2] not in _OPT_KEYS:
            _bad(path, key, "an unknown array name", f"state.<i>.{{{','.join(_OPT_KEYS)}}}")
        i = int(parts[1])
        if i >= len(params):
            _bad(path, key, f"parameter {i}", f"one of the {len(params)} parameters of this run's network")
        shape = () if parts[2] == "step" else tuple(params[i].shape)
        if a.dtype != np.float32 or tuple(a.shape) != shape:
            _bad(path, key, f"{a.dtype} {a.shape}", f"float32 {shape}")
        if parts[2] == "step" and not (0 <= float(a) <= MAX_STEPS and float(a) == int(a)):
            _bad(path, key, float(a), f"a whole number of steps in 0..{MAX_STEPS}")
        seen.setdefault(i, set()).add(parts[2])
    for i, ks in seen.items():
        if ks != set(_OPT_KEYS):
            _bad(path, f"state.{i}", sorted(ks), f"all of {list(_OPT_KEYS)}")


def restore(ck: Checkpoint, model, vec) -> None:
    """Fill ``model`` (built from the run's arguments) from the checked checkpoint ``ck``: the
    network's tensors, the optimiser's state, the step and update counters; then the RNGs."""
    import torch

    model.policy.load_state_dict({k: torch.from_numpy(np.array(a)) for k, a in ck.policy.items()})
    opt = model.policy.optimizer
    state = {}
    for key, a in ck.optimizer.items():
        _, i, k = key.split(".")
        state.setdefault(int(i), {})[k] = torch.from_numpy(np.array(a))
    opt.load_state_dict({"state": state, "param_groups": opt.state_dict()["param_groups"]})
    model.num_timesteps = int(ck.state["num_timesteps"])
    model._n_updates = int(ck.state["n_updates"])
    restore_rng(ck.path, ck.state, vec, ck.torch_rng)


def restore_rng(ckpt: Path, state: dict, vec, torch_rng: np.ndarray | None = None) -> None:
    """Put back the RNG states saved in ``ckpt`` (torch, numpy, Python, each environment copy's)."""
    import torch

    if torch_rng is None:
        torch_rng = np.load(ckpt / TORCH_RNG_FILE, allow_pickle=False)
    torch.set_rng_state(torch.from_numpy(np.array(torch_rng)))
    kind, keys, pos, has_gauss, gauss = state["rng"]["numpy"]
    np.random.set_state((kind, np.asarray(keys, dtype=np.uint32), pos, has_gauss, gauss))
    v, internal, g = state["rng"]["python"]
    random.setstate((v, tuple(internal), g))
    for e, s in zip(vec.envs, state.get("env_rng") or [], strict=False):
        if s is not None:
            e.rng_state = s
    vec.seed(None)  # the next reset continues each copy's restored generator, not its first seed


def remove_unfinished(run: Path) -> None:
    """Remove the ``.step_<N>.part`` directories a kill left (once a resume has checked the rest)."""
    root = Path(run) / "checkpoints"
    for part in root.glob(".step_*.part") if root.is_dir() else ():
        if part.is_dir():
            shutil.rmtree(part, ignore_errors=True)
        else:
            part.unlink(missing_ok=True)
