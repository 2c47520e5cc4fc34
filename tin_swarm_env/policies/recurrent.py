"""Recurrent policy files: a memory cell (LSTM or GRU) before the MLP head, numpy forward pass.

The pickle-free format of :mod:`tin_swarm_env.policies.learned` with ``"network"``::

    {"type": "recurrent", "cell": "lstm", "input_size": 59, "hidden_size": 64,
     "layer_sizes": [64, 64, 2], "activation": "tanh", "action_transform": "clip"}

and, in ``weights.npz`` beside the head's ``W0, b0, ...`` (``layer_sizes`` as an MLP's, starting
at ``hidden_size``), the cell in torch's layout (``nn.LSTM`` / ``nn.GRU`` with one layer):
``cell_W_ih (G*H, input_size)``, ``cell_W_hh (G*H, H)``, ``cell_b_ih (G*H,)``, ``cell_b_hh (G*H,)``,
``G`` = 4 gates for an LSTM (input, forget, cell, output) and 3 for a GRU (reset, update, new).
One step, ``x`` the observation and ``(h, c)`` the state (``c`` only for an LSTM)::

    LSTM: i, f, g, o = split(W_ih x + b_ih + W_hh h + b_hh); i, f, o = sigmoid(.); g = tanh(g)
          c' = f c + i g;  h' = o tanh(c')
    GRU:  r, z = sigmoid(split(W_ih x + b_ih + W_hh h + b_hh)[:2])
          n = tanh(W_in x + b_in + r (W_hn h + b_hn));  h' = (1 - z) n + z h
    action = clip(head(h'))   (the MLP of learned.py: activation after every layer but the last)

**Memory per robot.** Rows are robots, as :class:`~tin_swarm_env.policies.APFPolicy`'s:
``act_batch`` row ``i`` is robot ``i`` (or ``rows[i]``), ``act`` gives each agent name a row the
first time it sees it. A row's state starts at zero when the row is new and after :meth:`reset`
(which :func:`~tin_swarm_env.apps.rollout.rollout` calls after every env reset), as SB3's
RecurrentPPO zeroes it at an episode start; each call advances the state of the rows it is given.

**Symmetry** (``"symmetry": "mirror"``, :mod:`tin_swarm_env.policies.symmetry`): the policy keeps
two states per robot, one fed the observations and one their mirror images, and averages the
two streams' head outputs (``vy`` of the mirrored one negated) before the clip. It is then equivariant over whole
histories, exactly: a mirrored episode gives mirrored actions at every step.

**A categorical head** (the file's ``"head"``, :mod:`tin_swarm_env.policies.heads`): the MLP after
the cell gives the classes' logits; with the symmetry the two streams' logits are averaged with the
mirrored one's classes permuted, so the class probabilities are equivariant over whole histories.
A sampling head draws from each row's own stream, restarted by :meth:`RecurrentPolicy.reset`.
"""

from __future__ import annotations

import numpy as np

from ..env.observation import ACTION_PARITY
from ..errors import ArgumentError, PolicyFileError
from .base import act_dict
from .heads import CategoricalHead
from .network import ACTIVATIONS, MAX_LAYER_WIDTH, MAX_PARAMETERS, checked_array, dense
from .symmetry import file_options

__all__ = ["RecurrentPolicy", "CELLS", "CELL_ARRAYS", "check_cell", "recurrent_network"]

CELLS = {"lstm": 4, "gru": 3}  # cell type -> gates
CELL_ARRAYS = ("cell_W_ih", "cell_W_hh", "cell_b_ih", "cell_b_hh")


def recurrent_network(cell: str, input_size: int, hidden_size: int, head_sizes, activation: str = "tanh",
                      action_transform: str = "clip") -> dict:
    """The ``"network"`` entry of a recurrent policy file (module docstring)."""
    return {"type": "recurrent", "cell": cell, "input_size": int(input_size), "hidden_size": int(hidden_size),
            "layer_sizes": [int(s) for s in head_sizes], "activation": activation, "action_transform": action_transform}


def _pos_int(net, key, jname):
    v = net.get(key) if isinstance(net, dict) else None
    if key not in net:
        raise PolicyFileError(f"{jname}: missing key 'network.{key}'")
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise PolicyFileError(f"{jname}: key 'network.{key}' must be a positive integer, got {v!r}")
    return v


