"""The env's step after sensing, in one compiled pass: distance to go, rewards and observations.

:meth:`~tin_swarm_env.env.tin_swarm.TinSwarmEnv.step_arrays` moves the world, retires the robots
that arrive (:func:`~tin_swarm_env.env.reward.arrivals`: they must not be sensed), senses, and then
calls :func:`step_outcome`, which does for every robot, in one parallel loop, what three calls
would do one after another:

1. its distance to go: :class:`~tin_swarm_env.terrain.CostToGoStack`'s query
   (:func:`~tin_swarm_env.terrain._ctg_kernels.stacked_run`), or the given straight-line /
   per-field distances when the episode has no stack (euclidean progress, mobile targets);
2. its reward, termination and reason: :func:`~tin_swarm_env.env.reward.reward1`, the code of
   :func:`~tin_swarm_env.env.reward.compute_rewards`;
3. its observation row: :func:`~tin_swarm_env.env.observation.obs_row`, the code of
   :func:`~tin_swarm_env.env.observation.build_observations`.

Each robot's values are computed alone by the same per-robot code as those functions, so the
results are theirs bit for bit, on any thread count (tests/env/test_outcome.py). One parallel
region and one call instead of three: at 1 000 robots the three calls' fixed costs (argument
preparation, dispatch, waking the second thread, a serial reward loop) were most of what the env
adds to the world's step (bench/env.py).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..terrain._ctg_kernels import CHUNKS, stacked_run
from ..world.world import serial_if_small
from .observation import OBS_SERIAL_BELOW, encoder_args, obs_row
from .reward import reward1

__all__ = ["step_outcome"]

_NO_STACK = None


def _no_stack():
    """Stack arguments with no field (the kernel's types, nothing to query)."""
    global _NO_STACK
    if _NO_STACK is None:
        i0, f0 = np.zeros(1, dtype=np.int64), np.zeros(0)
        i1 = np.zeros(0, dtype=np.int64)
        _NO_STACK = ((i0, i0, i0, i0), (f0, f0, f0, np.zeros((0, 6), dtype=np.int64), np.zeros(0, dtype=np.bool_),
                                        np.zeros(0, dtype=np.bool_), np.zeros((0, 2)), f0, f0,
                                        np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3), dtype=np.int64), i1,
                                        np.zeros((0, 7)), i1, i1), 0.0, 0.0)
    return _NO_STACK


def step_outcome(world, state, readings, stack, dist_before, dist_after, events, target_idx, live, layout, rw):
    """``(obs (n, d) float32, rewards (n,) float32, terminated (n,) bool, reasons (n,) int8)`` of a
    step, and ``dist_after (n,)`` filled in place. ``state``: after the step and the retiring of
    the arrived robots (positions are kept); ``readings``: its sensing; ``stack``: the episode's
    :class:`~tin_swarm_env.terrain.CostToGoStack` (``dist_after`` is then written), or None
    (``dist_after`` already holds :func:`~tin_swarm_env.env.reward.distance_to_go`); ``rw``:
    :func:`~tin_swarm_env.env.reward.reward_params`. The same bits as
    :func:`~tin_swarm_env.env.reward.compute_rewards` and
    :func:`~tin_swarm_env.env.observation.build_observations` of the same arguments."""
    n = state.n_robots
    f64 = np.float64
    off, arrays, tol, eps = (stack._off, stack._arrays, stack._tol, stack._eps) if stack is not None else _no_stack()
    obs = np.zeros((n, layout.size), dtype=np.float32)
    r32 = np.empty(n, dtype=np.float32)
    term = np.empty(n, dtype=np.bool_)
    why = np.empty(n, dtype=np.int8)
    pos = np.ascontiguousarray(state.positions, dtype=f64)
    with serial_if_small(n, OBS_SERIAL_BELOW):
        _outcome(obs, r32, term, why, dist_after, stack is not None, *off, *arrays, tol, eps, rw,
                 np.ascontiguousarray(dist_before, dtype=f64), np.ascontiguousarray(events.energy_j, dtype=f64),
                 np.ascontiguousarray(events.collisions, dtype=f64), np.ascontiguousarray(events.fell, dtype=np.bool_),
                 np.ascontiguousarray(events.emptied, dtype=np.bool_), pos, live,
                 *encoder_args(world, state, readings, target_idx, layout))
    return obs, r32, term, why


@njit(cache=True, parallel=True, error_model="numpy")
def _outcome(obs, r32, term, why, dist, use_stack, off_node, off_tri, off_vert, off_win, nx, ny, nd, tri_nodes,
             passable, goal_tri, gxy, vx, vy, tris, nbrs, wstart, wgeo, wroot, twin, tol, eps_m, rw, before, energy,
             coll, fell, emptied, pos, live, o, o_rob, o_tgt, o_brk, o_ast, ks, opos, head, heights, own_n, own_scale,
             planes, tri, target_idx, tpos, tz, robots, targets, breaks, apos, assets, R, dz_scale):
    """:func:`step_outcome`'s loop: the robots cut into ``CHUNKS`` runs shared among the threads;
    in each run the distances (one pass per field), then each robot's reward and observation row."""
    cont, stand, rad, prog, ring, rtol, en, col, fa, bat, arr = (rw[0] != 0.0, rw[1], rw[2], rw[3], rw[4], rw[5],
                                                                rw[6], rw[7], rw[8], rw[9], rw[10])
    n = pos.shape[0]
    C = CHUNKS if n >= CHUNKS else 1
    for c in prange(C):
        lo = c * n // C
        hi = (c + 1) * n // C
        if use_stack:
            stacked_run(lo, hi, off_node, off_tri, off_vert, off_win, nx, ny, nd, tri_nodes, passable, goal_tri, gxy,
                        vx, vy, tris, nbrs, wstart, wgeo, wroot, twin, pos, tri, target_idx, tol, eps_m, dist)
        for i in range(lo, hi):
            k = target_idx[i]
            r32[i], term[i], why[i] = reward1(k >= 0, tpos[k, 0] if k >= 0 else 0.0, tpos[k, 1] if k >= 0 else 0.0,
                                              pos[i, 0], pos[i, 1], before[i], dist[i], energy[i], coll[i], fell[i],
                                              emptied[i], live[i], cont, stand, rad, prog, ring, rtol, en, col, fa, bat,
                                              arr)
            if live[i]:
                obs_row(obs, i, o, o_rob, o_tgt, o_brk, o_ast, ks, opos, head, heights, own_n, own_scale, planes, tri,
                        target_idx, tpos, tz, robots, targets, breaks, apos, assets, R, dz_scale)
