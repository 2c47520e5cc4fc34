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
from numba import njit

from ..world import Reason
from ..world.world import serial_if_small
from .field_pack import distance_copies

__all__ = ["Reason", "target_distance", "distance_to_go", "compute_rewards", "end_step", "measure",
           "DIST_SERIAL_BELOW"]


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
    d = np.full(state.n_robots, np.inf)
    tpos = state.targets.positions
    for k in range(len(tpos)):  # a loop over targets; each is batched over its robots
        rows = np.flatnonzero(target_idx == k)
        if not len(rows):
            continue
        f = fields[k] if k < len(fields) else None
        if f is None:  # the straight line, as target_distance (the same operations, so the same bits)
            v = tpos[k] - state.positions[rows]
            d[rows] = np.hypot(v[:, 0], v[:, 1])
        else:  # only the field's query: no straight line computed for every robot and then overwritten
            d[rows] = f.distance_at(state.positions[rows], state.tri_idx[rows])
    return d


def compute_rewards(cfg, dist_before, dist_after, state, events, target_idx, live):
    """``(rewards (n,), terminated (n,) bool, reasons (n,) int8)`` for robots in ``live``;
    reasons are :class:`~tin_swarm_env.world.Reason` codes (NONE, ARRIVED, FELL or BATTERY;
    precedence FELL > ARRIVED > BATTERY, and the battery penalty is not paid on arrival).
    ``dist_before``/``dist_after`` ``(n,)`` m: :func:`distance_to_go` before and after the step;
    ``state`` the state after it (arrival is judged on the straight line to the target).
    One compiled pass (:func:`rewards_kernel` through :func:`step_rewards`, the kernel both envs'
    :func:`end_step` runs); the numpy reference, equal bit for bit, is
    :func:`~.reference.compute_rewards_reference`."""
    return step_rewards(reward_params(cfg), dist_before, dist_after, state, events, target_idx, live, False)[:3]


def reward_params(cfg) -> tuple:
    """The scenario's reward terms as :func:`rewards_kernel` reads them (a tuple of floats, built
    once per episode by the env): containment (bool), standoff, arrival radius, then the
    ``[rewards]`` weights progress_per_m, on_ring_per_step, ring_tolerance_m, energy_per_kj,
    collision, fall, battery_empty, arrival."""
    w = cfg.rewards
    c = cfg.task == "containment"
    return (c, float(cfg.targets.standoff_m) if c else 0.0, 0.0 if c else float(cfg.targets.arrival_radius_m),
            float(w.progress_per_m), float(w.on_ring_per_step), float(w.ring_tolerance_m), float(w.energy_per_kj),
            float(w.collision), float(w.fall), float(w.battery_empty), float(w.arrival))


def step_rewards(rw, dist_before, dist_after, state, events, target_idx, live, timeout: bool):
    """:func:`compute_rewards` with ``rw`` from :func:`reward_params` (one world's state and events; the
    envs keep their books with :func:`end_step`, on the same kernel), and the truncation in the same
    pass: ``(rewards, terminated, reasons, truncated, live_after, n_arrived)``, where
    ``timeout`` (the episode's last step) truncates every live robot not terminated (reason
    TIMEOUT), ``live_after = live & ~terminated & ~truncated`` and ``n_arrived`` counts reason
    ARRIVED. On one thread: a parallel region's start-up costs more than 1 000 robots' rewards
    (bench 2026-11-26: 45 us parallel vs numpy 52 us at 1 000 robots)."""
    f64 = np.float64
    n = len(dist_before)
    return rewards_kernel(
        np.array([rw], dtype=f64), np.zeros(n, dtype=np.int64), np.ascontiguousarray(dist_before, dtype=f64),
        np.ascontiguousarray(dist_after, dtype=f64),
        np.ascontiguousarray(state.positions, dtype=f64),
        np.ascontiguousarray(state.targets.positions, dtype=f64).reshape(-1, 2),
        np.ascontiguousarray(target_idx, dtype=np.int64), np.ascontiguousarray(live, dtype=np.bool_),
        np.ascontiguousarray(events.energy_j, dtype=f64), np.ascontiguousarray(events.collisions, dtype=f64),
        np.ascontiguousarray(events.fell, dtype=np.bool_), np.ascontiguousarray(events.emptied, dtype=np.bool_),
        np.full(n, bool(timeout)))


_NONE, _ARRIVED, _FELL, _BATTERY, _TIMEOUT = (int(Reason.NONE), int(Reason.ARRIVED), int(Reason.FELL),
                                              int(Reason.BATTERY), int(Reason.TIMEOUT))
# robots: fewer have their distance to go measured (the step's geodesic query) on one numba thread. In the env's
# step the query runs between the world's step and sensing, alone in its parallel region, and near 1 000 robots the
# other thread's start costs about what its half of the query saves. batched/world, medians of process-alternating
# idle runs, 2026-11-26: 1 000 robots 0.816 serial vs 0.811 parallel (30 runs each), 2 000 robots 0.837 vs 0.845
# (4 each). The same bits either way.
DIST_SERIAL_BELOW = 1536