def check_cell(net: dict, arrays: dict | None, jname: str, wname: str) -> tuple[int, dict]:
    """Check the cell part of a recurrent ``network`` entry and its arrays (``arrays`` None: the
    entry alone, against the size limits of :mod:`~tin_swarm_env.policies.network`, before the
    weights are read); returns ``(input_size, {name: float64 array})``. Raises
    :class:`PolicyFileError` naming the file and the key or array."""
    cell = net.get("cell")
    if "cell" not in net:
        raise PolicyFileError(f"{jname}: missing key 'network.cell'")
    if cell not in CELLS:
        raise PolicyFileError(f"{jname}: key 'network.cell' is {cell!r}; known: {sorted(CELLS)}")
    d, H = _pos_int(net, "input_size", jname), _pos_int(net, "hidden_size", jname)
    sizes = net.get("layer_sizes")
    if isinstance(sizes, list) and sizes and sizes[0] != H:
        raise PolicyFileError(f"{jname}: key 'network.layer_sizes' must start at hidden_size {H} (the head reads "
                              f"the cell's output), got {sizes}")
    G = CELLS[cell]
    if max(d, G * H) > MAX_LAYER_WIDTH or G * H * (d + H + 2) > MAX_PARAMETERS:
        raise PolicyFileError(f"{jname}: a {cell} cell with 'network.input_size' {d} and 'network.hidden_size' {H} "
                              f"is beyond the limits: at most {MAX_LAYER_WIDTH} gate units and {MAX_PARAMETERS:,} "
                              "parameters")
    shapes = {"cell_W_ih": (G * H, d), "cell_W_hh": (G * H, H), "cell_b_ih": (G * H,), "cell_b_hh": (G * H,)}
    out = {}
    if arrays is None:
        return d, out
    for k, shape in shapes.items():
        if k not in arrays:
            raise PolicyFileError(f"{wname}: missing array {k!r} (a {cell} cell needs {list(shapes)})")
        out[k] = checked_array(arrays[k], k, shape, wname,
                               f"a {cell} cell with input_size {d} and hidden_size {H} needs")
    return d, out


def expit(x):
    """The logistic sigmoid as ``(1 + tanh(x / 2)) / 2``: no overflow for any finite ``x``."""
    return 0.5 * (1.0 + np.tanh(0.5 * x))


def cell_step(cell: str, w: dict, x, h, c):
    """One step of the cell for a batch: ``x (n, d)``, ``h, c (n, H)`` -> ``(h', c')`` (``c`` is
    unused, and returned as is, for a GRU). Plain numpy over :func:`~.network.dense`."""
    H = h.shape[1]
    gi, gh = dense(x, w["cell_W_ih"], w["cell_b_ih"]), dense(h, w["cell_W_hh"], w["cell_b_hh"])
    if cell == "lstm":
        g = gi + gh
        i, f, o = expit(g[:, :H]), expit(g[:, H:2 * H]), expit(g[:, 3 * H:])
        c2 = f * c + i * np.tanh(g[:, 2 * H:3 * H])
        return o * np.tanh(c2), c2
    r = expit(gi[:, :H] + gh[:, :H])
    z = expit(gi[:, H:2 * H] + gh[:, H:2 * H])
    n = np.tanh(gi[:, 2 * H:] + r * gh[:, 2 * H:])
    return (1.0 - z) * n + z * h, c


