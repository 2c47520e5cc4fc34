"""Action heads of a policy file: how the network's last layer becomes an action.

A policy file's optional ``"head"`` key (:mod:`tin_swarm_env.policies.learned`) says it; without
it the head is ``{"type": "mean"}``: the last layer has 2 units and its output, clipped to
[-1, 1], is the action (a Gaussian policy's deterministic action).

``{"type": "categorical", "actions": [[vx, vy], ...], "acting": "mode" | "sample", "seed": 0}``:
the last layer has one unit per class (``len(actions)``, 2 to :data:`MAX_CLASSES`), its outputs
are the classes' logits, ``p = softmax(logits)``, and class ``k`` drives the body-frame action
``actions[k]`` (each component in [-1, 1], no two alike). Unlike a mean, such a head can say
"left or right, not straight on": where a teacher goes round an obstacle one way on one map and
the other way on another that looks the same, a likelihood fit puts the probability on both
ways, a mean-squared-error fit on their mean (:mod:`tin_swarm_env.training.imitation`).

* ``"acting": "mode"`` (the default): the class of largest logit; at an exact tie the lowest
  class index (:func:`categorical_classes` orders a heading with ``vy > 0`` before its mirror
  image, so a tie between the two sides turns to ``+y``). Deterministic.
* ``"acting": "side"``: first the side, then the mode within it: the classes are grouped by the
  sign of ``vy`` (``+y``, straight ``vy = 0``, ``-y``), the group of largest total probability is
  taken (each group's sum in sorted order; at an exact tie ``+y``, then straight), then its class
  of largest logit (the lowest index at a tie). A fine class set spreads a turn over several
  headings, so the single most likely class can be straight on while a turn is more likely
  than not (research/teacher_multimodal.md); this asks "which way" before "how far".
  Deterministic, and mirror-equivariant but for the exact ties.
* ``"acting": "sample"``: a class drawn from ``p`` by inverse CDF over the class order, with a
  uniform number that is a hash of (``seed``, the robot's row, how many draws that row has made
  since :meth:`CategoricalHead.reset`): every robot has its own reproducible stream, independent
  of which other rows are acted for in the same call and of the batch order (:func:`uniforms`).

**Mirror symmetry** (``"symmetry": "mirror"``, :mod:`tin_swarm_env.policies.symmetry`): the class
permutation ``P`` maps each class to the one of action ``(vx, -vy)`` (found by exact comparison:
a file whose actions are not closed under that reflection is refused with ``"mirror"``). The
logits are ``(f(o) + f(M o)[P]) / 2``, so ``logits(M o) = logits(o)[P]`` bit for bit (``P`` is an
involution and float addition commutes), and the probabilities too (the softmax is computed on each
row sorted, which no permutation changes): the policy is mirror-equivariant *in
distribution*. At an observation that is its own mirror image the two sides have equal
probability; sampling breaks the tie per robot, the mode by the class order above.
"""

from __future__ import annotations

import numpy as np

from ..errors import ArgumentError, PolicyFileError

__all__ = ["HEADS", "ACTINGS", "MAX_CLASSES", "CategoricalHead", "categorical_classes", "categorical_head",
           "check_head", "head_outputs", "nearest_class", "softmax", "uniforms", "mirror_permutation"]

HEADS = ("mean", "categorical")
ACTINGS = ("mode", "side", "sample")
MAX_CLASSES = 1024
ACTION_SIZE = 2


