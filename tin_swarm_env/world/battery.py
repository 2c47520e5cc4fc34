"""Battery model: drain per step, batched (see :class:`~.params.BatteryParams`)."""

from __future__ import annotations

import numpy as np

from .state import Reason

__all__ = ["drain"]


def drain(battery_j, status, distance_m, climb_m, params, dt_s):
    """New charge ``(n,)`` J after one step. Only active robots (``Reason.NONE``) draw power (idle, sensing,
    driving ``distance_m`` and climbing ``max(climb_m, 0)``); the result is clipped at 0 and is
    never above ``battery_j``."""
    use = (params.idle_w + params.sensing_w) * dt_s + params.drive_j_per_m * distance_m \
        + params.climb_j_per_m * np.maximum(climb_m, 0.0)
    use = np.where(status == Reason.NONE, use, 0.0)
    return np.maximum(battery_j - use, 0.0)
