"""Very Important Point (VIP) reduction of a DEM grid (thesis 2.1, after Chen & Guevara).

Significance of a cell: for each of its four neighbour pairs (N-S, W-E, SW-NE, SE-NW), the
perpendicular distance from the cell to the line through the pair, drawn in the plane of
(horizontal distance along the pair, z); the cell's significance is the mean over its pairs.
With the pair at horizontal distances ``-d`` and ``+d`` and heights ``z1``, ``z2``::

    distance = |z0 - (z1 + z2)/2| * 2d / sqrt((2d)^2 + (z2 - z1)^2)

Border cells
------------
The thesis computes significance for every cell but the four corners and says nothing more.
Here a border cell (not a corner) averages the pairs that lie inside the grid: along the
border that is exactly one pair (its two neighbours on the border line), so border cells are
ranked by how much they bend the border profile, like interior cells by how much they bend
the surface. Plain thesis VIP (``border="none"``: border cells get significance 0) keeps no
border point, and the TIN's sides become straight lines between corners: on jacksboro that is
a 527 m maximum error along the edges.

Backbone
--------
Significance is local (3x3): VIP spends its budget on rough, high-curvature cells and leaves
smooth but large areas with no vertex at all, which costs more RMS error than the detail
gains. ``backbone`` reserves that fraction of the budget for a regular lattice of cells
(borders included) and fills the rest by significance. Measured on jacksboro at 10k vertices
(bench/terrain.py), RMS error against every cell, relative to greedy insertion (hmm, 8.06 m):

=====================================  ========  ======
variant                                RMS m     max m
=====================================  ========  ======
thesis VIP (``border="none"``, 0)      33.8 4.2x  526.9
``border="line"``, backbone 0          32.3 4.0x  265.7
``border="line"``, backbone 0.5 (def)  16.5 2.0x  110.8
plain lattice                          15.3 1.9x  107.9
=====================================  ========  ======

VIP's local significance is a poor global selector; the default keeps it for half the budget
(the detail it is good at) and spends the other half on the lattice.

Everything is vectorised over the grid (slicing, one argpartition).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ArgumentError, DemFormatError
from .dem import Dem

__all__ = ["vip_significance", "vip_select"]


def vip_significance(dem: Dem, border: str = "line") -> np.ndarray:
    """Significance ``(rows, cols)`` m of every cell; corners get ``+inf`` (always kept).

    ``border``: ``"line"`` (default) averages the in-grid pairs of border cells (see module
    docstring); ``"none"`` gives border cells 0 (the thesis read literally).
    """
    if border not in ("line", "none"):
        raise ArgumentError(f"border must be 'line' or 'none', got {border!r}")
    z = dem.z
    if np.isnan(z).any():
        raise DemFormatError(f"{dem.source}: {dem.n_nodata} NODATA cells; VIP needs a complete grid "
                             "(use dem.fill_nodata() or crop them away)")
    rows, cols = z.shape
    dx, dy = dem.dx, dem.dy
    dd = math.hypot(dx, dy)
    total = np.zeros_like(z)
    count = np.zeros_like(z)
    # (row offset, col offset, horizontal half distance) of the first neighbour of each pair;
    # the second neighbour is the mirror image
    pairs = ((1, 0, dy), (0, 1, dx), (1, 1, dd), (1, -1, dd))
    for dr, dc, d in pairs:
        # cells whose neighbours (r-dr, c-dc) and (r+dr, c+dc) both exist
        r0, r1 = dr, rows - dr
        c0, c1 = abs(dc), cols - abs(dc)
        if r1 <= r0 or c1 <= c0:
            continue
        zc = z[r0:r1, c0:c1]
        za = z[r0 - dr:r1 - dr, c0 - dc:c1 - dc]
        zb = z[r0 + dr:r1 + dr, c0 + dc:c1 + dc]
        dev = np.abs(zc - 0.5 * (za + zb))
        dist = dev * (2 * d) / np.hypot(2 * d, zb - za)
        total[r0:r1, c0:c1] += dist
        count[r0:r1, c0:c1] += 1
    sig = np.divide(total, count, out=np.zeros_like(total), where=count > 0)
    if border == "none":
        sig[0, :] = sig[-1, :] = 0.0
        sig[:, 0] = sig[:, -1] = 0.0
    sig[0, 0] = sig[0, -1] = sig[-1, 0] = sig[-1, -1] = np.inf
    return sig


def _lattice_mask(dem: Dem, n_target: int) -> np.ndarray:
    """A regular lattice of about ``n_target`` cells (square in metres), borders included."""
    rows, cols = dem.shape
    mask = np.zeros((rows, cols), dtype=bool)
    if n_target <= 4:
        return mask
    w = dem.dx * (cols - 1)
    h = dem.dy * (rows - 1)
    step = math.sqrt(w * h / n_target)
    nc = int(min(cols, max(2, round(w / step) + 1)))
    nr = int(min(rows, max(2, round(h / step) + 1)))
    ri = np.unique(np.round(np.linspace(0, rows - 1, nr)).astype(int))
    ci = np.unique(np.round(np.linspace(0, cols - 1, nc)).astype(int))
    mask[np.ix_(ri, ci)] = True
    return mask


def vip_select(dem: Dem, max_vertices: int | None = None, min_significance_m: float | None = None,
               *, border: str = "line", backbone: float = 0.5) -> np.ndarray:
    """Cells kept by VIP: a ``(rows, cols)`` bool mask.

    Exactly one of ``max_vertices`` (keep that many: the corners, a ``backbone`` lattice of
    ``backbone * max_vertices`` cells, then the most significant remaining cells; ties broken by
    cell order) or ``min_significance_m`` (keep every cell at least that significant, the
    corners, and a backbone lattice of ``backbone / (1 - backbone)`` times as many cells).
    """
    if (max_vertices is None) == (min_significance_m is None):
        raise ArgumentError("give exactly one of max_vertices or min_significance_m")
    if not 0.0 <= backbone < 1.0:
        raise ArgumentError(f"backbone must be in [0, 1), got {backbone}")
    sig = vip_significance(dem, border=border)
    rows, cols = sig.shape
    n_cells = rows * cols
    flat = sig.ravel()
    if max_vertices is not None:
        if int(max_vertices) != max_vertices or max_vertices < 4:
            raise ArgumentError(f"max_vertices must be an integer >= 4 (the four corners), got {max_vertices}")
        n = int(min(max_vertices, n_cells))
        keep = _lattice_mask(dem, int(backbone * n)).ravel()
        keep[[0, cols - 1, n_cells - cols, n_cells - 1]] = True
        n_more = n - int(keep.sum())
        if n_more > 0:
            cand = np.flatnonzero(~keep)
            if n_more >= len(cand):
                keep[cand] = True
            else:
                # stable top-k: sort by (-significance, index)
                s = flat[cand]
                part = np.argpartition(-s, n_more - 1)[:n_more]
                thr = s[part].min()
                above = cand[s > thr]
                ties = cand[s == thr]
                keep[above] = True
                keep[ties[: n_more - len(above)]] = True
        return keep.reshape(rows, cols)
    thr = float(min_significance_m)
    if not np.isfinite(thr) or thr < 0:
        raise ArgumentError(f"min_significance_m must be a finite number >= 0, got {min_significance_m}")
    keep = flat >= thr
    n_sig = int(keep.sum())
    if backbone > 0:
        keep |= _lattice_mask(dem, int(round(n_sig * backbone / (1 - backbone)))).ravel()
    return keep.reshape(rows, cols)
