"""Pickle-free learned policy files: a directory with ``policy.json`` and ``weights.npz``.

Loading one never unpickles and never runs code from the file: the JSON is parsed as data, the
weights are read with ``np.load(allow_pickle=False)``, and the forward pass is plain numpy.
(An SB3 ``.zip`` is a pickle: loading one runs whatever it holds, so only trusted ones may be
loaded that way; export them once with :func:`tin_swarm_env.adapters.sb3.export_sb3_policy`.)

``policy.json``::

    {"format": "tin_swarm_env.policy", "version": 1,
     "network": {"type": "mlp", "layer_sizes": [59, 64, 64, 2], "activation": "tanh",
                 "action_transform": "clip"},
     "observation": {"size": 59, "layout": {"k_robots": 4, "k_targets": 2, "k_breaks": 3,
                                             "names": ["own.battery", ...]}},
     "action": {"size": 2, "low": -1.0, "high": 1.0},
     "scenario": "cliff_goal",
     "shield": "safety_cut",                 # optional: "none" (default), "safety_cut" or "safety_cut_scan"
     "symmetry": "mirror",                   # optional: "none" (default) or "mirror"
     "training": {...}}                      # free-form metadata (library versions, steps...)

``weights.npz``: ``W0, b0, W1, b1, ...``; ``W{i}`` has shape ``(layer_sizes[i+1], layer_sizes[i])``
(torch's ``nn.Linear`` layout), ``b{i}`` ``(layer_sizes[i+1],)``, real and finite. The network is
``a = transform(W_L (act(... act(W_0 x + b_0) ...)) + b_L)``: the activation after every layer
but the last; ``"clip"`` clips the output to ``[-1, 1]`` (the deterministic action of a Gaussian
policy: its mean, clipped to the action space, as SB3's ``predict(deterministic=True)``).

``"shield": "safety_cut"`` filters the network's action through the same safety cut every
built-in controller applies last (:func:`tin_swarm_env.policies.base.safety_cut`: no command into
the blind sector, none that closes on a robot the robot sees to within 1.5 body diameters or on
a dangerous break it sees to within one diameter). The filter reads only the observation, so
the policy stays observation-only; it is a shield in the safe-RL sense (the network proposes,
the filter removes the unsafe part). The constants come from the environment the policy is
loaded for, so a shielded policy needs ``load_policy(path, env)``. ``"shield": "safety_cut_scan"``
adds the scan's cut (:func:`tin_swarm_env.policies.base.scan_cut`): no robot comes within one body
diameter of a point where a beam of its terrain scan meets a dangerous break, so the policy cannot
drive down onto ground too steep to hold it that the break slots miss (real hillside).

``"network": {"type": "recurrent", "cell": "lstm" | "gru", ...}``: a memory cell before the MLP,
state per robot reset with the episode (:mod:`tin_swarm_env.policies.recurrent` describes it).

``"symmetry": "mirror"`` makes the network mirror-equivariant, ``clip((g(o) + M g(M o)) / 2)``
with ``g`` the network before its clip (:mod:`tin_swarm_env.policies.symmetry`), before the
shield; it needs the layout's named fields, which every policy file records.

``"prior": "apf"`` or ``"apf_mirror"`` (optional; default ``"none"``; an MLP with the mean head): a
residual policy, ``shield(clip(apf(o) + clip(g(o))))`` with the env's default APF beside the network
(``"apf_mirror"``: two of them, one fed the mirror images, so that the file can be exactly
mirror-equivariant; :mod:`tin_swarm_env.policies.residual` describes both).

``"head": {"type": "categorical", "actions": [[vx, vy], ...], "acting": "mode", "seed": 0}``
(optional; default ``{"type": "mean"}``, the clipped output above): the last layer gives one logit
per class instead of the action, and the action is a class's (:mod:`tin_swarm_env.policies.heads`
describes it, its mirror symmetry in distribution and how it acts). Both network types take it.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from ..env.observation import ObsLayout
from ..errors import ArgumentError, ObservationLayoutError, OutputError, PolicyFileError
from .base import act_dict, make_shield, unwrap_env
from .network import (ACTIVATIONS, MAX_ABS_WEIGHT, MAX_JSON_BYTES, MAX_JSON_DEPTH, MAX_LAYER_WIDTH,  # noqa: F401
                      MAX_LAYERS, MAX_PARAMETERS, MAX_WEIGHTS_BYTES, SHIELDS, checked_array, dense)
from .heads import CategoricalHead, check_head
from .recurrent import FEEDBACKS, RecurrentPolicy, check_cell, recurrent_network
from .residual import PRIORS, add_prior, make_prior
from .symmetry import SYMMETRIES, file_options, symmetrize

__all__ = ["MLPPolicy", "ShieldedPolicy", "save_policy", "load_policy", "policy_layout", "FORMAT", "VERSION", "ACTIVATIONS",
           "SHIELDS"]

FORMAT = "tin_swarm_env.policy"
VERSION = 1
POLICY_JSON = "policy.json"
WEIGHTS = "weights.npz"
ACTION_TRANSFORMS = ("clip",)
NETWORK_TYPES = ("mlp", "recurrent")  # "recurrent": a memory cell before the MLP (policies/recurrent.py)
ACTION_SIZE = 2


def _layout_dict(layout) -> dict:
    """The observation layout as plain data (:meth:`ObsLayout.to_dict`; a dict passes through)."""
    if isinstance(layout, dict):
        return layout
    return layout.to_dict()


class MLPPolicy:
    """A multi-layer perceptron policy read from a policy file (numpy forward pass).

    ``layers``: ``[(W (out, in), b (out,)), ...]`` float64. ``act_batch(obs (n, d)) -> (n, 2)``
    float32, deterministic; ``act({agent: obs}) -> {agent: action}``. ``shield="safety_cut"``
    (with ``env``, whose constants and layout it reads) filters each action through
    :func:`~tin_swarm_env.policies.base.safety_cut`; ``net_batch`` is the unfiltered network.
    """

    def __init__(self, layers, activation: str = "tanh", action_transform: str = "clip", *, layout: dict,
                 scenario: str = "", training: dict | None = None, source: str = "<memory>",
                 shield: str = "none", env=None, symmetry: str = "none", head: dict | None = None,
                 prior: str = "none"):
        self.layers = [(np.ascontiguousarray(W, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64))
                       for W, b in layers]
        self.head = None if head is None or head.get("type", "mean") == "mean" else CategoricalHead(
            head, source, mirror=symmetry == "mirror")
        self.activation = activation
        self.action_transform = action_transform
        self.layout = layout
        self.scenario = scenario
        self.training = dict(training or {})
        self.source = source
        self.obs_size = self.layers[0][0].shape[1]
        self.shield, self.symmetry = shield, symmetry
        self._mirror, self.shield_cut = file_options(shield, symmetry, layout, env, source)
        if prior != "none" and self.head is not None:
            raise ArgumentError(f"{source}: prior {prior!r} adds the network's mean to the prior's command; a "
                                "categorical head has no mean")
        self.prior_name, self.prior = prior, make_prior(prior, env, source)
        self._rows: dict = {}  # agent name -> row, for act() (a sampling head's draws follow the robot)

    def act_batch(self, obs, rows=None) -> np.ndarray:
        """``rows``: each row's robot, for a sampling categorical head's per-robot draws and a prior's
        memory (default 0..n-1)."""
        if self.prior is None:
            a = self.net_batch(obs, rows)
        else:  # residual: the prior's command plus the network's, before the clip (policies/residual.py)
            a = add_prior(self.prior(obs, rows), self._mean(obs))
        a = a if self.shield_cut is None else self.shield_cut(a, obs)
        if self.prior is not None:
            self.prior.driven(a, rows)
        return a

    def reset(self) -> None:
        """Restart a sampling head's per-robot draws, forget the agent names and the prior's memory
        (the network itself has no memory)."""
        self._rows = {}
        if self.head is not None:
            self.head.reset()
        if self.prior is not None:
            self.prior.reset()

    def logits(self, obs) -> np.ndarray:
        """A categorical head's ``(n, K)`` float64 logits (mirror-averaged with the symmetry)."""
        x = np.ascontiguousarray(obs, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.obs_size:
            raise ArgumentError(f"{self.source}: obs must have shape (n, {self.obs_size}), got {x.shape}")
        if self.head is None:
            raise ArgumentError(f"{self.source}: the policy has no categorical head")
        if self._mirror is None:
            return self._forward(x)
        both = self._forward(np.concatenate([x, self._mirror(x)]))
        return self.head.mirror(both[:len(x)], both[len(x):])

    def net_batch(self, obs, rows=None) -> np.ndarray:
        """The network's action, clipped, before the shield (without a prior's command)."""
        if self.head is not None:
            return self.head.act(self.logits(obs), rows).astype(np.float32)
        return np.clip(self._mean(obs), -1.0, 1.0).astype(np.float32)

    def _mean(self, obs) -> np.ndarray:
        """The mean head's output before its clip (mirror-averaged with the symmetry), ``(n, 2)`` float64."""
        x = np.ascontiguousarray(obs, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.obs_size:
            raise ArgumentError(f"{self.source}: obs must have shape (n, {self.obs_size}), got {x.shape}")
        return symmetrize(self._forward, x, self._mirror) if self._mirror is not None else self._forward(x)

    def _forward(self, x) -> np.ndarray:
        """The network alone: ``x (n, d)`` float64 -> ``(n, 2)`` float64, before the clip."""
        f = ACTIVATIONS[self.activation]
        for i, (W, b) in enumerate(self.layers):
            x = dense(x, W, b)
            if i < len(self.layers) - 1:
                x = f(x)
        bad = ~np.isfinite(x).all(axis=1)
        if bad.any():  # finite weights whose products overflow: the file is at fault, not the robot
            raise PolicyFileError(f"{self.source}: the network's output is not finite (NaN or inf) for observation "
                                  f"row {int(np.flatnonzero(bad)[0])}: its weights overflow float64")
        return x

    def act(self, obs: dict) -> dict:
        """Each agent keeps the row it got the first time it was seen (as the recurrent policy's),
        so a sampling head's draws for a robot do not depend on which other robots are acting."""
        return act_dict(self.act_batch, obs, [self._rows.setdefault(k, len(self._rows)) for k in obs])

    def __repr__(self) -> str:
        sizes = [self.obs_size] + [W.shape[0] for W, _ in self.layers]
        shield = "" if self.shield == "none" else f", shield={self.shield!r}"
        sym = "" if self.symmetry == "none" else f", symmetry={self.symmetry!r}"
        head = "" if self.head is None else f", head=categorical({len(self.head.actions)}, {self.head.acting})"
        prior = "" if self.prior is None else f", prior={self.prior_name!r}"
        return (f"MLPPolicy({self.source!r}, {sizes}, {self.activation}, scenario={self.scenario!r}{shield}{sym}"
                f"{head}{prior})")


class ShieldedPolicy:
    """Any policy (``act_batch(obs (n, d)) -> (n, 2)``, optional ``reset()``) acting through the
    shield ``shield`` (``"safety_cut"`` or ``"safety_cut_scan"``) of ``env`` (see the module
    docstring): what training uses for a shielded learner before it is exported."""

    def __init__(self, policy, env, shield: str = "safety_cut"):
        self.policy = policy
        self.shield = make_shield(shield, env)
        if self.shield is None:
            raise ArgumentError("ShieldedPolicy: shield 'none' shields nothing; use the policy itself")

    def reset(self):
        if hasattr(self.policy, "reset"):
            self.policy.reset()

    def act_batch(self, obs) -> np.ndarray:
        return self.shield(self.policy.act_batch(obs), obs)

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs)


# -- saving ---------------------------------------------------------------------------------


def save_policy(path, layers, activation: str = "tanh", *, layout, scenario: str, action_transform: str = "clip",
                extra: dict | None = None, shield: str = "none", symmetry: str = "none", cell=None,
                head: dict | None = None, feedback: str = "none", prior: str = "none") -> Path:
    """Write a policy directory ``path/`` (``policy.json`` + ``weights.npz``) atomically (``shield``:
    ``"none"`` or ``"safety_cut"``, ``symmetry``: ``"none"`` or ``"mirror"``, see the module
    docstring; ``cell``: ``(name, {cell_W_ih: ..., ...})`` for a recurrent policy whose head is
    ``layers``, :mod:`tin_swarm_env.policies.recurrent`, ``feedback`` its ``"network.feedback"``
    (``"action"``: the cell also reads the previous action); ``prior``: ``"apf"`` or ``"apf_mirror"`` for a residual
    network (:mod:`tin_swarm_env.policies.residual`); ``head``: the ``"head"`` entry, e.g.
    :func:`~tin_swarm_env.policies.heads.categorical_head`, None: the mean head): both
    files go into a temporary directory beside it, which is then renamed into place; an existing
    policy directory at ``path`` is replaced, anything else there is refused. Returns the path."""
    p = Path(os.fspath(path))
    layers = [(np.asarray(W, dtype=np.float64), np.asarray(b, dtype=np.float64)) for W, b in layers]
    lay = _layout_dict(layout)
    sizes = [int(layers[0][0].shape[1])] + [int(W.shape[0]) for W, _ in layers] if layers else []
    arrays = {f"{k}{i}": a for i, (W, b) in enumerate(layers) for k, a in (("W", W), ("b", b))}
    network = {"type": "mlp", "layer_sizes": sizes, "activation": activation, "action_transform": action_transform}
    obs_size = sizes[0] if sizes else 0
    if cell is None and feedback != "none":
        raise ArgumentError(f"save_policy: feedback={feedback!r} needs a memory cell (cell=...): an MLP reads no "
                            "previous action")
    if cell is not None:
        name, cw = cell
        cw = {k: np.asarray(v, dtype=np.float64) for k, v in cw.items()}
        in_size = int(cw["cell_W_ih"].shape[1]) if "cell_W_ih" in cw else 0
        obs_size = in_size - FEEDBACKS.get(feedback, 0)
        hidden = int(cw["cell_W_hh"].shape[1]) if "cell_W_hh" in cw else 0
        network = recurrent_network(name, in_size, hidden, sizes, activation, action_transform, feedback)
        arrays.update(cw)
    meta = {"format": FORMAT, "version": VERSION, "network": network,
            "observation": {"size": obs_size, "layout": lay},
            "action": {"size": ACTION_SIZE, "low": -1.0, "high": 1.0},
            "scenario": str(scenario), "training": dict(extra or {})}
    if shield != "none":
        meta["shield"] = shield
    if symmetry != "none":
        meta["symmetry"] = symmetry
    if head is not None and head.get("type") != "mean":
        meta["head"] = head
    if prior != "none":
        meta["prior"] = prior
    validate_policy(meta, arrays, str(p / POLICY_JSON), str(p / WEIGHTS))
    if p.exists() and not (p.is_dir() and (p / POLICY_JSON).is_file()):
        raise PolicyFileError(f"{p}: exists and is not a policy directory; refusing to replace it")
    if not p.parent.is_dir():
        raise PolicyFileError(f"{p.parent}: directory does not exist")
    tmp = Path(tempfile.mkdtemp(prefix=f".{p.name}.", suffix=".part", dir=p.parent))
    try:
        with open(tmp / WEIGHTS, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        with open(tmp / POLICY_JSON, "w", encoding="utf-8") as fh:
            json.dump(meta, fh, indent=1, allow_nan=False)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)
        _swap_into_place(tmp, p)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and not isinstance(exc, OutputError) and (
                exc.filename is None or str(tmp) in str(exc.filename)):  # a write into the temporary directory
            raise OutputError(exc.errno or errno.EIO, f"{exc.strerror or exc}; not written (an old policy there "
                              "is unchanged)", str(p)) from exc
        raise
    return p


def _swap_into_place(tmp: Path, p: Path) -> None:
    if not p.exists():
        os.replace(tmp, p)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{p.name}.", suffix=".old", dir=p.parent))
    os.replace(p, old / "policy")  # the old policy moves aside whole, then the new one moves in
    try:
        os.replace(tmp, p)
    except BaseException:
        os.replace(old / "policy", p)
        raise
    finally:
        shutil.rmtree(old, ignore_errors=True)


# -- loading --------------------------------------------------------------------------------


def _read_meta(path, who: str = "load_policy") -> tuple[Path, Path, Path, dict]:
    """The policy directory of ``path`` (or of its ``policy.json``): ``(dir, json path, weights path, meta)``,
    the JSON read with its size and depth limits and checked (sizes and limits, no weights read yet)."""
    if not isinstance(path, (str, os.PathLike)):
        raise ArgumentError(f"{who}(path=...): path must be a policy directory (str or os.PathLike), got "
                            f"{type(path).__name__}")
    p = Path(os.fspath(path))
    d = p.parent if p.name in (POLICY_JSON, WEIGHTS) and p.is_file() else p  # a file of it: its directory
    jpath, wpath = d / POLICY_JSON, d / WEIGHTS
    if not d.is_dir():
        what = "is a file, not a policy directory" if d.is_file() else "no such policy directory"
        raise PolicyFileError(f"{d}: {what} (expected {POLICY_JSON} and {WEIGHTS} in it)")
    for f in (jpath, wpath):
        if not f.is_file():
            what = "is not a file" if f.exists() else "missing"
            raise PolicyFileError(f"{f}: {what}; a policy directory holds {POLICY_JSON} and {WEIGHTS}")
    for f, limit in ((jpath, MAX_JSON_BYTES), (wpath, MAX_WEIGHTS_BYTES)):
        if f.stat().st_size > limit:
            raise PolicyFileError(f"{f}: {f.stat().st_size:,} bytes; a policy file has at most {limit:,} (networks of "
                                  f"up to {MAX_PARAMETERS:,} parameters)")
    try:
        text = jpath.read_text(encoding="utf-8")
        _check_depth(text, str(jpath))
        meta = json.loads(text)
    except json.JSONDecodeError as exc:
        raise PolicyFileError(f"{jpath}:{exc.lineno}: not valid JSON ({exc.msg})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PolicyFileError(f"{jpath}: cannot be read ({exc})") from None
    validate_policy(meta, None, str(jpath), str(wpath))  # sizes and limits before the weights are read
    return d, jpath, wpath, meta


def policy_layout(path) -> ObsLayout:
    """The observation layout the policy directory ``path`` was trained on (its ``policy.json``'s
    ``observation.layout``), read without the weights: build the env it runs on with
    :func:`~tin_swarm_env.scenario.with_layout` (a policy trained before the terrain scan was in the
    default layout runs on an env built with its own layout; any other env is refused by
    :func:`load_policy`, naming both layouts)."""
    _, jpath, _, meta = _read_meta(path, "policy_layout")
    try:
        return ObsLayout.from_dict(meta["observation"]["layout"])
    except ObservationLayoutError as exc:
        raise PolicyFileError(f"{jpath}: key 'observation.layout': {exc}") from None


def load_policy(path, env):
    """Read the policy directory ``path`` (or its ``policy.json``) for ``env``: no pickle, no
    torch; an :class:`MLPPolicy`, or a :class:`~tin_swarm_env.policies.recurrent.RecurrentPolicy`
    for a recurrent file. Raises :class:`~tin_swarm_env.errors.PolicyFileError` naming the file and the key for
    anything wrong: a missing file, bad JSON, unknown format or version, a missing key, unknown
    activation, weights that do not chain or are not finite, an object array in the weights, an
    observation size other than the env's, or a layout other than the env's (both named)."""
    d, jpath, wpath, meta = _read_meta(path)
    arrays = read_weights(wpath, meta["network"]["layer_sizes"])
    layers = validate_policy(meta, arrays, str(jpath), str(wpath))
    _check_env(meta, env, str(jpath))
    net = meta["network"]
    head = check_head(meta.get("head"), net["layer_sizes"][-1], meta.get("symmetry", "none"), str(jpath))
    if net["type"] == "recurrent":
        _, cw = check_cell(net, arrays, str(jpath), str(wpath))
        return RecurrentPolicy(net["cell"], cw, layers, net["activation"], net["action_transform"],
                               layout=meta["observation"]["layout"], scenario=meta["scenario"],
                               training=meta.get("training", {}), source=str(d), shield=meta.get("shield", "none"),
                               env=env, symmetry=meta.get("symmetry", "none"), head=head,
                               feedback=net.get("feedback", "none"))
    return MLPPolicy(layers, net["activation"], net["action_transform"], layout=meta["observation"]["layout"],
                     scenario=meta["scenario"], training=meta.get("training", {}), source=str(d),
                     shield=meta.get("shield", "none"), env=env, symmetry=meta.get("symmetry", "none"), head=head,
                     prior=meta.get("prior", "none"))


def _check_depth(text: str, where: str) -> None:
    """Refuse JSON nested deeper than :data:`MAX_JSON_DEPTH` before parsing it (vectorised: strings
    removed, then the running count of brackets)."""
    import re

    bare = re.sub(r'"(?:[^"\\]|\\.)*"', "", text).encode("utf-8", "replace")
    c = np.frombuffer(bare, dtype=np.uint8)
    step = np.isin(c, (ord("["), ord("{"))).astype(np.int64) - np.isin(c, (ord("]"), ord("}")))
    depth = int(np.cumsum(step).max()) if len(step) else 0
    if depth > MAX_JSON_DEPTH:
        raise PolicyFileError(f"{where}: JSON nested {depth} deep; at most {MAX_JSON_DEPTH}")


def _npz_shapes(wpath: Path) -> dict:
    """``{name: (shape, dtype)}`` of the arrays in an .npz, from their headers only (no data read)."""
    import zipfile

    out = {}
    with zipfile.ZipFile(wpath) as z:
        for info in z.infolist():
            if not info.filename.endswith(".npy"):
                continue
            with z.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                read = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
                if version not in read:
                    raise ValueError(f"array {info.filename!r}: .npy format version {version}")
                shape, _, dtype = read[version](fh)
            out[info.filename[:-4]] = (shape, dtype)
    return out


def read_weights(wpath: Path, sizes=None) -> dict:
    try:
        if sizes is not None:  # every array's size from its header, against what the layer sizes allow
            for k, (shape, dtype) in _npz_shapes(wpath).items():
                n = int(np.prod(shape, dtype=np.float64)) if shape else 1
                if n > MAX_LAYER_WIDTH ** 2 or dtype.itemsize * n > MAX_WEIGHTS_BYTES:
                    raise PolicyFileError(f"{wpath}: array {k!r} has shape {shape}; a layer has at most "
                                          f"{MAX_LAYER_WIDTH} x {MAX_LAYER_WIDTH} weights")
        with np.load(wpath, allow_pickle=False) as f:
            out = {}
            for k in f.files:
                try:
                    out[k] = f[k]
                except ValueError as exc:  # object arrays need pickle: refused
                    raise PolicyFileError(f"{wpath}: array {k!r} cannot be read without unpickling ({exc}); "
                                          "policy weights are plain numbers") from None
            return out
    except PolicyFileError:
        raise
    except Exception as exc:
        raise PolicyFileError(f"{wpath}: not a readable .npz archive ({type(exc).__name__}: {exc})") from None


def _get(d, key, typ, where):
    if not isinstance(d, dict) or key not in d:
        raise PolicyFileError(f"{where}: missing key {key!r}")
    v = d[key]
    ok = isinstance(v, typ) and not (isinstance(v, bool) and typ is not bool)
    if not ok:
        raise PolicyFileError(f"{where}: key {key!r} must be {typ.__name__ if isinstance(typ, type) else typ}, "
                              f"got {type(v).__name__} {v!r}")
    return v


KEYS = {  # the keys a policy file may hold, per table ("training" is the trainer's own record: any keys)
    "": ("format", "version", "network", "observation", "action", "scenario", "training", "shield", "symmetry", "head",
         "prior"),
    "network": ("type", "layer_sizes", "activation", "action_transform", "cell", "input_size", "hidden_size",
                "feedback"),
    "observation": ("size", "layout"),
    "action": ("size", "low", "high"),
}


def _unknown_keys(meta: dict, jname: str):
    """Refuse a key no table of :data:`KEYS` names (a misspelt ``shield`` would load a policy without it)."""
    for table, known in KEYS.items():
        d = meta if not table else meta.get(table)
        extra = sorted(set(d) - set(known)) if isinstance(d, dict) else []
        if extra:
            where = f"'{table}.{extra[0]}'" if table else f"'{extra[0]}'"
            raise PolicyFileError(f"{jname}: unknown key {where}; known {'in ' + repr(table) if table else 'at the top'}"
                                  f": {list(known)}")


def validate_policy(meta, arrays: dict | None, jname: str, wname: str) -> list:
    """Check a policy description and its weights (``arrays``; None: the description alone);
    return ``[(W, b), ...]`` float64."""
    if not isinstance(meta, dict):
        raise PolicyFileError(f"{jname}: the top level must be a JSON object")
    fmt = meta.get("format")
    if fmt != FORMAT:
        raise PolicyFileError(f"{jname}: key 'format' is {fmt!r}; expected {FORMAT!r}")
    ver = _get(meta, "version", int, jname)
    if ver != VERSION:
        raise PolicyFileError(f"{jname}: key 'version' is {ver}; this tin_swarm_env reads version {VERSION}")
    _unknown_keys(meta, jname)
    net = _get(meta, "network", dict, jname)
    if _get(net, "type", str, f"{jname} [network]") not in NETWORK_TYPES:
        raise PolicyFileError(f"{jname}: key 'network.type' is {net['type']!r}; expected one of {list(NETWORK_TYPES)}")
    sizes = _get(net, "layer_sizes", list, f"{jname} [network]")
    if len(sizes) < 2 or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 1 for s in sizes):
        raise PolicyFileError(f"{jname}: key 'network.layer_sizes' must be 2 or more positive integers, got "
                              f"{str(sizes)[:80]}")
    if len(sizes) > MAX_LAYERS + 1 or max(sizes) > MAX_LAYER_WIDTH or sum(
            a * b + b for a, b in zip(sizes[:-1], sizes[1:])) > MAX_PARAMETERS:
        raise PolicyFileError(f"{jname}: key 'network.layer_sizes' {str(sizes)[:80]} is beyond the limits: at most "
                              f"{MAX_LAYERS} layers of {MAX_LAYER_WIDTH} units and {MAX_PARAMETERS:,} parameters")
    act = _get(net, "activation", str, f"{jname} [network]")
    if act not in ACTIVATIONS:
        raise PolicyFileError(f"{jname}: key 'network.activation' is {act!r}; known: {sorted(ACTIVATIONS)}")
    tr = _get(net, "action_transform", str, f"{jname} [network]")
    if tr not in ACTION_TRANSFORMS:
        raise PolicyFileError(f"{jname}: key 'network.action_transform' is {tr!r}; known: {list(ACTION_TRANSFORMS)}")
    in_size, what = sizes[0], "the first layer size"
    if net["type"] != "recurrent" and "feedback" in net:
        raise PolicyFileError(f"{jname}: key 'network.feedback' is for a recurrent network (a memory cell reads "
                              f"the previous action); this network's type is {net['type']!r}")
    if net["type"] == "recurrent":  # the cell reads the observation; the head (layer_sizes) reads the cell
        in_size, cell = check_cell(net, arrays, jname, wname)
        what = "the cell's 'network.input_size'" + (" less its 'network.feedback' inputs"
                                                    if net.get("feedback", "none") != "none" else "")
        if arrays is not None:
            arrays = {k: v for k, v in arrays.items() if k not in cell}
    obs = _get(meta, "observation", dict, jname)
    if _get(obs, "size", int, f"{jname} [observation]") != in_size:
        raise PolicyFileError(f"{jname}: key 'observation.size' ({obs['size']}) differs from {what} ({in_size})")
    _get(obs, "layout", dict, f"{jname} [observation]")
    action = _get(meta, "action", dict, jname)
    if _get(action, "size", int, f"{jname} [action]") != ACTION_SIZE:
        raise PolicyFileError(f"{jname}: the action size must be {ACTION_SIZE} (key 'action.size' = {action['size']})")
    if "head" not in meta and sizes[-1] != ACTION_SIZE:
        raise PolicyFileError(f"{jname}: the action size must be {ACTION_SIZE} (last layer size {sizes[-1]}; a "
                              "categorical 'head' has one per class)")
    _get(meta, "scenario", str, jname)
    if "training" in meta:
        _get(meta, "training", dict, jname)
    if "shield" in meta and _get(meta, "shield", str, jname) not in SHIELDS:
        raise PolicyFileError(f"{jname}: key 'shield' is {meta['shield']!r}; known: {list(SHIELDS)}")
    if "symmetry" in meta and _get(meta, "symmetry", str, jname) not in SYMMETRIES:
        raise PolicyFileError(f"{jname}: key 'symmetry' is {meta['symmetry']!r}; known: {list(SYMMETRIES)}")
    if "head" in meta:
        check_head(meta["head"], sizes[-1], meta.get("symmetry", "none"), jname)
    if "prior" in meta:
        _check_prior(meta, jname)
    return [] if arrays is None else _check_weights(arrays, sizes, wname)


def _check_prior(meta: dict, jname: str) -> None:
    prior = _get(meta, "prior", str, jname)
    if prior not in PRIORS:
        raise PolicyFileError(f"{jname}: key 'prior' is {prior!r}; known: {list(PRIORS)}")
    if prior != "none" and (meta["network"]["type"] != "mlp" or meta.get("head", {}).get("type", "mean") != "mean"):
        raise PolicyFileError(f"{jname}: key 'prior' {prior!r} needs an 'mlp' network with the mean head (the "
                              f"network's mean is added to the prior's command); this one is "
                              f"{meta['network']['type']!r} with head {meta.get('head', {}).get('type', 'mean')!r}")


def _check_weights(arrays: dict, sizes: list, wname: str) -> list:
    expected = [f"{k}{i}" for i in range(len(sizes) - 1) for k in ("W", "b")]
    missing = [k for k in expected if k not in arrays]
    extra = sorted(set(arrays) - set(expected))
    if missing or extra:
        raise PolicyFileError(f"{wname}: arrays {sorted(arrays)} do not match the layer sizes {sizes} "
                              f"(missing {missing}, unexpected {extra})")
    layers = []
    for i in range(len(sizes) - 1):
        pair = []
        for k, shape in (("W", (sizes[i + 1], sizes[i])), ("b", (sizes[i + 1],))):
            pair.append(checked_array(arrays[f"{k}{i}"], f"{k}{i}", shape, wname, f"layer sizes {sizes} need"))
        layers.append(tuple(pair))
    return layers


def _check_env(meta: dict, env, jname: str) -> None:
    e = unwrap_env(env)
    mine = _layout_dict(e.layout)
    theirs = meta["observation"]["layout"]
    if theirs != mine:
        raise PolicyFileError(f"{jname}: key 'observation.layout' {_brief(theirs, mine)} differs from the "
                              f"environment's layout {_brief(mine, theirs)}; the policy was trained on other "
                              "observations")
    if meta["observation"]["size"] != e.layout.size:
        raise PolicyFileError(f"{jname}: key 'observation.size' is {meta['observation']['size']} but the "
                              f"environment's observations have {e.layout.size} elements")


def _brief(lay, other) -> str:
    """A layout in a message: its K counts, and the first element name that differs."""
    if not isinstance(lay, dict):
        return repr(lay)
    ks = {k: lay.get(k) for k in ("k_robots", "k_targets", "k_breaks", "k_assets", "k_scan") if k in lay
          or k in ("k_robots", "k_targets", "k_breaks")}
    names, onames = lay.get("names"), other.get("names") if isinstance(other, dict) else None
    if isinstance(names, list) and isinstance(onames, list) and names != onames:
        i = next((i for i, (a, b) in enumerate(zip(names, onames)) if a != b), min(len(names), len(onames)))
        ks["names"] = f"{len(names)} elements, element {i} = {names[i] if i < len(names) else None!r}"
    elif isinstance(other, dict):  # the counts and names agree: show the first other entry that differs
        diff = _first_difference(lay, other)
        if diff:
            ks[diff[0]] = diff[1]
    return str(ks)


def _first_difference(a: dict, b: dict, where: str = ""):
    """``(dotted key, a's value)`` of the first key (sorted, depth first) where ``a`` and ``b`` differ; None
    if they are equal."""
    for k in sorted(set(a) | set(b), key=str):
        va, vb = a.get(k), b.get(k)
        if va == vb:
            continue
        if isinstance(va, dict) and isinstance(vb, dict):
            return _first_difference(va, vb, f"{where}{k}.")
        return f"{where}{k}", va
    return None
