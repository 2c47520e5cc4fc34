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
(which :func:`~tin_swarm_env.training.rollout.rollout` calls after every env reset), as SB3's
RecurrentPPO zeroes it at an episode start; each call advances the state of the rows it is given.

**Feedback** (``"network": {..., "feedback": "action"}``; absent or ``"none"``: none): the cell
also reads the action the policy commanded for that robot at its previous step, before the shield
(a categorical head's drawn class action, a mean head's clipped output; ``(0, 0)`` at a row's first
step and after :meth:`~RecurrentPolicy.reset`): ``x = [observation, previous action]``, so
``input_size`` is the observation size plus 2 and ``cell_W_ih``'s last two columns weigh
``(vx, vy)``. A sampling head can then keep the side it drew. Callers that take
:meth:`~RecurrentPolicy.logits` and choose the action themselves hand it back with
:meth:`~RecurrentPolicy.remember`; :meth:`~RecurrentPolicy.net_batch` does so itself.

**Symmetry** (``"symmetry": "mirror"``, :mod:`tin_swarm_env.policies.symmetry`): the policy keeps
two states per robot, one fed the observations and one their mirror images (with feedback: and the
previous action mirrored, ``vy -> -vy``), and averages the
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

__all__ = ["RecurrentPolicy", "CELLS", "CELL_ARRAYS", "FEEDBACKS", "check_cell", "recurrent_network"]

CELLS = {"lstm": 4, "gru": 3}  # cell type -> gates
CELL_ARRAYS = ("cell_W_ih", "cell_W_hh", "cell_b_ih", "cell_b_hh")
FEEDBACKS = {"none": 0, "action": 2}  # "network.feedback" -> inputs the cell reads beyond the observation


