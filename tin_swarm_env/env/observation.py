"""Observations: one flat float32 vector per robot, egocentric, normalised, in [-1, 1].

Body frame: x forward, y left; world vectors are rotated by minus the robot's heading.
``R`` is the sensor range. Layout (``K_r``, ``K_t``, ``K_b`` slots; :class:`ObsLayout` is its one
description: names, offsets, scales, and the encode/decode helpers):

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
                            safe side (nx, ny), drop / (|drop| + 10 m), d / R, danger (1 for a
                            cliff edge or the terrain's border, 0 for a bend between two
                            traversable planes), of the K_b nearest terrain breaks in range
assets               4 K_a  valid, x / R, y / R, d / R of the K_a nearest visible assets
scan                 K_s    per beam k (bearing 2 pi k / K_s from the heading, counter-clockwise):
                            t / R, t the distance along it to the first dangerous break it
                            crosses (1: none within R); a terrain scanner's ranges
===================  =====  ==================================================================

**Mirror symmetry.** Reflecting the world across a vertical plane (``y -> -y`` in the world,
headings ``theta -> -theta``) reflects every robot's body frame across its x axis: each
observation maps to the observation of the mirrored world by negating the elements that are
body-frame y components or signed turns, and keeping the rest (:data:`OWN_PARITY`,
:data:`SLOT_PARITY`: the sign of every field, so a new field must declare its own). The action
maps by :data:`ACTION_PARITY` (``vy`` negated). :meth:`ObsLayout.mirror` and :func:`mirror_action`
apply them; both are involutions. The scan's beams are the one part the reflection permutes
instead: beam ``k`` becomes beam ``(K_s - k) mod K_s`` (:meth:`ObsLayout.mirror_permutation`), so
with scan beams the mirror image is not a sign flip and :meth:`ObsLayout.mirror_signs` refuses.

``K_a`` (the assets part, after the breaks so the other offsets never move): the scenario's
``[observation] k_assets`` when given, else :data:`DEFAULT_K_ASSETS` when the scenario has assets
and 0 when it has none, so a scenario without assets keeps the default size (59 + ``K_s``). ``K_s``
(the scan, last): the scenario's ``[observation] k_scan``, default
:data:`~tin_swarm_env.scenario.config.DEFAULT_K_SCAN` (32 beams; 0: no scan part, the layout of
policies trained before the scan was in the default, 59 elements).

The 10 m is :data:`DZ_SCALE_M` (the height field's scale, ``world.fields.HEIGHT_SCALE_M``: one
constant). Empty slots are all zero. Robots no longer in ``agents`` get an all-zero vector.
"""

from __future__ import annotations

import functools
import math
from collections import namedtuple
from dataclasses import dataclass, fields

import numpy as np
from numba import njit, prange

from ..errors import ObservationLayoutError
from ..scenario.config import ObservationSpec
from ..terrain import ANGLE
from ..world.fields import HEIGHT_SCALE_M as DZ_SCALE_M
from ..world.pack import frozen
from ..world.scan_kernels import (  # noqa: F401 (re-exported: the scan's primitives, world/scan_kernels.py)
    ANGLE_ERROR, SPAN_MARGIN, approx_angle, beam_span, crossing, scan_contact, scan_start)
from ..world.world import serial_if_small

__all__ = ["ObsLayout", "build_observations", "OWN_FIELDS", "SLOT_FIELDS", "DZ_SCALE_M", "DEFAULT_K_ASSETS",
           "OWN_PARITY", "SLOT_PARITY", "ACTION_PARITY", "mirror_action"]

OWN_FIELDS = (("battery", 1), ("speed", 1), ("tilt", 1), ("slope", 1), ("uphill", 2), ("target_valid", 1),
              ("target_dir", 2), ("target_dist", 1), ("target_dz", 1))
SLOT_FIELDS = {"robots": ("valid", "x", "y", "d"), "targets": ("valid", "x", "y", "d"),
               "breaks": ("valid", "x", "y", "nx", "ny", "drop", "d", "danger"), "assets": ("valid", "x", "y", "d"),
               "scan": ("d",)}
PARTS = tuple(SLOT_FIELDS)
# The mirror image (module docstring): +1 for a field the reflection keeps, -1 for one it negates
# (a body-frame y component or a signed angle about the vertical); one sign per element.
OWN_PARITY = {"battery": (1,), "speed": (1,), "tilt": (-1,), "slope": (1,), "uphill": (1, -1),
              "target_valid": (1,), "target_dir": (1, -1), "target_dist": (1,), "target_dz": (1,)}