class RecurrentPolicy:
    """A recurrent policy read from a policy file (module docstring): ``act_batch(obs (n, d),
    rows=None) -> (n, 2)`` float32 advances each row's memory by one step; ``act({agent: obs})``;
    :meth:`reset` forgets every robot (call it after each env reset). ``shield="safety_cut"``
    (with ``env``) filters the actions as an MLP file's; ``net_batch`` is the unfiltered
    network (it advances the memory too)."""

    def __init__(self, cell: str, cell_weights: dict, layers, activation: str = "tanh",
                 action_transform: str = "clip", *, layout: dict, scenario: str = "", training: dict | None = None,
                 source: str = "<memory>", shield: str = "none", env=None, symmetry: str = "none",
                 head: dict | None = None):
        if cell not in CELLS:
            raise ArgumentError(f"{source}: cell {cell!r} is not one of {sorted(CELLS)}")
        if activation not in ACTIVATIONS:
            raise ArgumentError(f"{source}: activation {activation!r} is not one of {sorted(ACTIVATIONS)}")
        self.cell = cell
        self.w = {k: np.ascontiguousarray(cell_weights[k], dtype=np.float64) for k in CELL_ARRAYS}
        self.layers = [(np.ascontiguousarray(W, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64))
                       for W, b in layers]
        self.hidden_size = self.w["cell_W_hh"].shape[1]
        self.obs_size = self.w["cell_W_ih"].shape[1]
        self.activation, self.action_transform = activation, action_transform
        self._act = ACTIVATIONS[activation]
        self.layout, self.scenario, self.training, self.source = layout, scenario, dict(training or {}), source
        self.shield, self.symmetry = shield, symmetry
        self._signs, self.shield_cut = file_options(shield, symmetry, layout, env, source)
        self.head = None if head is None or head.get("type", "mean") == "mean" else CategoricalHead(
            head, source, mirror=symmetry == "mirror")
        self.reset()

    # -- memory --------------------------------------------------------------------------------
    def reset(self):
        """Forget every robot (state back to zero; agent names forgotten)."""
        streams = 2 if self._signs is not None else 1
        self._h = np.zeros((streams, 0, self.hidden_size))
        self._c = np.zeros((streams, 0, self.hidden_size))
        self._rows: dict = {}
        if self.head is not None:
            self.head.reset()

    @property
    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """``(h, c)``, each ``(streams, rows, H)`` (a copy; ``c`` is zero for a GRU)."""
        return self._h.copy(), self._c.copy()

    def _grow(self, n: int) -> None:
        k = n - self._h.shape[1]
        if k > 0:
            pad = np.zeros((self._h.shape[0], k, self.hidden_size))
            self._h, self._c = np.concatenate([self._h, pad], axis=1), np.concatenate([self._c, pad], axis=1)

    # -- acting --------------------------------------------------------------------------------
    def net_batch(self, obs, rows=None) -> np.ndarray:
        if self.head is not None:
            z, rows = self.logits(obs, rows)
            return self.head.act(z, rows).astype(np.float32)
        return self._outputs(obs, rows)[0]

    def logits(self, obs, rows=None) -> tuple[np.ndarray, np.ndarray]:
        """A categorical head's ``(n, K)`` float64 logits (mirror-averaged with the symmetry) and
        the rows; advances the memory of those rows like :meth:`net_batch`."""
        if self.head is None:
            raise ArgumentError(f"{self.source}: the policy has no categorical head")
        return self._outputs(obs, rows)

    def _outputs(self, obs, rows):
        x = np.ascontiguousarray(obs, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.obs_size:
            raise ArgumentError(f"{self.source}: obs must have shape (n, {self.obs_size}), got {x.shape}")
        rows = np.arange(len(x)) if rows is None else np.asarray(rows, dtype=np.int64)
        if rows.shape != (len(x),) or (len(rows) and rows.min() < 0) or len(np.unique(rows)) != len(rows):
            raise ArgumentError(f"{self.source}: rows must be {len(x)} distinct indices >= 0, got {rows.tolist()}")
        if not len(x):
            k = 2 if self.head is None else len(self.head.actions)
            return np.zeros((0, k), dtype=np.float32 if self.head is None else np.float64), rows
        self._grow(int(rows.max()) + 1)
        n = len(x)
        if self._signs is not None:  # both streams in one pass: the observations, then their mirror images
            x = np.concatenate([x, x * self._signs])
        h = self._h[:, rows].reshape(-1, self.hidden_size)
        c = self._c[:, rows].reshape(-1, self.hidden_size)
        h, c = cell_step(self.cell, self.w, x, h, c)
        self._h[:, rows] = h.reshape(-1, n, self.hidden_size)
        self._c[:, rows] = c.reshape(-1, n, self.hidden_size)
        a = self._head(h)
        if self.head is not None:
            return (self.head.mirror(a[:n], a[n:]) if self._signs is not None else a), rows
        if self._signs is not None:
            a = (a[:n] + a[n:] * np.asarray(ACTION_PARITY)) / 2
        return np.clip(a, -1.0, 1.0).astype(np.float32), rows

    def _head(self, x) -> np.ndarray:
        for i, (W, b) in enumerate(self.layers):
            x = dense(x, W, b)
            if i < len(self.layers) - 1:
                x = self._act(x)
        bad = ~np.isfinite(x).all(axis=1)
        if bad.any():  # finite weights whose products overflow: the file is at fault, not the robot
            raise PolicyFileError(f"{self.source}: the network's output is not finite (NaN or inf) for row "
                                  f"{int(np.flatnonzero(bad)[0])}: its weights overflow float64")
        return x

    def act_batch(self, obs, rows=None) -> np.ndarray:
        a = self.net_batch(obs, rows)
        return a if self.shield_cut is None else self.shield_cut(a, obs)

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs, [self._rows.setdefault(k, len(self._rows)) for k in obs])

    def __repr__(self) -> str:
        sizes = [self.obs_size, f"{self.cell}({self.hidden_size})"] + [W.shape[0] for W, _ in self.layers]
        extra = "".join(f", {k}={v!r}" for k, v in (("shield", self.shield), ("symmetry", self.symmetry))
                        if v != "none")
        if self.head is not None:
            extra += f", head=categorical({len(self.head.actions)}, {self.head.acting})"
        return f"RecurrentPolicy({self.source!r}, {sizes}, {self.activation}, scenario={self.scenario!r}{extra})"
