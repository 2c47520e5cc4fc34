"""GeodesicPolicy: the map-knowing reference controller (an upper bound, not a baseline).

Every other policy here acts from the observation alone. This one reads the environment's
terrain, world state and target assignment (``env.tin``, ``env.world.steep``,
``env.world_state``, ``env.target_assignment``), so its rows in the tables say how well a
controller that *knows the map* does: what a learned or reactive policy could hope to reach.

Per target it builds the shortest-drivable-path field (:func:`~tin_swarm_env.terrain.cost_to_go`
over the triangles a robot may drive on) once and caches it; robots move along the field's first
leg, the robot field of :mod:`tin_swarm_env.world.fields` spreads them, and the same last cuts as
the APF baseline (:func:`~tin_swarm_env.policies.base.safety_cut`) keep robots that see each other
apart and every robot off the dangerous breaks it senses.

*Pinches* (vertices where two passable areas touch only at one point) are handled by the
cost-to-go itself: no field passes through one (:func:`~tin_swarm_env.terrain.pinch_vertices`).

*Off the clear ground* (a robot on the ring of triangles next to steep ground, where the eroded
field does not reach), the full field's first leg runs to a corner of the steep ground, and the
safety cut, which keeps a robot ``edge_m`` off every dangerous break, removes all of it at the
corner: measured on the 50 held-out seeds per generated family, every robot GeodesicPolicy lost
(3.0% canyon, 4.0% mesa, 2.0% fork, 1.2% trap) stood there, 2-6 m from the corner of a cliff or of
a TIN sliver, swinging between two headings (net displacement 0 over its last 100 steps). There,
within ``LOOK_M + CLEAR_FACTOR edge_m`` of a dangerous break, the robot looks :data:`LOOK_M` ahead
instead (:meth:`GeodesicPolicy.around`): of :data:`LOOK_DIRS` straight legs that keep
:data:`CLEAR_FACTOR` ``edge_m`` off every dangerous break, it takes the one whose end is nearest
the target by the field (legs half as long where none of those ends nearer).
"""

from __future__ import annotations

import weakref

import numpy as np
from scipy.spatial import cKDTree

from ..terrain import Tin, cost_to_go
from ..terrain.breaks import ANGLE
from ..world.fields import FieldParams, away_from, facing, robot_field
from .base import DecodedObs, SafetyShield, act_dict, unwrap_env

__all__ = ["GeodesicPolicy", "eroded", "LOOK_M", "LOOK_DIRS", "CLEAR_FACTOR"]

LOOK_M = 4.0  # off the clear ground: length of the straight legs looked along, m
LOOK_DIRS = 24  # ... and how many (evenly spaced bearings)
CLEAR_FACTOR = 1.5  # ... each keeps this many edge_m (the safety cut's break clearance) off dangerous breaks
_SAMPLE_M = 0.25  # spacing of the points that stand for the dangerous breaks in the clearance index, m
_WALLS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # Breaks -> its clearance index (None: no breaks)


def eroded(tin: Tin, passable, rings: int = 1) -> np.ndarray:
    """``(T,)`` bool: ``passable`` less every triangle within ``rings`` vertex-rings of an
    impassable one (``rings`` 0: ``passable`` itself)."""
    ok = np.asarray(passable, dtype=bool).copy()
    for _ in range(rings):
        bad_v = np.zeros(tin.n_vertices, dtype=bool)
        bad_v[tin.triangles[~ok].ravel()] = True
        ok &= ~bad_v[tin.triangles].any(axis=1)
    return ok