def categorical_classes(headings: int = 16, speeds=(0.5, 1.0), stop: bool = True) -> np.ndarray:
    """``(K, 2)`` float64 class actions: ``stop`` (0, 0) first, then for each speed ``s`` (in
    order) the ``headings`` directions ``s (cos t, sin t)``, ``t = 0`` (straight ahead) first, then
    in pairs ``+t`` (``vy > 0``) before ``-t``, ending with straight back when ``headings`` is even.
    Mirror-closed exactly: a pair's actions differ only in the sign of ``vy``; ahead and back
    have ``vy = 0`` exactly."""
    if isinstance(headings, bool) or not isinstance(headings, (int, np.integer)) or headings < 2:
        raise ArgumentError(f"categorical_classes: headings must be an integer >= 2, got {headings!r}")
    sp = [float(s) for s in speeds]
    if not sp or any(not 0 < s <= 1 for s in sp):
        raise ArgumentError(f"categorical_classes: speeds must be in (0, 1], got {list(speeds)}")
    out = [(0.0, 0.0)] if stop else []
    for s in sp:
        out.append((s, 0.0))
        for k in range(1, (headings + 1) // 2):
            t = 2 * np.pi * k / headings
            vx, vy = s * np.cos(t), s * np.sin(t)
            out += [(vx, vy), (vx, -vy)]
        if headings % 2 == 0:
            out.append((-s, 0.0))
    return np.array(out, dtype=np.float64)


def categorical_head(actions=None, acting: str = "mode", seed: int = 0) -> dict:
    """The ``"head"`` entry of a categorical policy file (module docstring); ``actions`` None:
    :func:`categorical_classes`'s default (16 headings x 2 speeds and stop: 33 classes)."""
    a = categorical_classes() if actions is None else np.asarray(actions, dtype=np.float64)
    return {"type": "categorical", "actions": [[float(x), float(y)] for x, y in a], "acting": acting,
            "seed": int(seed)}


def mirror_permutation(actions) -> np.ndarray | None:
    """``(K,)`` int64: class ``k``'s mirror image, the class of action ``(vx, -vy)``; None when some
    class has none (exact comparison)."""
    a = np.asarray(actions, dtype=np.float64)
    m = a * np.array([1.0, -1.0])
    eq = (m[:, None, :] == a[None, :, :]).all(-1)
    if not eq.any(axis=1).all():
        return None
    return np.argmax(eq, axis=1).astype(np.int64)


def check_head(head, out_size: int, symmetry: str, jname: str) -> dict:
    """The file's ``"head"`` entry (None: the mean head) checked against the last layer's size
    ``out_size`` and ``symmetry``; returns it normalised (``acting`` and ``seed`` filled in).
    Raises :class:`PolicyFileError` naming ``jname`` and the key."""
    if head is None:
        head = {"type": "mean"}
    if not isinstance(head, dict):
        raise PolicyFileError(f"{jname}: key 'head' must be an object, got {type(head).__name__}")
    typ = head.get("type")
    if typ not in HEADS:
        raise PolicyFileError(f"{jname}: key 'head.type' is {typ!r}; known: {list(HEADS)}")
    known = {"mean": {"type"}, "categorical": {"type", "actions", "acting", "seed"}}[typ]
    extra = sorted(set(head) - known)
    if extra:
        raise PolicyFileError(f"{jname}: key 'head' has unknown keys {extra} for type {typ!r} (known: {sorted(known)})")
    if typ == "mean":
        if out_size != ACTION_SIZE:
            raise PolicyFileError(f"{jname}: the last layer size is {out_size}; a 'mean' head needs {ACTION_SIZE}")
        return {"type": "mean"}
    acts = head.get("actions")
    if not isinstance(acts, list) or not 2 <= len(acts) <= MAX_CLASSES or not all(
            isinstance(r, list) and len(r) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                         for v in r) for r in acts):
        raise PolicyFileError(f"{jname}: key 'head.actions' must be a list of 2 to {MAX_CLASSES} [vx, vy] number "
                              f"pairs, got {str(acts)[:80]}")
    a = np.array(acts, dtype=np.float64)
    if not np.all(np.isfinite(a)) or np.abs(a).max() > 1.0:
        raise PolicyFileError(f"{jname}: key 'head.actions' holds a value outside [-1, 1] (or not finite)")
    if len(np.unique(a, axis=0)) != len(a):
        raise PolicyFileError(f"{jname}: key 'head.actions' lists an action twice")
    if out_size != len(a):
        raise PolicyFileError(f"{jname}: the last layer size is {out_size}; key 'head.actions' has {len(a)} classes "
                              "(one logit per class)")
    acting = head.get("acting", "mode")
    if acting not in ACTINGS:
        raise PolicyFileError(f"{jname}: key 'head.acting' is {acting!r}; known: {list(ACTINGS)}")
    seed = head.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2 ** 63:
        raise PolicyFileError(f"{jname}: key 'head.seed' must be an integer in [0, 2**63), got {seed!r}")
    if symmetry == "mirror" and mirror_permutation(a) is None:
        raise PolicyFileError(f"{jname}: key 'head.actions' is not closed under the mirror (vy -> -vy), which "
                              "'symmetry': 'mirror' needs")
    return {"type": "categorical", "actions": acts, "acting": acting, "seed": seed}


def head_outputs(head: dict | None) -> int:
    """The last layer's size a (checked) head entry needs."""
    return ACTION_SIZE if head is None or head.get("type", "mean") == "mean" else len(head["actions"])


def softmax(logits) -> np.ndarray:
    """Row-wise softmax of ``(n, K)`` float64 computed on each row sorted (the exponentials and
    their sum; vectorised ``exp`` may round an element differently by its position), so that
    permuting a row's logits permutes its probabilities exactly."""
    z = np.asarray(logits, dtype=np.float64)
    order = np.argsort(z, axis=1, kind="stable")
    zs = np.take_along_axis(z, order, axis=1)
    es = np.exp(zs - zs[:, -1:])
    e = np.empty_like(es)
    np.put_along_axis(e, order, es / es.sum(axis=1, keepdims=True), axis=1)
    return e


