"""Stalled and looping robots: how a robot that timed out spent the end of its episode.

The one home of the two definitions (``rollout``'s :class:`~tin_swarm_env.training.rollout.Outcome`,
``tin-swarm eval`` and ``bench/apf.py`` all report them through :func:`stalled_looping`):

- **stalled**: its net displacement over its last :data:`STALL_STEPS` (100) steps is under one
  body length (two body radii);
- **looping**: not stalled, and its net displacement over its last :data:`LOOP_STEPS` (500) steps
  is under :data:`LOOP_FRACTION` (a tenth) of the path it drove in those steps.

Only robots still on the move when the episode was cut off (``Reason.TIMEOUT``) can be either:
an arrived, fallen or battery-empty robot ended for its own reason. When the episode is shorter
than a window, the window is the whole episode (from the reset position). The two are disjoint,
so arrived + fell + battery + timed out = 1 and stalled + looping <= timed out.

:class:`Track` keeps the last ``LOOP_STEPS + 1`` positions of every robot in a ring buffer
(one array write per step, batched over robots).
"""

from __future__ import annotations

import numpy as np

__all__ = ["STALL_STEPS", "LOOP_STEPS", "LOOP_FRACTION", "stalled_looping", "Track"]

STALL_STEPS = 100  # window of the stalled test, steps
LOOP_STEPS = 500  # window of the looping test, steps
LOOP_FRACTION = 0.1  # looping: net displacement under this fraction of the path driven


def stalled_looping(window: np.ndarray, body_length_m: float, candidates: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """``(stalled (n,), looping (n,))`` bool from ``window`` ``(k + 1, n, 2)`` m: each robot's
    positions over its last ``k`` steps, oldest first, the last row its position at the end
    (``k`` is at most :data:`LOOP_STEPS`; fewer when the episode was shorter).

    stalled: ``|p[-1] - p[-1 - min(k, STALL_STEPS)]| < body_length_m``. looping: not stalled and
    ``|p[-1] - p[0]| < LOOP_FRACTION * sum |p[i + 1] - p[i]|`` over the window. ``candidates``
    ``(n,)`` bool (default all) masks the robots that may be either (those that timed out)."""
    w = np.asarray(window, dtype=np.float64)
    if w.ndim != 3 or w.shape[2] != 2 or w.shape[0] < 1:
        raise ValueError(f"stalled_looping: window must be (k + 1, n, 2) positions, got shape {w.shape}")
    if not body_length_m > 0:
        raise ValueError(f"stalled_looping: body_length_m must be > 0, got {body_length_m!r}")
    k = w.shape[0] - 1
    last = w[-1]
    net_short = np.hypot(*(last - w[-1 - min(k, STALL_STEPS)]).T)
    net_long = np.hypot(*(last - w[0]).T)
    path = np.hypot(*np.diff(w, axis=0).transpose(2, 0, 1)).sum(axis=0) if k else np.zeros(w.shape[1])
    ok = np.ones(w.shape[1], dtype=bool) if candidates is None else np.asarray(candidates, dtype=bool)
    stalled = ok & (net_short < body_length_m)
    looping = ok & ~stalled & (net_long < LOOP_FRACTION * path)
    return stalled, looping


class Track:
    """The last ``LOOP_STEPS + 1`` positions of ``n`` robots: ``push(positions (n, 2))`` after the
    reset and after every step, then :meth:`window` or :meth:`stalled_looping`."""

    def __init__(self, n: int, steps: int = LOOP_STEPS):
        self._buf = np.zeros((steps + 1, n, 2))  # ring buffer: row t % (steps + 1) holds push number t
        self._count = 0

    def push(self, positions: np.ndarray) -> None:
        self._buf[self._count % len(self._buf)] = positions
        self._count += 1

    def window(self) -> np.ndarray:
        """``(k + 1, n, 2)`` m, the kept positions oldest first (``k + 1`` = pushes so far, at most
        the buffer's length)."""
        size = len(self._buf)
        if self._count <= size:
            return self._buf[: self._count].copy()
        start = self._count % size
        return np.concatenate([self._buf[start:], self._buf[:start]])

    def stalled_looping(self, body_length_m: float, candidates: np.ndarray | None = None):
        """:func:`stalled_looping` over :meth:`window`."""
        return stalled_looping(self.window(), body_length_m, candidates)