SLOT_PARITY = {"valid": 1, "x": 1, "y": -1, "d": 1, "nx": 1, "ny": -1, "drop": 1, "danger": 1}
ACTION_PARITY = (1.0, -1.0)  # body-frame (vx, vy): the mirrored robot drives to the other side
if {n: len(p) for n, p in OWN_PARITY.items()} != dict(OWN_FIELDS) or not all(
        f in SLOT_PARITY for fs in SLOT_FIELDS.values() for f in fs):  # pragma: no cover (a new field)
    raise ImportError("observation.py: every own and slot field needs its mirror sign in OWN_PARITY / SLOT_PARITY")
_COUNT = {"robots": "k_robots", "targets": "k_targets", "breaks": "k_breaks", "assets": "k_assets", "scan": "k_scan"}


def _own_slices() -> dict:
    out, i = {}, 0
    for name, n in OWN_FIELDS:
        out[name] = slice(i, i + n)
        i += n
    return out


_OWN_SLICES = _own_slices()  # the own fields' columns (ObsLayout.own hands out a copy)
_OWN_SIZE = sum(n for _, n in OWN_FIELDS)


@functools.lru_cache(maxsize=256)
def _part_slice(layout, part: str) -> slice:
    """:meth:`ObsLayout.part_slice`, once per (layout, part): a step's decode asks for it some ten times."""
    return layout._part_slice(part)


DEFAULT_K_ASSETS = 2  # asset slots of a scenario that has assets and does not set k_assets

# offsets handed to the compiled encoder (named, so the kernel never indexes by number)
OwnOffsets = namedtuple("OwnOffsets", [name for name, _ in OWN_FIELDS])
PointSlot = namedtuple("PointSlot", ["start", "width", *SLOT_FIELDS["robots"]])
BreakSlot = namedtuple("BreakSlot", ["start", "width", *SLOT_FIELDS["breaks"]])

_DEFAULT = ObservationSpec()
# robots: fewer are encoded on one numba thread (the distance to go has its own threshold,
# tin_swarm.DIST_SERIAL_BELOW): below it the work is too small to pay for the other thread's start. In the env's
# step, right after sensing (best of 4, 2026-11-26, jacksboro, ~10 robots in range): 300 robots 0.48 ms a step
# serial vs 0.49 parallel, 500 robots 0.62 vs 0.63, 1 000 robots 0.96 vs 0.92 (bench/world.py's isolated stage,
# 2048 before, favoured one thread longer). The same bits either way
OBS_SERIAL_BELOW = 768
OBS_RUNS = 64  # fill_observations cuts the rows into this many runs (each with its scratch) among the threads
NO_SCAN = np.zeros((0, 1))  # fill_observations' ``scan`` ``pre`` when it computes the scan itself


def _ratio(v, scale):
    """Inverse of ``x / (|x| + scale)``: ``scale * v / (1 - |v|)`` (v clipped just inside +-1)."""
    v = np.clip(np.asarray(v, dtype=np.float64), -1 + 1e-9, 1 - 1e-9)
    return scale * v / (1 - np.abs(v))


