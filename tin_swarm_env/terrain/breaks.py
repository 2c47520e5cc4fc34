"""Terrain breaks: the TIN edges a robot must respect.

An edge is a break when

* ``BORDER``: it lies on the TIN's boundary (one triangle);
* ``STEEP``: one side is traversable (slope <= ``max_slope_deg``) and the other too steep;
* ``ANGLE``: the planes on its two sides differ by more than ``break_angle_deg`` (the angle
  between their normals) - ridges, valley floors, the top and foot of a cliff.

For each break: the segment, the unit normal in x, y pointing toward the *safe* side (the
triangle a robot may stand on: the only triangle for a border edge, the traversable one for a
steep edge, the less steep one for an angle break), and the drop in metres: the height of
the edge's midpoint above the unsafe triangle's far vertex (positive where the ground falls
away, a cliff top; negative where it rises, the foot of a wall; 0 for border edges).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ArgumentError

__all__ = ["Breaks", "find_breaks", "closest_on_segments", "BORDER", "STEEP", "ANGLE", "MAX_SLOPE_DEG",
           "BREAK_ANGLE_DEG"]

BORDER, STEEP, ANGLE = 0, 1, 2

# the defaults of these settings everywhere (terrain queries, robot and world parameters)
MAX_SLOPE_DEG = 30.0  # steepest traversable triangle
BREAK_ANGLE_DEG = 25.0  # planes meeting at more than this angle form a break


def closest_on_segments(points, a, b):
    """Closest points on segments ``a -> b`` to ``points`` (all broadcast against each other,
    last axis x, y): ``(closest (..., 2), distance (...))``."""
    ab = b - a
    L2 = np.maximum(np.sum(ab * ab, axis=-1), 1e-300)
    u = np.clip(np.sum((points - a) * ab, axis=-1) / L2, 0.0, 1.0)
    closest = a + u[..., None] * ab
    return closest, np.sqrt(np.sum((points - closest) ** 2, axis=-1))


@dataclass(frozen=True, eq=False)
class Breaks:
    """Break edges of a TIN (``B`` of them).

    segments     (B, 2, 3) m    end points of each break edge
    normals      (B, 2)         unit normal in x, y pointing to the safe side
    drops_m      (B,)  m        edge midpoint height above the unsafe triangle's far vertex
    kinds        (B,)  int8     BORDER, STEEP or ANGLE (a steep edge is STEEP even when its
                                angle also exceeds the break angle)
    edge_idx     (B,)  int64    index into ``tin.edges``
    safe_idx     (B,)  int64    the safe triangle
    unsafe_idx   (B,)  int64    the other triangle, -1 on the border
    """

    segments: np.ndarray
    normals: np.ndarray
    drops_m: np.ndarray
    kinds: np.ndarray
    edge_idx: np.ndarray
    safe_idx: np.ndarray
    unsafe_idx: np.ndarray

    def __len__(self) -> int:
        return len(self.kinds)

    def nearest(self, xy, range_m: float | None = None):
        """Distance ``(n,)`` m from each point to its nearest break segment and that
        segment's index (``-1`` and ``inf`` when none lies within ``range_m``). Vectorised over
        points x segments in chunks: for a few points; the world layer keeps its own index."""
        pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
        a = self.segments[:, 0, :2]
        b = self.segments[:, 1, :2]
        best = np.full(len(pts), np.inf)
        idx = np.full(len(pts), -1, dtype=np.int64)
        for s in range(0, len(pts), 512):
            p = pts[s:s + 512]
            _, d = closest_on_segments(p[:, None, :], a[None], b[None])
            j = d.argmin(axis=1) if d.shape[1] else np.zeros(len(p), dtype=np.int64)
            dm = d[np.arange(len(p)), j] if d.shape[1] else np.full(len(p), np.inf)
            best[s:s + 512] = dm
            idx[s:s + 512] = j if d.shape[1] else -1
        if range_m is not None:
            far = best > range_m
            best[far] = np.inf
            idx[far] = -1
        return best, idx


def find_breaks(tin, max_slope_deg: float = MAX_SLOPE_DEG, break_angle_deg: float | None = BREAK_ANGLE_DEG) -> Breaks:
    """All break edges of ``tin`` (see the module docstring). ``break_angle_deg=None`` turns
    angle breaks off."""
    if not (0 < max_slope_deg <= 90):
        raise ArgumentError(f"max_slope_deg must be in (0, 90], got {max_slope_deg}")
    if break_angle_deg is not None and not (0 <= break_angle_deg <= 180):
        raise ArgumentError(f"break_angle_deg must be in [0, 180], got {break_angle_deg}")
    E = tin.edges
    t0, t1 = tin.edge_triangles[:, 0], tin.edge_triangles[:, 1]
    border = t1 < 0
    t1c = np.where(border, t0, t1)
    steep = tin.slope_deg > max_slope_deg
    is_steep = ~border & (steep[t0] != steep[t1c])
    cosang = np.clip(np.einsum("ij,ij->i", tin.normals[t0], tin.normals[t1c]), -1.0, 1.0)
    angle = np.degrees(np.arccos(cosang))
    is_angle = ~border & ~is_steep
    if break_angle_deg is None:
        is_angle &= False
    else:
        is_angle &= angle > break_angle_deg
    sel = border | is_steep | is_angle
    e_idx = np.flatnonzero(sel)
    a0, a1, b = t0[e_idx], t1c[e_idx], border[e_idx]
    # safe side: the only triangle; the traversable one; the less steep one
    first_safe = np.where(is_steep[e_idx], ~steep[a0], tin.slope_deg[a0] <= tin.slope_deg[a1])
    first_safe |= b
    safe = np.where(first_safe, a0, a1)
    unsafe = np.where(b, -1, np.where(first_safe, a1, a0))
    p = tin.vertices[E[e_idx, 0]]
    q = tin.vertices[E[e_idx, 1]]
    seg = np.stack([p, q], axis=1)
    d = q[:, :2] - p[:, :2]
    n = np.column_stack([-d[:, 1], d[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    # orient toward the safe triangle's centroid
    c_safe = tin.vertices[tin.triangles[safe], :2].mean(axis=1)
    flip = np.einsum("ij,ij->i", c_safe - p[:, :2], n) < 0
    n[flip] *= -1
    drops = np.zeros(len(e_idx))
    nb = ~b
    if nb.any():
        tri_u = tin.triangles[unsafe[nb]]  # (m, 3)
        ends = E[e_idx[nb]]
        opp = (tri_u != ends[:, :1]) & (tri_u != ends[:, 1:])  # the vertex off the edge
        z_opp = tin.vertices[tri_u[opp], 2]
        drops[nb] = 0.5 * (p[nb, 2] + q[nb, 2]) - z_opp
    kinds = np.where(b, BORDER, np.where(is_steep[e_idx], STEEP, ANGLE)).astype(np.int8)
    return Breaks(segments=seg, normals=n, drops_m=drops, kinds=kinds, edge_idx=e_idx,
                  safe_idx=safe.astype(np.int64), unsafe_idx=unsafe.astype(np.int64))
