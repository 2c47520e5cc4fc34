"""Artificial Potential Field policy: acts from the observation alone, for all robots at once.

The observation (see :class:`~tin_swarm_env.env.observation.ObsLayout`) is egocentric, so the
fields of :mod:`tin_swarm_env.world.fields` are evaluated in the body frame and their sum is
the commanded body-frame velocity, full speed once the force reaches ``speed_saturation``:
``action = F / max(|F|, speed_saturation)``. Where a dangerous break blocks the way, the
attraction is replaced by wall-following (:func:`~tin_swarm_env.world.fields.follow_field`) on a
side kept in a small per-robot memory (:class:`BugMemory`), and a robot drives through a gap
between two break ends that leads toward its target (:func:`pass_gap`); last, the command is cut so that no
robot closes on a robot it sees by more than half the gap in one step (:func:`~tin_swarm_env.policies.base.keep_clear`).
What the policy takes from the environment is static: the observation layout, the sensor range,
the task's standoff distance, the robot's radius, top speed and time step, never the world state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world.fields import (
    FIELDS,
    FieldParams,
    asset_field,
    away_from,
    break_field,
    facing,
    follow_field,
    height_field,
    robot_field,
    target_field,
)
from .base import DecodedObs, SafetyShield, act_dict, decode, unwrap_env

__all__ = ["APFPolicy", "apf_forces", "field_forces", "follow_term", "FORCES", "BugMemory", "bug_update", "pass_gap"]


FORCES = ("robot", "target", "break", "follow", "height", "asset")


def apf_forces(obs, layout, range_m, standoff_m, params: FieldParams, follow=None, step_m=1.0, guard_m=0.0):
    """Per-field body-frame forces for observations ``obs (n, d)``: a dict name -> ``(n, 2)``
    (:data:`FORCES`: ``robot``, ``target``, ``break``, ``follow``, ``height``, ``asset``; fields
    switched off are zeros; the asset field reads the layout's asset slots, guard ring radius
    ``guard_m``). ``follow = (side (n,), slot (n,))``: each robot's wall-following side (+1 the
    break on its right, -1 on its left, 0 none) and the break slot it follows (-1 none), from
    :func:`bug_update`; ``follow`` is then the wall-following term
    (:func:`~tin_swarm_env.world.fields.follow_field`, ``step_m`` the distance covered in one
    step at full speed); without it, zero."""
    d = decode(obs, layout, range_m)
    out = field_forces(d, layout, standoff_m, params, guard_m)
    if follow is not None and params.on("break") and layout.k_breaks:
        out["follow"] = follow_term(d, out["target"] + out["height"], *follow, params, step_m)
    return out


def field_forces(d: DecodedObs, layout, standoff_m, params: FieldParams, guard_m=0.0) -> dict:
    """:func:`apf_forces` from the decoded observation ``d`` (:func:`decode`), without the
    wall-following term (``follow`` is zeros)."""
    n = len(d.dist)
    zero = np.zeros((n, 2))
    out = dict.fromkeys(FORCES, zero)
    if params.on("asset") and layout.k_assets:
        out["asset"], _ = asset_field(d.a_rel, d.a_valid, guard_m, params.asset_gain, params.asset_range_m)
    has_t = d.has_t[:, None]
    if params.on("target"):
        f, _ = target_field(d.rel_t, standoff_m, params.target_gain, params.target_range_m)
        out["target"] = np.where(has_t, f, 0.0)
    if params.on("height"):
        f, _ = height_field(d.grad_z, d.dz, params.height_gain)
        out["height"] = np.where(has_t, f, 0.0)
    if params.on("robot") and layout.k_robots:
        out["robot"], _ = robot_field(d.r_rel, d.r_valid, params.robot_gain, params.robot_range_m)
    if params.on("break") and layout.k_breaks:
        out["break"], _ = break_field(d.b_rel, d.b_normal, d.b_danger, params.break_gain,
                                      params.break_range_m, params.break_decay_m)
    return out


def follow_term(d: DecodedObs, pull, side, slot, params: FieldParams, step_m: float):
    """The wall-following term ``(n, 2)`` of robots following break ``slot (n,)`` (-1 none) on
    ``side (n,)`` with attraction ``pull (n, 2)`` (:func:`~tin_swarm_env.world.fields.follow_field`)."""
    k = np.maximum(slot, 0)[:, None, None]
    side = np.where(slot >= 0, side, 0)
    rel = np.take_along_axis(d.b_rel, k, axis=1)[:, 0]
    nrm = np.take_along_axis(d.b_normal, k, axis=1)[:, 0]
    return follow_field(pull, rel, nrm, side, params.follow_hold_m, step_m)


@dataclass
class BugMemory:
    """What each robot remembers between steps (arrays over robot rows):

    side      (n,) int8   0: heading for the target; +1: following a dangerous break with it on
                          the robot's right; -1: on its left
    turn      (n,)  rad   while following, the direction of travel (the followed break's
                          tangent) relative to the target's bearing, unwrapped: it counts the
                          turns made round the break (the Pledge algorithm's counter)
    stall     (n,) int    steps it has been following without moving, no robot near
    on_border (n,) bool   the break it followed last step was the terrain's border
    wall      (n,)  rad   direction from the followed break to the robot relative to the target's
                          bearing, last step: the robot keeps to the same break (it goes round
                          the end of a wall in a corridor instead of crossing to the other one)
    start_m   (n,)  m     distance to the target when it started following (its progress mark)
    kept      (n,) bool   it has turned back from a dead end since it started following: it
                          keeps that side (no second dead-end turn) until it leaves the break
    gap       (n,) int8   0: has not driven at a gap in the wall it follows; 1: is driving at one
                          (:func:`pass_gap`); 2: has done so since it started following (one gap
                          per following: a gap that proves to be none is not tried again)
    """

    side: np.ndarray
    turn: np.ndarray
    stall: np.ndarray
    on_border: np.ndarray
    wall: np.ndarray
    start_m: np.ndarray
    kept: np.ndarray
    gap: np.ndarray

    _KEYS = ("side", "turn", "stall", "on_border", "wall", "start_m", "kept", "gap")

    @classmethod
    def empty(cls, n: int) -> BugMemory:
        return cls(np.zeros(n, dtype=np.int8), np.zeros(n), np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool),
                   np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool), np.zeros(n, dtype=np.int8))

    def grow(self, n: int) -> BugMemory:
        if n <= len(self.side):
            return self
        e = BugMemory.empty(n - len(self.side))
        return BugMemory(*(np.concatenate([getattr(self, k), getattr(e, k)]) for k in self._KEYS))


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _angle_to(v, ref):
    """Angle (rad, in [-pi, pi)) from ``ref (n, 2)`` to ``v (n, 2)``, counter-clockwise."""
    return _wrap(np.arctan2(v[:, 1], v[:, 0]) - np.arctan2(ref[:, 1], ref[:, 0]))


def _followed(seen, dist_b, ang, following, last_ang, hold_m):
    """The break slot each robot follows (-1 none): among the dangerous breaks it sees from
    their safe side (``seen (n, K)``), the nearest whose direction to the robot ``ang (n, K)``
    (relative to the target's bearing) lies within 120 degrees of last step's ``last_ang (n,)``
    for a robot already following; the nearest of all when none does, or when one is closer
    than ``hold_m / 2``."""
    cont = seen & (np.abs(_wrap(ang - last_ang[:, None])) < 2 * np.pi / 3) & following[:, None]
    close = seen & (dist_b < hold_m / 2)
    pick = np.where((cont.any(axis=-1) & ~close.any(axis=-1))[:, None], cont, seen)
    k = np.argmin(np.where(pick, dist_b, np.inf), axis=-1)
    return np.where(seen.any(axis=-1), k, -1)


def _sensed(d: DecodedObs, pull, params: FieldParams) -> dict:
    """What :func:`bug_update` reads from the decoded observation, per break slot ``(m, K)``:
    ``dist`` (m), ``e`` (unit vector from the break to the robot, ``(m, K, 2)``), ``facing``
    (dangerous, seen from the safe side), ``into`` (facing, within ``follow_engage_m`` and the
    pull points into it), ``ang`` (``e``'s direction relative to the target's bearing, rad);
    per robot: ``blocked (m,)`` and ``ref (m, 2)`` (the target's bearing)."""
    rel = d.b_rel
    dist = np.sqrt(np.sum(rel * rel, axis=-1))
    face = facing(rel, d.b_normal, d.b_danger)
    e = away_from(rel, d.b_normal)
    into = face & (dist < params.follow_engage_m) & (np.einsum("nj,nkj->nk", pull, e) < 0)
    ref = np.where(d.dist[:, None] > 0, d.rel_t, 1.0)
    ang = _wrap(np.arctan2(e[..., 1], e[..., 0]) - np.arctan2(ref[:, 1], ref[:, 0])[:, None])
    return {"dist": dist, "e": e, "facing": face, "into": into, "ang": ang, "ref": ref,
            "blocked": into.any(axis=-1) & d.has_t}


def _start_side(s: dict, pull) -> tuple[np.ndarray, np.ndarray]:
    """For each robot, the nearest blocking break slot ``(m,)`` and the side ``(m,)`` (+1 / -1)
    whose tangent points more toward the pull; when the break lies square across it (|cos| <
    0.05), the side its heading (body x) already leans to."""
    rows_i = np.arange(len(pull))
    kb = np.argmin(np.where(s["into"], s["dist"], np.inf), axis=-1)
    eb = s["e"][rows_i, kb]
    tb = np.stack([eb[:, 1], -eb[:, 0]], axis=-1)
    pn = pull / np.maximum(np.sqrt(np.sum(pull * pull, axis=-1)), 1e-12)[:, None]
    score = np.sum(tb * pn, axis=-1)
    score = np.where(np.abs(score) < 0.05, tb[:, 0], score)
    return kb, np.where(score >= 0, 1, -1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _closes(q, pi, pj, g, depth_m):
    """``(n,)``: point ``q (n, 2)`` lies in the cone from the robot (the origin) through the gap
    ``pi``-``pj`` and at most ``depth_m`` beyond the gap's line (``g`` its normal, away from the robot)."""
    in_cone = (_cross(pi, q) * _cross(pi, pj) > 0) & (_cross(pj, q) * _cross(pj, pi) > 0)
    depth = np.sum((q - pi) * g, axis=-1)
    return in_cone & (depth > -0.5) & (depth < depth_m)


def pass_gap(d: DecodedObs, width_m: float, reach_m: float, end_deg: float = 5.0) -> dict:
    """A gap between two dangerous breaks that the robot can drive through toward its target,
    read from the break slots of the decoded observation ``d`` (:func:`decode`). A pair of slots
    ``i, j`` (closest points ``p_i``, ``p_j``, body frame) bounds a gap when:

    * both are dangerous breaks seen from their safe side, and both are break *ends*: the robot
      stands past the end of each, so the direction from the closest point to the robot is more
      than ``end_deg`` off the break's normal (square in front of a wall the two are the same;
      two pieces of one straight wall show one point seen square on and one end);
    * they are at least ``width_m`` apart and their midpoint lies within ``reach_m``;
    * the robot and its target lie on opposite sides of the line through ``p_i`` and ``p_j``;
    * nothing sensed closes it: neither the corner where the two breaks' lines would meet (were
      they to run on) nor a third slot's closest point lies in the cone from the robot through
      the gap, beyond its line (a third point: within ``width_m`` beyond).

    Only closest points are sensed (``K_b`` of them), so a wall hidden behind the slots can make
    a gap that is none; the caller keeps the edge cut, which stops the robot a body diameter off
    any break it then senses. Returns ``has (n,)`` bool, ``aim (n, 2)`` (unit: toward the gap's
    midpoint plus the gap's normal toward the target side, so the robot drives through it) and
    ``slots (n, 2)`` (the pair; -1 where none); the nearest gap (by midpoint) wins."""
    rel, nrm = d.b_rel, d.b_normal
    n, k = rel.shape[:2]
    face = facing(rel, nrm, d.b_danger)
    e = away_from(rel, nrm)
    end = face & (np.sum(e * nrm, axis=-1) < np.cos(np.radians(end_deg)))
    rel_t = d.rel_t
    best = np.full(n, np.inf)
    aim = np.zeros((n, 2))
    slots = np.full((n, 2), -1)
    for i in range(k):
        for j in range(i + 1, k):
            pi, pj = rel[:, i], rel[:, j]
            w = pj - pi
            width = np.sqrt(np.sum(w * w, axis=-1))
            mid = 0.5 * (pi + pj)
            mid_d = np.sqrt(np.sum(mid * mid, axis=-1))
            c_robot, c_target = _cross(w, -pi), _cross(w, rel_t - pi)
            ok = (end[:, i] & end[:, j] & (width >= width_m) & (mid_d < reach_m) & (c_robot * c_target < 0)
                  & d.has_t)
            g = np.stack([-w[:, 1], w[:, 0]], axis=-1) / np.maximum(width, 1e-9)[:, None] * np.sign(c_target)[:, None]
            # the corner where the two breaks' lines meet, if they were to run on to it
            ni, nj = nrm[:, i], nrm[:, j]
            det = _cross(ni, nj)
            bi, bj = np.sum(ni * pi, axis=-1), np.sum(nj * pj, axis=-1)
            par = np.abs(det) < 1e-6
            sd = np.where(par, 1.0, det)
            corner = np.stack([(bi * nj[:, 1] - bj * ni[:, 1]) / sd, (ni[:, 0] * bj - nj[:, 0] * bi) / sd], axis=-1)
            ok &= par | ~_closes(corner, pi, pj, g, np.inf)
            for m in range(k):
                if m in (i, j):
                    continue
                ok &= ~(face[:, m] & _closes(rel[:, m], pi, pj, g, width_m))
            take = ok & (mid_d < best)
            best = np.where(take, mid_d, best)
            a = mid / np.maximum(mid_d, 1e-9)[:, None] + g
            aim = np.where(take[:, None], a / np.maximum(np.sqrt(np.sum(a * a, axis=-1)), 1e-9)[:, None], aim)
            slots = np.where(take[:, None], np.array([i, j]), slots)
    return {"has": np.isfinite(best), "aim": aim, "slots": slots}


def bug_update(mem: BugMemory, rows, d: DecodedObs, pull, params: FieldParams, crowd_m: float, gap=None) -> np.ndarray:
    """One step of the bug rules for the robots in ``rows`` (their decoded observations ``d``
    and attraction ``pull (m, 2)``); updates ``mem`` in place and returns the break slot each
    robot follows ``(m,)`` (-1 none).

    * *blocked*: the pull points into a dangerous break seen from its safe side within
      ``follow_engage_m`` (``pull . e < 0``, ``e`` from :func:`~tin_swarm_env.world.fields.away_from`).
    * start: a free robot that is blocked follows the nearest blocking break on the side whose
      tangent points more toward the pull (:func:`_start_side`); it marks its distance to the
      target (``start_m``).
    * follow: the followed break is the one seen within ``break_range_m`` that continues last
      step's (:func:`_followed`); ``turn`` adds up how the direction of travel along it turns
      relative to the target's bearing.
    * leave (Pledge's rule): a following robot that is not blocked and whose counted ``turn``
      is back within 90 degrees of the target's bearing: it has come round the break, not merely
      turned away from it (at the head of a cut in a plateau the counter reads about 180 degrees).
    * turn back (side -> -side, ``turn`` restarts from the new direction), :func:`_turn_back`:
      at the border, when stalled, or at a dead end (the counted turn exceeds
      ``dead_end_turn_deg`` while the robot is no nearer the target than where it started
      following: it went into a pocket or round a tongue; once per following, ``kept``).
    * gap (``gap (m,)`` bool, :func:`pass_gap`): a robot driving through a gap between two break
      ends is not blocked; it keeps its side (and counted turn), so if the gap proves to be none
      it goes on following as before."""
    side, turn = mem.side[rows], mem.turn[rows]
    s = _sensed(d, pull, params)
    n = len(pull)
    if gap is not None:  # driving through a gap: not blocked (the side is kept)
        s["blocked"] &= ~gap
    rows_i = np.arange(n)
    new = (side == 0) & s["blocked"]
    kb, start = _start_side(s, pull)
    side = np.where(new, start, side).astype(np.int8)
    last_wall = np.where(new, s["ang"][rows_i, kb], mem.wall[rows])
    mem.start_m[rows] = np.where(new, d.dist, mem.start_m[rows])
    mem.kept[rows] &= ~new
    # the followed break and the direction of travel along it
    seen = s["facing"] & (s["dist"] < params.break_range_m)
    kf = _followed(seen, s["dist"], s["ang"], side != 0, last_wall, params.follow_hold_m)
    has_wall = kf >= 0
    kc = np.maximum(kf, 0)
    ef = s["e"][rows_i, kc]
    t_left = np.stack([ef[:, 1], -ef[:, 0]], axis=-1)  # tangent with the break on the right
    theta = _angle_to(side[:, None] * t_left, s["ref"])
    turn = np.where(new, theta, turn)
    turn = np.where((side != 0) & ~new & has_wall, turn + _wrap(theta - _wrap(turn)), turn)
    # leave when clear and heading within 90 degrees of the target again, counted
    through = np.zeros(n, dtype=bool) if gap is None else gap  # not while driving through a gap
    side = np.where((side != 0) & ~s["blocked"] & (np.abs(turn) < np.pi / 2) & ~through, 0, side).astype(np.int8)
    on_border = has_wall & d.b_border[rows_i, kc]
    back = _turn_back(mem, rows, d, s, side, turn, t_left, on_border, params, crowd_m) & ~new
    side = np.where(back, -side, side).astype(np.int8)
    mem.side[rows] = side
    mem.turn[rows] = np.where(back, _angle_to(side[:, None] * t_left, s["ref"]), turn)
    mem.stall[rows] = np.where(back, 0, mem.stall[rows])
    mem.kept[rows] &= side != 0
    mem.gap[rows] = np.where((side == 0) | new, 0, mem.gap[rows])
    mem.on_border[rows] = on_border
    mem.wall[rows] = np.where(has_wall, s["ang"][rows_i, kc], last_wall)
    return np.where(side != 0, kf, -1)


def _turn_back(mem: BugMemory, rows, d: DecodedObs, s: dict, side, turn, t_left, on_border, params: FieldParams,
               crowd_m: float) -> np.ndarray:
    """Which following robots turn back ``(m,)``: the followed break becomes the border (it
    cannot be gone round) after one that was not, or the border lies ahead along the followed
    break within ``follow_engage_m``; ``stall_steps`` steps following without moving (speed
    under 5%) with no robot within ``crowd_m`` (a corner); or a dead end (``|turn| >
    dead_end_turn_deg`` and the distance to the target at least ``start_m``, unless ``kept``;
    sets ``kept``). Advances ``mem.stall``."""
    following = side != 0
    ahead = np.einsum("nj,nkj->nk", side[:, None] * t_left, -s["e"]) > 0.3
    border_ahead = (d.b_border & s["facing"] & ahead & (s["dist"] < params.follow_engage_m)).any(axis=-1)
    r_d = np.sqrt(np.sum(d.r_rel ** 2, axis=-1))
    crowded = ((d.r_valid > 0.5) & (r_d < crowd_m)).any(axis=-1)
    stall = np.where(following & (d.speed < 0.05) & ~crowded, mem.stall[rows] + 1, 0)
    mem.stall[rows] = stall
    dead_end = (following & ~mem.kept[rows] & (np.abs(turn) > np.radians(params.dead_end_turn_deg))
                & (d.dist >= mem.start_m[rows]))
    mem.kept[rows] |= dead_end
    return following & (border_ahead | (on_border & ~mem.on_border[rows]) | (stall >= params.stall_steps) | dead_end)


class APFPolicy:
    """The thesis's potential-field controller as a policy: ``act(obs_dict) -> action_dict``
    and ``act_batch(obs (n, d)) -> actions (n, 2)``.

    ``fields``: any subset of ``("robot", "target", "break", "height", "asset")`` (the asset field
    acts only where the observation has asset slots: a scenario with assets); ``params``: gains and
    ranges (:class:`~tin_swarm_env.world.fields.FieldParams`), ``fields`` overriding its own.
    Without ``params``, the containment task widens the robot field's range to 1.1 times the
    arc between robots evenly spread on the standoff ring (from the scenario's robot and threat
    counts), so that robots spread around each threat instead of bunching where they arrive.

    **Memory** (with the break field on): per robot, its wall-following side, how far its
    direction of travel has turned while following, a stall counter, whether it followed the
    border, its distance to the target when it started following and whether it has turned
    back from a dead end since (:class:`BugMemory`; the rules are :func:`bug_update`'s: follow
    a blocking dangerous break on the side whose tangent points more toward the target, keep
    that side until clear of it and heading toward the target again by the turn count, turn
    back at the border, when stuck, or once at a dead end: the counted turn passes
    ``dead_end_turn_deg`` with the robot no nearer the target than where it started).

    **Gaps**: where two sensed break ends leave a gap at least 3 body diameters wide (the edge cut
    keeps one diameter off each side) with the target beyond it and no sensed corner or break
    closing it (:func:`pass_gap`), the robot drives through it: its attraction turns toward the
    gap and through it, the two ends do not push (the edge cut still applies) and it does not
    count as blocked. A robot following a wall at ``follow_hold_m`` would otherwise walk past a
    pass narrower than twice that, and the two ends' break field would close it.
    Rows are robots: ``act_batch`` row ``i`` is robot ``i``; ``act`` maps each agent name to a row
    the first time it sees it. The memory
    grows lazily to the number of rows; :meth:`reset` clears it (call it after each env reset).

    **Crowding and edges**: the summed command is cut by :func:`~tin_swarm_env.policies.base.keep_clear` so that robots that
    see each other never come within 1.5 body diameters (the robot field spreads them; a
    command into the blind sector behind the robot is first turned to the edge of its field of
    view, :func:`~tin_swarm_env.policies.base.into_view`), and,
    with the break field on, so that no robot comes within one body diameter of a dangerous
    break it sees, however long its step.
    """

    def __init__(self, env, fields=FIELDS, params: FieldParams | None = None):
        base = unwrap_env(env)
        cfg = base.config
        self.shield = SafetyShield(env)
        if params is None:
            params = FieldParams()
            n_threats = cfg.targets.n
            if cfg.task == "containment" and n_threats and self.shield.standoff_m > 0:
                # spread around the ring: robots repel out to the arc spacing of an even ring
                per_ring = -(-cfg.robots.count // n_threats)
                spacing = 2 * np.pi * self.shield.standoff_m / max(per_ring, 1)
                params = FieldParams(robot_range_m=max(params.robot_range_m, 1.1 * spacing))
        self.params = FieldParams(**{**params.__dict__, "fields": tuple(fields)})
        self.layout = base.layout
        self.reset()

    def reset(self):
        """Forget every robot's memory (call after each environment reset)."""
        self.memory = BugMemory.empty(0)
        self._rows: dict = {}

    def forces(self, obs, rows=None) -> dict:
        """Per-field forces (:func:`apf_forces`) for observations ``obs (n, d)`` of the robots in
        ``rows`` (default ``0..n-1``); advances their memory by one step."""
        return self._forces(decode(obs, self.layout, self.shield.range_m), rows)

    def _forces(self, d: DecodedObs, rows=None) -> dict:
        f = field_forces(d, self.layout, self.shield.standoff_m, self.params, self.shield.guard_m)
        if not (self.params.on("break") and self.layout.k_breaks):
            return f
        rows = np.arange(len(d.dist)) if rows is None else np.asarray(rows, dtype=np.int64)
        self.memory = self.memory.grow(int(rows.max(initial=-1)) + 1)
        pull = f["target"] + f["height"]
        g = pass_gap(d, self.shield.pass_m, self.params.follow_engage_m)
        # a robot with another one ahead toward the gap queues (the usual fields) instead
        r_d = np.sqrt(np.sum(d.r_rel ** 2, axis=-1))
        ahead = np.einsum("nkj,nj->nk", d.r_rel, g["aim"]) > 0
        queue = ((d.r_valid > 0.5) & ahead & (r_d < 2 * self.params.robot_range_m)).any(axis=-1)
        mem_gap = self.memory.gap[rows]
        has = g["has"] & ~queue & (self.memory.side[rows] != 0) & (mem_gap < 2)
        self.memory.gap[rows] = np.where(has, 1, np.where(mem_gap == 1, 2, mem_gap))
        if has.any():  # the two ends bounding the gap do not push (the edge cut still keeps it off them)
            danger = d.b_danger.copy()
            r = np.flatnonzero(has)
            danger[r, g["slots"][r, 0]] = danger[r, g["slots"][r, 1]] = False
            p = self.params
            f["break"], _ = break_field(d.b_rel, d.b_normal, danger, p.break_gain, p.break_range_m,
                                        p.break_decay_m)
        slot = bug_update(self.memory, rows, d, pull, self.params, 2 * self.params.robot_range_m, gap=has)
        f["follow"] = follow_term(d, pull, self.memory.side[rows], slot, self.params, self.shield.step_m)
        mag = np.sqrt(np.sum(pull * pull, axis=-1, keepdims=True))
        f["follow"] = np.where(has[:, None], mag * g["aim"] - pull, f["follow"])
        return f

    def act_batch(self, obs, rows=None) -> np.ndarray:
        d = decode(obs, self.layout, self.shield.range_m)
        f = sum(self._forces(d, rows).values())
        mag = np.sqrt(np.sum(f * f, axis=-1, keepdims=True))
        return self.shield.cut(f / np.maximum(mag, self.params.speed_saturation), d, edges=self.params.on("break"))

    def act(self, obs: dict) -> dict:
        return act_dict(self.act_batch, obs, [self._rows.setdefault(k, len(self._rows)) for k in obs])
