"""Threats/targets and assets: static points, or mobile ones on a random walk."""

from __future__ import annotations

import math

import numpy as np

from .placement import check_placement
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
    step = speed_mps * dt_s * np.column_stack([np.cos(h), np.sin(h)])
    prop = ent.positions[m] + step
    tri = tin.locate(prop, hint=ent.tri_idx[m])
    ok = tri >= 0
    ok[ok] = ~steep[tri[ok]]
    out.positions[m[ok]] = prop[ok]
    out.tri_idx[m[ok]] = tri[ok]
    h[~ok] += math.pi
    out.headings[m] = (h + math.pi) % (2 * math.pi) - math.pi
    return out
