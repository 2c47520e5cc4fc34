"""Threats/targets and assets: static points, or mobile ones on a random walk."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .placement import check_placement
from .sense_kernels import locate1, terrain_arrays
from .state import Entities

__all__ = ["make_entities", "move_entities"]


def make_entities(tin, steep, positions, mobile, rng, what: str) -> Entities:
    """Entities at ``positions (m, 2)``; each must lie on a traversable triangle (a
    PlacementError names the entity otherwise: :func:`~.placement.check_placement`). Mobile
    ones get a random initial heading from ``rng``."""
    p, tri = check_placement(tin, steep, positions, what + " {i}")
    mob = np.broadcast_to(np.asarray(mobile, dtype=bool), (len(p),)).copy()
    headings = rng.uniform(-math.pi, math.pi, len(p)) if mob.any() else np.zeros(len(p))
    return Entities(p.copy(), tri, headings, mob)


def move_entities(tin, steep, ent: Entities, speed_mps, turn_sd_rad, dt_s, rng) -> Entities:
    """One random-walk step of the mobile entities: the heading changes by a normal draw
    (one per mobile entity, from ``rng``), then the entity moves ``speed * dt`` unless that
    would leave the terrain or enter a too-steep triangle, in which case it turns around and
    stays. Static entities never draw from ``rng``."""
    if not ent.mobile.any() or speed_mps == 0:
        return ent
    out = ent.copy()
    m = np.flatnonzero(ent.mobile)
    h = ent.headings[m] + rng.normal(0.0, turn_sd_rad, len(m))
    ok = _walk(terrain_arrays(tin), steep, out.positions, out.tri_idx, m, speed_mps * dt_s, np.cos(h), np.sin(h))
    h[~ok] += math.pi
    out.headings[m] = (h + math.pi) % (2 * math.pi) - math.pi
    return out


@njit(cache=True)
def _walk(T, steep, pos, tri, m, step, c, s):
    """Entities ``m`` moved by ``step * (c, s)`` in place where the new point lies on the TIN
    (located from the entity's triangle, as :meth:`Tin.locate` with a hint) on a traversable
    triangle; returns which moved."""
    ok = np.zeros(m.shape[0], dtype=np.bool_)
    for k in range(m.shape[0]):
        i = m[k]
        x = pos[i, 0] + step * c[k]
        y = pos[i, 1] + step * s[k]
        t = locate1(T, x, y, tri[i])
        if t >= 0 and not steep[t]:
            pos[i, 0] = x
            pos[i, 1] = y
            tri[i] = t
            ok[k] = True
    return ok
