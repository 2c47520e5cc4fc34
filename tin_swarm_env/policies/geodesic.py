"""GeodesicPolicy: the map-knowing reference controller (an upper bound, not a baseline).

Every other policy here acts from the observation alone. This one reads the environment's
terrain, world state and target assignment (``env.tin``, ``env.world.steep``,
``env.world_state``, ``env.target_assignment``), so its rows in the tables say how well a
controller that *knows the map* does: what a learned or reactive policy could hope to reach.

Per target it builds the shortest-drivable-path field (:func:`~tin_swarm_env.terrain.cost_to_go`
over the triangles a robot may drive on) once and caches it; robots move along the field's first
leg, the robot field of :mod:`tin_swarm_env.world.fields` spreads them, and the same last cuts as
the APF baseline (:func:`~tin_swarm_env.policies.apf.safety_cut`) keep robots that see each other
apart and every robot off the dangerous breaks it senses.

*Pinches.* The cost-to-go treats passable ground as the closed union of passable triangles, so
a path may go through a vertex where two steep triangles meet and two passable fans touch only
at that point. A robot cannot pass there (it would have to hit the vertex exactly). The field is
therefore built on a copy of the TIN in which each such vertex is split into one copy per fan,
each moved a hair (``1e-6`` of the terrain's extent) into its fan (:func:`split_pinches`): the
triangle indices are unchanged, only the point contact is cut.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import TinStructureError
from ..terrain import Tin, cost_to_go
from ..world.fields import FieldParams, away_from, facing, robot_field
from .apf import Controller, decode, unwrap_env

__all__ = ["GeodesicPolicy", "split_pinches", "pinch_vertices"]


def _fans(tin: Tin, passable):
    """Corners ``(t, k)`` of passable triangles grouped into fans: two corners at the same
    vertex are in one fan when their triangles share an edge through that vertex (both passable),
    or are linked through a chain of such triangles. Returns ``(labels (T, 3) int, -1 on
    impassable triangles; n_fans)``."""
    tri, nb = tin.triangles, tin.neighbors
    T = len(tri)
    ids = np.arange(3 * T).reshape(T, 3)
    rows, cols = [], []
    for j in range(3):  # edge opposite corner j joins corners (j+1)%3 and (j+2)%3 of t to u
        u = nb[:, j]
        ok = (u >= 0) & passable & passable[np.maximum(u, 0)]
        t_ok, u_ok = np.flatnonzero(ok), u[ok]
        for c in ((j + 1) % 3, (j + 2) % 3):
            v = tri[t_ok, c]
            k_u = np.argmax(tri[u_ok] == v[:, None], axis=1)
            rows.append(ids[t_ok, c])
            cols.append(ids[u_ok, k_u])
    r, c = np.concatenate(rows), np.concatenate(cols)
    g = coo_matrix((np.ones(len(r)), (r, c)), shape=(3 * T, 3 * T))
    _, lab = connected_components(g, directed=False)
    lab = lab.reshape(T, 3)
    return np.where(passable[:, None], lab, -1)


def pinch_vertices(tin: Tin, passable) -> np.ndarray:
    """``(P,)`` int: vertices whose passable triangles form more than one fan (two passable
    regions touching only at that vertex)."""
    lab = _fans(tin, np.asarray(passable, dtype=bool))
    ok = lab >= 0
    pairs = np.unique(np.stack([tin.triangles[ok], lab[ok]], axis=1), axis=0)
    v, count = np.unique(pairs[:, 0], return_counts=True)
    return v[count > 1]


def split_pinches(tin: Tin, passable, eps_frac: float = 1e-6) -> Tin:
    """A copy of ``tin`` in which every pinch vertex (:func:`pinch_vertices`) is replaced, in
    the passable triangles around it, by one new vertex per fan, moved ``eps_frac`` of the
    terrain's extent from the old one along the bisector of the fan's wedge (so each fan shrinks
    a hair and the fans no longer touch); impassable triangles keep the old vertex. Triangle
    indices and order are unchanged. Returns ``tin`` itself when there is no pinch."""
    passable = np.asarray(passable, dtype=bool)
    lab = _fans(tin, passable)
    ok = lab >= 0
    tri = tin.triangles
    pairs = np.unique(np.stack([tri[ok], lab[ok]], axis=1), axis=0)
    v_of, count = np.unique(pairs[:, 0], return_counts=True)
    pinch = v_of[count > 1]
    if len(pinch) == 0:
        return tin
    xy = tin.vertices[:, :2]
    eps = eps_frac * max(tin.bounds[2] - tin.bounds[0], tin.bounds[3] - tin.bounds[1])
    new_tri = tri.copy()
    new_v = [tin.vertices]
    n_v = len(tin.vertices)
    is_pinch = np.isin(tri, pinch) & ok
    for fan in np.unique(lab[is_pinch]):
        ts, ks = np.nonzero(is_pinch & (lab == fan))
        v = tri[ts[0], ks[0]]
        # the fan's wedge: corner (t, k) spans CCW from (next vertex - v) to (previous vertex - v)
        a = np.arctan2(*(xy[tri[ts, (ks + 1) % 3]] - xy[v])[:, ::-1].T)
        b = np.arctan2(*(xy[tri[ts, (ks + 2) % 3]] - xy[v])[:, ::-1].T)
        starts = set(np.round(a, 12)) - set(np.round(b, 12))  # a start ray no corner of the fan ends on
        a0 = a[np.isin(np.round(a, 12), list(starts))][0] if starts else a[0]
        span = np.sum((b - a) % (2 * np.pi))
        h = a0 + span / 2
        new_v.append(np.array([[xy[v, 0] + eps * np.cos(h), xy[v, 1] + eps * np.sin(h), tin.vertices[v, 2]]]))
        new_tri[ts, ks] = n_v
        n_v += 1
    try:
        out = Tin(np.concatenate(new_v), new_tri, source=f"{tin.source} (pinches split)")
    except TinStructureError:
        return tin  # a degenerate neighbourhood: keep the point contacts rather than fail
    return out if out.n_triangles == tin.n_triangles else tin


def eroded(tin: Tin, passable, rings: int = 1) -> np.ndarray:
    """``(T,)`` bool: ``passable`` less every triangle within ``rings`` vertex-rings of an
    impassable one (``rings`` 0: ``passable`` itself)."""
    ok = np.asarray(passable, dtype=bool).copy()
    for _ in range(rings):
        bad_v = np.zeros(tin.n_vertices, dtype=bool)
        bad_v[tin.triangles[~ok].ravel()] = True
        ok &= ~bad_v[tin.triangles].any(axis=1)
    return ok


def clear_of_breaks(u, d: dict, clear_m: float):
    """Unit directions ``u (n, 2)`` (body frame) kept ``clear_m`` off the dangerous breaks in the
    decoded observation ``d``: for each such break seen from its safe side at ``dist < clear_m``
    (``e`` the unit vector from it to the robot), the part of ``u`` toward it is removed and
    ``(1 - dist / clear_m) e`` added, so a path that runs along a cliff edge is followed a little
    off it and nothing of the motion along the edge is lost. Returns ``(n, 2)``."""
    rel, nrm = d["b_rel"], d["b_normal"]
    dist = np.sqrt(np.sum(rel * rel, axis=-1))
    e = away_from(rel, nrm)
    near = facing(rel, nrm, d["b_danger"]) & (dist < clear_m)
    out = np.array(u, dtype=np.float64)
    for j in range(rel.shape[1]):
        ej = e[:, j]
        toward = np.minimum(np.sum(out * ej, axis=-1), 0.0)
        push = np.where(near[:, j], 1.0 - dist[:, j] / clear_m, 0.0)
        out = out + np.where(near[:, j], push - toward, 0.0)[:, None] * ej
    return out


class GeodesicPolicy(Controller):
    """Map-knowing reference: each robot follows the shortest drivable path to its assigned
    target. ``act_batch(obs (n, d), rows=None) -> actions (n, 2)`` and ``act(obs_dict)``.

    **It reads the map and the world state** (``env.tin``, ``env.world.steep``,
    ``env.world_state`` positions, triangles, headings and targets, ``env.target_assignment``):
    it is a reference, an upper bound for the tables, not a baseline. Rows are robots
    (row ``i`` is ``robot_i``).

    Per robot: the unit direction ``u`` of the first leg of its path (the field built on the
    ground ``clear_rings`` triangle rings away from any steep triangle, :func:`eroded`, where that
    reaches the target from the robot; else the field over all passable ground), kept
    ``clear_m`` off the dangerous breaks it senses (:func:`clear_of_breaks`: shortest paths hug
    cliff edges and corners, and robots queueing on one would block each other), scaled by the
    target field's magnitude with the path length as the distance
    (``gain * clip((D - standoff) / range, -1, 1)``; inside the containment standoff the target
    pushes straight away), rotated into the body frame, plus the robot field from the
    observation; saturated like the APF (``F / max(|F|, speed_saturation)``) and cut by
    :func:`~tin_swarm_env.policies.apf.safety_cut`. Where the target cannot be reached (no
    drivable path), the robot heads straight for it.

    **Fields** are built per target (:func:`~tin_swarm_env.terrain.cost_to_go` over
    ``~env.world.steep`` and over its :func:`eroded` part, on :func:`split_pinches`'s copy of the
    TIN) and cached by target index and position; a field is rebuilt when its target has moved more than ``rebuild_m`` (mobile
    targets) and all are dropped when ``env.tin`` is a different object (generated terrains make a
    new one per reset); :meth:`reset` checks that too. ``fields``: ``("robot",)`` (default) or
    ``()`` to switch the robot field off.
    """

    def __init__(self, env, fields=("robot",), params: FieldParams | None = None, clear_m: float | None = None,
                 rebuild_m: float = 5.0, clear_rings: int = 1):
        base = unwrap_env(env)
        cfg = base.config
        self.env = base
        self._read_constants(cfg)
        self.params = params or FieldParams()
        self.clear_m = 5.0 * cfg.world.robot.radius_m if clear_m is None else float(clear_m)
        self.rebuild_m = float(rebuild_m)
        self.robot_field_on = "robot" in tuple(fields)
        self.layout = base.layout
        self.clear_rings = int(clear_rings)
        self._tin = None
        self._split = self._clear = None
        self._fields: dict = {}
        self.reset()

    def reset(self):
        """Drop the cached fields if the environment's terrain changed (call after env reset)."""
        self._sync()

    def _sync(self):
        tin = self.env.tin
        if tin is not self._tin:
            self._tin, self._split, self._fields = tin, None, {}

    def field(self, k: int, goal_xy):
        """The cached fields toward target ``k`` at ``goal_xy``: ``(full, clear)``, two
        :class:`~tin_swarm_env.terrain.CostToGo` over all passable ground and over its
        :func:`eroded` part (None when nothing is left of it)."""
        self._sync()
        goal_xy = np.asarray(goal_xy, dtype=np.float64)
        hit = self._fields.get(k)
        if hit is not None and np.hypot(*(hit[0].goal_xy - goal_xy)) <= self.rebuild_m:
            return hit
        passable = ~np.asarray(self.env.world.steep)
        if self._split is None:
            self._split = split_pinches(self._tin, passable)
            self._clear = eroded(self._tin, passable, self.clear_rings)
        full = cost_to_go(self._split, goal_xy, passable)
        clear = cost_to_go(self._split, goal_xy, self._clear) if self._clear.any() else None
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
            full, clear = self.field(int(k), goal)
            d0, u0 = full.query(pos[sel], tri[sel])
            if clear is not None:  # off the walls where the eroded ground reaches the target
                dc, uc = clear.query(pos[sel], tri[sel])
                u0 = np.where(np.isfinite(dc)[:, None], uc, u0)
                d0 = np.where(np.isfinite(dc), dc, d0)
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
        d = decode(obs, self.layout, self.range_m)
        straight = d["dist"]
        e = np.where(np.isfinite(dist), dist, straight) - self.standoff_m
        mag = p.target_gain * np.clip(e / p.target_range_m, -1.0, 1.0)
        h = s.headings[rows]
        c, sn = np.cos(h), np.sin(h)
        body = np.stack([c * u[:, 0] + sn * u[:, 1], -sn * u[:, 0] + c * u[:, 1]], axis=-1)
        if self.standoff_m > 0:  # inside the ring: straight away from the threat
            away = d["rel_t"] / np.maximum(straight, 1e-12)[:, None]
            body = np.where((straight < self.standoff_m)[:, None], away, body)
            mag = np.where(straight < self.standoff_m, p.target_gain * np.clip((straight - self.standoff_m)
                                                                               / p.target_range_m, -1, 0), mag)
        body = clear_of_breaks(body, d, self.clear_m)
        f = np.where((tgt >= 0)[:, None], mag[:, None] * body, 0.0)
        if self.robot_field_on and self.layout.k_robots:
            f = f + robot_field(d["r_rel"], d["r_valid"], p.robot_gain, p.robot_range_m)[0]
        a = f / np.maximum(np.sqrt(np.sum(f * f, axis=-1, keepdims=True)), p.speed_saturation)
        return self._cut(a, d)

    def act(self, obs: dict) -> dict:
        if not obs:
            return {}
        keys = list(obs)
        rows = [self.env.agent_name_mapping[k] for k in keys]
        a = self.act_batch(np.stack([obs[k] for k in keys]), rows)
        return {k: a[i] for i, k in enumerate(keys)}