def measure(fields, pos, tri, tpos, tidx) -> np.ndarray:
    """``(n,)`` m: every robot's distance to go (:func:`~.field_pack.distance_copies`; ``fields`` the
    ``(FieldPack, fid)`` of the robots), on one thread below :data:`DIST_SERIAL_BELOW` robots."""
    fpack, fid = fields
    n = len(pos)
    with serial_if_small(n, DIST_SERIAL_BELOW):
        return distance_copies(fpack, fid, np.ascontiguousarray(pos, dtype=np.float64),
                               np.ascontiguousarray(tri, dtype=np.int64), np.ascontiguousarray(tpos).reshape(-1, 2),
                               tidx, np.empty(n))


def end_step(rws, grp, fields, dist_before, pos, tri, tpos, tidx, live, energy, coll, fell, emptied, steps,
             max_cycles, cop, status):
    """The step's bookkeeping after the world step, its one home (the env's step and the vector
    env's call it; the env is the one-copy case): the distance to go after the step (:func:`measure`),
    the episode clocks ``steps (E,)`` advanced in place and every robot of a copy that reaches its
    ``max_cycles (E,)`` truncated (robot i is in copy ``cop[i]``), the rewards, terminations and
    reasons (:func:`rewards_kernel`, robot i with the reward terms ``rws[grp[i]]``), and the robots
    that arrived taken off the terrain (``status`` set to ARRIVED in place; a fallen one stays
    FELL). ``pos``/``tri`` the robots' positions and triangles (in their own TIN) after the step,
    ``tpos`` the targets' positions, ``tidx`` each robot's target among them (-1: none); ``energy``,
    ``coll``, ``fell``, ``emptied`` the step's events. Returns ``(dist_after, rewards, terminated,
    reasons, truncated, live_after)``."""
    dist = measure(fields, pos, tri, tpos, tidx)
    steps += 1
    timeout = (steps >= max_cycles)[cop]
    rew, term, why, trunc, live_after, n_arrived = rewards_kernel(
        rws, grp, dist_before, dist, pos, np.ascontiguousarray(tpos).reshape(-1, 2), tidx, live, energy,
        coll.astype(np.float64), fell, emptied, timeout)
    if n_arrived:
        status[(why == _ARRIVED) & (status != _FELL)] = _ARRIVED
    return dist, rew, term, why, trunc, live_after


@njit(cache=True, inline="always")
def _gain1(before, after):
    """``before - after``, 0 where either is inf (or NaN)."""
    if np.isfinite(before) and np.isfinite(after):
        return before - after
    return 0.0 - 0.0


@njit(cache=True)
def rewards_kernel(rws, grp, before, after, pos, tpos, tidx, live, energy, coll, fell, emptied, timeout):
    """:func:`step_rewards` for every robot in one loop: the terms added in the reference's
    order (so the float64 sums round the same), then cast to float32. ``rws (G, 11)``: rows of
    :func:`reward_params` (as floats), robot i reads row ``grp[i]``; ``timeout (n,)``: the robot's
    episode ends this step (the vector env's copies end at different steps and may differ in
    their reward terms)."""
    n = before.shape[0]
    r32 = np.empty(n, dtype=np.float32)
    term = np.empty(n, dtype=np.bool_)
    why = np.empty(n, dtype=np.int8)
    trunc = np.empty(n, dtype=np.bool_)
    nxt = np.empty(n, dtype=np.bool_)
    n_arrived = 0
    for i in range(n):
        g = grp[i]
        containment = rws[g, 0] != 0.0
        standoff, radius, progress_per_m, on_ring, ring_tol = rws[g, 1], rws[g, 2], rws[g, 3], rws[g, 4], rws[g, 5]
        energy_per_kj, collision, fall, battery_empty, arrival = rws[g, 6], rws[g, 7], rws[g, 8], rws[g, 9], rws[g, 10]
        k = tidx[i]
        has = k >= 0
        r = 0.0
        arrived = False
        if containment:
            e0 = abs(before[i] - standoff)
            e1 = abs(after[i] - standoff)
            r += progress_per_m * _gain1(e0, e1) + on_ring * (1.0 if e1 <= ring_tol else 0.0) if has else 0.0
        else:
            r += progress_per_m * _gain1(before[i], after[i]) if has else 0.0
            if has and not fell[i]:
                arrived = np.hypot(tpos[k, 0] - pos[i, 0], tpos[k, 1] - pos[i, 1]) <= radius
        r += energy_per_kj * energy[i] / 1000.0
        r += collision * coll[i]
        r += fall * (1.0 if fell[i] else 0.0)
        e = emptied[i] and not arrived
        r += battery_empty * (1.0 if e else 0.0)
        r += arrival * (1.0 if arrived else 0.0)
        code = _NONE
        if e:
            code = _BATTERY
        if arrived:
            code = _ARRIVED
        if fell[i]:
            code = _FELL
        if live[i]:
            r32[i] = np.float32(r)
            term[i] = code != _NONE
            trunc[i] = timeout[i] and code == _NONE
            why[i] = _TIMEOUT if trunc[i] else code
            nxt[i] = code == _NONE and not timeout[i]
            if code == _ARRIVED:
                n_arrived += 1
        else:
            r32[i] = np.float32(0.0)
            term[i] = False
            trunc[i] = False
            why[i] = _NONE
            nxt[i] = False
    return r32, term, why, trunc, nxt, n_arrived