@dataclass(frozen=True)
class ObsLayout:
    """The observation vector's one description: named slices, per-slot fields, scales.

    ``layout.own["battery"]`` is a slice; ``layout.robots`` / ``targets`` / ``breaks`` the slice of
    all slots of a part, which :meth:`slots` reshapes to ``(..., K, per_slot)`` and :meth:`field`
    reads one slot field of, by name (``layout.field(obs, "breaks", "danger")`` -> ``(..., K)``).
    Distances (slot x, y, d) are over the sensor range ``R``; the target distance is
    ``d / (d + R)`` and heights/drops ``dz / (|dz| + DZ_SCALE_M)``: :meth:`target_distance_m`,
    :meth:`target_dz_m` and :meth:`drop_m` invert them. The slot counts' defaults are
    :class:`~tin_swarm_env.scenario.ObservationSpec`'s (:meth:`from_spec`).
    """

    k_robots: int = _DEFAULT.k_robots
    k_targets: int = _DEFAULT.k_targets
    k_breaks: int = _DEFAULT.k_breaks
    k_assets: int = 0
    k_scan: int = _DEFAULT.k_scan

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise ObservationLayoutError(f"ObsLayout.{f.name} must be an integer >= 0, got {v!r}")

    @classmethod
    def from_spec(cls, spec: ObservationSpec, n_assets: int = 0) -> ObsLayout:
        """The layout of a scenario's ``[observation]`` table; ``n_assets``, the scenario's asset
        count, decides ``k_assets`` when the table does not (see the module docstring)."""
        k_a = spec.k_assets if spec.k_assets is not None else (DEFAULT_K_ASSETS if n_assets else 0)
        return cls(spec.k_robots, spec.k_targets, spec.k_breaks, k_a, spec.k_scan)

    # -- slices ------------------------------------------------------------------------------
    @property
    def own(self) -> dict[str, slice]:
        return dict(_OWN_SLICES)

    @property
    def own_size(self) -> int:
        return _OWN_SIZE

    def count(self, part: str) -> int:
        """Number of slots ``K`` of ``part`` (robots, targets, breaks, assets; the scan's beams)."""
        if part not in _COUNT:
            raise ObservationLayoutError(f"unknown observation part {part!r}; parts are {', '.join(PARTS)}")
        return getattr(self, _COUNT[part])

    def part_slice(self, part: str) -> slice:
        """The columns of ``part`` ("robots", "targets", "breaks", "assets", "scan") in an observation row."""
        if not isinstance(part, str) or part not in _COUNT:
            raise ObservationLayoutError(f"unknown observation part {part!r}; parts are {', '.join(PARTS)}")
        return _part_slice(self, part)

    def _part_slice(self, part: str) -> slice:
        a = self.own_size
        for p in PARTS:
            b = a + len(SLOT_FIELDS[p]) * self.count(p)
            if p == part:
                return slice(a, b)
            a = b
        raise ObservationLayoutError(f"unknown observation part {part!r}; parts are {', '.join(PARTS)}")

    @property
    def robots(self) -> slice:
        return self.part_slice("robots")

    @property
    def targets(self) -> slice:
        return self.part_slice("targets")

    @property
    def breaks(self) -> slice:
        return self.part_slice("breaks")

    @property
    def assets(self) -> slice:
        return self.part_slice("assets")

    @property
    def scan(self) -> slice:
        return self.part_slice("scan")

    @property
    def size(self) -> int:
        return self.part_slice(PARTS[-1]).stop

    # -- reading -----------------------------------------------------------------------------
    def slots(self, obs: np.ndarray, part: str) -> np.ndarray:
        """``obs[..., part]`` reshaped to ``(..., K, per_slot)`` for part robots/targets/breaks/assets."""
        sl = self.part_slice(part)
        return obs[..., sl].reshape(*obs.shape[:-1], self.count(part), len(SLOT_FIELDS[part]))

    def slot_index(self, part: str, name: str) -> int:
        """Position of field ``name`` inside one slot of ``part``."""
        names = SLOT_FIELDS.get(part)
        if names is None or name not in names:
            raise ObservationLayoutError(f"no slot field {part}.{name}; {part} slots hold "
                                         f"{', '.join(names) if names else '(unknown part)'}")
        return names.index(name)

    def field(self, obs: np.ndarray, part: str, name: str) -> np.ndarray:
        """One field of every slot of ``part``: ``(..., K)``; ``part="own"`` gives ``obs[..., own[name]]``."""
        obs = np.asarray(obs)
        if part == "own":
            if name not in _OWN_SLICES:
                raise ObservationLayoutError(f"no own field {name!r}; own fields are {', '.join(self.own)}")
            return obs[..., _OWN_SLICES[name]]
        return self.slots(obs, part)[..., self.slot_index(part, name)]

    def vectors(self, obs: np.ndarray, part: str, x: str = "x", y: str = "y") -> np.ndarray:
        """Two slot fields stacked: ``(..., K, 2)`` (e.g. the body-frame position over R)."""
        s = self.slots(np.asarray(obs), part)
        return s[..., [self.slot_index(part, x), self.slot_index(part, y)]]

    def target_distance_m(self, obs: np.ndarray, range_m: float) -> np.ndarray:
        """``(...,)`` horizontal distance to the assigned target (inverse of ``d / (d + R)``)."""
        v = np.clip(np.asarray(obs, dtype=np.float64)[..., _OWN_SLICES["target_dist"].start], 0.0, 1 - 1e-9)
        return v * range_m / (1 - v)

    def target_dz_m(self, obs: np.ndarray) -> np.ndarray:
        """``(...,)`` the assigned target's height above the robot (inverse of ``dz / (|dz| + s)``)."""
        return _ratio(np.asarray(obs)[..., _OWN_SLICES["target_dz"].start], DZ_SCALE_M)

    def drop_m(self, obs: np.ndarray) -> np.ndarray:
        """``(..., K_b)`` each break slot's drop in metres (inverse of ``drop / (|drop| + s)``)."""
        return _ratio(self.field(obs, "breaks", "drop"), DZ_SCALE_M)

    def names(self) -> list[str]:
        """One name per element, e.g. ``own.uphill[1]``, ``robots[2].x``."""
        out = []
        for name, n in OWN_FIELDS:
            out += [f"own.{name}"] if n == 1 else [f"own.{name}[{j}]" for j in range(n)]
        for part in PARTS:
            out += [f"{part}[{i}].{f}" for i in range(self.count(part)) for f in SLOT_FIELDS[part]]
        return out

    # -- mirror symmetry -------------------------------------------------------------------------
    def mirror_signs(self) -> np.ndarray:
        """``(size,)`` float32 of +-1: the sign the reflection gives each element, from
        :data:`OWN_PARITY` and :data:`SLOT_PARITY` over this layout's named slices. The whole
        reflection only when there are no scan beams (they are permuted, not negated: module
        docstring); with them it raises :class:`~tin_swarm_env.errors.ObservationLayoutError`."""
        if self.k_scan:
            raise ObservationLayoutError(
                f"ObsLayout.mirror_signs: with scan beams (k_scan = {self.k_scan}) the mirror image permutes the "
                f"beams (beam k <-> beam k_scan - k), it is not a sign flip; use ObsLayout.mirror")
        return _mirror_signs(self)

    def scan_bearings(self) -> np.ndarray:
        """``(K_s,)`` rad: each scan beam's bearing from the heading, counter-clockwise, ``2 pi k / K_s``
        (the one place it is written: the encoder, its reference and the decoder read it here)."""
        return _bearings(self.k_scan)

    def scan_units(self) -> np.ndarray:
        """``(K_s, 2)``: each beam's bearing as ``(cos, sin)`` (:meth:`scan_bearings`): the body-frame unit
        vectors the scan turns by the heading (:func:`~tin_swarm_env.world.scan_kernels.scan_start`)."""
        return _scan_units(self.k_scan)

    def mirror_permutation(self) -> np.ndarray:
        """``(size,)`` int64: element ``j`` of the mirrored observation is element ``perm[j]`` of the
        observation (before its sign, :meth:`mirror`): the identity but for the scan's beams,
        ``k -> (K_s - k) mod K_s``."""
        return _mirror_perm(self)

    def mirror(self, obs) -> np.ndarray:
        """The observation of the mirrored world (module docstring): ``obs (..., size)`` with its
        y components and signed turns negated and its scan beams permuted. Exact, and
        ``mirror(mirror(o)) == o``."""
        obs = np.asarray(obs)
        if obs.shape[-1:] != (self.size,):
            raise ObservationLayoutError(f"mirror: observations must end in size {self.size}, got shape {obs.shape}")
        if self.k_scan:
            obs = obs[..., self.mirror_permutation()]
        return obs * _mirror_signs(self).astype(obs.dtype if np.issubdtype(obs.dtype, np.floating) else np.float64)

    # -- saving ------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """JSON-able description (counts, field names, scale constants, size): a saved policy
        records it; two layouts read the same vectors exactly when their dicts are equal. Without
        asset slots the dict is the one layouts had before the assets part existed."""
        parts = [p for p in PARTS if (p != "assets" or self.k_assets) and (p != "scan" or self.k_scan)]
        extra = {"k_assets": self.k_assets} if self.k_assets else {}
        extra.update({"k_scan": self.k_scan} if self.k_scan else {})
        return {"k_robots": self.k_robots, "k_targets": self.k_targets, "k_breaks": self.k_breaks, **extra,
                "own": [[name, n] for name, n in OWN_FIELDS],
                "slots": {p: list(SLOT_FIELDS[p]) for p in parts},
                "scales": {"distance": "sensor range_m", "target_dist": "d / (d + range_m)",
                           "dz_scale_m": DZ_SCALE_M},
                "size": self.size, "names": self.names()}

    @classmethod
    def from_dict(cls, d: dict) -> ObsLayout:
        """The layout :meth:`to_dict` described; raises :class:`~tin_swarm_env.errors.ObservationLayoutError`
        naming the first key that this version's layout does not share."""
        try:
            out = cls(int(d["k_robots"]), int(d["k_targets"]), int(d["k_breaks"]), int(d.get("k_assets", 0)),
                      int(d.get("k_scan", 0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ObservationLayoutError(f"observation layout {d!r}: needs integer k_robots, k_targets, "
                                         f"k_breaks ({exc})") from None
        want = out.to_dict()
        for key in want:
            if key in d and _jsonish(d[key]) != _jsonish(want[key]):
                raise ObservationLayoutError(f"observation layout mismatch in {key!r}: saved {d[key]!r}, "
                                             f"this version has {want[key]!r}")
        return out

    # -- the compiled encoder's offsets -----------------------------------------------------------
    def kernel_offsets(self):
        """``(own, robots, targets, breaks, assets, scan)`` named offsets for :func:`fill_observations` (the scan's:
        its first column)."""
        own = OwnOffsets(*(sl.start for sl in self.own.values()))

        def slot(cls, part):
            names = SLOT_FIELDS[part]
            return cls(self.part_slice(part).start, len(names), *range(len(names)))

        return (own, slot(PointSlot, "robots"), slot(PointSlot, "targets"), slot(BreakSlot, "breaks"),
                slot(PointSlot, "assets"), self.part_slice("scan").start)


def _bearings(k: int) -> np.ndarray:
    """``(k,)`` the scan beams' bearings, ``2 pi j / k`` (:meth:`ObsLayout.scan_bearings`)."""
    return 2 * np.pi * np.arange(k) / max(k, 1)


@functools.lru_cache(maxsize=64)
def _scan_units(k: int) -> np.ndarray:
    b = _bearings(k)
    out = np.ascontiguousarray(np.column_stack([np.cos(b), np.sin(b)]))
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=64)
def _mirror_signs(layout: ObsLayout) -> np.ndarray:
    signs = np.ones(layout.size, dtype=np.float32)
    for name, sl in layout.own.items():
        signs[sl] = OWN_PARITY[name]
    for part in PARTS:
        k, w = layout.count(part), len(SLOT_FIELDS[part])
        per_slot = np.array([SLOT_PARITY[f] for f in SLOT_FIELDS[part]], dtype=np.float32)
        signs[layout.part_slice(part)] = np.tile(per_slot, k) if k * w else per_slot[:0]
    signs.setflags(write=False)
    return signs


@functools.lru_cache(maxsize=64)
def _mirror_perm(layout: ObsLayout) -> np.ndarray:
    perm = np.arange(layout.size)
    k = layout.k_scan
    if k:
        a = layout.scan.start
        perm[a:a + k] = a + (k - np.arange(k)) % k
    perm.setflags(write=False)
    return perm


def mirror_action(action) -> np.ndarray:
    """The mirrored body-frame action ``(..., 2)``: ``vy`` negated (:data:`ACTION_PARITY`); exact."""
    a = np.asarray(action)
    if a.shape[-1:] != (len(ACTION_PARITY),):
        raise ObservationLayoutError(f"mirror_action: actions must end in size {len(ACTION_PARITY)}, got {a.shape}")
    return a * np.asarray(ACTION_PARITY, dtype=a.dtype if np.issubdtype(a.dtype, np.floating) else np.float64)


def _jsonish(v):
    """Tuples as lists, recursively (a dict read back from JSON compares equal)."""
    if isinstance(v, dict):
        return {k: _jsonish(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonish(x) for x in v]
    return v


@njit(cache=True, inline="always")
def _point_slots(obs, i, sl, K, start, idx, dist, src, pos, c, s, R):
    """Robot or target slots of robot ``i`` (``sl`` a :class:`PointSlot`): valid, x/R, y/R
    (body frame), d/R of its first ``K`` contacts ``start[i]:start[i + 1]`` (nearest first;
    ``idx`` -1 leaves a slot empty)."""
    for k in range(min(start[i + 1] - start[i], K)):
        p = start[i] + k
        j = idx[p]
        if j < 0:
            continue
        dx = src[j, 0] - pos[i, 0]
        dy = src[j, 1] - pos[i, 1]
        b = sl.start + sl.width * k
        obs[i, b + sl.valid] = 1.0
        obs[i, b + sl.x] = (c * dx + s * dy) / R
        obs[i, b + sl.y] = (-s * dx + c * dy) / R
        obs[i, b + sl.d] = dist[p] / R


@njit(cache=True, inline="always")
def _break_slots(obs, i, sl, K, start, idx, dist, closest, normals, drops, danger, pos, c, s, R, dz_scale):
    """Break slots of robot ``i`` (``sl`` a :class:`BreakSlot`; contacts as in :func:`_point_slots`)."""
    for k in range(min(start[i + 1] - start[i], K)):
        p = start[i] + k
        j = idx[p]
        if j < 0:
            continue
        dx = closest[p, 0] - pos[i, 0]
        dy = closest[p, 1] - pos[i, 1]
        nx = normals[j, 0]
        ny = normals[j, 1]
        b = sl.start + sl.width * k
        obs[i, b + sl.valid] = 1.0
        obs[i, b + sl.x] = (c * dx + s * dy) / R
        obs[i, b + sl.y] = (-s * dx + c * dy) / R
        obs[i, b + sl.nx] = c * nx + s * ny
        obs[i, b + sl.ny] = -s * nx + c * ny
        obs[i, b + sl.drop] = drops[j] / (abs(drops[j]) + dz_scale)
        obs[i, b + sl.d] = dist[p] / R
        obs[i, b + sl.danger] = danger[j]


@njit(cache=True, inline="always")
def scan_beams(obs, i, at, K, start, idx, ends, units, danger, pos, c, s, R, b):
    """Scan beams of robot ``i`` (columns ``at .. at + K``): along bearing ``2 pi k / K`` from the heading
    (``units`` :meth:`ObsLayout.scan_units`, the bearings' cos and sin), the distance to the first
    dangerous break among its contacts ``start[i]:start[i + 1]`` that the beam crosses, over ``R`` (1 when
    none within ``R``; ``ends (B, 4)``: ax, ay, bx, by; ``(c, s)`` the heading's cos and sin; ``b`` a
    ``(K, 3)`` scratch, overwritten). Each dangerous contact is crossed with the beams of its wedge only
    (:func:`~tin_swarm_env.world.scan_kernels.scan_contact`): O(contacts + K) a robot, the minimum over
    the same crossings as every beam against every contact, so the same bits."""
    px = pos[i, 0]
    py = pos[i, 1]
    used = False
    for p in range(start[i], start[i + 1]):
        j = idx[p]
        if j < 0 or danger[j] == 0.0:
            continue
        if not used:
            used = True
            scan_start(b, c, s, units, R, K)
        scan_contact(b, ends[j, 0] - px, ends[j, 1] - py, ends[j, 2] - ends[j, 0], ends[j, 3] - ends[j, 1], c, s, K)
    for k in range(K):
        obs[i, at + k] = b[k, 0] / R if used else 1.0


@njit(cache=True, inline="always")
def _own(obs, i, o, c, s, own_n, own_scale, planes, tri, target_idx, tpos, tz, pos, heights, R, dz_scale):
    """Own fields of robot ``i`` (``o`` an :class:`OwnOffsets`; ``own_n``: the ``(n,)`` battery,
    speed, tilt and slope, each divided here by its ``own_scale``; the uphill gradient from the
    plane of its triangle)."""
    bat, spd, tilt, slope = own_n
    bs, ss, ts, ls = own_scale
    obs[i, o.battery] = bat[i] / bs
    obs[i, o.speed] = min(max(spd[i] / ss, 0.0), 1.0)
    obs[i, o.tilt] = tilt[i] / ts
    obs[i, o.slope] = slope[i] / ls
    gx = planes[tri[i], 0]
    gy = planes[tri[i], 1]
    gn = np.sqrt(gx * gx + gy * gy)
    if gn > 1e-6:  # below a micro-degree the ground counts as level: no uphill direction
        obs[i, o.uphill] = (c * gx + s * gy) / gn
        obs[i, o.uphill + 1] = (-s * gx + c * gy) / gn
    t = target_idx[i]
    if t >= 0 and tpos.shape[0] > 0:
        dx = tpos[t, 0] - pos[i, 0]
        dy = tpos[t, 1] - pos[i, 1]
        d = np.sqrt(dx * dx + dy * dy)
        obs[i, o.target_valid] = 1.0
        if d > 0:
            obs[i, o.target_dir] = (c * dx + s * dy) / d
            obs[i, o.target_dir + 1] = (-s * dx + c * dy) / d
        obs[i, o.target_dist] = d / (d + R)
        dz = tz[t] - heights[i]
        obs[i, o.target_dz] = dz / (abs(dz) + dz_scale)


@njit(cache=True, parallel=True)
def fill_observations(obs, o, o_rob, o_tgt, o_brk, o_ast, o_scn, ks, pos, head, heights, own_n, own_scale, planes,
                      tri, live, target_idx, tpos, tz, robots, targets, breaks, apos, assets, scan, R, dz_scale):
    """Write every live robot's row of ``obs``; ``o, o_rob, o_tgt, o_brk, o_ast, o_scn`` the offsets of
    :meth:`ObsLayout.kernel_offsets` (passed one by one: numba's parallel loop takes namedtuples
    as arguments, not unpacked inside), ``ks`` the slot counts (robots, targets, breaks, assets,
    scan beams); ``robots``/``targets``/``assets`` ``(start, idx, dist)`` and ``breaks`` ``(start,
    idx, dist, closest, normals, drops, danger)``: the sensor readings' contacts, grouped by
    observer and nearest first (:func:`_grouped`), and the break set's arrays; ``apos (k, 2)``;
    ``scan`` ``(start, idx, ends, units, pre)``: every break contact of each observer, the segments'
    ends and the beams' unit vectors (:meth:`ObsLayout.scan_units`) the scan is computed from
    (:func:`scan_beams`), or, when ``pre (n, K)`` has rows, the scan as the sensing pass computed it
    (the vector env's :func:`~tin_swarm_env.world.sense_kernels.break_row`, the same bits), copied."""
    rs, ri, rd = robots  # (numba's parallel loops take arrays, not tuples of them)
    ts, ti, td = targets
    bs, bi, bd, bc, bn, bdrop, bdanger = breaks
    as_, ai, ad = assets
    ss, si, se, sun, spre = scan
    kr, kt, kb, ka, ks_ = ks
    n = pos.shape[0]
    C = min(n, OBS_RUNS)
    for run in prange(C):  # runs of rows, each row computed alone: bit-identical for any thread count
        b = np.empty((max(ks_, 1), 3))  # the scan's scratch, one per run
        for i in range(run * n // C, (run + 1) * n // C):
            if not live[i]:
                continue
            c = np.cos(head[i])
            s = np.sin(head[i])
            _own(obs, i, o, c, s, own_n, own_scale, planes, tri, target_idx, tpos, tz, pos, heights, R, dz_scale)
            _point_slots(obs, i, o_rob, kr, rs, ri, rd, pos, pos, c, s, R)
            _point_slots(obs, i, o_tgt, kt, ts, ti, td, tpos, pos, c, s, R)
            _break_slots(obs, i, o_brk, kb, bs, bi, bd, bc, bn, bdrop, bdanger, pos, c, s, R, dz_scale)
            _point_slots(obs, i, o_ast, ka, as_, ai, ad, apos, pos, c, s, R)
            if ks_ and spre.shape[0]:
                for k in range(ks_):  # computed by the sensing pass (the vector env: break_row)
                    obs[i, o_scn + k] = spre[i, k]
            elif ks_:
                scan_beams(obs, i, o_scn, ks_, ss, si, se, sun, bdanger, pos, c, s, R, b)
            for m in range(obs.shape[1]):
                obs[i, m] = min(max(obs[i, m], -1.0), 1.0)


def _grouped(contacts, n, k, extra=None):
    """``(start (n + 1,), idx, dist[, extra])`` of ``contacts`` (sensing's Contacts or
    BreakContacts) grouped by observer, nearest first: their own lists when they carry
    ``start``, else their :meth:`nearest` ``k`` as rows of ``k`` (``idx`` -1 in empty slots).
    ``extra`` names a further per-contact array (the breaks' ``closest``)."""
    if contacts.start is not None and len(contacts.start) == n + 1:
        out = (contacts.start, np.ascontiguousarray(contacts.target if extra is None else contacts.break_idx),
               np.ascontiguousarray(contacts.distance_m, dtype=np.float64))
        if extra is not None:
            out += (np.ascontiguousarray(getattr(contacts, extra), dtype=np.float64).reshape(-1, 2),)
        return out
    got = contacts.nearest(n, k)
    out = (np.arange(n + 1, dtype=np.int64) * k, np.ascontiguousarray(got[0], dtype=np.int64).reshape(-1),
           np.ascontiguousarray(got[1], dtype=np.float64).reshape(-1))
    if extra is not None:
        out += (np.ascontiguousarray(got[2], dtype=np.float64).reshape(-1, 2),)
    return out


@functools.lru_cache(maxsize=64)
def layout_offsets(layout: ObsLayout):
    return layout.kernel_offsets()


def _target_heights(world, tg):
    """The targets' ground heights ``(k,)``, kept per world while the targets stand where they
    stood (static targets: every step after the first reads the cache)."""
    if not len(tg):
        return np.zeros(0)
    key = (tg.positions.tobytes(), np.asarray(tg.tri_idx).tobytes())
    got = world.__dict__.get("_obs_target_heights")
    if got is None or got[0] != key:
        got = world.__dict__["_obs_target_heights"] = (key, world.tin.height_in(tg.positions, tg.tri_idx))
    return got[1]


def _break_arrays(world):
    """The break set's per-segment arrays the encoder reads, built once per world: normals, drops,
    danger (1.0 / 0.0) and ends ``(B, 4)`` (ax, ay, bx, by)."""
    got = world.__dict__.get("_obs_break_arrays")
    if got is None or got[0] is not world.breaks:
        br = world.breaks
        arrays = (np.ascontiguousarray(br.normals.reshape(-1, 2)), np.ascontiguousarray(br.drops_m.reshape(-1)),
                  (br.kinds != ANGLE).astype(np.float64),
                  np.ascontiguousarray(br.segments[:, :, :2].reshape(-1, 4), dtype=np.float64))
        # read-only, as the vector env's (its pack's, world/pack.py frozen): the encoder compiles once for both
        got = world.__dict__["_obs_break_arrays"] = (br,) + tuple(frozen(a) for a in arrays)
    return got[1:]


def _all_contacts(contacts, n):
    """``(start (n + 1,), idx)``: every one of ``contacts`` (BreakContacts), grouped by observer."""
    if contacts.start is not None and len(contacts.start) == n + 1:
        return contacts.start, np.ascontiguousarray(contacts.break_idx, dtype=np.int64)
    order = np.argsort(contacts.observer, kind="stable")
    start = np.zeros(n + 1, dtype=np.int64)
    start[1:] = np.cumsum(np.bincount(contacts.observer, minlength=n)[:n])
    return start, np.ascontiguousarray(contacts.break_idx[order], dtype=np.int64)


def build_observations(world, state, readings, target_idx, live, layout: ObsLayout) -> np.ndarray:
    """``(n, layout.size)`` float32 observations for all robots (zeros where ``live`` is False);
    one compiled pass over the robots (:func:`tin_swarm_env.env.reference.build_observations_reference`
    is the plain numpy version it is tested against)."""
    P = world.params
    n = state.n_robots
    ks = (layout.k_robots, layout.k_targets, layout.k_breaks, layout.k_assets, layout.k_scan)
    tg = state.targets
    tz = _target_heights(world, tg)
    own_n = tuple(np.ascontiguousarray(v, dtype=np.float64)
                  for v in (state.battery_j, state.speeds, readings.tilt_rad, readings.slope_deg))
    own_scale = (float(P.battery.capacity_j), float(P.robot.max_speed_mps), np.pi / 2, 90.0)
    arrays = _break_arrays(world)
    breaks = _grouped(readings.breaks, n, ks[2], "closest") + arrays[:3]
    scan = (_all_contacts(readings.breaks, n) + arrays[3:] if layout.k_scan
            else (np.zeros(n + 1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 4))))
    scan += (layout.scan_units(), NO_SCAN)
    obs = np.zeros((n, layout.size), dtype=np.float32)
    with serial_if_small(n, OBS_SERIAL_BELOW):
        fill_observations(obs, *layout_offsets(layout), ks, state.positions, state.headings, state.heights, own_n,
                          own_scale, world.tin.planes, np.ascontiguousarray(state.tri_idx, dtype=np.int64), live,
                          target_idx, tg.positions.reshape(-1, 2), tz, _grouped(readings.robots, n, ks[0]),
                          _grouped(readings.targets, n, ks[1]), breaks, state.assets.positions.reshape(-1, 2),
                          _grouped(readings.assets, n, ks[3]), scan, float(P.sensor.range_m), DZ_SCALE_M)
    return obs
