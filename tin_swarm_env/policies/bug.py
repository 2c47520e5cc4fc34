"""The boundary-following layer of :class:`~tin_swarm_env.policies.APFPolicy`: per-robot memory,
odometry and the bug rules (the rule itself, and why it is complete, is written once, in the
:mod:`tin_swarm_env.policies.apf` module docstring). Everything here is batched over robot rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..world.fields import FieldParams, away_from, facing
from .base import DecodedObs, check_positive_fields

__all__ = ["BugMemory", "BugParams", "RING", "bug_update", "odometry", "pass_gap", "sensed"]

END_DEG = 5.0  # a break's closest point is its end when the direction to the robot is this far off its normal


@dataclass(frozen=True)
class BugParams:
    """Constants of the boundary-following rules (the module docstring of
    :mod:`tin_swarm_env.policies.apf` says what each does).

    margin_m        a robot leaves a boundary only where its distance to go is this much under the
                    distance at which it met the boundary; a new meeting starts a fresh search only
                    this much nearer than the last one (else the robot takes up its search again)
    line_m          on the m-line: within this of it, or crossed it since the last step
    leave_gain      off the m-line, a robot leaves where its distance to go is this share under
                    the distance at H
    home_m          back within this of the hit point, after ``home_arc_m`` or more of boundary
                    driven from it: the robot has gone round the whole boundary
    home_arc_m
    first_budget    along the first side, the search turns back (to try the other side) once the
                    robot's distance to go has grown, summed over its way from H, by this many
                    times the distance to go at H (at least ``min_budget`` sensor ranges); the
                    budget doubles at every turn (the lost-cow search)
    min_budget
    split           where the boundary lies square across the way to the target (the cosine between
                    the pull and the tangent of either side under this), the side its heading
                    already leans to (robots arriving together take the same side)
    stall_crowded   a robot stalled with robots near counts this many times ``stall_steps`` before
                    it gives up the side (with none near: ``stall_steps``)
    ring_m          the loop finder's places (:data:`RING` of them per robot) lie this far apart along
                    the boundary at the start of a leg (the spacing doubles each time the ring fills)
    ring_cos        a place is passed again "going the same way" when the cosine between the robot's
                    step and its direction of travel there is over this
    """

    margin_m: float = 2.0
    line_m: float = 1.0
    leave_gain: float = 0.2
    home_m: float = 5.0
    home_arc_m: float = 30.0
    first_budget: float = 2.0
    min_budget: float = 6.0
    split: float = 0.05
    stall_crowded: int = 4
    ring_m: float = 5.0
    ring_cos: float = 0.7

    def __post_init__(self):  # split, ring_cos are cosines, leave_gain a share
        check_positive_fields(self, {"split": {"hi": 1}, "ring_cos": {"hi": 1}, "leave_gain": {"hi": 1},
                                     "stall_crowded": {"hi": 10**6}})


_FLOAT2 = ("last_rel", "last_act", "hit", "wall_pt", "last_q", "t_hit", "r_pt", "r_dir", "b1_q")
_SPEC = {"seen": bool, "psi": float, "last_rel": float, "last_act": float, "side": np.int8, "fside": np.int8,
         "first": np.int8, "hit": float, "rec": float, "arc": float, "budget": float, "ended_first": bool,
         "ended_other": bool, "unreachable": bool, "stall": np.int64, "wall": float, "on_border": bool,
         "gap": np.int8, "wall_pt": float, "has_pt": bool, "mside": np.int8, "far": bool, "last_q": float,
         "t_hit": float, "passed": bool, "climb": float, "last_togo": float, "probed": bool, "v_steps": np.int64,
         "pt_end": bool, "r_pt": float, "r_dir": float, "r_len": float, "r_next": float,
         "circ": bool, "g_n": np.int64, "g_sp": float, "g_len": float, "g_p": float, "g_d": float,
         "g_s": float, "g_m": float, "g_q": float, "g_h": float, "b1": bool, "b1_q": float, "b1_t": float,
         "lvl": float}
RING = 16  # places in each robot's loop finder (BugMemory.g_*)
_RING1 = ("g_s", "g_m", "g_h")  # (n, RING)
_RING2 = ("g_p", "g_d", "g_q")  # (n, RING, 2)


def _shape(k: str, n: int) -> tuple:
    return (n, RING, 2) if k in _RING2 else (n, RING) if k in _RING1 else (n, 2) if k in _FLOAT2 else (n,)


@dataclass
class BugMemory:
    """What each robot remembers between steps, arrays over robot rows (``n`` rows, grown lazily).

    Odometry (the robot's own frame ``F``: its heading at its first step is F's x axis):

    seen         (n,)   bool   it has acted at least once
    psi          (n,)   rad    its heading in ``F`` (:func:`odometry`)
    last_rel     (n, 2) m      the vector to its target last step, body frame
    last_act     (n, 2)        its command last step, body frame

    Boundary search:

    side         (n,)   int8   0: heading for its target; +1 following a boundary (a dangerous break)
                               with it on the robot's right, -1 on its left
    fside        (n,)   int8   the side of the current search (kept while it heads for the target)
    first        (n,)   int8   the side the current search started on
    hit          (n, 2) m      the hit point H (where the search started), in ``F`` relative to the target
    rec          (n,)   m      distance to go at H (inf before the first search)
    arc          (n,)   m      boundary driven from H, signed: + along the first side's direction
    budget       (n,)   m      how far from H (in ``arc``) it goes before it turns back (doubles per turn)
    ended_first  (n,)   bool   the boundary ended (the terrain's border, a pinch) on the first side
    ended_other  (n,)   bool   ... on the other side
    unreachable  (n,)   bool   it has shown its target unreachable from where it is (it stops)
    stall        (n,)   int    steps following without moving
    wall         (n,)   rad    direction in ``F`` from the followed break to the robot, last step
    on_border    (n,)   bool   the break it followed last step was the terrain's border
    gap          (n,)   int8   0: no gap tried; 1: driving through one; 2: tried one in this search
    wall_pt      (n, 2) m      the followed break's closest point last seen, in ``F`` relative to the target
    has_pt       (n,)   bool   ``wall_pt`` holds a point (the robot is following)
    mside        (n,)   int8   the side of the line from its target to H (the m-line) it was on last step
    far          (n,)   bool   it has been more than ``4 home_m`` from H since it last passed H
    last_q       (n, 2) m      its position last step, in ``F`` relative to the target
    t_hit        (n, 2)        its direction of travel along the boundary when it left H (first side), in ``F``
    passed       (n,)   bool   it has not turned back since it last passed H (or set off from it)
    climb        (n,)   m      how much its distance to go has grown, summed, since it last set off from H
                               (or passed it) on this side: the search's budget is spent in it
    last_togo    (n,)   m      its distance to go last step
    probed       (n,)   bool   it left this search on a clear view that proved wrong (no second such leave
                               until it has shown it goes round a loop: ``r_pt``)
    r_pt         (n, 2) m      a place on its way since then (Brent's cycle finding: moved on to where
                               it is whenever it has driven ``r_next`` from the last one, ``r_next``
                               doubling), in ``F`` relative to the target
    r_dir        (n, 2)        its direction of travel along the boundary there, in ``F``
    r_len        (n,)   m      boundary driven since ``r_pt``
    r_next       (n,)   m      how far it drives before ``r_pt`` moves on
    v_steps      (n,)   int    steps it has followed the remembered point (its break out of its slots)
    pt_end       (n,)   bool   ``wall_pt`` was seen at its break's end (not square on to it)
    circ         (n,)   bool   it came back round to H once in this search (and turned back)

    Loop finder (one *leg*: the boundary driven since the robot last met a boundary, turned, or drove
    through a gap; the places are cleared then):

    g_n          (n,)   int    places held (at most :data:`RING`; 0: not following)
    g_sp         (n,)   m      boundary driven between two places (``ring_m``, doubled each time the
                               ring fills: every other place is dropped, so the places always span the leg)
    g_len        (n,)   m      boundary driven on this leg
    g_p          (n, R, 2) m   the places, in ``F`` relative to the target
    g_d          (n, R, 2)     the direction of travel along the boundary at each
    g_s          (n, R) m      ``g_len`` at each
    g_m          (n, R) m      the least distance to go from each place to the next (or to here)
    g_q          (n, R, 2) m   where it was
    g_h          (n, R) m      the least distance from ``H`` over the same stretch
    b1           (n,)   bool   it has driven round a closed boundary and heads round it for ``b1_q``,
                               the place of least distance to go on the lap (Bug1's leave point)
    b1_q         (n, 2) m      that place, in ``F`` relative to the target
    b1_t         (n,)   m      the distance to go there
    lvl          (n,)   m      the distance to go where it last left a boundary at such a place in this
                               search (inf: not yet); the next such leave must be ``margin_m`` nearer
    """

    seen: np.ndarray
    psi: np.ndarray
    last_rel: np.ndarray
    last_act: np.ndarray
    side: np.ndarray
    fside: np.ndarray
    first: np.ndarray
    hit: np.ndarray
    rec: np.ndarray
    arc: np.ndarray
    budget: np.ndarray
    ended_first: np.ndarray
    ended_other: np.ndarray
    unreachable: np.ndarray
    stall: np.ndarray
    wall: np.ndarray
    on_border: np.ndarray
    gap: np.ndarray
    wall_pt: np.ndarray
    has_pt: np.ndarray
    mside: np.ndarray
    far: np.ndarray
    last_q: np.ndarray
    t_hit: np.ndarray
    passed: np.ndarray
    climb: np.ndarray
    last_togo: np.ndarray
    probed: np.ndarray
    v_steps: np.ndarray
    pt_end: np.ndarray
    r_pt: np.ndarray
    r_dir: np.ndarray
    r_len: np.ndarray
    r_next: np.ndarray
    circ: np.ndarray
    g_n: np.ndarray
    g_sp: np.ndarray
    g_len: np.ndarray
    g_p: np.ndarray
    g_d: np.ndarray
    g_s: np.ndarray
    g_m: np.ndarray
    g_q: np.ndarray
    g_h: np.ndarray
    b1: np.ndarray
    b1_q: np.ndarray
    b1_t: np.ndarray
    lvl: np.ndarray

    @classmethod
    def empty(cls, n: int) -> BugMemory:
        out = {k: np.zeros(_shape(k, n), dtype=t) for k, t in _SPEC.items()}
        out["rec"][:] = np.inf
        out["lvl"][:] = np.inf
        return cls(**out)

    def grow(self, n: int) -> BugMemory:
        """This memory with at least ``n`` rows (new rows empty)."""
        if n <= len(self.side):
            return self
        e = BugMemory.empty(n - len(self.side))
        return BugMemory(**{k: np.concatenate([getattr(self, k), getattr(e, k)]) for k in _SPEC})


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _norm(v):
    return np.sqrt(np.sum(v * v, axis=-1))


def _rot(psi, v):
    """``v (n, 2)`` rotated by ``psi (n,)`` (counter-clockwise)."""
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=-1)


def odometry(mem: BugMemory, rows, d: DecodedObs, step_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Advance the robots' heading ``psi`` in their own frame from what the observation gives, and
    return ``(q (m, 2), moved (m,))``: each robot's position relative to its target in its frame
    ``F`` and the distance it moved last step.

    The robot moved last step along its own command (body frame of then), by the speed the
    observation reports (``own.speed``, a fraction of top speed, times ``step_m``): ``delta``. Its
    target (a fixed point) was at ``last_rel`` then, so it is at ``last_rel - delta`` in the old
    body frame and at ``rel_t`` in the new one: the heading turned by the angle between the two.
    The position is then ``q = -R(psi) rel_t``: exact up to the observation's float32 rounding, as
    long as the target stands still (a mobile target drags the frame along)."""
    a = mem.last_act[rows]
    an = _norm(a)
    moved = np.where(an > 1e-9, d.speed * step_m, 0.0)
    delta = a / np.maximum(an, 1e-9)[:, None] * moved[:, None]
    v = mem.last_rel[rows] - delta
    ok = mem.seen[rows] & d.has_t & (_norm(v) > 0.5) & (d.dist > 0.5)
    turn = _wrap(np.arctan2(v[:, 1], v[:, 0]) - np.arctan2(d.rel_t[:, 1], d.rel_t[:, 0]))
    psi = mem.psi[rows] + np.where(ok, turn, 0.0)
    mem.psi[rows] = psi
    mem.last_rel[rows] = d.rel_t
    mem.seen[rows] |= d.has_t
    return -_rot(psi, d.rel_t), np.where(mem.seen[rows], moved, 0.0)


def _followed(seen, dist_b, ang, following, last_ang, hold_m, v_ok, v_ang, defer=None):
    """The break slot each robot follows (-1 none, ``K`` the remembered point). For a robot
    already following: among the dangerous breaks it sees from their safe side (``seen (n, K)``)
    whose direction to the robot ``ang (n, K)`` (in the robot's frame) lies within 120 degrees of
    last step's ``last_ang (n,)`` (*continuing*), the nearest that is not deferred (``defer (n, K)``:
    another break's end across an open gap from the point it followed); when none is, the point
    it followed last (``v_ok (n,)``, direction ``v_ang (n,)``), so that it goes round the end of a
    break that has dropped out of its slots instead of jumping the gap; else the nearest
    continuing break, else the nearest of all; and the nearest of all whenever one is closer
    than ``hold_m / 2``."""
    k_n = seen.shape[1]
    cont = seen & (np.abs(_wrap(ang - last_ang[:, None])) < 2 * np.pi / 3) & following[:, None]
    ok = cont if defer is None else cont & ~defer
    v_cont = v_ok & following & (np.abs(_wrap(v_ang - last_ang)) < 2 * np.pi / 3)
    close = (seen & (dist_b < hold_m / 2)).any(axis=-1)
    has_ok, has_cont = ok.any(axis=-1) & ~close, cont.any(axis=-1) & ~close
    virtual = ~close & v_cont & ~has_ok
    pick = np.where(has_ok[:, None], ok, np.where(has_cont[:, None], cont, seen))
    k = np.argmin(np.where(pick, dist_b, np.inf), axis=-1)
    k = np.where(seen.any(axis=-1), k, -1)
    return np.where(virtual, k_n, k)


def sensed(d: DecodedObs, pull, params: FieldParams) -> dict:
    """Per break slot ``(m, K)``: ``dist`` (m), ``e`` (unit vector from the break to the robot,
    ``(m, K, 2)``), ``facing`` (dangerous, seen from the safe side), ``into`` (facing, within
    ``follow_engage_m`` and the pull points into it); per robot ``blocked (m,)``."""
    rel = d.b_rel
    dist = _norm(rel)
    face = facing(rel, d.b_normal, d.b_danger)
    e = away_from(rel, d.b_normal)
    into = face & (dist < params.follow_engage_m) & (np.einsum("nj,nkj->nk", pull, e) < 0)
    return {"dist": dist, "e": e, "facing": face, "into": into, "blocked": into.any(axis=-1) & d.has_t}


def _start_side(s: dict, pull, rows, split: float) -> tuple[np.ndarray, np.ndarray]:
    """For each robot, the nearest blocking break slot ``(m,)`` and the side ``(m,)`` (+1 / -1)
    whose tangent points more toward the pull; when the break lies nearly square across it
    (|cos| < ``split``), the side its heading (body x) already leans to."""
    rows_i = np.arange(len(pull))
    kb = np.argmin(np.where(s["into"], s["dist"], np.inf), axis=-1)
    eb = s["e"][rows_i, kb]
    tb = np.stack([eb[:, 1], -eb[:, 0]], axis=-1)
    pn = pull / np.maximum(_norm(pull), 1e-12)[:, None]
    score = np.sum(tb * pn, axis=-1)
    score = np.where(np.abs(score) < split, tb[:, 0], score)
    return kb, np.where(score >= 0, 1, -1)


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _closes(q, pi, pj, g, depth_m):
    """``(n,)``: point ``q (n, 2)`` lies in the cone from the robot (the origin) through the gap
    ``pi``-``pj`` and at most ``depth_m`` beyond the gap's line (``g`` its normal, away from the robot)."""
    in_cone = (_cross(pi, q) * _cross(pi, pj) > 0) & (_cross(pj, q) * _cross(pj, pi) > 0)
    depth = np.sum((q - pi) * g, axis=-1)
    return in_cone & (depth > -0.5) & (depth < depth_m)


def pass_gap(d: DecodedObs, width_m: float, reach_m: float, end_deg: float = END_DEG) -> dict:
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


def _ring(mem: BugMemory, rows, bp: BugParams, *, new, on, g_len, togo, q, to_h, t_now):
    """Advance the loop finder's places (``BugMemory.g_*``) of the robots in ``rows``: a leg starts
    where ``new`` (one place, here), stops where not ``on``; otherwise the last stretch's least
    distance to go (and from H) takes this step in, and a place is added every ``g_sp`` of boundary;
    a full ring keeps every other place (merging their stretches) and doubles ``g_sp``."""
    n_g, sp = mem.g_n[rows], mem.g_sp[rows]
    g = {k: getattr(mem, k)[rows] for k in ("g_p", "g_d", "g_s", "g_m", "g_q", "g_h")}
    ri = np.arange(len(rows))
    k = np.maximum(n_g - 1, 0)
    better = togo < g["g_m"][ri, k]
    g["g_m"][ri, k] = np.where(better, togo, g["g_m"][ri, k])
    g["g_q"][ri, k] = np.where(better[:, None], q, g["g_q"][ri, k])
    g["g_h"][ri, k] = np.minimum(g["g_h"][ri, k], to_h)
    add = on & ~new & (n_g > 0) & (g_len - g["g_s"][ri, k] >= sp)
    full = add & (n_g >= RING)
    if full.any():
        f = np.flatnonzero(full)
        a, b = np.arange(0, RING, 2), np.arange(1, RING, 2)
        take_b = g["g_m"][f][:, b] < g["g_m"][f][:, a]
        for key in ("g_p", "g_d", "g_s"):
            g[key][f, : RING // 2] = g[key][f][:, a]
        g["g_q"][f, : RING // 2] = np.where(take_b[..., None], g["g_q"][f][:, b], g["g_q"][f][:, a])
        g["g_m"][f, : RING // 2] = np.minimum(g["g_m"][f][:, a], g["g_m"][f][:, b])
        g["g_h"][f, : RING // 2] = np.minimum(g["g_h"][f][:, a], g["g_h"][f][:, b])
        n_g = np.where(full, RING // 2, n_g)
        sp = np.where(full, 2 * sp, sp)
    at = np.where(new, 0, np.where(add, n_g, 0))
    put = new | add
    for key, v in (("g_p", q), ("g_d", t_now), ("g_q", q)):
        g[key][ri, at] = np.where(put[:, None], v, g[key][ri, at])
    for key, v in (("g_s", np.where(new, 0.0, g_len)), ("g_m", togo), ("g_h", to_h)):
        g[key][ri, at] = np.where(put, v, g[key][ri, at])
    n_g = np.where(new, 1, np.where(add, n_g + 1, n_g))
    for key, v in g.items():
        getattr(mem, key)[rows] = v
    mem.g_n[rows] = np.where(on, n_g, 0)
    mem.g_sp[rows] = np.where(new, bp.ring_m, sp)
    mem.g_len[rows] = np.where(new | ~on, 0.0, g_len)


def _round_hit(mem: BugMemory, rows, bp: BugParams, *, q, hit, side, first, following, arc, togo, home: bool):
    """Rule 5's whole-circuit test: back at the hit point, heading on out, after driving round it
    (passing H on the way back from a turn, the robot's boundary coordinate starts again from 0
    there); and the distance-to-go growth the turn-back budget counts. Returns ``(to_h, far, step,
    sl, circuit, back, arc, passed, climb)``: ``step`` last step's move, ``sl`` its squared length."""
    to_h = _norm(q - hit)
    far = (mem.far[rows] | (to_h > 4 * bp.home_m)) & following
    step = q - mem.last_q[rows]  # last step's move, and its closest approach to H
    sl = np.sum(step * step, axis=-1)
    u = np.clip(np.sum((hit - mem.last_q[rows]) * step, axis=-1) / np.maximum(sl, 1e-12), 0.0, 1.0)
    near = following & (_norm(mem.last_q[rows] + u[:, None] * step - hit) < bp.home_m)
    out_now = np.where(side == first, 1.0, -1.0)
    same_way = np.sum(step * mem.t_hit[rows], axis=-1) * out_now > 0.5 * np.sqrt(sl)
    passed = mem.passed[rows]
    circuit = near & far & passed & same_way & (np.abs(arc) > bp.home_arc_m) & home
    back = near & ~passed  # on its way back from a turn: it passes H and goes on to the other side
    arc = np.where(back, 0.0, arc)
    far &= ~back
    passed |= back
    rise = np.where(mem.seen[rows] & following & passed, np.maximum(togo - mem.last_togo[rows], 0.0), 0.0)
    climb = np.where(back, 0.0, mem.climb[rows] + rise)
    return to_h, far, step, sl, circuit, back, arc, passed, climb


def _leave_rules(mem: BugMemory, rows, d: DecodedObs, s: dict, params: FieldParams, bp: BugParams, *, q, hit, togo,
                 rec, following, step, sl, moved, range_m: float, home: bool, blocked, through):
    """Rules 2 and 3's leaves (Bug2's m-line, DistBug's clear view) and the clear view's ban after one
    proved wrong. Returns ``(hn, leave, probed, round_r, r_len)``: ``hn`` the unit direction of H
    (the m-line's), ``round_r`` robots back round the cycle finder's place (the ban lifted)."""
    # leave (Bug2): on the m-line (the line from H to the target), the way to the target clear, and
    # nearer than where it met the boundary
    hn = hit / np.maximum(_norm(hit), 1e-9)[:, None]
    off = q[:, 0] * hn[:, 1] - q[:, 1] * hn[:, 0]  # signed distance from the m-line
    mside = np.where(off >= 0, 1, -1)
    on_line = (np.abs(off) < bp.line_m) | (mside != mem.mside[rows]) | (togo < (1.0 - bp.leave_gain) * rec)
    # ... or (DistBug's range rule) where it sees the way to the target clear of dangerous breaks
    # as far as it senses and the clear stretch would bring it nearer than H
    ut = d.rel_t / np.maximum(d.dist, 1e-9)[:, None]
    along = np.einsum("nkj,nj->nk", d.b_rel, ut)
    across = np.abs(d.b_rel[..., 0] * ut[:, None, 1] - d.b_rel[..., 1] * ut[:, None, 0])
    reach = np.minimum(range_m, d.dist)
    in_way = s["facing"] & (along > 0) & (along < reach[:, None]) & (across < params.follow_hold_m)
    # the followed break's point last seen counts too: it may have dropped out of the K_b slots (or
    # into the blind sector) for a step as the robot turns, which is no clear view
    p_rel = _rot(-mem.psi[rows], mem.wall_pt[rows] - q)
    p_along = np.sum(p_rel * ut, axis=-1)
    p_across = np.abs(p_rel[:, 0] * ut[:, 1] - p_rel[:, 1] * ut[:, 0])
    p_way = mem.has_pt[rows] & following & (p_along > 0) & (p_along < reach) & (p_across < params.follow_hold_m)
    in_way = np.concatenate([in_way, p_way[:, None]], axis=-1)
    # after such a leave proved wrong (probed), not again until it comes back to a place it passed
    # since (r_pt, Brent's cycle finding) going the same way, with home_arc_m or more driven from it: it
    # goes round a loop that H is not on (an island reached through a gap) and may leave it on a clear
    # view (passing it the other way, it retraces its way after a turn: no loop)
    r_len = mem.r_len[rows] + np.where(following, moved, 0.0)
    u_r = np.clip(np.sum((mem.r_pt[rows] - mem.last_q[rows]) * step, axis=-1) / np.maximum(sl, 1e-12), 0.0, 1.0)
    r_near = following & (_norm(mem.last_q[rows] + u_r[:, None] * step - mem.r_pt[rows]) < bp.home_m)
    r_near &= np.sum(step * mem.r_dir[rows], axis=-1) > 0.5 * np.sqrt(sl)
    round_r = r_near & (r_len > bp.home_arc_m) & mem.probed[rows] & home
    probed = mem.probed[rows] & ~round_r
    clear = ~in_way.any(axis=-1) & ~probed & (togo - reach < rec - bp.margin_m)
    leave = following & ~blocked & ~through & (togo < rec - bp.margin_m) & on_line
    leave |= following & ~blocked & ~through & clear
    return hn, leave, probed, round_r, r_len


def _lap_leave(mem: BugMemory, rows, bp: BugParams, *, q, togo, to_h, following, moved, step, sl, through,
               home: bool):
    """The loop finder (Bug1 on whatever boundary the robot is on): passing a place of its leg again
    going the same way, home_arc_m or more after it (and 2 home_m away from it on the way), it has
    driven round a closed boundary. A lap that passes H is the whole-circuit test's (rule 5); on any
    other, it goes round once more to the lap's place of least distance to go and leaves there
    (Bug1), rec and probed aside, if that place is margin_m nearer than its last such leave in this
    search (so there are finitely many); else it follows on (budget, border, stall end that side).
    Returns ``(g_len, at_b1, lvl, b1, b1_q, b1_t)``: ``at_b1`` the robots at their Bug1 leave."""
    ri = np.arange(len(rows))
    held = np.arange(RING)[None, :] < mem.g_n[rows][:, None]
    g_len = mem.g_len[rows] + np.where(following, moved, 0.0)
    g_p, lq = mem.g_p[rows], mem.last_q[rows]
    u_g = np.clip(np.einsum("nkj,nj->nk", g_p - lq[:, None], step) / np.maximum(sl, 1e-12)[:, None], 0.0, 1.0)
    d_g = _norm(lq[:, None] + u_g[..., None] * step[:, None] - g_p)
    same = np.einsum("nkj,nj->nk", mem.g_d[rows], step) > bp.ring_cos * np.sqrt(sl)[:, None]
    hit_g = held & (d_g < bp.home_m) & same & (g_len[:, None] - mem.g_s[rows] > bp.home_arc_m)
    found = following & hit_g.any(axis=-1) & ~through & home
    j = RING - 1 - np.argmax(hit_g[:, ::-1], axis=-1)  # the latest such place: the lap starts there
    on_lap = held & (np.arange(RING)[None, :] >= j[:, None])
    # a lap goes somewhere: a place on it lies more than 2 home_m from its start (swinging in a corner,
    # the robot passes the same place the same way again without going round anything)
    found &= (on_lap & (_norm(g_p - g_p[ri, j][:, None]) > 2 * bp.home_m)).any(axis=-1)
    g_m = np.where(on_lap, mem.g_m[rows], np.inf)
    kmin = np.argmin(g_m, axis=-1)
    lap_t, lap_q = g_m[ri, kmin], mem.g_q[rows][ri, kmin]
    now = togo < lap_t
    lap_t, lap_q = np.where(now, togo, lap_t), np.where(now[:, None], q, lap_q)
    h_lap = np.minimum(np.where(on_lap, mem.g_h[rows], np.inf).min(axis=-1), to_h) < bp.home_m
    lvl = mem.lvl[rows]
    go = found & ~h_lap & (lap_t < lvl - bp.margin_m)
    b1 = (mem.b1[rows] & following) | go
    b1_q, b1_t = np.where(go[:, None], lap_q, mem.b1_q[rows]), np.where(go, lap_t, mem.b1_t[rows])
    u_b = np.clip(np.sum((b1_q - lq) * step, axis=-1) / np.maximum(sl, 1e-12), 0.0, 1.0)
    # there: within home_m of it, and as near as it was or past its least (its distance to go rising again)
    at_b1 = b1 & ~through & ((togo <= b1_t + bp.line_m / 2) | (togo > mem.last_togo[rows])) & (
        (_norm(lq + u_b[:, None] * step - b1_q) < bp.home_m) | (_norm(q - b1_q) < bp.home_m))
    lvl = np.where(at_b1, togo, lvl)
    b1 &= ~at_b1
    return g_len, at_b1, lvl, b1, b1_q, b1_t


def _followed_break(mem: BugMemory, rows, d: DecodedObs, s: dict, params: FieldParams, *, q, met, kb, following,
                    pass_m: float, step_m: float, fov_deg: float):
    """The break each robot follows: it continues last step's (directions in the robot's frame);
    meeting a boundary (a fresh search or one taken up again), the break that blocks it; else the
    remembered point (``virtual``). Returns ``(psi, ang, last_wall, kf, virtual, has_wall, kc, f_rel,
    f_nrm, t_right, v_ang, cand_end)``: slot ``kc`` (``kf`` -1 none, ``K_b`` the remembered point),
    its closest point, normal and tangent with the break on the right."""
    ri = np.arange(len(rows))
    psi = mem.psi[rows]
    k_n = d.b_rel.shape[1]
    ang = np.arctan2(s["e"][..., 1], s["e"][..., 0]) + psi[:, None]
    # meeting a boundary (a fresh search or one taken up again), it follows the break that blocks it
    last_wall = np.where(met, ang[ri, np.minimum(kb, k_n - 1)], mem.wall[rows])
    seen = s["facing"] & (s["dist"] < params.break_range_m)
    v_rel = _rot(-psi, mem.wall_pt[rows] - q)  # the remembered point, body frame
    v_d = _norm(v_rel)
    v_ok = mem.has_pt[rows] & ~met & (v_d > 1e-6) & (v_d < params.break_range_m)
    v_e = -v_rel / np.maximum(v_d, 1e-6)[:, None]
    v_ang = np.arctan2(v_e[:, 1], v_e[:, 0]) + psi
    # a break seen at its end whose closest point lies a passable gap (pass_m) from the point the
    # robot followed: the way between the two is open, and the boundary it follows goes round its own
    # end (which may have dropped out of its K_b slots); deferred for half a turn round that end.
    # Not when the remembered point was seen square on and now lies behind, in the blind sector
    # (fov_deg): the break runs on past it out of view, and a break ahead closes a corner with it
    cand_end = np.sum(s["e"] * d.b_normal, axis=-1) < np.cos(np.radians(END_DEG))
    young = mem.v_steps[rows] * step_m < np.pi * params.follow_hold_m
    in_view = np.abs(np.arctan2(v_rel[:, 1], v_rel[:, 0])) <= np.radians(min(fov_deg, 360.0)) / 2
    v_end = v_ok & young & (mem.pt_end[rows] | in_view)
    defer = (_norm(d.b_rel - v_rel[:, None, :]) > pass_m) & cand_end & v_end[:, None] if pass_m else None
    kf = _followed(seen, s["dist"], ang, following, last_wall, params.follow_hold_m, v_ok, v_ang, defer)
    virtual = kf == k_n
    has_wall = (kf >= 0) & ~virtual
    kc = np.clip(kf, 0, k_n - 1)
    ef = np.where(virtual[:, None], v_e, s["e"][ri, kc])
    f_rel = np.where(virtual[:, None], v_rel, d.b_rel[ri, kc])
    f_nrm = np.where(virtual[:, None], v_e, d.b_normal[ri, kc])
    t_right = np.stack([ef[:, 1], -ef[:, 0]], axis=-1)  # tangent with the break on the right
    return psi, ang, last_wall, kf, virtual, has_wall, kc, f_rel, f_nrm, t_right, v_ang, cand_end


def _ends_and_turns(mem: BugMemory, rows, d: DecodedObs, s: dict, params: FieldParams, bp: BugParams, *, side,
                    first, following, fresh, passed, circuit, climb, budget, ended_f, ended_o, unreach, has_wall,
                    kc, t_right, crowd_m: float):
    """Where a side ends (the terrain's border, a pinch, a stall, the first time round to H) and
    where the search turns back (the other side not yet ended, or the budget spent); both sides
    ended, or round H twice: the target is unreachable. Returns ``(side, budget, ended_f, ended_o,
    unreach, circ, turn, stall, on_border)``."""
    ri = np.arange(len(side))
    # the boundary ends on this side: the terrain's border, or a pinch the robot cannot pass
    on_border = has_wall & d.b_border[ri, kc]
    ahead = np.einsum("nj,nkj->nk", side[:, None] * t_right, -s["e"]) > 0.3
    border_ahead = (d.b_border & s["facing"] & ahead & (s["dist"] < params.follow_engage_m)).any(axis=-1)
    r_d = _norm(d.r_rel)
    crowded = ((d.r_valid > 0.5) & (r_d < crowd_m)).any(axis=-1)
    stall = np.where(following & (d.speed < 0.05), mem.stall[rows] + 1, 0)
    stuck = stall >= np.where(crowded, bp.stall_crowded * params.stall_steps, params.stall_steps)
    # an end counts only heading out (passed: it has not turned back since it last passed H): on its
    # way back to H after a turn it retraces boundary it has driven, so a border or a stall met there
    # (the corner it just turned in, a queue) ends nothing, least of all the side it has not tried yet
    # the first time round to H ends that side (the robot turns back and tries the other way, on which
    # a boundary sensed only through K_b slots may show the opening it walked past); the second is a verdict
    circ = mem.circ[rows] & ~fresh
    ends = following & ~fresh & ((passed & (border_ahead | (on_border & ~mem.on_border[rows]) | stuck
                                            | (circuit & ~circ))))
    out = np.where(side == first, 1, -1)  # +1: heading out along the first side
    ended_f |= ends & (out == 1)
    ended_o |= ends & (out == -1)
    other_ended = np.where(out == 1, ended_o, ended_f)
    over = following & ~ends & ~fresh & (climb > budget) & ~other_ended
    turn = (ends & ~other_ended) | over
    budget = np.where(over, 2.0 * budget, budget)
    unreach |= (ends & other_ended) | (circuit & circ)
    circ |= circuit
    side = np.where(turn, -side, side)
    side = np.where(unreach, 0, side)
    stall = np.where(turn | (side == 0), 0, stall)
    return side, budget, ended_f, ended_o, unreach, circ, turn, stall, on_border


def bug_update(mem: BugMemory, rows, d: DecodedObs, pull, params: FieldParams, bp: BugParams, *, togo, q, moved,
               crowd_m: float, range_m: float, gap=None, home: bool = True, pass_m: float = 0.0,
               step_m: float = 1.0, fov_deg: float = 360.0):
    """One step of the boundary search for the robots in ``rows`` (decoded observations ``d``,
    attraction ``pull (m, 2)``, distance to go ``togo (m,)``, position ``q (m, 2)`` and distance
    moved last step ``moved (m,)`` from :func:`odometry`); updates ``mem`` in place and returns
    what each robot follows: ``(rel (m, 2), normal (m, 2), side (m,))``, the closest point of the
    followed break (or the remembered one) in the body frame, its normal and the side (0 none),
    for :func:`~tin_swarm_env.world.fields.follow_field`. The rules are the
    :mod:`~tin_swarm_env.policies.apf` module docstring's; ``gap (m,)`` marks robots driving
    through a gap (:func:`pass_gap`: not blocked, they keep their side), ``home=False`` (a mobile
    target, whose frame drifts) turns the whole-circuit test off; ``fov_deg`` is the sensor's field of view."""
    side, first = mem.side[rows].astype(np.int64), mem.first[rows].astype(np.int64)
    following = side != 0
    # the boundary driven since the hit point, signed (+ along the first side's direction)
    arc = mem.arc[rows] + np.where(following, np.where(side == first, 1.0, -1.0) * moved, 0.0)
    hit, rec, budget = mem.hit[rows], mem.rec[rows], mem.budget[rows]
    ended_f, ended_o, unreach = mem.ended_first[rows], mem.ended_other[rows], mem.unreachable[rows]
    s = sensed(d, pull, params)
    blocked = s["blocked"] & ~unreach
    through = np.zeros(len(rows), dtype=bool) if gap is None else np.asarray(gap, dtype=bool)
    blocked &= ~through
    to_h, far, step, sl, circuit, back, arc, passed, climb = _round_hit(
        mem, rows, bp, q=q, hit=hit, side=side, first=first, following=following, arc=arc, togo=togo, home=home)
    hn, leave, probed, round_r, r_len = _leave_rules(
        mem, rows, d, s, params, bp, q=q, hit=hit, togo=togo, rec=rec, following=following, step=step, sl=sl,
        moved=moved, range_m=range_m, home=home, blocked=blocked, through=through)
    g_len, at_b1, lvl, b1, b1_q, b1_t = _lap_leave(mem, rows, bp, q=q, togo=togo, to_h=to_h, following=following,
                                                   moved=moved, step=step, sl=sl, through=through, home=home)
    leave |= at_b1 & ~blocked  # blocked there, it meets the break in its way at once (rule 1)
    side = np.where(leave | at_b1, 0, side)
    # meet a boundary: a fresh search when nearer than the last hit point, else take the last one up again
    met = (side == 0) & blocked & ~leave
    fresh = met & (togo < rec - bp.margin_m)
    probed |= met & ~fresh
    kb, start = _start_side(s, pull, rows, bp.split)
    side = np.where(fresh, start, np.where(met, mem.fside[rows], side))
    first = np.where(fresh, start, first)
    hit = np.where(fresh[:, None], q, hit)
    rec = np.where(fresh, togo, rec)
    arc = np.where(fresh, 0.0, arc)
    budget = np.where(fresh, np.maximum(bp.first_budget * togo, bp.min_budget * range_m), budget)
    ended_f &= ~fresh
    ended_o &= ~fresh
    following = side != 0
    psi, ang, last_wall, kf, virtual, has_wall, kc, f_rel, f_nrm, t_right, v_ang, cand_end = _followed_break(
        mem, rows, d, s, params, q=q, met=met, kb=kb, following=following, pass_m=pass_m, step_m=step_m,
        fov_deg=fov_deg)
    side, budget, ended_f, ended_o, unreach, circ, turn, stall, on_border = _ends_and_turns(
        mem, rows, d, s, params, bp, side=side, first=first, following=following, fresh=fresh, passed=passed,
        circuit=circuit, climb=climb, budget=budget, ended_f=ended_f, ended_o=ended_o, unreach=unreach,
        has_wall=has_wall, kc=kc, t_right=t_right, crowd_m=crowd_m)
    # write back: the search
    mem.side[rows] = side
    mem.fside[rows] = np.where(side != 0, side, mem.fside[rows])
    mem.first[rows] = first
    mem.hit[rows], mem.rec[rows], mem.arc[rows], mem.budget[rows] = hit, rec, arc, budget
    mem.ended_first[rows], mem.ended_other[rows], mem.unreachable[rows] = ended_f, ended_o, unreach
    mem.stall[rows] = stall
    mem.far[rows] = far & ~fresh
    mem.passed[rows] = (passed | fresh) & ~turn
    mem.climb[rows] = np.where(fresh | turn, 0.0, climb)
    mem.probed[rows] = probed & ~fresh
    mem.circ[rows] = circ
    mem.lvl[rows] = np.where(fresh, np.inf, lvl)
    mem.b1[rows] = b1 & (side != 0) & ~turn & ~fresh
    mem.b1_q[rows], mem.b1_t[rows] = b1_q, b1_t
    t_now = _rot(psi, side[:, None] * t_right)  # the direction of travel along the followed break
    _ring(mem, rows, bp, new=(side != 0) & (met | turn | through | (mem.g_n[rows] == 0)), on=side != 0,
          g_len=g_len, togo=togo, q=q, to_h=_norm(q - hit), t_now=t_now)
    _remember(mem, rows, d, bp, q=q, hn=hn, side=side, met=met, fresh=fresh, round_r=round_r, r_len=r_len,
              t_now=t_now, togo=togo, on_border=on_border, ang=ang, last_wall=last_wall, kc=kc, has_wall=has_wall,
              virtual=virtual, v_ang=v_ang, psi=psi, cand_end=cand_end)
    on = (side != 0) & (kf >= 0)
    return np.where(on[:, None], f_rel, 0.0), np.where(on[:, None], f_nrm, 0.0), np.where(on, side, 0)


def _remember(mem: BugMemory, rows, d: DecodedObs, bp: BugParams, *, q, hn, side, met, fresh, round_r, r_len, t_now,
              togo, on_border, ang, last_wall, kc, has_wall, virtual, v_ang, psi, cand_end):
    """:func:`bug_update`'s write-back of the cycle finder's place, the last step's odometry, the
    direction set off in from H, the m-line side and the followed break (angle, point, end)."""
    ri = np.arange(len(rows))
    # the cycle finder's place: set where the search is taken up, moved on at doubling distances
    anew = (met & ~fresh) | round_r
    move_on = anew | (r_len >= mem.r_next[rows])
    mem.r_pt[rows] = np.where(move_on[:, None], q, mem.r_pt[rows])
    mem.r_len[rows] = np.where(move_on, 0.0, r_len)
    mem.r_dir[rows] = np.where(move_on[:, None], t_now, mem.r_dir[rows])
    mem.r_next[rows] = np.where(anew, 2 * bp.home_arc_m, np.where(move_on, 2 * mem.r_next[rows], mem.r_next[rows]))
    mem.last_togo[rows] = togo
    mem.last_q[rows] = q
    # the direction it sets off in from H (first side): the tangent of the followed break
    mem.t_hit[rows] = np.where(fresh[:, None], t_now, mem.t_hit[rows])
    mem.on_border[rows] = on_border
    off = q[:, 0] * hn[:, 1] - q[:, 1] * hn[:, 0]
    mem.mside[rows] = np.where(fresh, 0, np.where(off >= 0, 1, -1))
    mem.wall[rows] = np.where(has_wall, ang[ri, kc], np.where(virtual, v_ang, last_wall))
    mem.gap[rows] = np.where((side == 0) | fresh, 0, mem.gap[rows])
    mem.wall_pt[rows] = np.where(has_wall[:, None], q + _rot(psi, d.b_rel[ri, kc]), mem.wall_pt[rows])
    mem.has_pt[rows] = (side != 0) & (has_wall | virtual)
    mem.pt_end[rows] = np.where(has_wall, cand_end[ri, kc], mem.pt_end[rows])
    mem.v_steps[rows] = np.where(virtual & (side != 0), mem.v_steps[rows] + 1, 0)
