"""Digital elevation models: a regular grid (:class:`Dem`) or scattered points (:class:`PointCloud`).

Conventions
-----------
* x east, y north, z up, metres.
* ``Dem.z`` has shape ``(rows, cols)``; ``Dem.x`` (cols,) and ``Dem.y`` (rows,) are the
  cell-centre coordinates, both strictly increasing. Row 0 is therefore the *south* row:
  every reader flips north-up rasters (ESRI ASCII, GeoTIFF, image-like ``.npz``) on load.
* Missing cells (NODATA) are ``NaN`` in ``z``. Readers keep them (masked); building a TIN
  refuses a DEM with NaN cells and says so, and :meth:`Dem.fill_nodata` fills them with the
  nearest valid cell's elevation when that is what you want.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import DemFormatError

__all__ = ["Dem", "PointCloud", "geographic_to_metres", "metres_per_degree"]


@dataclass(frozen=True, eq=False)
class Dem:
    """A regular elevation grid in metres.

    Attributes
    ----------
    z : (rows, cols) float64 m, NaN where no data.
    x : (cols,) float64 m, cell-centre eastings, strictly increasing, evenly spaced.
    y : (rows,) float64 m, cell-centre northings, strictly increasing, evenly spaced.
    source : where it came from (a path or a sample name), for messages.
    """

    z: np.ndarray
    x: np.ndarray
    y: np.ndarray
    source: str = "<array>"

    def __post_init__(self):
        z = np.array(self.z, dtype=np.float64)  # own copy: a Dem never aliases caller memory
        x = np.array(self.x, dtype=np.float64).reshape(-1)
        y = np.array(self.y, dtype=np.float64).reshape(-1)
        if z.ndim != 2:
            raise DemFormatError(f"{self.source}: elevation must be 2-D (rows, cols), got shape {z.shape}")
        if z.shape != (y.size, x.size):
            raise DemFormatError(
                f"{self.source}: elevation shape {z.shape} does not match len(y)={y.size}, len(x)={x.size}"
            )
        if z.shape[0] < 2 or z.shape[1] < 2:
            raise DemFormatError(f"{self.source}: a DEM needs at least 2x2 cells, got {z.shape}")
        for name, c in (("x", x), ("y", y)):
            if not np.all(np.isfinite(c)):
                raise DemFormatError(f"{self.source}: {name} coordinates are not all finite")
            d = np.diff(c)
            if np.any(d <= 0):
                raise DemFormatError(f"{self.source}: {name} coordinates must be strictly increasing")
            if not np.allclose(d, d[0], rtol=1e-6, atol=0):
                raise DemFormatError(f"{self.source}: {name} coordinates are not evenly spaced")
        if np.any(np.isinf(z)):
            raise DemFormatError(f"{self.source}: elevation has infinite values")
        for a in (z, x, y):
            a.setflags(write=False)
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "y", y)

    # -- derived -------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.z.shape

    @property
    def dx(self) -> float:
        """Cell width (east-west), m."""
        return float((self.x[-1] - self.x[0]) / (self.x.size - 1))

    @property
    def dy(self) -> float:
        """Cell height (north-south), m."""
        return float((self.y[-1] - self.y[0]) / (self.y.size - 1))

    @property
    def n_nodata(self) -> int:
        return int(np.count_nonzero(np.isnan(self.z)))

    def cell_centres(self) -> np.ndarray:
        """All cell centres as ``(rows*cols, 2)`` xy, row-major (the order of ``z.ravel()``)."""
        xx, yy = np.meshgrid(self.x, self.y)
        return np.column_stack([xx.ravel(), yy.ravel()])

    def points(self) -> np.ndarray:
        """All valid cells as ``(n, 3)`` xyz points (NaN cells left out)."""
        xy = self.cell_centres()
        z = self.z.ravel()
        ok = ~np.isnan(z)
        return np.column_stack([xy[ok], z[ok]])

    def fill_nodata(self) -> Dem:
        """A copy with every NaN cell set to the elevation of its nearest valid cell."""
        from scipy import ndimage

        nan = np.isnan(self.z)
        if not nan.any():
            return self
        if nan.all():
            raise DemFormatError(f"{self.source}: every cell is NODATA; nothing to fill from")
        idx = ndimage.distance_transform_edt(nan, return_distances=False, return_indices=True)
        return Dem(self.z[tuple(idx)], self.x, self.y, self.source)

    def crop(self, rows: slice, cols: slice) -> Dem:
        """A sub-grid (numpy slices over rows and columns)."""
        return Dem(self.z[rows, cols], self.x[cols], self.y[rows], self.source)

    def __repr__(self) -> str:
        r, c = self.shape
        return (
            f"Dem({self.source!r}, {r}x{c} cells, dx={self.dx:.3g} m, dy={self.dy:.3g} m, "
            f"z {np.nanmin(self.z):.1f}..{np.nanmax(self.z):.1f} m, nodata={self.n_nodata})"
        )


@dataclass(frozen=True, eq=False)
class PointCloud:
    """Scattered elevation points (a non-grid ``x y z`` file). ``points`` is ``(n, 3)`` m."""

    points: np.ndarray
    source: str = "<array>"
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        p = np.array(self.points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise DemFormatError(f"{self.source}: points must have shape (n, 3), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise DemFormatError(f"{self.source}: points contain NaN or infinite values")
        p.setflags(write=False)
        object.__setattr__(self, "points", p)

    def __repr__(self) -> str:
        return f"PointCloud({self.source!r}, {len(self.points)} points)"


# -- geographic coordinates ----------------------------------------------------------------


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """Metres per degree of longitude and of latitude at latitude ``lat_deg`` on WGS84.

    The standard series expansion of the meridian and parallel arc lengths (accurate to
    about a centimetre per degree).
    """
    p = math.radians(lat_deg)
    m_lat = 111132.92 - 559.82 * math.cos(2 * p) + 1.175 * math.cos(4 * p) - 0.0023 * math.cos(6 * p)
    m_lon = 111412.84 * math.cos(p) - 93.5 * math.cos(3 * p) + 0.118 * math.cos(5 * p)
    return m_lon, m_lat


def geographic_to_metres(lon: np.ndarray, lat: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Local equirectangular projection of cell-centre longitudes/latitudes (degrees) to metres.

    Scales by the metres per degree at the grid's mid latitude and puts the origin on the
    south-west cell centre. Over a grid a fraction of a degree tall the east-west scale
    changes by ``tan(lat)*dlat`` across it (0.4 % for jacksboro), which this ignores.
    Returns ``x (cols,)``, ``y (rows,)`` and the mid latitude used.
    """
    lon = np.asarray(lon, dtype=np.float64)
    lat = np.asarray(lat, dtype=np.float64)
    lat0 = 0.5 * (float(lat.min()) + float(lat.max()))
    m_lon, m_lat = metres_per_degree(lat0)
    return (lon - lon.min()) * m_lon, (lat - lat.min()) * m_lat, lat0
