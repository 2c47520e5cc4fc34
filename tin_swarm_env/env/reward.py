"""Rewards and terminations, per robot, from one world step.

Goal task: progress is the decrease of the horizontal distance to the robot's assigned target;
reaching it (within ``arrival_radius_m``) pays ``arrival`` and terminates with reason
"arrived". Containment: progress is the decrease of ``|distance - standoff|`` to the assigned
threat, plus ``on_ring_per_step`` while within ``ring_tolerance_m`` of the ring; no arrival.
Both: ``fall`` and termination "fell" when the robot drives into a cliff triangle;
``battery_empty`` and termination "battery" when its charge runs out; ``collision`` per robot
touched this step; ``energy_per_kj`` per kJ drawn.
"""

from __future__ import annotations

import numpy as np

from ..world import Reason

__all__ = ["Reason", "target_distance", "compute_rewards"]


def target_distance(state, target_idx) -> np.ndarray:
    """Horizontal distance (n,) from each robot to its assigned target (0 where none)."""
    d = np.zeros(state.n_robots)
    has = target_idx >= 0
    if has.any():
        v = state.targets.positions[target_idx[has]] - state.positions[has]
        d[has] = np.hypot(v[:, 0], v[:, 1])
    return d


def compute_rewards(cfg, prev_state, state, events, target_idx, live):
    """``(rewards (n,), terminated (n,) bool, reasons (n,) int8)`` for robots in ``live``;
    reasons are :class:`~tin_swarm_env.world.Reason` codes (NONE, ARRIVED, FELL or BATTERY)."""
    w = cfg.rewards
    d0 = target_distance(prev_state, target_idx)
    d1 = target_distance(state, target_idx)
    has = target_idx >= 0
    r = np.zeros(state.n_robots)
    if cfg.task == "containment":
        s = cfg.targets.standoff_m
        e0, e1 = np.abs(d0 - s), np.abs(d1 - s)
        r += np.where(has, w.progress_per_m * (e0 - e1) + w.on_ring_per_step * (e1 <= w.ring_tolerance_m), 0.0)
        arrived = np.zeros(state.n_robots, dtype=bool)
    else:
        r += np.where(has, w.progress_per_m * (d0 - d1), 0.0)
        arrived = has & (d1 <= cfg.targets.arrival_radius_m) & ~events.fell
    r += w.energy_per_kj * events.energy_j / 1000.0
    r += w.collision * events.collisions
    r += w.fall * events.fell
    r += w.battery_empty * events.emptied
    r += w.arrival * arrived
    reasons = np.full(state.n_robots, Reason.NONE, dtype=np.int8)
    reasons[arrived] = Reason.ARRIVED
    reasons[events.emptied] = Reason.BATTERY
    reasons[events.fell] = Reason.FELL
    terminated = (reasons != Reason.NONE) & live
    r = np.where(live, r, 0.0)
    reasons = np.where(live, reasons, Reason.NONE).astype(np.int8)
    return r.astype(np.float32), terminated, reasons
