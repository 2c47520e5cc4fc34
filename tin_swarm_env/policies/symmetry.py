"""Mirror-equivariant policies: ``pi(o) = clip((g(o) + M g(M o)) / 2)``.

The world has a mirror symmetry (:mod:`tin_swarm_env.env.observation`: reflecting the body frame's
y axis maps observations by :meth:`~tin_swarm_env.env.observation.ObsLayout.mirror` and actions by
:func:`~tin_swarm_env.env.observation.mirror_action`). A network ``f`` trained without it learns
whichever side its first successes took; averaging it with its mirror image gives a policy that
turns both ways alike: with ``g`` the network's output before its clip to [-1, 1], ``vx`` is the
mean of ``g_x(o)`` and ``g_x(M o)``, ``vy`` half the difference of ``g_y(o)`` and ``g_y(M o)``, then
clipped. (Averaging before the clip is what a Gaussian policy trained with the symmetry built in
does: its mean is the average and SB3 clips its deterministic action;
:func:`tin_swarm_env.adapters.sb3.mirror_policy_class`.) It is equivariant exactly, not to a
tolerance: ``pi(M o) == M pi(o)`` bit for bit, because ``M`` only flips signs (``M M o == o``),
float addition commutes, ``b - a == -(a - b)`` and the clip is odd. With the observation's terrain
scan, ``M`` also permutes the beams (beam ``k`` to ``(K_s - k) mod K_s``): still exact, and still
``M M o == o`` (:func:`mirror_map`). Where ``o`` is its own mirror
image (a wall straight ahead, nothing else in view) the policy drives straight (``vy = 0``);
memory, or any asymmetry in view, breaks that tie.

A policy file asks for it with ``"symmetry": "mirror"`` (:mod:`tin_swarm_env.policies.learned`;
``"none"``, the default, is the network alone). The shield, when there is one, filters the
averaged action. It is mirror-equivariant (every cut is a projection on sensed geometry) but for
one tie: a command exactly backwards (``vy == 0``) into the blind sector is turned toward the left
edge of the field of view in both images (:func:`~tin_swarm_env.policies.base.into_view`). A mirror
policy gives ``vy == 0`` exactly where both images saturate ``vy`` alike, so this tie does occur;
it is a fixed tie-break, not a side learned from data.
"""

from __future__ import annotations

import numpy as np

from ..env.observation import ACTION_PARITY, ObsLayout
from ..errors import ArgumentError
from .base import make_shield
from .network import SHIELDS

__all__ = ["SYMMETRIES", "Mirror", "mirror_signs", "mirror_map", "check_mirror_map", "symmetrize", "file_options"]

SYMMETRIES = ("none", "mirror")


def mirror_signs(layout) -> np.ndarray:
    """``(d,)`` float64 signs of the reflection for ``layout`` (an :class:`ObsLayout` or its
    ``to_dict()``, as a policy file records it)."""
    lay = layout if isinstance(layout, ObsLayout) else ObsLayout.from_dict(layout)
    return lay.mirror_signs().astype(np.float64)


def mirror_map(layout) -> tuple[np.ndarray, np.ndarray]:
    """``(perm (d,) int64, signs (d,) float64)`` of the reflection for ``layout`` (an :class:`ObsLayout`
    or its ``to_dict()``): the mirror image of ``o (..., d)`` is ``o[..., perm] * signs``
    (:meth:`ObsLayout.mirror`; ``perm`` is the identity but for the scan's beams). The torch
    networks of :mod:`tin_swarm_env.adapters.sb3` and :mod:`tin_swarm_env.training.recurrent_imitation`
    take these two arrays."""
    lay = layout if isinstance(layout, ObsLayout) else ObsLayout.from_dict(layout)
    return lay.mirror_permutation(), lay.mirror(np.ones(lay.size))


def check_mirror_map(layout, perm, signs, who: str) -> None:
    """ArgumentError naming ``who`` unless ``perm`` (None: the identity) and ``signs`` are
    :func:`mirror_map` of ``layout``: a mirror-equivariant model exported for ``layout`` acts as its
    file only if it mirrored observations the way the file will."""
    want_perm, want_signs = mirror_map(layout)
    perm = np.arange(len(signs)) if perm is None else np.asarray(perm)
    if (len(signs) != len(want_signs) or perm.tolist() != want_perm.tolist()
            or np.asarray(signs, dtype=np.float64).tolist() != want_signs.tolist()):
        raise ArgumentError(f"{who}: its mirror signs / permutation are not the mirror map of the layout it is "
                            "exported with (mirror_map(layout)); the file would act unlike the model")


class Mirror:
    """The reflection of observations ``(n, d)`` as a callable: ``Mirror(layout)(x) == x[:, perm] * signs``
    (:func:`mirror_map`), float64."""

    def __init__(self, layout):
        self.perm, self.signs = mirror_map(layout)
        self._identity = bool(np.array_equal(self.perm, np.arange(len(self.perm))))

    def __call__(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        return (x if self._identity else x[:, self.perm]) * self.signs


def symmetrize(f, x, mirror) -> np.ndarray:
    """``(f(x) + M f(M x)) / 2`` (no clip) for observations ``x (n, d)``: ``f`` maps ``(m, d)`` float64 to
    ``(m, 2)`` and is called once, on ``x`` and its mirror image stacked (row ``i`` of the result
    never depends on another row, so this equals two separate calls). ``mirror``: the reflection,
    a :class:`Mirror` (any callable ``(n, d) -> (n, d)``) or, for a layout without scan beams, its
    signs ``(d,)``. Returns ``(n, 2)`` float64."""
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    mx = mirror(x) if callable(mirror) else x * mirror
    both = np.asarray(f(np.concatenate([x, mx])), dtype=np.float64)
    a, b = both[:n], both[n:]
    return (a + b * np.asarray(ACTION_PARITY)) / 2


def file_options(shield: str, symmetry: str, layout, env, source: str):
    """A policy file's ``shield`` and ``symmetry`` options, checked: returns ``(mirror, shield_cut)``,
    the reflection of observations (a :class:`Mirror`; None without symmetry) and the shield
    applied to the network's actions (:func:`~tin_swarm_env.policies.base.make_shield`; None
    without one). Shared by the MLP and recurrent policies."""
    if shield not in SHIELDS:
        raise ArgumentError(f"{source}: shield {shield!r} is not one of {list(SHIELDS)}")
    if symmetry not in SYMMETRIES:
        raise ArgumentError(f"{source}: symmetry {symmetry!r} is not one of {list(SYMMETRIES)}")
    mirror = Mirror(layout) if symmetry == "mirror" else None
    if shield != "none" and env is None:
        raise ArgumentError(f"{source}: a shielded policy needs the env it acts in (load_policy(path, env))")
    return mirror, make_shield(shield, env, source)
