"""Rewards and terminations, per robot, from one world step.

Progress is measured by a *distance to go* ``d`` (n,) m, to each robot's assigned target:
with ``[rewards] progress = "geodesic"`` (the default) the length of the shortest drivable path
(the target's :class:`~tin_swarm_env.terrain.CostToGo` field, over triangles no steeper than the
robots' ``max_slope_deg``), with ``"euclidean"`` the straight line. The geodesic reward does
not pay a robot to walk to a cliff edge above the target. The progress term ``d - d'`` is
potential-based shaping (Ng, Harada and Russell 1999: ``F = gamma * Phi(s') - Phi(s)`` with
``Phi = -d``, which leaves the optimal policy unchanged) only for ``gamma = 1``; with a learner's
``gamma < 1`` it differs from that ``F`` by ``(1 - gamma) * d'`` per step, a small bias toward
being near the target. ``d`` is ``inf`` where the target cannot be reached (a robot on a
too-steep triangle, or cut off); the progress of a step where either distance is ``inf`` is 0, so
rewards stay finite, which also breaks the shaping property on such steps. **Mobile targets** use the
straight line whatever ``progress`` says (a field is built for a target's start position only:
rebuilding it as the target wanders would cost a field build every few steps); the env warns at
construction when that applies.

Goal task: progress is the decrease of ``d``; reaching the target (straight-line distance within
``arrival_radius_m``) pays ``arrival`` and terminates with reason "arrived"; arriving takes
precedence over an empty battery in the same step (no ``battery_empty``, reason "arrived"), a fall
over both (the fall happened on the way). Containment:
progress is the decrease of ``|d - standoff|``, plus ``on_ring_per_step`` while within
``ring_tolerance_m`` of the ring; no arrival. Both: ``fall`` and termination "fell" when the
robot drives into a cliff triangle; ``battery_empty`` and termination "battery" when its charge
runs out; ``collision`` per robot touched this step; ``energy_per_kj`` per kJ drawn.
"""

from __future__ import annotations

import numpy as np

from ..world import Reason

__all__ = ["Reason", "target_distance", "distance_to_go", "compute_rewards"]


def target_distance(state, target_idx) -> np.ndarray:
    """Horizontal distance (n,) from each robot to its assigned target (0 where none)."""
    d = np.zeros(state.n_robots)
    has = target_idx >= 0
    if has.any():
        v = state.targets.positions[target_idx[has]] - state.positions[has]
        d[has] = np.hypot(v[:, 0], v[:, 1])
    return d


def distance_to_go(state, target_idx, fields) -> np.ndarray:
    """``(n,)`` m: each robot's distance to go to its assigned target. ``fields``: one entry per
    target, a :class:`~tin_swarm_env.terrain.CostToGo` (geodesic, queried with the robots' known
    triangles) or None (straight line). ``inf`` where no target is assigned or it cannot be reached."""
    d = target_distance(state, target_idx)
    d[target_idx < 0] = np.inf
    for k, f in enumerate(fields):  # a loop over targets; each query is batched over their robots
        rows = np.flatnonzero(target_idx == k)
        if f is not None and len(rows):
            d[rows] = f.distance_at(state.positions[rows], state.tri_idx[rows])
    return d


def _gain(before, after) -> np.ndarray:
    """``before - after``, 0 where either is inf."""
    ok = np.isfinite(before) & np.isfinite(after)
    return np.where(ok, before, 0.0) - np.where(ok, after, 0.0)


def compute_rewards(cfg, dist_before, dist_after, state, events, target_idx, live):
    """``(rewards (n,), terminated (n,) bool, reasons (n,) int8)`` for robots in ``live``;
    reasons are :class:`~tin_swarm_env.world.Reason` codes (NONE, ARRIVED, FELL or BATTERY;
    precedence FELL > ARRIVED > BATTERY, and the battery penalty is not paid on arrival).
    ``dist_before``/``dist_after`` ``(n,)`` m: :func:`distance_to_go` before and after the step;
    ``state`` the state after it (arrival is judged on the straight line to the target)."""
    w = cfg.rewards
    has = target_idx >= 0
    r = np.zeros(state.n_robots)
    if cfg.task == "containment":
        s = cfg.targets.standoff_m
        e0, e1 = np.abs(dist_before - s), np.abs(dist_after - s)
        r += np.where(has, w.progress_per_m * _gain(e0, e1) + w.on_ring_per_step * (e1 <= w.ring_tolerance_m), 0.0)
        arrived = np.zeros(state.n_robots, dtype=bool)
    else:
        r += np.where(has, w.progress_per_m * _gain(dist_before, dist_after), 0.0)
        arrived = has & (target_distance(state, target_idx) <= cfg.targets.arrival_radius_m) & ~events.fell
    r += w.energy_per_kj * events.energy_j / 1000.0
    r += w.collision * events.collisions
    r += w.fall * events.fell
    emptied = events.emptied & ~arrived  # arriving wins over running dry in the same step
    r += w.battery_empty * emptied
    r += w.arrival * arrived
    reasons = np.full(state.n_robots, Reason.NONE, dtype=np.int8)
    reasons[emptied] = Reason.BATTERY
    reasons[arrived] = Reason.ARRIVED
    reasons[events.fell] = Reason.FELL
    terminated = (reasons != Reason.NONE) & live
    r = np.where(live, r, 0.0)
    reasons = np.where(live, reasons, Reason.NONE).astype(np.int8)
    return r.astype(np.float32), terminated, reasons
