"""The swarm world: static terrain context plus a batched, deterministic ``step``."""

from __future__ import annotations

import math
from contextlib import contextmanager
from dataclasses import dataclass

import numba
import numpy as np

from ..errors import ArgumentError
from ..terrain import Tin
from .entities import make_entities, move_entities
from .pack import one_copy, pack_one
from .params import WorldParams
from .placement import check_placement
from .sensing import BreakIndex, SensorReadings, sense
from .state import Entities, Reason, WorldState, copy_rng
from .step_kernel import step_copies

__all__ = ["World", "StepEvents", "flat_tin", "SERIAL_BELOW", "step_scalars"]

SERIAL_BELOW = 256  # robots: fewer run the step's and sensing's kernels on one thread (see serial_if_small)


@contextmanager
def serial_if_small(n: int, below: int | None = None):
    """Run the enclosed kernels on one numba thread when ``n < below`` (default
    :data:`SERIAL_BELOW`): a parallel region's start-up (waking the other threads) costs more
    than a few hundred robots' work (100 robots: 0.57x on 2 threads, bench/world.py). The
    results are the same bit for bit on any thread count, so this changes time only."""
    k = numba.get_num_threads()
    if n >= (SERIAL_BELOW if below is None else below) or k == 1:
        yield
        return
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(k)


def step_scalars(P: WorldParams) -> tuple:
    """The scalars :func:`~.step_kernel.step_copies` reads, from the world parameters (their one
    home: the world's step and the vector env's): ``(max_speed, max_climb_deg, max_turn (rad per
    step), dt, idle_j (the idle and sensing draw of one step), drive_j_per_m, climb_j_per_m,
    collision diameter)``."""
    B = P.battery
    return (float(P.robot.max_speed_mps), float(P.robot.max_climb_deg), math.radians(P.robot.turn_rate_dps) * P.dt_s,
            float(P.dt_s), float((B.idle_w + B.sensing_w) * P.dt_s), float(B.drive_j_per_m), float(B.climb_j_per_m),
            float(2 * P.robot.radius_m))


def flat_tin(width_m: float, height_m: float) -> Tin:
    """The plane used when no terrain is given: two triangles at z = 0 over [0, w] x [0, h]."""
    v = np.array([[0, 0, 0], [width_m, 0, 0], [width_m, height_m, 0], [0, height_m, 0]], dtype=float)
    return Tin(v, [[0, 1, 2], [0, 2, 3]], source="flat plane")


@dataclass
class StepEvents:
    """What happened in one step, per robot (n,) unless noted."""

    moved_m: np.ndarray  # distance driven
    climb_m: np.ndarray  # height gained (negative: lost)
    energy_j: np.ndarray  # battery drawn
    motion_event: np.ndarray  # locomotion.MOVED / BLOCKED_BORDER / BLOCKED_STEEP / FELL_INTO
    fell: np.ndarray  # bool: fell this step
    emptied: np.ndarray  # bool: battery ran out this step
    collisions: np.ndarray  # robots within two radii of this one, this step
    collision_pairs: np.ndarray  # (C, 2) int64


