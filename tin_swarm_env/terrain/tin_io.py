"""TIN files: the thesis text format (``.tin``) and a binary ``.npz`` form.

Thesis text format: one triangle per line, nine numbers ``x1 y1 z1 x2 y2 z2 x3 y3 z3``
(whitespace or commas; blank lines and ``#`` comments ignored). Loading rebuilds shared
vertices (points with identical coordinates are one vertex) and adjacency. Numbers are
written with 17 significant digits, so ``load_tin(save_tin(t)) == t`` exactly.

Binary ``.npz``: arrays ``vertices (V, 3) float64`` and ``triangles (T, 3) int64`` plus
``format`` (``"tin_swarm_env.tin/1"``); adjacency and planes are rebuilt on load.

Writing is atomic: the data goes to a temporary file in the same directory, which is then
renamed over the target, so a failed write never leaves a partial file.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .._atomic import atomic_path
from ..errors import ArgumentError, TinFormatError, TinStructureError
from ._text import numeric_rows
from .tin import Tin

__all__ = ["save_tin", "load_tin"]

NPZ_FORMAT = "tin_swarm_env.tin/1"


def save_tin(tin: Tin, path) -> Path:
    """Write ``tin`` to ``path`` (``.tin`` or ``.txt``: the thesis's text format; ``.npz``), atomically.
    Returns the path."""
    p = Path(os.fspath(path))
    suffix = p.suffix.lower()
    if suffix not in (".tin", ".npz", ".txt"):
        raise ArgumentError(f"path {p}: unknown TIN suffix {suffix!r}; expected .tin or .txt (thesis text) or .npz")
    with atomic_path(p) as tmp, open(tmp, "wb") as fh:
        if suffix == ".npz":
            np.savez(fh, vertices=tin.vertices, triangles=tin.triangles, format=np.array(NPZ_FORMAT))
        else:
            rows = tin.vertices[tin.triangles].reshape(-1, 9)
            np.savetxt(fh, rows, fmt="%.17g")
        fh.flush()
        os.fsync(fh.fileno())
    return p


def load_tin(path) -> Tin:
    """Read a TIN written by :func:`save_tin` (or any thesis-format text file)."""
    p = Path(os.fspath(path))
    if not p.exists():
        raise TinFormatError(f"{p}: no such TIN file")
    if p.suffix.lower() == ".npz":
        return _load_npz(p)
    return _load_text(p)


def _load_npz(p: Path) -> Tin:
    try:
        with np.load(p, allow_pickle=False) as f:
            if "vertices" not in f.files or "triangles" not in f.files:
                raise TinFormatError(
                    f"{p}: not a TIN archive: needs arrays 'vertices' and 'triangles', found {f.files}")
            v, t = f["vertices"], f["triangles"]
    except TinFormatError:
        raise
    except Exception as exc:
        raise TinFormatError(f"{p}: not a readable .npz archive ({exc})") from None
    try:
        return Tin(v, t, source=str(p))
    except TinStructureError as exc:
        raise TinFormatError(str(exc)) from None


def _load_text(p: Path) -> Tin:
    rows = []
    for i, vals, line in numeric_rows(p, "x1 y1 z1 x2 y2 z2 x3 y3 z3", TinFormatError):
        if not np.all(np.isfinite(vals)):
            raise TinFormatError(f"{p}:{i}: NaN or infinite coordinate in {line.strip()!r}")
        rows.append(vals)
    if not rows:
        raise TinFormatError(f"{p}: empty TIN file (no triangle lines)")
    corners = np.asarray(rows, dtype=np.float64).reshape(-1, 3)  # (3T, 3)
    verts, inv = np.unique(corners, axis=0, return_inverse=True)
    tri = inv.reshape(-1, 3)
    # shared x, y with different z would make two vertices at one map position
    _, xy_inv = np.unique(verts[:, :2], axis=0, return_inverse=True)
    if len(np.unique(xy_inv)) != len(verts):
        counts = np.bincount(xy_inv.ravel())
        dup = int(np.flatnonzero(counts[xy_inv.ravel()] > 1)[0])
        raise TinFormatError(f"{p}: two vertices at x={verts[dup, 0]!r} y={verts[dup, 1]!r} with different z; "
                             "a TIN is a single-valued surface")
    try:
        return Tin(verts, tri, source=str(p))
    except TinStructureError as exc:
        raise TinFormatError(str(exc)) from None