def clear_of_breaks(u, d: DecodedObs, clear_m: float):
    """Unit directions ``u (n, 2)`` (body frame) kept ``clear_m`` off the dangerous breaks in the
    decoded observation ``d``: for each such break seen from its safe side at ``dist < clear_m``
    (``e`` the unit vector from it to the robot), the part of ``u`` toward it is removed and
    ``(1 - dist / clear_m) e`` added, so a path that runs along a cliff edge is followed a little
    off it and nothing of the motion along the edge is lost. Returns ``(n, 2)``."""
    rel, nrm = d.b_rel, d.b_normal
    dist = np.sqrt(np.sum(rel * rel, axis=-1))
    e = away_from(rel, nrm)
    near = facing(rel, nrm, d.b_danger) & (dist < clear_m)
    out = np.array(u, dtype=np.float64)
    for j in range(rel.shape[1]):
        ej = e[:, j]
        toward = np.minimum(np.sum(out * ej, axis=-1), 0.0)
        push = np.where(near[:, j], 1.0 - dist[:, j] / clear_m, 0.0)
        out = out + np.where(near[:, j], push - toward, 0.0)[:, None] * ej
    return out


class GeodesicPolicy:
    """Map-knowing reference: each robot follows the shortest drivable path to its assigned
    target. ``act_batch(obs (n, d), rows=None) -> actions (n, 2)`` and ``act(obs_dict)``.

    **It reads the map and the world state** (``env.tin``, ``env.world.steep``,
    ``env.world_state`` positions, triangles, headings and targets, ``env.target_assignment``):
    it is a reference, an upper bound for the tables, not a baseline. Rows are robots
    (row ``i`` is ``robot_i``).

    Per robot: the unit direction ``u`` of the first leg of its path (the field built on the
    ground ``clear_rings`` triangle rings away from any steep triangle, :func:`eroded`, where that
    reaches the target from the robot; else the field over all passable ground, and there, near a
    dangerous break, the best clear straight leg :data:`LOOK_M` long, :meth:`around`), kept
    ``clear_m`` off the dangerous breaks it senses (:func:`clear_of_breaks`: shortest paths hug
    cliff edges and corners, and robots queueing on one would block each other), scaled by the
    target field's magnitude with the path length as the distance
    (``gain * clip((D - standoff) / range, -1, 1)``; inside the containment standoff the target
    pushes straight away), rotated into the body frame, plus the robot field from the
    observation; saturated like the APF (``F / max(|F|, speed_saturation)``) and cut by
    :func:`~tin_swarm_env.policies.base.safety_cut`. Where the target cannot be reached (no
    drivable path), the robot heads straight for it.

    **Fields** are built per target (:func:`~tin_swarm_env.terrain.cost_to_go` over
    ``~env.world.steep`` and over its :func:`eroded` part) and cached by target index within an
    episode: a static target's field is rebuilt whenever its position differs, a mobile target's
    once it has moved more than ``rebuild_m``; :meth:`reset` (call it after each env reset) drops
    them all, and so does a change of ``env.tin`` (generated terrains make a new one per reset).
    ``fields``: ``("robot",)`` (default) or ``()`` to switch the robot field off.
    """

    def __init__(self, env, fields=("robot",), params: FieldParams | None = None, clear_m: float | None = None,
                 rebuild_m: float = 5.0, clear_rings: int = 1):
        base = unwrap_env(env)
        cfg = base.config
        self.env = base
        self.shield = SafetyShield(env)
        self.params = params or FieldParams()
        self.clear_m = 5.0 * cfg.world.robot.radius_m if clear_m is None else float(clear_m)
        self.rebuild_m = float(rebuild_m)
        self.robot_field_on = "robot" in tuple(fields)
        self.layout = base.layout
        self.clear_rings = int(clear_rings)
        self.look_clear_m = CLEAR_FACTOR * self.shield.edge_m
        self._tin = None
        self._clear = None
        self._fields: dict = {}
        self.reset()

    def reset(self):
        """Drop every cached field (call after each env reset: targets may be placed anew)."""
        self._tin, self._clear, self._fields = self.env.tin, None, {}

    def clearance(self, xy, upto_m: float = np.inf) -> np.ndarray:
        """``(...)`` m: distance from each point ``xy (..., 2)`` to the nearest dangerous break
        (cliff edge or border) of the current terrain, to within ``_SAMPLE_M / 2`` (the breaks are
        stood for by points that far apart; built once per terrain); inf beyond ``upto_m``."""
        self._sync()
        b = self.env.world.breaks
        if b not in _WALLS:  # built once per terrain, shared by every policy on it
            seg = b.segments[b.kinds != ANGLE][:, :, :2]
            n = np.maximum(np.ceil(np.hypot(*(seg[:, 1] - seg[:, 0]).T) / _SAMPLE_M), 1).astype(np.int64)
            k = np.repeat(np.arange(len(seg)), n + 1)  # point j of segment i: t = j / n_i, j = 0..n_i
            t = (np.arange(len(k)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) / n[k]
            pts = seg[k, 0] + t[:, None] * (seg[k, 1] - seg[k, 0])
            _WALLS[b] = cKDTree(pts) if len(pts) else None
        walls = _WALLS[b]
        xy = np.asarray(xy, dtype=np.float64)
        if walls is None:
            return np.full(xy.shape[:-1], np.inf)
        return walls.query(xy.reshape(-1, 2), distance_upper_bound=upto_m)[0].reshape(xy.shape[:-1])

    def around(self, field, pos) -> tuple[np.ndarray, np.ndarray]:
        """Off the clear ground: for each robot at ``pos (m, 2)``, the best of :data:`LOOK_DIRS`
        straight legs :data:`LOOK_M` long by ``field`` (the distance to go from the leg's end),
        among the legs whose every point stays ``look_clear_m`` off the dangerous breaks (or, for
        a robot already nearer one, no nearer than it is); where none of them ends nearer the
        target than the robot stands (round a corner the way on first runs sideways), the same
        with legs half as long. Returns ``(direction (m, 2), ok (m,))``: ``ok`` false where no
        leg of either length ends nearer."""
        pos = np.asarray(pos, dtype=np.float64)
        ang = 2.0 * np.pi * np.arange(LOOK_DIRS) / LOOK_DIRS
        dirs = np.stack([np.cos(ang), np.sin(ang)], axis=-1)  # (K, 2)
        frac = np.arange(1, 9) / 8.0
        need = np.minimum(self.look_clear_m, self.clearance(pos, self.look_clear_m)) - 1e-9
        here = field.distance_at(pos)
        out, ok = np.zeros((len(pos), 2)), np.zeros(len(pos), dtype=bool)
        for look in (LOOK_M, LOOK_M / 2):
            todo = np.flatnonzero(~ok)
            if not len(todo):
                break
            pts = pos[todo, None, None, :] + look * frac[None, None, :, None] * dirs[None, :, None, :]  # (m, K, 8, 2)
            clear = self.clearance(pts, self.look_clear_m).min(axis=-1) >= need[todo, None]  # (m, K)
            togo = np.full(clear.shape, np.inf)
            if clear.any():
                togo[clear] = field.distance_at(pts[:, :, -1][clear])
            best = np.argmin(togo, axis=1)
            out[todo] = dirs[best]
            ok[todo] = togo[np.arange(len(todo)), best] < here[todo]
        return out, ok

    def _sync(self):
        if self.env.tin is not self._tin:
            self.reset()

    def field(self, k: int, goal_xy, mobile: bool = False):
        """The cached fields toward target ``k`` at ``goal_xy``: ``(full, clear)``, two
        :class:`~tin_swarm_env.terrain.CostToGo` over all passable ground and over its
        :func:`eroded` part (None when nothing is left of it). A cached field is reused when
        built for the same position, or, for a ``mobile`` target, within ``rebuild_m``."""
        self._sync()
        goal_xy = np.asarray(goal_xy, dtype=np.float64)
        hit = self._fields.get(k)
        if hit is not None:
            moved = np.hypot(*(hit[0].goal_xy - goal_xy))
            if moved == 0.0 or (mobile and moved <= self.rebuild_m):
                return hit
        passable = ~np.asarray(self.env.world.steep)
        if self._clear is None:
            self._clear = eroded(self._tin, passable, self.clear_rings)
        full = cost_to_go(self._tin, goal_xy, passable)
        clear = cost_to_go(self._tin, goal_xy, self._clear) if self._clear.any() else None
        self._fields[k] = (full, clear)
        return self._fields[k]

    def directions(self, rows) -> tuple[np.ndarray, np.ndarray]:
        """World-frame unit directions ``(m, 2)`` along the path and path
        lengths ``(m,)`` m (inf: unreachable; then the direction is the straight bearing) for
        the robots in ``rows``."""
        s = self.env.world_state
        pos, tri = s.positions[rows], s.tri_idx[rows]
        tgt = self.env.target_assignment[rows]
        u = np.zeros((len(rows), 2))
        dist = np.full(len(rows), np.inf)
        for k in np.unique(tgt[tgt >= 0]):  # one batched query per target
            sel = np.flatnonzero(tgt == k)
            goal = s.targets.positions[k]
            full, clear = self.field(int(k), goal, bool(s.targets.mobile[k]))
            d0, u0 = full.query(pos[sel], tri[sel])
            u0 = np.array(u0, dtype=np.float64)
            off = np.isfinite(d0)  # off the clear ground, the field still reaching the target
            if clear is not None:  # off the walls where the eroded ground reaches the target
                dc, uc = clear.query(pos[sel], tri[sel])
                u0 = np.where(np.isfinite(dc)[:, None], uc, u0)
                d0 = np.where(np.isfinite(dc), dc, d0)
                off &= ~np.isfinite(dc)
            reach = LOOK_M + self.look_clear_m  # a corner no nearer than this is no leg's concern
            off[off] = self.clearance(pos[sel][off], reach) < reach
            if off.any():  # round the corner the first leg runs to, clear of it (module docstring)
                ua, ok = self.around(full, pos[sel][off])
                u0[off] = np.where(ok[:, None], ua, u0[off])
            w = u0
            straight = goal - pos[sel]
            w = np.where(np.isfinite(d0)[:, None], w, straight)
            u[sel] = w / np.maximum(np.hypot(w[:, 0], w[:, 1]), 1e-12)[:, None]
            dist[sel] = d0
        return u, dist

    def act_batch(self, obs, rows=None) -> np.ndarray:
        obs = np.asarray(obs, dtype=np.float64)
        rows = np.arange(len(obs)) if rows is None else np.asarray(rows, dtype=np.int64)
        s = self.env.world_state
        p = self.params
        u, dist = self.directions(rows)
        tgt = self.env.target_assignment[rows]
        d = self.shield.decode(obs)
        straight = d.dist
        e = np.where(np.isfinite(dist), dist, straight) - self.shield.standoff_m
        mag = p.target_gain * np.clip(e / p.target_range_m, -1.0, 1.0)
        h = s.headings[rows]
        c, sn = np.cos(h), np.sin(h)
        body = np.stack([c * u[:, 0] + sn * u[:, 1], -sn * u[:, 0] + c * u[:, 1]], axis=-1)
        if self.shield.standoff_m > 0:  # inside the ring: straight away from the threat
            away = d.rel_t / np.maximum(straight, 1e-12)[:, None]
            body = np.where((straight < self.shield.standoff_m)[:, None], away, body)
            inner = p.target_gain * np.clip((straight - self.shield.standoff_m) / p.target_range_m, -1, 0)
            mag = np.where(straight < self.shield.standoff_m, inner, mag)
        body = clear_of_breaks(body, d, self.clear_m)
        f = np.where((tgt >= 0)[:, None], mag[:, None] * body, 0.0)
        if self.robot_field_on and self.layout.k_robots:
            f = f + robot_field(d.r_rel, d.r_valid, p.robot_gain, p.robot_range_m)[0]
        a = f / np.maximum(np.sqrt(np.sum(f * f, axis=-1, keepdims=True)), p.speed_saturation)
        return self.shield.cut(a, d)

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs, [self.env.agent_name_mapping[k] for k in obs])
