"""What every policy shares: the :class:`Policy` protocol, :func:`unwrap_env`, the decoded
observation (:class:`DecodedObs`, :func:`decode`) and the safety shield (:class:`SafetyShield`:
the cuts every built-in controller applies last, :func:`safety_cut`, and that a policy file may
ask for).

A policy maps observations to actions, one row per robot: ``act_batch(obs (n, d)) -> (n, 2)``
body-frame velocities as fractions of top speed, and ``act({agent: obs}) -> {agent: action}``.
Policies read the observation through :class:`~tin_swarm_env.env.observation.ObsLayout` and the
environment's static constants (:class:`SafetyShield`), never the world state; the one exception
is :class:`~tin_swarm_env.policies.GeodesicPolicy`, the map-knowing reference.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields
from typing import Protocol, runtime_checkable

import numpy as np
from numba import njit

from ..errors import ArgumentError
from ..world.fields import facing

__all__ = ["Policy", "unwrap_env", "DecodedObs", "decode", "keep_clear", "into_view", "safety_cut", "SafetyShield",
           "act_dict"]


@runtime_checkable
class Policy(Protocol):
    """The interface every policy here implements (a structural protocol: no base class needed).

    ``act_batch(obs (n, d)) -> (n, 2)`` float32 body-frame velocities in ``[-1, 1]`` (fractions of
    top speed), row ``i`` for observation row ``i``; ``act({agent: obs (d,)}) -> {agent: (2,)}``.
    A policy with per-robot memory also has ``reset()`` (call it after each environment reset)."""

    def act_batch(self, obs) -> np.ndarray: ...

    def act(self, obs: dict) -> dict: ...


def act_dict(act_batch, obs: dict, rows=None) -> dict:
    """``act`` from ``act_batch``: stack the agents' observations (dict order), act, split again.
    ``rows`` (optional, one per agent) is passed on as ``act_batch(obs, rows)``."""
    if not obs:
        return {}
    keys = list(obs)
    stacked = np.stack([obs[k] for k in keys])
    a = act_batch(stacked) if rows is None else act_batch(stacked, rows)
    return {k: a[i] for i, k in enumerate(keys)}


MAX_PARAM = 1e12  # the largest value any policy constant may take (a finite number whose square is finite too)


def check_positive_fields(params, limits: dict | None = None) -> None:
    """Every field of the dataclass ``params`` must be a finite number > 0 and <= :data:`MAX_PARAM`
    (a field annotated ``int``: an integer; a bool is never a number); ``limits`` maps a field to
    other :func:`~tin_swarm_env.errors.check_range` keywords (``{"cells": {"hi": 2048}}``). Raises
    :class:`~tin_swarm_env.errors.ParameterError` (a ValueError) naming the class and field."""
    import typing

    from ..errors import check_range

    hints = typing.get_type_hints(type(params))
    for f in fields(params):
        kw = {"lo": 0, "lo_open": True, "hi": MAX_PARAM, "integer": hints.get(f.name) is int,
              **(limits or {}).get(f.name, {})}
        check_range(type(params).__name__, f.name, getattr(params, f.name), **kw)


def unwrap_env(env):
    """The :class:`~tin_swarm_env.env.TinSwarmEnv` under ``env`` (itself or a wrapper of one)."""
    e = env
    for _ in range(10):
        if hasattr(e, "layout") and hasattr(e, "config"):
            return e
        e = getattr(e, "env", None) or getattr(e, "unwrapped", None)
        if e is None:
            break
    raise ArgumentError("the policy needs a tin_swarm_env environment (or a wrapper of one)")


@dataclass
class DecodedObs:
    """Observations ``(n, d)`` as physical quantities in the body frame (metres), :func:`decode`.

    ``K_r``, ``K_b``, ``K_a``: the layout's robot, break and asset slots (``K_a`` may be 0). The
    observation does not name the terrain's border; its sensed proxy is ``b_border``, a dangerous
    break with zero drop (a border edge has no triangle beyond it, so its drop is 0; a cliff
    edge's drop is not)."""

    has_t: np.ndarray  # (n,) bool: the task assigns the robot a target
    dist: np.ndarray  # (n,) m: horizontal distance to it
    rel_t: np.ndarray  # (n, 2) m: vector to it
    dz: np.ndarray  # (n,) m: its height above the robot
    grad_z: np.ndarray  # (n, 2): terrain gradient underfoot (tan(slope) times the uphill unit vector)
    speed: np.ndarray  # (n,): speed achieved last step, fraction of top speed
    r_rel: np.ndarray  # (n, K_r, 2) m: vectors to the robots it sees
    r_valid: np.ndarray  # (n, K_r) float 0/1
    b_rel: np.ndarray  # (n, K_b, 2) m: vectors to the closest points of the breaks in range
    b_normal: np.ndarray  # (n, K_b, 2): their unit normals toward the safe side
    b_danger: np.ndarray  # (n, K_b) bool: valid and dangerous (a cliff edge or the border)
    b_border: np.ndarray  # (n, K_b) bool: dangerous with zero drop (the terrain's border)
    a_rel: np.ndarray  # (n, K_a, 2) m: vectors to the assets it sees
    a_valid: np.ndarray  # (n, K_a) float 0/1
    s_rel: np.ndarray | None = None  # (n, K_s, 2) m: vectors to where the scan's beams meet a dangerous break
    s_hit: np.ndarray | None = None  # (n, K_s) bool: the beam met one within range
    s_dir: np.ndarray | None = None  # (K_s, 2): the beams' unit vectors (ObsLayout.scan_bearings)

    @property
    def n(self) -> int:
        return len(self.dist)


def decode(obs, layout, range_m) -> DecodedObs:
    """Observations ``(n, d)`` laid out by ``layout`` (sensor range ``range_m``) -> :class:`DecodedObs`."""
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim != 2 or obs.shape[1] != layout.size:
        raise ArgumentError(f"decode: observations (n, {layout.size}) expected for this layout, got {obs.shape}")
    R = range_m
    c = _columns(layout)
    dist = layout.target_distance_m(obs, R)
    slope = np.radians(obs[:, c["slope"]] * 90.0)
    b_valid = obs[:, c["b_valid"]]
    b_danger = (b_valid * obs[:, c["b_danger"]]) > 0.5
    s_rel, s_hit = _scan_rows(obs, c["scan"], float(R), float(R * (1 - 1e-6)), layout.scan_units())
    return DecodedObs(
        has_t=obs[:, c["target_valid"]] > 0.5, dist=dist,
        rel_t=obs[:, c["target_dir"]] * dist[:, None], dz=layout.target_dz_m(obs),
        grad_z=np.tan(slope)[:, None] * obs[:, c["uphill"]],
        speed=obs[:, c["speed"]],
        r_rel=obs[:, c["r_xy"]] * R, r_valid=obs[:, c["r_valid"]],
        b_rel=obs[:, c["b_xy"]] * R, b_normal=obs[:, c["b_nxy"]],
        b_danger=b_danger, b_border=b_danger & (obs[:, c["b_drop"]] == 0.0),
        a_rel=obs[:, c["a_xy"]] * R, a_valid=obs[:, c["a_valid"]],
        s_rel=s_rel, s_hit=s_hit, s_dir=layout.scan_units())


@functools.lru_cache(maxsize=64)
def _columns(layout) -> dict:
    """The columns :func:`decode` reads, by name, found by running the layout's own readers
    (:meth:`~tin_swarm_env.env.observation.ObsLayout.field`, ``vectors``) on a row of column numbers:
    the layout stays the one home of where each field lies, and a step reads each with one index."""
    row = np.arange(layout.size, dtype=np.float64)[None]

    def at(a):
        return np.asarray(a[0], dtype=np.int64)

    f, v = layout.field, layout.vectors
    return {"slope": int(at(f(row, "own", "slope"))[0]), "target_valid": int(at(f(row, "own", "target_valid"))[0]),
            "speed": int(at(f(row, "own", "speed"))[0]), "target_dir": at(f(row, "own", "target_dir")),
            "uphill": at(f(row, "own", "uphill")), "r_xy": at(v(row, "robots")),
            "r_valid": at(f(row, "robots", "valid")),
            "b_xy": at(v(row, "breaks")), "b_nxy": at(v(row, "breaks", "nx", "ny")),
            "b_valid": at(f(row, "breaks", "valid")), "b_danger": at(f(row, "breaks", "danger")),
            "b_drop": at(f(row, "breaks", "drop")), "a_xy": at(v(row, "assets")),
            "a_valid": at(f(row, "assets", "valid")),
            "scan": np.ascontiguousarray(at(f(row, "scan", "d")))}


@njit(cache=True)
def _scan_rows(obs, cols, R, hit_below, unit):
    """The scan's beams (columns ``cols``) as body-frame vectors to their hits, ``s_rel (n, K, 2)``: the
    beam's reading times ``R`` along its unit vector (``unit (K, 2)``, :meth:`ObsLayout.scan_units`), and
    which met a break, ``s_hit (n, K)``: nearer than ``hit_below``, never in an all-zero row (a robot no
    longer in the episode). The same products as the array version it replaced, so the same bits."""
    n, K = obs.shape[0], cols.shape[0]
    s_rel = np.empty((n, K, 2))
    s_hit = np.empty((n, K), np.bool_)
    for i in range(n):
        live = False
        for j in range(obs.shape[1]):
            if obs[i, j] != 0:
                live = True
                break
        for k in range(K):
            t = obs[i, cols[k]] * R
            s_rel[i, k, 0] = t * unit[k, 0]
            s_rel[i, k, 1] = t * unit[k, 1]
            s_hit[i, k] = live and t < hit_below
    return s_rel, s_hit


def keep_clear(action, rel, valid, gap_m: float, step_m: float, share: float = 2.0, passes: int = 2):
    """Cut body-frame ``action (n, 2)`` (fractions of top speed) so that no robot closes on what
    it sees at ``rel (n, K, 2)`` m (``valid (n, K)``) by more than ``1 / share`` of the free gap
    ``d - gap_m`` in one step of ``step_m`` at full speed: ``a . u <= max(d - gap, 0) / (share
    step)``, ``u`` the unit vector toward it. For robots (``share`` 2, both move) two robots
    that see each other never come closer than ``gap_m``; for the closest points of dangerous
    breaks (``share`` 1, they stand still) the robot never comes within ``gap_m`` of them (the
    distance to a segment after a move ``delta`` is at least ``d - delta . u``). Only the part
    of the action toward each is removed (a projection onto each half-plane, ``passes`` sweeps
    over the slots), so the cut never adds motion toward anything. Returns ``(n, 2)``."""
    a = np.array(action, dtype=np.float64)
    rel = np.ascontiguousarray(rel, dtype=np.float64)  # (the cut is computed in float64)
    if a.ndim != 2 or a.shape[1] != 2 or rel.ndim != 3 or rel.shape[0] != len(a) or rel.shape[2] != 2:
        raise ArgumentError(f"keep_clear: action (n, 2) and rel (n, K, 2) expected, got {a.shape} and {rel.shape}")
    try:
        ok = np.ascontiguousarray(np.broadcast_to(np.asarray(valid) > 0.5, rel.shape[:2]))
    except ValueError:
        raise ArgumentError(f"keep_clear: valid {np.shape(valid)} does not match rel's (n, K) = "
                            f"{rel.shape[:2]}") from None
    _keep_clear_rows(a, rel, ok, float(gap_m), float(share) * float(step_m), int(passes))
    return a


@njit(cache=True)
def _keep_clear_rows(a, rel, valid, gap_m, den, passes):
    """:func:`keep_clear`'s cut of ``a (n, 2)`` in place, a row at a time (each row's cut reads that
    row alone): the same products, sums and quotients, in the same order, as the array version
    it replaced (``tests/policies/test_base.py`` holds it as the reference), so the same bits."""
    n, K = rel.shape[0], rel.shape[1]
    u = np.empty((K, 2))
    limit = np.empty(K)
    ok = np.empty(K, np.bool_)
    for i in range(n):
        for j in range(K):
            x, y = rel[i, j, 0], rel[i, j, 1]
            d = np.sqrt(x * x + y * y)
            ok[j] = valid[i, j] and d > 1e-9
            m = max(d, 1e-9)
            u[j, 0], u[j, 1] = x / m, y / m
            limit[j] = max(d - gap_m, 0.0) / den
        for _ in range(passes):
            for j in range(K):
                excess = (a[i, 0] * u[j, 0] + a[i, 1] * u[j, 1]) - limit[j]
                cut = excess if ok[j] and excess > 0 else 0.0
                a[i, 0] -= cut * u[j, 0]  # (a zero cut too: a -0.0 becomes +0.0 as it did)
                a[i, 1] -= cut * u[j, 1]


def into_view(action, fov_deg: float):
    """Body-frame ``action (n, 2)`` turned out of the robot's blind sector: a command whose
    bearing lies beyond ``fov_deg / 2`` (where the robot sees no robot) is projected onto the
    nearer edge of its field of view, so robots do not back into robots they cannot see (the
    heading turns toward the motion, so the next step sees further round). Returns ``(n, 2)``."""
    a = np.array(action, dtype=np.float64)
    half = np.radians(min(fov_deg, 360.0)) / 2
    if half >= np.pi:
        return a
    bearing = np.arctan2(a[:, 1], a[:, 0])
    blind = np.abs(bearing) > half
    edge = np.stack([np.full(len(a), np.cos(half)), np.where(a[:, 1] >= 0, 1.0, -1.0) * np.sin(half)], axis=-1)
    along = np.maximum(np.sum(a * edge, axis=-1), 0.0)
    return np.where(blind[:, None], along[:, None] * edge, a)


def safety_cut(action, d: DecodedObs, gap_m: float, edge_m: float | None, step_m: float, fov_deg: float):
    """The cuts every built-in controller applies last to its body-frame ``action (n, 2)``, from
    the decoded observation ``d``: turned out of the blind sector (:func:`into_view`), then cut
    so that robots that see each other never come within ``gap_m`` (:func:`keep_clear`,
    ``share`` 2) and, unless ``edge_m`` is None, so that no robot comes within ``edge_m`` of a
    dangerous break it sees from its safe side (``share`` 1)."""
    a = keep_clear(into_view(action, fov_deg), d.r_rel, d.r_valid, gap_m, step_m)
    if edge_m is not None:
        a = keep_clear(a, d.b_rel, facing(d.b_rel, d.b_normal, d.b_danger), edge_m, step_m, share=1.0)
    return a


class SafetyShield:
    """The static quantities every built-in controller reads from an environment, and the
    safety cut made with them; a shield in the safe-RL sense (a policy proposes an action, the
    shield removes its unsafe part), reading only the observation.

    ``SafetyShield(env)`` (an env or a wrapper of one; :meth:`from_config` from a scenario config
    and an :class:`~tin_swarm_env.env.observation.ObsLayout`) sets ``layout``, ``range_m`` (sensor
    range), ``standoff_m`` (the containment ring's radius, 0 for a goal task), ``guard_m`` (the
    assets' guard ring), ``gap_m`` (3 robot radii: 1.5 body diameters kept between robots that
    see each other), ``edge_m`` (2 radii: one body diameter kept off a dangerous break),
    ``fov_deg``, ``step_m`` (the distance covered in one step at full speed) and ``pass_m`` (3
    body diameters: the narrowest gap between breaks a robot drives through).
    ``shield(action, obs)`` is :func:`safety_cut` of ``action (n, 2)`` for observations
    ``obs (n, d)`` (the break cut when the layout has break slots), float32; :meth:`cut` the same
    from an observation already decoded. The cut reads only world parameters a vector env's mix
    shares (:class:`~tin_swarm_env.env.vector.VectorEnv` checks them) and the layout, so the
    shield of a mix's first scenario is every copy's (the SB3 and PufferLib adapters' shield).

    ``scan=True`` (the policy files' ``"safety_cut_scan"``): ``shield(action, obs)`` then also
    keeps every robot ``edge_m`` off the points where its terrain scan's beams meet a dangerous
    break (:func:`scan_cut`), so a policy cannot drive down onto ground too steep to hold it
    where the break slots (the nearest few break points) miss it, as on real hillside. The
    built-in controllers' :meth:`cut` is unchanged."""

    def __init__(self, env, scan: bool = False):
        base = unwrap_env(env)
        self._set(base.config, base.layout, scan)

    @classmethod
    def from_config(cls, cfg, layout, scan: bool = False) -> SafetyShield:
        s = cls.__new__(cls)
        s._set(cfg, layout, scan)
        return s

    def _set(self, cfg, layout, scan: bool = False):
        self.layout = layout
        self.scan = bool(scan) and bool(layout.k_scan)
        self.range_m = cfg.world.sensor.range_m
        self.standoff_m = cfg.targets.standoff_m if cfg.task == "containment" else 0.0
        self.guard_m = cfg.assets.standoff_m
        self.gap_m = 3.0 * cfg.world.robot.radius_m
        self.edge_m = 2.0 * cfg.world.robot.radius_m
        self.fov_deg = cfg.world.sensor.fov_deg
        self.step_m = cfg.world.robot.max_speed_mps * cfg.world.dt_s
        self.pass_m = 3.0 * self.edge_m

    def decode(self, obs) -> DecodedObs:
        """:func:`decode` with this environment's layout and sensor range."""
        return decode(obs, self.layout, self.range_m)

    def cut(self, action, d: DecodedObs, edges: bool = True) -> np.ndarray:
        """:func:`safety_cut` of ``action (n, 2)`` (the break cut only when ``edges``), float32."""
        return safety_cut(action, d, self.gap_m, self.edge_m if edges else None, self.step_m,
                          self.fov_deg).astype(np.float32)

    def __call__(self, action, obs) -> np.ndarray:
        a = self.cut(action, self.decode(obs), edges=bool(self.layout.k_breaks))
        return scan_cut(a, obs, self) if self.scan else a


def scan_cut(action, obs, shield: SafetyShield) -> np.ndarray:
    """``action (n, 2)`` cut so that no robot comes within ``shield.edge_m`` of a point where a
    beam of its terrain scan meets a dangerous break (:func:`keep_clear`, ``share`` 1, over the
    beams that hit), float32. The beams are cut one after another, and the mirror image permutes
    them, so the cut is made both ways and averaged, ``(k(a, o) + M k(M a, M o)) / 2``: exactly
    mirror-equivariant (a mirror-equivariant network stays so behind it), and inside the cut's
    half-planes as each way is (they are convex)."""
    from ..env.observation import mirror_action

    obs = np.asarray(obs)

    def one_way(a, o):
        d = shield.decode(o)
        return keep_clear(a, d.s_rel, d.s_hit, shield.edge_m, shield.step_m, share=1.0)

    there = one_way(mirror_action(np.asarray(action, dtype=np.float64)), shield.layout.mirror(obs))
    return ((one_way(action, obs) + mirror_action(there)) / 2).astype(np.float32)


def make_shield(name: str, env, where: str = "make_shield") -> SafetyShield | None:
    """The shield a policy file's ``"shield"`` names (``policies.network.SHIELDS``) for ``env``:
    None for ``"none"``, :class:`SafetyShield` for ``"safety_cut"``, with ``scan=True`` for
    ``"safety_cut_scan"``; :class:`~tin_swarm_env.errors.ArgumentError` naming ``where`` for
    another name, or for the scan shield on a layout without a terrain scan (it would cut nothing)."""
    from .network import SHIELDS

    if name not in SHIELDS:
        raise ArgumentError(f"{where}: shield must be one of {list(SHIELDS)}, got {name!r}")
    if name == "safety_cut_scan" and not unwrap_env(env).layout.k_scan:
        raise ArgumentError(f"{where}: shield 'safety_cut_scan' needs an observation layout with a terrain scan "
                            "([observation] k_scan > 0); this one has none")
    return None if name == "none" else SafetyShield(env, scan=name == "safety_cut_scan")

