"""Observations: one flat float32 vector per robot, egocentric, normalised, in [-1, 1].

Body frame: x forward, y left; world vectors are rotated by minus the robot's heading.
``R`` is the sensor range. Layout (``K_r``, ``K_t``, ``K_b`` slots; see :class:`ObsLayout`):

===================  =====  ==================================================================
slice                size   contents (range)
===================  =====  ==================================================================
own.battery          1      charge / capacity (0..1)
own.speed            1      speed achieved last step / max speed (0..1)
own.tilt             1      sensor tilt (thesis 3.1) / 90 deg (-1..1)
own.slope            1      slope of the triangle underfoot / 90 deg (0..1)
own.uphill           2      unit vector toward uphill, body frame; 0 on flat ground
own.target_valid     1      1 when the task assigns this robot a target
own.target_dir       2      unit vector toward the assigned target, body frame
own.target_dist      1      d / (d + R), d the horizontal distance to it (0..1)
own.target_dz        1      dz / (|dz| + 10 m), dz its height above the robot (-1..1)
robots               4 K_r  per slot: valid, x / R, y / R, d / R of the K_r nearest visible robots
targets              4 K_t  the same for the K_t nearest visible threats/targets
breaks               8 K_b  per slot: valid, closest point x / R, y / R, unit normal toward the
                            safe side (x, y), drop / (|drop| + 10 m), d / R, danger (1 for a
                            cliff edge or the terrain's border, 0 for a bend between two
                            traversable planes), of the K_b nearest terrain breaks in range
===================  =====  ==================================================================

Empty slots are all zero. Robots no longer in ``agents`` get an all-zero vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from ..terrain import ANGLE

__all__ = ["ObsLayout", "build_observations", "build_observations_reference", "OWN_FIELDS"]

OWN_FIELDS = (("battery", 1), ("speed", 1), ("tilt", 1), ("slope", 1), ("uphill", 2), ("target_valid", 1),
              ("target_dir", 2), ("target_dist", 1), ("target_dz", 1))
ROBOT_SLOT, TARGET_SLOT, BREAK_SLOT = 4, 4, 8
DZ_SCALE_M = 10.0


@dataclass(frozen=True)
class ObsLayout:
    """Named slices of the observation vector, for policies (APF or learned) to read.

    ``layout.own["battery"]`` is a slice; ``layout.robots`` the slice of all robot slots, which
    :meth:`slots` reshapes to ``(..., K, per_slot)``.
    """

    k_robots: int = 4
    k_targets: int = 2
    k_breaks: int = 3

    @property
    def own(self) -> dict[str, slice]:
        out, i = {}, 0
        for name, n in OWN_FIELDS:
            out[name] = slice(i, i + n)
            i += n
        return out

    @property
    def own_size(self) -> int:
        return sum(n for _, n in OWN_FIELDS)

    @property
    def robots(self) -> slice:
        a = self.own_size
        return slice(a, a + ROBOT_SLOT * self.k_robots)

    @property
    def targets(self) -> slice:
        a = self.robots.stop
        return slice(a, a + TARGET_SLOT * self.k_targets)

    @property
    def breaks(self) -> slice:
        a = self.targets.stop
        return slice(a, a + BREAK_SLOT * self.k_breaks)

    @property
    def size(self) -> int:
        return self.breaks.stop

    def slots(self, obs: np.ndarray, part: str) -> np.ndarray:
        """``obs[..., part]`` reshaped to ``(..., K, per_slot)`` for part robots/targets/breaks."""
        sl = getattr(self, part)
        per = {"robots": ROBOT_SLOT, "targets": TARGET_SLOT, "breaks": BREAK_SLOT}[part]
        return obs[..., sl].reshape(*obs.shape[:-1], -1, per)

    def names(self) -> list[str]:
        """One name per element, e.g. ``own.uphill[1]``, ``robots[2].x``."""
        out = []
        for name, n in OWN_FIELDS:
            out += [f"own.{name}"] if n == 1 else [f"own.{name}[{j}]" for j in range(n)]
        for part, k, fields in (("robots", self.k_robots, ("valid", "x", "y", "d")),
                                ("targets", self.k_targets, ("valid", "x", "y", "d")),
                                ("breaks", self.k_breaks, ("valid", "x", "y", "nx", "ny", "drop", "d", "danger"))):
            out += [f"{part}[{i}].{f}" for i in range(k) for f in fields]
        return out


def _to_body(vx, vy, heading):
    c, s = np.cos(heading), np.sin(heading)
    return c * vx + s * vy, -s * vx + c * vy


def build_observations_reference(world, state, readings, target_idx, live, layout: ObsLayout) -> np.ndarray:
    """Plain numpy version of :func:`build_observations` (the reference its kernel is tested
    against)."""
    P = world.params
    R = P.sensor.range_m
    n = state.n_robots
    obs = np.zeros((n, layout.size), dtype=np.float64)
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
        # below 1e-6 (a micro-degree) the ground counts as level: no uphill direction
        obs[:, own["uphill"]] = np.where(gn[:, None] > 1e-6, np.column_stack([ux, uy]) / gn[:, None], 0.0)
    has = target_idx >= 0
    if has.any() and len(state.targets):
        t = target_idx[has]
        tp = state.targets.positions[t]
        d = tp - state.positions[has]
        dist = np.hypot(d[:, 0], d[:, 1])
        bx, by = _to_body(d[:, 0], d[:, 1], h[has])
        safe = np.maximum(dist, 1e-12)
        tz = world.tin.height_in(tp, state.targets.tri_idx[t])
        dz = tz - state.heights[has]
        rows = np.flatnonzero(has)
        obs[rows, own["target_valid"].start] = 1.0
        obs[rows, own["target_dir"].start] = np.where(dist > 0, bx / safe, 0.0)
        obs[rows, own["target_dir"].start + 1] = np.where(dist > 0, by / safe, 0.0)
        obs[rows, own["target_dist"].start] = dist / (dist + R)
        obs[rows, own["target_dz"].start] = dz / (np.abs(dz) + DZ_SCALE_M)

    # robot slots
    if layout.k_robots:
        idx, dist, _ = readings.robots.nearest(n, layout.k_robots)
        ok = idx >= 0
        j = np.where(ok, idx, 0)
        d = state.positions[j] - state.positions[:, None, :]
        bx, by = _to_body(d[..., 0], d[..., 1], h[:, None])
        slot = np.stack([ok, bx / R, by / R, np.where(ok, dist, 0.0) / R], axis=-1) * ok[..., None]
        obs[:, layout.robots] = slot.reshape(n, -1)
    if layout.k_targets:
        idx, dist, _ = readings.targets.nearest(n, layout.k_targets)
        ok = idx >= 0
        if len(state.targets):
            j = np.where(ok, idx, 0)
            d = state.targets.positions[j] - state.positions[:, None, :]
        else:
            d = np.zeros((n, layout.k_targets, 2))
        bx, by = _to_body(d[..., 0], d[..., 1], h[:, None])
        slot = np.stack([ok, bx / R, by / R, np.where(ok, dist, 0.0) / R], axis=-1) * ok[..., None]
        obs[:, layout.targets] = slot.reshape(n, -1)
    if layout.k_breaks:
        bidx, dist, closest = readings.breaks.nearest(n, layout.k_breaks)
        ok = bidx >= 0
        j = np.where(ok, bidx, 0)
        br = world.breaks
        if len(br):
            nrm = br.normals[j]
            drop = br.drops_m[j]
            danger = (br.kinds[j] != ANGLE).astype(float)
        else:
            nrm = np.zeros((n, layout.k_breaks, 2))
            drop = np.zeros((n, layout.k_breaks))
            danger = np.zeros((n, layout.k_breaks))
        d = closest - state.positions[:, None, :]
        px, py = _to_body(d[..., 0], d[..., 1], h[:, None])
        nx, ny = _to_body(nrm[..., 0], nrm[..., 1], h[:, None])
        slot = np.stack([ok, px / R, py / R, nx, ny, drop / (np.abs(drop) + DZ_SCALE_M),
                         np.where(ok, dist, 0.0) / R, danger], axis=-1) * ok[..., None]
        obs[:, layout.breaks] = slot.reshape(n, -1)
    obs[~live] = 0.0
    np.clip(obs, -1.0, 1.0, out=obs)
    return obs.astype(np.float32)


@njit(cache=True, inline="always")
def _point_slots(obs, i, start, idx, dist, src, pos, c, s, R):
    """Robot or target slots of robot ``i``: valid, x/R, y/R (body frame), d/R."""
    for k in range(idx.shape[1]):
        j = idx[i, k]
        if j < 0:
            continue
        dx = src[j, 0] - pos[i, 0]
        dy = src[j, 1] - pos[i, 1]
        b = start + 4 * k
        obs[i, b] = 1.0
        obs[i, b + 1] = (c * dx + s * dy) / R
        obs[i, b + 2] = (-s * dx + c * dy) / R
        obs[i, b + 3] = dist[i, k] / R


@njit(cache=True)
def _fill(obs, pos, head, heights, speeds_n, battery_n, tilt_n, slope_n, grad, live,
          target_idx, tpos, tz, r_idx, r_dist, t_idx, t_dist, b_idx, b_dist, b_closest, b_normals, b_drops,
          b_danger, R, dz_scale, o_rob, o_tgt, o_brk):
    n = pos.shape[0]
    for i in range(n):
        if not live[i]:
            continue
        c = np.cos(head[i])
        s = np.sin(head[i])
        obs[i, 0] = battery_n[i]
        obs[i, 1] = min(max(speeds_n[i], 0.0), 1.0)
        obs[i, 2] = tilt_n[i]
        obs[i, 3] = slope_n[i]
        gx = grad[i, 0]
        gy = grad[i, 1]
        gn = np.sqrt(gx * gx + gy * gy)
        if gn > 1e-6:
            obs[i, 4] = (c * gx + s * gy) / gn
            obs[i, 5] = (-s * gx + c * gy) / gn
        t = target_idx[i]
        if t >= 0 and tpos.shape[0] > 0:
            dx = tpos[t, 0] - pos[i, 0]
            dy = tpos[t, 1] - pos[i, 1]
            d = np.sqrt(dx * dx + dy * dy)
            obs[i, 6] = 1.0
            if d > 0:
                obs[i, 7] = (c * dx + s * dy) / d
                obs[i, 8] = (-s * dx + c * dy) / d
            obs[i, 9] = d / (d + R)
            dz = tz[t] - heights[i]
            obs[i, 10] = dz / (abs(dz) + dz_scale)
        _point_slots(obs, i, o_rob, r_idx, r_dist, pos, pos, c, s, R)
        _point_slots(obs, i, o_tgt, t_idx, t_dist, tpos, pos, c, s, R)
        for k in range(b_idx.shape[1]):
            j = b_idx[i, k]
            if j < 0:
                continue
            dx = b_closest[i, k, 0] - pos[i, 0]
            dy = b_closest[i, k, 1] - pos[i, 1]
            nx = b_normals[j, 0]
            ny = b_normals[j, 1]
            b = o_brk + 8 * k
            obs[i, b] = 1.0
            obs[i, b + 1] = (c * dx + s * dy) / R
            obs[i, b + 2] = (-s * dx + c * dy) / R
            obs[i, b + 3] = c * nx + s * ny
            obs[i, b + 4] = -s * nx + c * ny
            obs[i, b + 5] = b_drops[j] / (abs(b_drops[j]) + dz_scale)
            obs[i, b + 6] = b_dist[i, k] / R
            obs[i, b + 7] = b_danger[j]
        for m in range(obs.shape[1]):
            obs[i, m] = min(max(obs[i, m], -1.0), 1.0)


def build_observations(world, state, readings, target_idx, live, layout: ObsLayout) -> np.ndarray:
    """``(n, layout.size)`` float32 observations for all robots (zeros where ``live`` is False);
    one compiled pass over the robots (see :func:`build_observations_reference`)."""
    P = world.params
    n = state.n_robots
    ri, rd, _ = readings.robots.nearest(n, layout.k_robots)
    ti, td, _ = readings.targets.nearest(n, layout.k_targets)
    bi, bd, bc = readings.breaks.nearest(n, layout.k_breaks)
    tg = state.targets
    tz = world.tin.height_in(tg.positions, tg.tri_idx) if len(tg) else np.zeros(0)
    br = world.breaks
    obs = np.zeros((n, layout.size), dtype=np.float32)
    _fill(obs, state.positions, state.headings, state.heights, state.speeds / P.robot.max_speed_mps,
          state.battery_j / P.battery.capacity_j, readings.tilt_rad / (np.pi / 2), readings.slope_deg / 90.0,
          world.tin.planes[state.tri_idx, :2], live, target_idx, tg.positions.reshape(-1, 2), tz,
          ri, rd, ti, td, bi, bd, np.ascontiguousarray(bc, dtype=np.float64),
          br.normals.reshape(-1, 2), br.drops_m.reshape(-1), (br.kinds != ANGLE).astype(np.float64),
          float(P.sensor.range_m), DZ_SCALE_M,
          layout.robots.start, layout.targets.start, layout.breaks.start)
    return obs
