"""World state: every array ``step`` reads, and the random generator."""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import IntEnum

import numpy as np

__all__ = ["WorldState", "Entities", "Reason", "is_present", "copy_rng"]


class Reason(IntEnum):
    """Why a robot's episode ended (the codes ``step_arrays`` returns; ``NONE``: it did not).

    ``.label`` is the string in ``infos[agent]["reason"]``: "arrived", "fell", "battery",
    "max_cycles" (TIMEOUT: cut off by the episode length, a truncation).
    """

    NONE = 0
    ARRIVED = 1
    FELL = 2
    BATTERY = 3
    TIMEOUT = 4

    @property
    def label(self) -> str:
        return _LABELS[self]


_LABELS = {Reason.NONE: "", Reason.ARRIVED: "arrived", Reason.FELL: "fell", Reason.BATTERY: "battery",
           Reason.TIMEOUT: "max_cycles"}



def is_present(status: np.ndarray) -> np.ndarray:
    """``(n,)`` bool: robots physically on the terrain (active or out of battery; fallen and
    done ones are gone): they are seen and collide."""
    return (status == Reason.NONE) | (status == Reason.BATTERY)


@dataclass
class Entities:
    """Threats/targets or assets: points on the terrain, static or mobile.

    positions   (m, 2) m
    tri_idx     (m,)   containing triangle
    headings    (m,)   rad, direction of travel of mobile ones
    mobile      (m,)   bool
    """

    positions: np.ndarray
    tri_idx: np.ndarray
    headings: np.ndarray
    mobile: np.ndarray

    @classmethod
    def empty(cls) -> Entities:
        return cls(np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0, dtype=bool))

    def __len__(self) -> int:
        return len(self.positions)

    def copy(self) -> Entities:
        return Entities(*(getattr(self, f.name).copy() for f in fields(self)))


def copy_rng(rng):
    """An independent generator in the same state (its future draws equal ``rng``'s): the bit
    generator's state copied into a fresh one, a quarter of ``copy.deepcopy``'s time."""
    import copy

    bg = rng.bit_generator
    try:
        fresh = type(bg)(0)
        fresh.state = bg.state
    except Exception:  # an exotic bit generator: the slow general way
        return copy.deepcopy(rng)
    return type(rng)(fresh)


@dataclass
class WorldState:
    """One world snapshot. Arrays over the ``n`` robots:

    positions   (n, 2) m        x east, y north
    headings    (n,)   rad      counter-clockwise from east
    tri_idx     (n,)   int64    triangle under each robot
    heights     (n,)   m        ground height under each robot
    speeds      (n,)   m/s      speed achieved in the last step
    battery_j   (n,)   J        charge left
    status      (n,)   int8     a :class:`Reason` code: NONE (active), FELL, BATTERY (out of battery:
                               still on the terrain) or ARRIVED (taken off the terrain by the task;
                               like a fallen robot it no longer moves, senses, is seen or collides)
    collisions  (n,)   int64    collisions counted so far (robots within 2 radii, per step)
    targets, assets             :class:`Entities`
    step        int             steps taken
    rng         np.random.Generator, the only source of randomness below reset()
    """

    positions: np.ndarray
    headings: np.ndarray
    tri_idx: np.ndarray
    heights: np.ndarray
    speeds: np.ndarray
    battery_j: np.ndarray
    status: np.ndarray
    collisions: np.ndarray
    targets: Entities
    assets: Entities
    rng: np.random.Generator
    step: int = 0

    @property
    def n_robots(self) -> int:
        return len(self.positions)

    @property
    def active(self) -> np.ndarray:
        """``(n,)`` bool: robots that move, sense and draw power."""
        return self.status == Reason.NONE

    @property
    def present(self) -> np.ndarray:
        """``(n,)`` bool, see :func:`is_present`."""
        return is_present(self.status)

    def copy(self) -> WorldState:
        """A deep copy (the generator too, so the copy's future draws equal the original's)."""
        kw = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, np.ndarray):
                kw[f.name] = v.copy()
            elif isinstance(v, Entities):
                kw[f.name] = v.copy()
            elif f.name == "rng":
                kw[f.name] = copy_rng(v)
            else:
                kw[f.name] = v
        return WorldState(**kw)
