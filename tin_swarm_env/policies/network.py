"""The numeric pieces every policy file shares (MLP and recurrent): the compiled dense layer, the
activations, the shield names and the size limits a file is checked against. Imports nothing
from the policy modules, so :mod:`~tin_swarm_env.policies.learned` and
:mod:`~tin_swarm_env.policies.recurrent` both build on it without an import circle.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..errors import PolicyFileError

__all__ = ["ACTIVATIONS", "SHIELDS", "dense", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_LAYERS", "MAX_LAYER_WIDTH",
           "MAX_PARAMETERS", "MAX_WEIGHTS_BYTES", "MAX_ABS_WEIGHT", "checked_array"]

ACTIVATIONS = {
    "tanh": np.tanh,
    "relu": lambda x: np.maximum(x, 0.0),
    "elu": lambda x: np.where(x > 0, x, np.expm1(np.minimum(x, 0.0))),
    "leaky_relu": lambda x: np.where(x > 0, x, 0.01 * x),
    "identity": lambda x: x,
}


@njit(cache=True, fastmath={"reassoc", "contract"})
def dense(x, W, b):
    """One layer, ``x @ W.T + b``: ``x (n, d)``, ``W (m, d)``, ``b (m,)`` float64 -> ``(n, m)``.

    Compiled single-threaded loops instead of BLAS: for the few robots of one env step, a
    multi-threaded BLAS whose threads wait for a busy core (a second job, pytest -n 2, a training
    run beside the evaluation) took 26-31 ms per forward pass of a 59-256-256-2 network on the
    2-core machine, this 1 ms; it is as fast as BLAS at 2 000 robots there, and its sums do not
    depend on a thread count. ``dense.py_func`` is the plain reference (tests/policies/test_network.py)."""
    n, d = x.shape
    m = W.shape[0]
    out = np.empty((n, m))
    for i in range(n):
        for j in range(m):
            s = b[j]
            for k in range(d):
                s += x[i, k] * W[j, k]
            out[i, j] = s
    return out


SHIELDS = ("none", "safety_cut", "safety_cut_scan")  # policies.base.make_shield builds each

# Limits checked before anything is read into memory (a policy file is data from anywhere):
MAX_JSON_BYTES = 1_000_000  # policy.json: metadata and the layout's element names, a few KB in practice
MAX_JSON_DEPTH = 64  # nesting of policy.json (deeper would exhaust the parser's recursion)
MAX_LAYERS = 16  # linear layers of the MLP
MAX_LAYER_WIDTH = 4096  # units per layer: a 4096-wide float64 layer is 128 MB at most
MAX_PARAMETERS = 20_000_000  # weights and biases in all: 160 MB of float64 (the shipped net has ~20 000)
MAX_WEIGHTS_BYTES = 8 * MAX_PARAMETERS + 1_000_000  # weights.npz on disk (uncompressed arrays + headers)
MAX_ABS_WEIGHT = 1e6  # trained weights are O(1-100); beyond this a forward pass can overflow to NaN/inf


def checked_array(a, name: str, shape: tuple, wname: str, need: str) -> np.ndarray:
    """One weights array of a policy file, checked: real numbers of ``shape`` (``need`` says what
    asks for it, e.g. ``"layer sizes [59, 64, 2] need"``), finite and at most
    :data:`MAX_ABS_WEIGHT` in magnitude; returned as contiguous float64. Raises
    :class:`~tin_swarm_env.errors.PolicyFileError` naming ``wname`` and the array."""
    a = np.asarray(a)
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise PolicyFileError(f"{wname}: array {name!r} holds {a.dtype} values; expected real numbers")
    if a.shape != shape:
        raise PolicyFileError(f"{wname}: array {name!r} has shape {a.shape}; {need} {shape}")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        raise PolicyFileError(f"{wname}: array {name!r} holds NaN or infinite values")
    if np.abs(a).max(initial=0.0) > MAX_ABS_WEIGHT:
        raise PolicyFileError(f"{wname}: array {name!r} holds a value of magnitude {np.abs(a).max():.3g}; at most "
                              f"{MAX_ABS_WEIGHT:g} (larger weights overflow the forward pass)")
    return np.ascontiguousarray(a)