def recurrent_network(cell: str, input_size: int, hidden_size: int, head_sizes, activation: str = "tanh",
                      action_transform: str = "clip", feedback: str = "none") -> dict:
    """The ``"network"`` entry of a recurrent policy file (module docstring; ``input_size``: the
    cell's, feedback included)."""
    net = {"type": "recurrent", "cell": cell, "input_size": int(input_size), "hidden_size": int(hidden_size),
           "layer_sizes": [int(s) for s in head_sizes], "activation": activation, "action_transform": action_transform}
    if feedback != "none":
        net["feedback"] = feedback
    return net


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
    weights are read); returns ``(observation size, {name: float64 array})`` (the observation
    size is ``input_size`` less the feedback's inputs). Raises
    :class:`PolicyFileError` naming the file and the key or array."""
    cell = net.get("cell")
    if "cell" not in net:
        raise PolicyFileError(f"{jname}: missing key 'network.cell'")
    if not isinstance(cell, str) or cell not in CELLS:
        raise PolicyFileError(f"{jname}: key 'network.cell' is {cell!r}; known: {sorted(CELLS)}")
    d, H = _pos_int(net, "input_size", jname), _pos_int(net, "hidden_size", jname)
    fb = net.get("feedback", "none")
    if not isinstance(fb, str) or fb not in FEEDBACKS:
        raise PolicyFileError(f"{jname}: key 'network.feedback' is {fb!r}; known: {list(FEEDBACKS)}")
    if d <= FEEDBACKS[fb]:
        raise PolicyFileError(f"{jname}: key 'network.input_size' is {d}; with 'network.feedback' {fb!r} it holds "
                              f"the observation and {FEEDBACKS[fb]} feedback inputs")
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
        return d - FEEDBACKS[fb], out
    for k, shape in shapes.items():
        if k not in arrays:
            raise PolicyFileError(f"{wname}: missing array {k!r} (a {cell} cell needs {list(shapes)})")
        out[k] = checked_array(arrays[k], k, shape, wname,
                               f"a {cell} cell with input_size {d} and hidden_size {H} needs")
    return d - FEEDBACKS[fb], out


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
    network (it advances the memory too). ``feedback="action"``: the cell also reads each row's
    previous commanded action (module docstring)."""

    def __init__(self, cell: str, cell_weights: dict, layers, activation: str = "tanh",
                 action_transform: str = "clip", *, layout: dict, scenario: str = "", training: dict | None = None,
                 source: str = "<memory>", shield: str = "none", env=None, symmetry: str = "none",
                 head: dict | None = None, feedback: str = "none"):
        if cell not in CELLS:
            raise ArgumentError(f"{source}: cell {cell!r} is not one of {sorted(CELLS)}")
        if activation not in ACTIVATIONS:
            raise ArgumentError(f"{source}: activation {activation!r} is not one of {sorted(ACTIVATIONS)}")
        self.cell = cell
        self.w = {k: np.ascontiguousarray(cell_weights[k], dtype=np.float64) for k in CELL_ARRAYS}
        self.layers = [(np.ascontiguousarray(W, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64))
                       for W, b in layers]
        self.hidden_size = self.w["cell_W_hh"].shape[1]
        if feedback not in FEEDBACKS:
            raise ArgumentError(f"{source}: feedback {feedback!r} is not one of {list(FEEDBACKS)}")
        self.feedback = feedback
        self.obs_size = self.w["cell_W_ih"].shape[1] - FEEDBACKS[feedback]
        self.activation, self.action_transform = activation, action_transform
        self._act = ACTIVATIONS[activation]
        self.layout, self.scenario, self.training, self.source = layout, scenario, dict(training or {}), source
        self.shield, self.symmetry = shield, symmetry
        self._mirror, self.shield_cut = file_options(shield, symmetry, layout, env, source)
        self.head = None if head is None or head.get("type", "mean") == "mean" else CategoricalHead(
            head, source, mirror=symmetry == "mirror")
        self.reset()

    # -- memory --------------------------------------------------------------------------------
    def reset(self):
        """Forget every robot (state back to zero; agent names forgotten)."""
        streams = 2 if self._mirror is not None else 1
        self._h = np.zeros((streams, 0, self.hidden_size))
        self._c = np.zeros((streams, 0, self.hidden_size))
        self._prev = np.zeros((0, 2))  # each row's previous commanded action (feedback)
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
        if n > len(self._prev):
            self._prev = np.concatenate([self._prev, np.zeros((n - len(self._prev), 2))])

    # -- acting --------------------------------------------------------------------------------
    def net_batch(self, obs, rows=None) -> np.ndarray:
        if self.head is not None:
            z, rows = self.logits(obs, rows)
            a = self.head.act(z, rows)
        else:
            a, rows = self._outputs(obs, rows)
        self.remember(a, rows)
        return np.asarray(a, dtype=np.float32)

    def remember(self, actions, rows=None) -> None:
        """Record ``actions (n, 2)`` as the rows' commanded actions, the feedback of their next
        step (module docstring); a no-op without feedback. :meth:`net_batch` calls it."""
        if self.feedback == "none":
            return
        a = np.asarray(actions, dtype=np.float64)
        rows = np.arange(len(a)) if rows is None else np.asarray(rows, dtype=np.int64)
        if a.shape != (len(rows), 2):
            raise ArgumentError(f"{self.source}: remember needs ({len(rows)}, 2) actions, got {a.shape}")
        if len(rows):
            self._grow(int(rows.max()) + 1)
            self._prev[rows] = a

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
        prev = self._prev[rows] if self.feedback != "none" else None
        if self._mirror is not None:  # both streams in one pass: the observations, then their mirror images
            x = np.concatenate([x, self._mirror(x)])
            if prev is not None:
                prev = np.concatenate([prev, prev * np.asarray(ACTION_PARITY, dtype=np.float64)])
        if prev is not None:
            x = np.concatenate([x, prev], axis=1)
        h = self._h[:, rows].reshape(-1, self.hidden_size)
        c = self._c[:, rows].reshape(-1, self.hidden_size)
        h, c = cell_step(self.cell, self.w, x, h, c)
        self._h[:, rows] = h.reshape(-1, n, self.hidden_size)
        self._c[:, rows] = c.reshape(-1, n, self.hidden_size)
        a = self._head(h)
        if self.head is not None:
            return (self.head.mirror(a[:n], a[n:]) if self._mirror is not None else a), rows
        if self._mirror is not None:
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
        sizes = [self.obs_size if self.feedback == "none" else f"{self.obs_size}+{self.feedback}",
                 f"{self.cell}({self.hidden_size})"] + [W.shape[0] for W, _ in self.layers]
        extra = "".join(f", {k}={v!r}" for k, v in (("shield", self.shield), ("symmetry", self.symmetry))
                        if v != "none")
        if self.head is not None:
            extra += f", head=categorical({len(self.head.actions)}, {self.head.acting})"
        return f"RecurrentPolicy({self.source!r}, {sizes}, {self.activation}, scenario={self.scenario!r}{extra})"