def nearest_class(actions, classes) -> np.ndarray:
    """``(N,)`` int64: the class whose action is nearest (Euclidean) to each of ``actions (N, 2)``
    (clipped to [-1, 1] first); the lower index at a tie. The label a likelihood fit uses."""
    a = np.clip(np.asarray(actions, dtype=np.float64), -1.0, 1.0)
    c = np.asarray(classes, dtype=np.float64)
    d = ((a[:, None, :] - c[None, :, :]) ** 2).sum(-1)
    return np.argmin(d, axis=1).astype(np.int64)


_M = np.uint64(0xFFFFFFFFFFFFFFFF)


def _mix(z):
    """splitmix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def uniforms(seed: int, rows, counts) -> np.ndarray:
    """``(n,)`` float64 in [0, 1): a hash of (``seed``, ``rows[i]``, ``counts[i]``) per row: the
    ``counts[i]``-th draw of robot ``rows[i]``'s stream (splitmix64; 53 bits)."""
    with np.errstate(over="ignore"):
        z = _mix(np.full(len(rows), np.uint64(seed)))
        z = _mix(z ^ np.asarray(rows, dtype=np.int64).astype(np.uint64))
        z = _mix(z ^ np.asarray(counts, dtype=np.int64).astype(np.uint64))
    return (z >> np.uint64(11)).astype(np.float64) * 2.0 ** -53


class CategoricalHead:
    """A checked categorical ``"head"`` entry (module docstring) turned into actions.

    ``mirror(a, b)``: the symmetrised logits of the two streams (``b`` from the mirrored
    observations); ``probs(logits)``; ``act(logits, rows) -> (n, 2)`` float64 (the mode, or a
    draw advancing each row's stream); :meth:`reset` restarts every row's stream."""

    def __init__(self, head: dict, source: str = "<memory>", mirror: bool = False):
        self.actions = np.array(head["actions"], dtype=np.float64)
        self.acting, self.seed = head.get("acting", "mode"), int(head.get("seed", 0))
        if self.acting not in ACTINGS:
            raise ArgumentError(f"{source}: acting {self.acting!r} is not one of {list(ACTINGS)}")
        self.perm = mirror_permutation(self.actions)
        if mirror and self.perm is None:
            raise ArgumentError(f"{source}: the head's actions are not closed under the mirror (vy -> -vy), which "
                                "symmetry 'mirror' needs")
        self.source = source
        self.reset()

    def reset(self) -> None:
        self._draws = np.zeros(0, dtype=np.int64)

    def mirror(self, a, b) -> np.ndarray:
        if self.perm is None:
            raise ArgumentError(f"{self.source}: the head's actions are not closed under the mirror")
        return (a + b[:, self.perm]) / 2

    probs = staticmethod(softmax)

    def choose(self, logits, rows=None) -> np.ndarray:
        """``(n,)`` int64 classes for ``logits (n, K)`` (rows: each row's robot, default 0..n-1)."""
        z = np.asarray(logits, dtype=np.float64)
        if self.acting == "mode":
            return np.argmax(z, axis=1).astype(np.int64)
        if self.acting == "side":
            return self._side(z)
        rows = np.arange(len(z)) if rows is None else np.asarray(rows, dtype=np.int64)
        if rows.shape != (len(z),) or (len(rows) and (rows.min() < 0 or len(np.unique(rows)) != len(rows))):
            raise ArgumentError(f"{self.source}: rows must be {len(z)} distinct robot rows >= 0 (one per "
                                f"observation), got {np.asarray(rows).tolist()[:10]}")
        if len(rows) and rows.max() >= len(self._draws):
            self._draws = np.concatenate([self._draws, np.zeros(rows.max() + 1 - len(self._draws), np.int64)])
        u = uniforms(self.seed, rows, self._draws[rows])
        self._draws[rows] += 1
        cdf = np.cumsum(softmax(z), axis=1)
        k = (cdf < (u * cdf[:, -1])[:, None]).sum(axis=1)
        return np.minimum(k, z.shape[1] - 1).astype(np.int64)

    def _side(self, z) -> np.ndarray:
        p = softmax(z)
        vy = self.actions[:, 1]
        groups = [vy > 0, vy == 0, vy < 0]  # the tie order: +y, straight, -y
        mass = np.stack([np.sort(np.where(g, p, 0.0), axis=1).sum(axis=1) for g in groups], axis=1)
        g = np.argmax(mass, axis=1)
        member = np.stack(groups)[g]  # (n, K): the classes of each row's group
        return np.argmax(np.where(member, z, -np.inf), axis=1).astype(np.int64)

    def act(self, logits, rows=None) -> np.ndarray:
        return self.actions[self.choose(logits, rows)]
