"""The artificial potential fields of thesis 3.3 and an asset field, as batched pure math (:data:`FIELDS`).

The thesis gives shapes, not formulas; these are ours. Every field is a force ``-grad U`` of a
potential ``U`` (returned too, for plots and for the finite-difference tests), evaluated on
relative vectors so that one implementation serves the egocentric policy (body frame) and
world-frame grids (plots).

=========  ==========================================================================================
field      potential U and force F = -grad U (``p`` the robot, ``d`` a distance)
=========  ==========================================================================================
robot      purely repulsive, quadratic, stronger the closer: for ``d < range``,
           ``U = gain * range / 3 * (1 - d/range)^3``, ``|F| = gain * (1 - d/range)^2`` away from the
           other robot; 0 beyond ``range``.
target     attraction that turns repulsive inside ``standoff`` (0 for a goal): with ``e = d - standoff``,
           ``U = gain * e^2 / (2 range)`` for ``|e| <= range`` and linear beyond (a Huber potential), so
           ``|F| = gain * clip(e / range, -1, 1)`` toward the target (away from it when ``e < 0``).
break      purely repulsive, perpendicular to the break segment, strong at its core and dying quickly:
           ``U = gain * decay * exp(-d / decay)`` for ``d < range`` (``d`` to the segment), ``F`` along
           the segment's normal toward the safe side, ``|F| = gain * exp(-d / decay)``. Only dangerous
           breaks (cliff edges, the border) push, and only from their safe side.
height     pulls along the local slope toward the target's height: ``U = gain * f(z - z_t)`` with
           ``f(x) = |x| - s ln(1 + |x|/s)`` (``s`` = 10 m), so ``F = gain * dz/(|dz| + s) * grad z``,
           ``dz = z_t - z``: uphill when the target is higher, downhill when lower, 0 on level ground.
asset      the assets' role (a protection task, thesis 4.3): the target field's shape toward the
           guard ring (radius ``guard``, the scenario's ``[assets] standoff_m``) around the nearest
           asset the robot sees, with its own gain and range: robots that see an asset close on
           it and hold the ring (spread along it by the robot field); 0 when none is seen.
=========  ==========================================================================================

Not a potential: the break field's *wall-following* term (:func:`follow_field`). Pure potential
fields stop at the edge of a cliff that lies between a robot and its goal (a local minimum: with
the break field off the thesis's "poor ending" is a fall, with it on a robot would stand at the
edge for ever). A robot
that follows the edge on a chosen side (the policy chooses it, from what it senses, and keeps it
in a small memory: :class:`~tin_swarm_env.policies.APFPolicy`) turns the minimum into the bug
algorithms' wall-following, which gets around the cliff on either side.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError, check_range

__all__ = ["FIELDS", "FieldParams", "robot_field", "target_field", "break_field", "height_field",
           "follow_field", "away_from", "facing", "asset_field", "fields_at", "HEIGHT_SCALE_M"]

FIELDS = ("robot", "target", "break", "height", "asset")
HEIGHT_SCALE_M = 10.0


MAX_FIELD_VALUE = 1e12  # the largest gain or range a FieldParams takes (its square stays finite)


@dataclass(frozen=True)
class FieldParams:
    """Gains and ranges of the fields, and which are on."""

    robot_gain: float = 1.0
    robot_range_m: float = 4.0
    target_gain: float = 1.0
    target_range_m: float = 10.0
    break_gain: float = 4.0
    break_range_m: float = 15.0
    break_decay_m: float = 2.5
    speed_saturation: float = 0.3
    height_gain: float = 0.5
    follow_engage_m: float = 8.0
    follow_hold_m: float = 5.0
    stall_steps: int = 20
    asset_gain: float = 0.5
    asset_range_m: float = 10.0
    fields: tuple[str, ...] = FIELDS

    def __post_init__(self):
        if not isinstance(self.fields, (tuple, list)) or not all(isinstance(f, str) for f in self.fields):
            raise ParameterError(f"FieldParams.fields must be a tuple of field names ({', '.join(FIELDS)}), got "
                                 f"{self.fields!r}")
        unknown = set(self.fields) - set(FIELDS)
        if unknown:
            raise ParameterError(f"unknown field(s) {sorted(unknown)}; the fields are {', '.join(FIELDS)}")
        for k in ("robot_range_m", "target_range_m", "break_range_m", "break_decay_m", "follow_engage_m",
                  "follow_hold_m", "asset_range_m", "speed_saturation"):
            check_range("FieldParams", k, getattr(self, k), 0, MAX_FIELD_VALUE, lo_open=True)
        for k in ("robot_gain", "target_gain", "break_gain", "height_gain", "asset_gain"):  # 0: the field is off
            check_range("FieldParams", k, getattr(self, k), 0, MAX_FIELD_VALUE)
        check_range("FieldParams", "stall_steps", self.stall_steps, 1, 10**9, integer=True)

    def on(self, name: str) -> bool:
        return name in self.fields


def _norm(v):
    return np.sqrt(np.sum(v * v, axis=-1))


def facing(rel, normal, valid):
    """Breaks ``(..., K)`` whose safe side the robot is on: ``valid`` and the normal points from
    the break toward the robot (``rel . normal <= 0``, ``rel`` from the robot to the break's
    closest point). A break seen from its unsafe side lies behind another one and does not push;
    every controller reads "the dangerous breaks it must keep off" through this one test."""
    return valid.astype(bool) & (np.sum(rel * normal, axis=-1) <= 1e-9)


def robot_field(rel, valid, gain, range_m):
    """Sum over slots of the robot-robot field. ``rel (..., K, 2)``: vectors from the robot to
    the others; ``valid (..., K)``. Returns ``(force (..., 2), potential (...))``."""
    d = _norm(rel)
    inside = valid.astype(bool) & (d < range_m) & (d > 0)
    w = np.where(inside, 1 - d / range_m, 0.0)
    unit = rel / np.where(d > 0, d, 1.0)[..., None]
    force = -(gain * w * w)[..., None] * unit
    pot = gain * range_m / 3 * w ** 3
    return force.sum(axis=-2), pot.sum(axis=-1)


def target_field(rel, standoff_m, gain, range_m):
    """``rel (..., 2)`` from the robot to its target. Returns ``(force (..., 2), potential (...))``."""
    d = _norm(rel)
    e = d - standoff_m
    a = np.abs(e)
    pot = np.where(a <= range_m, gain * e * e / (2 * range_m), gain * (a - range_m / 2))
    mag = gain * np.clip(e / range_m, -1.0, 1.0)
    unit = rel / np.where(d > 0, d, 1.0)[..., None]
    return mag[..., None] * unit * (d > 0)[..., None], pot


def break_field(rel, normal, valid, gain, range_m, decay_m):
    """Sum over slots of the break field. ``rel (..., K, 2)``: from the robot to the closest
    point of each break; ``normal (..., K, 2)``: unit normal toward the safe side; ``valid``
    selects dangerous breaks. Returns ``(force (..., 2), potential (...))``."""
    d = _norm(rel)
    inside = facing(rel, normal, valid) & (d < range_m)
    mag = np.where(inside, gain * np.exp(-d / decay_m), 0.0)
    pot = np.where(inside, gain * decay_m * (np.exp(-d / decay_m) - np.exp(-range_m / decay_m)), 0.0)
    return (mag[..., None] * normal).sum(axis=-2), pot.sum(axis=-1)


def away_from(rel, normal):
    """Unit vectors ``(..., 2)`` from the closest point of each break to the robot: ``-rel / d``,
    the break's normal where the robot stands on it (``d`` ~ 0). Along a break's middle this is
    its normal; past its end it turns round the end point."""
    d = _norm(rel)
    return np.where((d > 1e-6)[..., None], -rel / np.maximum(d, 1e-6)[..., None], normal)


def follow_field(pull, rel, normal, side, hold_m, step_m):
    """The wall-following term (not a potential) of robots following a dangerous break.

    ``rel (..., 2)``: from the robot to the closest point of the followed break; ``normal
    (..., 2)``: its normal toward the safe side; ``side (...)``: +1 follows with the break on the
    robot's right (it turns left), -1 on its left, 0 not following; ``step_m``: the distance a
    robot covers in one step at full speed. With ``e`` the unit vector from the closest point to
    the robot (:func:`away_from`) at distance ``d`` and ``t = side (e_y, -e_x)`` the tangent, the
    direction of travel is ``t`` turned toward the break by
    ``beta = asin(min(step / 2d, 1)) + clip((d - hold) / hold, -1, 1)`` rad: the first part keeps
    the robot at its distance while it rounds a break's end (a step along a circle's tangent
    leaves the circle), the second draws it back to ``hold_m``. The attraction ``pull (..., 2)``
    is replaced by ``|pull|`` times that direction; returns ``force (..., 2)``:
    ``|pull| (cos(beta) t - sin(beta) e) - pull`` where ``side != 0``, else 0."""
    d = _norm(rel)
    e = away_from(rel, normal)
    side = np.asarray(side, dtype=np.float64)
    t = side[..., None] * np.stack([e[..., 1], -e[..., 0]], axis=-1)
    beta = np.arcsin(np.minimum(step_m / np.maximum(2 * d, 1e-9), 1.0)) + np.clip((d - hold_m) / hold_m, -1.0, 1.0)
    f = _norm(pull)[..., None] * (np.cos(beta)[..., None] * t - np.sin(beta)[..., None] * e) - pull
    return np.where((side != 0)[..., None], f, 0.0)


def height_field(grad_z, dz, gain, scale_m=HEIGHT_SCALE_M):
    """``grad_z (..., 2)``: the terrain gradient under the robot (tan(slope) times the uphill
    unit vector); ``dz (...)``: the target's height above the robot. Returns
    ``(force (..., 2), potential (...))`` with the potential ``gain * f(-dz)``."""
    x = np.abs(dz)
    pot = gain * (x - scale_m * np.log1p(x / scale_m))
    return (gain * dz / (x + scale_m))[..., None] * grad_z, pot


def asset_field(rel, valid, guard_m, gain, range_m):
    """The asset field: ``rel (..., K, 2)`` from the robot to each asset slot, ``valid (..., K)``.
    The target field (:func:`target_field`, standoff ``guard_m``) toward the nearest valid one
    (``K >= 1``).
    Returns ``(force (..., 2), potential (...))``, zero where no slot is valid."""
    d = np.where(np.asarray(valid) > 0.5, _norm(rel), np.inf)  # (..., K), K >= 1
    k = np.argmin(d, axis=-1)
    seen = np.isfinite(d).any(axis=-1)
    near = np.take_along_axis(rel, k[..., None, None], axis=-2)[..., 0, :]
    f, u = target_field(near, guard_m, gain, range_m)
    return np.where(seen[..., None], f, 0.0), np.where(seen, u, 0.0)


def fields_at(points, params: FieldParams, *, robots=None, target=None, standoff_m=0.0, breaks=None,
              tin=None, z_target=None, assets=None, guard_m=0.0):
    """The fields felt at world points ``(P, 2)`` (a grid around a robot, for plots): a dict
    name -> ``(force (P, 2), potential (P,))`` for each field that is on and has sources, plus
    ``"total"``. Sources: ``robots (M, 2)``, ``target (2,)`` with ``standoff_m``, ``breaks`` a
    :class:`~tin_swarm_env.terrain.Breaks` (dangerous ones push: cliff edges and border),
    ``tin`` with ``z_target`` for the height field, ``assets (A, 2)`` with ``guard_m`` for the
    asset field (the nearest asset to each point). The wall-following term is left out (it
    depends on the robot's memory, not on its position alone)."""
    from ..terrain import ANGLE
    from ..terrain.breaks import closest_on_segments

    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    P = len(p)
    out = {}
    if params.on("robot") and robots is not None and len(robots):
        rel = np.asarray(robots, dtype=np.float64)[None, :, :] - p[:, None, :]
        out["robot"] = robot_field(rel, np.ones(rel.shape[:2]), params.robot_gain, params.robot_range_m)
    if params.on("target") and target is not None:
        rel = np.asarray(target, dtype=np.float64)[None, :] - p
        out["target"] = target_field(rel, standoff_m, params.target_gain, params.target_range_m)
    if params.on("break") and breaks is not None and len(breaks):
        closest, _ = closest_on_segments(p[:, None, :], breaks.segments[None, :, 0, :2],
                                         breaks.segments[None, :, 1, :2])
        rel = closest - p[:, None, :]
        danger = np.broadcast_to(breaks.kinds != ANGLE, rel.shape[:2])
        nrm = np.broadcast_to(breaks.normals[None], rel.shape)
        out["break"] = break_field(rel, nrm, danger, params.break_gain, params.break_range_m, params.break_decay_m)
    if params.on("height") and tin is not None and z_target is not None:
        t = tin.locate(p)
        inside = t >= 0
        g = np.zeros((P, 2))
        dz = np.zeros(P)
        g[inside] = tin.planes[t[inside], :2]
        dz[inside] = z_target - tin.height_in(p[inside], t[inside])
        f, u = height_field(g, dz, params.height_gain)
        out["height"] = (f, np.where(inside, u, 0.0))
    if params.on("asset") and assets is not None and len(assets):
        rel = np.asarray(assets, dtype=np.float64)[None, :, :] - p[:, None, :]
        out["asset"] = asset_field(rel, np.ones(rel.shape[:2]), guard_m, params.asset_gain, params.asset_range_m)
    total_f = sum((v[0] for v in out.values()), np.zeros((P, 2)))
    total_u = sum((v[1] for v in out.values()), np.zeros(P))
    out["total"] = (total_f, total_u)
    return out
