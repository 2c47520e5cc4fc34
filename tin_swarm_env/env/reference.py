"""Plain numpy references of the env's compiled kernels (tests check the two agree)."""

from __future__ import annotations

import numpy as np

from ..terrain import ANGLE
from ..world import Reason
from .observation import DZ_SCALE_M, SLOT_FIELDS, ObsLayout
from .reward import target_distance

__all__ = ["build_observations_reference", "compute_rewards_reference"]


def _to_body(vx, vy, heading):
    c, s = np.cos(heading), np.sin(heading)
    return c * vx + s * vy, -s * vx + c * vy


def _write_slots(obs, layout, part, values, ok):
    """Stack ``values`` (name -> ``(n, K)``) in the layout's slot order into ``obs[:, part]``."""
    slot = np.stack([values[f] for f in SLOT_FIELDS[part]], axis=-1) * ok[..., None]
    obs[:, layout.part_slice(part)] = slot.reshape(len(obs), -1)


def _own(obs, world, state, readings, target_idx, layout):
    P = world.params
    R = P.sensor.range_m
    h = state.headings
    own = layout.own
    obs[:, own["battery"]] = (state.battery_j / P.battery.capacity_j)[:, None]
    obs[:, own["speed"]] = np.clip(state.speeds / P.robot.max_speed_mps, 0, 1)[:, None]
    obs[:, own["tilt"]] = (readings.tilt_rad / (np.pi / 2))[:, None]
    obs[:, own["slope"]] = (readings.slope_deg / 90.0)[:, None]
    g = world.tin.planes[state.tri_idx, :2]
    gn = np.hypot(g[:, 0], g[:, 1])
    ux, uy = _to_body(g[:, 0], g[:, 1], h)
    with np.errstate(invalid="ignore", divide="ignore"):
        obs[:, own["uphill"]] = np.where(gn[:, None] > 1e-6, np.column_stack([ux, uy]) / gn[:, None], 0.0)
    has = target_idx >= 0
    if has.any() and len(state.targets):
        t = target_idx[has]
        tp = state.targets.positions[t]
        d = tp - state.positions[has]
        dist = np.hypot(d[:, 0], d[:, 1])
        bx, by = _to_body(d[:, 0], d[:, 1], h[has])
        safe = np.maximum(dist, 1e-12)
        dz = world.tin.height_in(tp, state.targets.tri_idx[t]) - state.heights[has]
        rows = np.flatnonzero(has)
        obs[rows, own["target_valid"]] = 1.0
        obs[rows, own["target_dir"]] = np.column_stack([np.where(dist > 0, bx / safe, 0.0),
                                                        np.where(dist > 0, by / safe, 0.0)])
        obs[rows, own["target_dist"]] = (dist / (dist + R))[:, None]
        obs[rows, own["target_dz"]] = (dz / (np.abs(dz) + DZ_SCALE_M))[:, None]


def _points(obs, layout, part, contacts, src, state, R):
    n, k = state.n_robots, layout.count(part)
    idx, dist, _ = contacts.nearest(n, k)
    ok = idx >= 0
    d = src[np.where(ok, idx, 0)] - state.positions[:, None, :] if len(src) else np.zeros((n, k, 2))
    bx, by = _to_body(d[..., 0], d[..., 1], state.headings[:, None])
    _write_slots(obs, layout, part, {"valid": ok, "x": bx / R, "y": by / R, "d": np.where(ok, dist, 0.0) / R}, ok)


def _breaks(obs, world, state, readings, layout, R):
    n, k = state.n_robots, layout.k_breaks
    bidx, dist, closest = readings.breaks.nearest(n, k)
    ok = bidx >= 0
    j = np.where(ok, bidx, 0)
    br = world.breaks
    if len(br):
        nrm, drop, danger = br.normals[j], br.drops_m[j], (br.kinds[j] != ANGLE).astype(float)
    else:
        nrm, drop, danger = np.zeros((n, k, 2)), np.zeros((n, k)), np.zeros((n, k))
    h = state.headings[:, None]
    d = closest - state.positions[:, None, :]
    px, py = _to_body(d[..., 0], d[..., 1], h)
    nx, ny = _to_body(nrm[..., 0], nrm[..., 1], h)
    _write_slots(obs, layout, "breaks", {"valid": ok, "x": px / R, "y": py / R, "nx": nx, "ny": ny,
                                         "drop": drop / (np.abs(drop) + DZ_SCALE_M),
                                         "d": np.where(ok, dist, 0.0) / R, "danger": danger}, ok)


def _scan(obs, world, state, readings, layout, R):
    """Each beam against each dangerous break the robot senses, by the parametric crossing of two lines."""
    k = layout.k_scan
    br = world.breaks
    col = layout.scan.start
    obs[:, col:col + k] = 1.0
    c = readings.breaks
    for i in range(state.n_robots):
        j = c.break_idx[c.observer == i]
        j = j[br.kinds[j] != ANGLE] if len(br) else j[:0]
        ch, sh, u = np.cos(state.headings[i]), np.sin(state.headings[i]), layout.scan_units()
        d = np.stack([ch * u[:, 0] - sh * u[:, 1], sh * u[:, 0] + ch * u[:, 1]], -1)[:, None, :]  # (k, 1, 2)
        a = br.segments[j, 0, :2][None]  # (1, m, 2)
        e = br.segments[j, 1, :2][None] - a
        w = a - state.positions[i]
        den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
        ok = np.abs(den) >= 1e-12
        den = np.where(ok, den, 1.0)
        t = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / den
        u = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / den
        hit = ok & (u >= -1e-12) & (u <= 1 + 1e-12) & (t >= 0) & (t < R)
        obs[i, col:col + k] = np.where(hit, t, R).min(axis=1, initial=R) / R


def build_observations_reference(world, state, readings, target_idx, live, layout: ObsLayout) -> np.ndarray:
    """Plain numpy version of :func:`~tin_swarm_env.env.observation.build_observations`."""
    R = world.params.sensor.range_m
    obs = np.zeros((state.n_robots, layout.size), dtype=np.float64)
    _own(obs, world, state, readings, target_idx, layout)
    if layout.k_robots:
        _points(obs, layout, "robots", readings.robots, state.positions, state, R)
    if layout.k_targets:
        _points(obs, layout, "targets", readings.targets, state.targets.positions, state, R)
    if layout.k_breaks:
        _breaks(obs, world, state, readings, layout, R)
    if layout.k_assets:
        _points(obs, layout, "assets", readings.assets, state.assets.positions, state, R)
    if layout.k_scan:
        _scan(obs, world, state, readings, layout, R)
    obs[~live] = 0.0
    np.clip(obs, -1.0, 1.0, out=obs)
    return obs.astype(np.float32)


def _gain(before, after) -> np.ndarray:
    """``before - after``, 0 where either is inf."""
    ok = np.isfinite(before) & np.isfinite(after)
    return np.where(ok, before, 0.0) - np.where(ok, after, 0.0)


def compute_rewards_reference(cfg, dist_before, dist_after, state, events, target_idx, live):
    """``(rewards (n,), terminated (n,) bool, reasons (n,) int8)`` for robots in ``live``;
    reasons are :class:`~tin_swarm_env.world.Reason` codes (NONE, ARRIVED, FELL or BATTERY;
    precedence FELL > ARRIVED > BATTERY, and the battery penalty is not paid on arrival).
    ``dist_before``/``dist_after`` ``(n,)`` m: :func:`distance_to_go` before and after the step;
    ``state`` the state after it (arrival is judged on the straight line to the target).
    The numpy reference of :func:`~.reward.compute_rewards` (a string of array passes)."""
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
