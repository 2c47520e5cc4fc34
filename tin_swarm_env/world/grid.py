"""A compiled uniform grid for neighbour candidates, rebuilt in O(n) every step.

Points are binned into square cells of side at least ``radius / reach``, so every point within
the radius of a query point lies in the ``(2 reach + 1)^2`` cells around it (:func:`grid_block`):
collisions use cells of the collision diameter and the 3 x 3 block (:func:`grid_cells`),
sensing cells of half the sensor range and the 5 x 5 block (:data:`SENSE_REACH`, :func:`sense_cell`),
which holds about 30 % fewer candidates to reject. The grid covers the bounding box of the points
it holds; when that box would need more than ``4 n + 64`` cells the side grows (fewer, larger
cells: still correct, only slower). Within a cell, points keep their index order (a counting sort), so whoever reads the
grid sees the same candidates in the same order on any thread count.

:func:`grid_build` is serial (it is O(n) and far cheaper than the queries); queries run inside
the callers' parallel loops (:func:`grid_block`, :func:`grid_cells`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["SENSE_REACH", "grid_block", "grid_build", "grid_build_copies", "grid_cells", "sense_cell"]

# sensing grids: cells of range / 2, queries scan the 5 x 5 block (6.25 r^2 against 9 r^2 for 3 x 3 of r)
SENSE_REACH = 2


@njit(cache=True)
def grid_build(x, y, use, min_cell):
    """Bin the points ``(x[i], y[i])`` with ``use[i]`` into a grid with cells of side
    ``>= min_cell``. Returns ``(x0, y0, inv_cs, nx, ny, start (nx*ny + 1,), items (m,), gx (m,), gy (m,))``:
    the points of cell ``c = cy * nx + cx`` are ``items[start[c]:start[c + 1]]``, in index order,
    and ``gx``/``gy`` their coordinates in that order (read contiguously by the queries). The
    one-copy case of :func:`grid_build_copies` (one binning code for the env and the vector env)."""
    X0, Y0, INV, NX, NY, base, start, items, gx, gy = grid_build_copies(
        x, y, use, np.array([0, x.shape[0]], dtype=np.int64), min_cell)
    return X0[0], Y0[0], INV[0], NX[0], NY[0], start, items, gx, gy


@njit(cache=True)
def grid_build_copies(x, y, use, off, min_cell):
    """:func:`~.grid.grid_build` for each copy's points ``off[c]:off[c + 1]`` at once: per copy
    ``(x0, y0, inv, nx, ny)`` ``(E,)`` arrays and its first cell ``base (E + 1,)``; one counting
    sort over every point, so ``items[start[base[c] + cell] : start[base[c] + cell + 1]]`` are
    copy ``c``'s points in that cell, in index order (the same cells as ``grid_build`` on the
    copy alone)."""
    E = off.shape[0] - 1
    n = x.shape[0]
    X0 = np.zeros(E)
    Y0 = np.zeros(E)
    INV = np.empty(E)
    NX = np.ones(E, dtype=np.int64)
    NY = np.ones(E, dtype=np.int64)
    base = np.zeros(E + 1, dtype=np.int64)
    cs0 = max(min_cell, 1e-9)
    for c in range(E):
        m = 0
        x0 = np.inf
        y0 = np.inf
        x1 = -np.inf
        y1 = -np.inf
        for i in range(off[c], off[c + 1]):
            if use[i]:
                m += 1
                x0 = min(x0, x[i])
                y0 = min(y0, y[i])
                x1 = max(x1, x[i])
                y1 = max(y1, y[i])
        if m == 0:
            INV[c] = 1.0 / cs0
            base[c + 1] = base[c] + 1
            continue
        cs = cs0
        max_cells = 4 * m + 64
        while True:
            nx = int((x1 - x0) / cs) + 1
            ny = int((y1 - y0) / cs) + 1
            if nx * ny <= max_cells:
                break
            cs *= 2.0
        X0[c] = x0
        Y0[c] = y0
        INV[c] = 1.0 / cs
        NX[c] = nx
        NY[c] = ny
        base[c + 1] = base[c] + nx * ny
    start = np.zeros(base[E] + 1, dtype=np.int64)
    cell = np.empty(n, dtype=np.int64)
    m = 0
    for c in range(E):
        for i in range(off[c], off[c + 1]):
            if use[i]:
                cx = min(int((x[i] - X0[c]) * INV[c]), NX[c] - 1)
                cy = min(int((y[i] - Y0[c]) * INV[c]), NY[c] - 1)
                k = base[c] + cy * NX[c] + cx
                cell[i] = k
                start[k + 1] += 1
                m += 1
    for k in range(base[E]):
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    items = np.empty(m, dtype=np.int64)
    gx = np.empty(m)
    gy = np.empty(m)
    for i in range(n):
        if use[i]:
            k = cell[i]
            items[fill[k]] = i
            gx[fill[k]] = x[i]
            gy[fill[k]] = y[i]
            fill[k] += 1
    return X0, Y0, INV, NX, NY, base, start, items, gx, gy


def sense_cell(range_m: float) -> float:
    """The cell side of a sensing grid queried with :data:`SENSE_REACH`: a hair above
    ``range_m / SENSE_REACH``, so a point exactly ``range_m`` away is at most ``SENSE_REACH``
    cells off in each axis despite rounding in the cell index."""
    return float(range_m) / SENSE_REACH * (1.0 + 1e-9)


@njit(cache=True, inline="always")
def grid_block(x0, y0, inv, nx, ny, px, py, reach):
    """The ``(2 reach + 1)^2`` block of cells around ``(px, py)``, clipped to the grid:
    ``(cx_lo, cx_hi, cy_lo, cy_hi)`` inclusive, empty (lo > hi) when the point is more than
    ``reach`` cells outside. Holds every point within ``reach`` cell sides of ``(px, py)``."""
    fx = math.floor((px - x0) * inv)
    fy = math.floor((py - y0) * inv)
    r = float(reach)
    cx_lo = int(max(fx - r, 0.0)) if fx - r < nx else nx
    cx_hi = int(min(fx + r, nx - 1.0)) if fx + r >= 0.0 else -1
    cy_lo = int(max(fy - r, 0.0)) if fy - r < ny else ny
    cy_hi = int(min(fy + r, ny - 1.0)) if fy + r >= 0.0 else -1
    return cx_lo, cx_hi, cy_lo, cy_hi


@njit(cache=True, inline="always")
def grid_cells(x0, y0, inv, nx, ny, px, py):
    """The 3 x 3 block of cells around ``(px, py)``, clipped to the grid:
    ``(cx_lo, cx_hi, cy_lo, cy_hi)`` inclusive, empty (lo > hi) when the point is more than one
    cell outside."""
    fx = math.floor((px - x0) * inv)
    fy = math.floor((py - y0) * inv)
    cx_lo = int(max(fx - 1.0, 0.0)) if fx - 1.0 < nx else nx
    cx_hi = int(min(fx + 1.0, nx - 1.0)) if fx + 1.0 >= 0.0 else -1
    cy_lo = int(max(fy - 1.0, 0.0)) if fy - 1.0 < ny else ny
    cy_hi = int(min(fy + 1.0, ny - 1.0)) if fy + 1.0 >= 0.0 else -1
    return cx_lo, cx_hi, cy_lo, cy_hi