class World:
    """Robots on a TIN (or on a flat plane when ``tin`` is None, thesis 4.3).

    Holds what does not change during an episode: the terrain, which triangles are too steep
    (slope > ``params.robot.max_slope_deg``), the terrain breaks and their spatial index.
    :meth:`reset` makes a :class:`~.state.WorldState`; :meth:`step` advances one; :meth:`sense`
    tells what every robot senses. Same state, same commands -> the same next state, bit for
    bit: every random draw comes from ``state.rng``.
    """

    def __init__(self, tin: Tin | None = None, params: WorldParams | None = None):
        self.params = params or WorldParams()
        self.flat = tin is None
        self.tin = flat_tin(*self.params.flat_size_m) if tin is None else tin
        self.steep = np.ascontiguousarray(self.tin.slope_deg > self.params.robot.max_slope_deg)
        self.breaks = self.tin.breaks(max_slope_deg=self.params.robot.max_slope_deg,
                                      break_angle_deg=self.params.break_angle_deg)
        self.break_index = BreakIndex(self.breaks, piece_m=self.params.sensor.range_m, bounds=self.tin.bounds)

    # -- reset --------------------------------------------------------------------------
    def reset(self, rng: np.random.Generator | int | None, robot_positions, headings=None, *,
              targets=None, targets_mobile=False, assets=None, assets_mobile=False) -> WorldState:
        """A new state. ``robot_positions (n, 2)``; ``headings (n,)`` rad (default: drawn
        uniformly from ``rng``); ``targets``/``assets`` ``(m, 2)`` positions, ``*_mobile`` a bool
        or ``(m,)`` bools. Raises a PlacementError naming the robot (or entity) that lies outside
        the terrain or on a too-steep triangle, an ArgumentError for zero robots."""
        rng = np.random.default_rng(rng) if not isinstance(rng, np.random.Generator) else rng
        if np.ndim(robot_positions) != 2 or np.shape(robot_positions)[1] != 2:
            raise ArgumentError(f"robot_positions must have shape (n, 2), got {np.shape(robot_positions)}")
        if len(robot_positions) == 0:
            raise ArgumentError("a world needs at least one robot, got 0")
        p, tri = self.check_placement(robot_positions, "robot {i}")
        n = len(p)
        if headings is None:
            h = rng.uniform(-math.pi, math.pi, n)
        else:
            h = np.broadcast_to(np.asarray(headings, dtype=np.float64), (n,)).copy()
            if not np.all(np.isfinite(h)):
                raise ArgumentError("headings must be finite")
        tg = Entities.empty() if targets is None or not np.size(targets) else make_entities(
            self.tin, self.steep, targets, targets_mobile, rng, "target")
        at = Entities.empty() if assets is None or not np.size(assets) else make_entities(
            self.tin, self.steep, assets, assets_mobile, rng, "asset")
        return WorldState(positions=p.copy(), headings=h, tri_idx=tri, heights=self.tin.height_in(p, tri),
                          speeds=np.zeros(n), battery_j=np.full(n, float(self.params.battery.capacity_j)),
                          status=np.zeros(n, dtype=np.int8), collisions=np.zeros(n, dtype=np.int64),
                          targets=tg, assets=at, rng=rng, step=0)

    def check_placement(self, positions, label: str = "point {i}"):
        """``(positions (m, 2), tri_idx (m,))`` of points on traversable ground, or a
        PlacementError naming the first that is not (:func:`~.placement.check_placement`)."""
        return check_placement(self.tin, self.steep, positions, label)

    # -- step ---------------------------------------------------------------------------
    def check_commands(self, state: WorldState, commands) -> np.ndarray:
        c = np.asarray(commands, dtype=np.float64)
        if c.shape != (state.n_robots, 2):
            raise ArgumentError(f"commands must have shape ({state.n_robots}, 2), got {c.shape}")
        if not np.isfinite(c).all():  # one pass; find the culprit only when there is one
            i = int(np.flatnonzero(~np.all(np.isfinite(c), axis=1))[0])
            raise ArgumentError(f"robot {i}: command {c[i].tolist()} is not finite (NaN or inf)")
        return np.ascontiguousarray(c)

    def step(self, state: WorldState, commands) -> tuple[WorldState, StepEvents]:
        """Advance one step of ``params.dt_s``. ``commands (n, 2)``: body-frame velocity as
        fractions of max speed (clipped; see :mod:`.locomotion`). NaN/inf commands raise a
        ValueError naming the robot. Returns the new state (the old one is not modified) and
        the step's events."""
        return self._step(state, self.check_commands(state, commands))

    def _step(self, state: WorldState, c: np.ndarray) -> tuple[WorldState, StepEvents]:
        """:meth:`step` with ``c`` already checked: ``(n, 2)`` C-contiguous float64, all finite (for a
        caller that has checked its commands itself, so the check is not paid twice a step)."""
        P = self.params
        # locomotion.move, battery.drain, the status codes and the collision count (the numpy and
        # kernel references) in one compiled pass: step_copies, the vector env's, on a pack of one copy
        wor, cop, off = one_copy(state.n_robots)
        pk = pack_one(self)
        with serial_if_small(state.n_robots):
            (pos, tri, head, heights, speeds, ev, moved, climb, new_batt, energy, status, fell, emptied, coll,
             pairs) = step_copies(
                pk.T0, pk.steep, wor, cop, off, np.ascontiguousarray(state.positions),
                np.ascontiguousarray(state.tri_idx), np.ascontiguousarray(state.headings),
                np.ascontiguousarray(state.heights), np.ascontiguousarray(state.status), state.battery_j, c,
                step_scalars(P))
        rng = copy_rng(state.rng)  # the old state keeps its generator (and its future draws)
        turn_sd = math.radians(P.entity_turn_sd_deg)
        targets = move_entities(self.tin, self.steep, state.targets, P.entity_speed_mps, turn_sd, P.dt_s, rng)
        assets = move_entities(self.tin, self.steep, state.assets, P.entity_speed_mps, turn_sd, P.dt_s, rng)
        new = WorldState(positions=pos, headings=head, tri_idx=tri, heights=heights, speeds=speeds,
                         battery_j=new_batt, status=status, collisions=state.collisions + coll,
                         targets=targets if targets is not state.targets else targets.copy(),
                         assets=assets if assets is not state.assets else assets.copy(), rng=rng, step=state.step + 1)
        return new, StepEvents(moved_m=moved, climb_m=climb, energy_j=energy, motion_event=ev, fell=fell,
                               emptied=emptied, collisions=coll, collision_pairs=pairs)

    def retire(self, state: WorldState, mask) -> WorldState:
        """A copy of ``state`` with the robots in ``mask`` taken off the terrain (status ``Reason.ARRIVED``):
        the task is over for them (e.g. they arrived); they no longer move, sense, are seen or
        collide. Fallen robots stay ``Reason.FELL``."""
        s = state.copy()
        m = np.asarray(mask, dtype=bool) & (s.status != Reason.FELL)
        s.status[m] = Reason.ARRIVED
        return s

    def sense(self, state: WorldState) -> SensorReadings:
        """What every robot senses (see :mod:`.sensing`)."""
        with serial_if_small(state.n_robots):
            return sense(self, state)
