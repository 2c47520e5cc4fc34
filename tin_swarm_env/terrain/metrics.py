"""How well a TIN fits its DEM: vertical error at every DEM cell."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dem import Dem

__all__ = ["vertical_error", "ErrorStats"]


@dataclass(frozen=True)
class ErrorStats:
    max_m: float  # max |TIN - DEM| over cells inside the TIN
    rms_m: float  # root mean square of TIN - DEM
    n_cells: int  # cells compared
    n_outside: int  # cells not covered by the TIN (not compared)


def vertical_error(tin, dem: Dem) -> tuple[ErrorStats, np.ndarray]:
    """TIN height minus DEM height at every cell centre: ``(stats, errors (rows, cols))``,
    NaN where the cell has no data or lies outside the TIN."""
    xy = dem.cell_centres()
    t = tin.locate(xy)
    err = np.full(len(xy), np.nan)
    ok = t >= 0
    err[ok] = tin.height_in(xy[ok], t[ok]) - dem.z.ravel()[ok]
    valid = ~np.isnan(err)
    e = err[valid]
    stats = ErrorStats(max_m=float(np.abs(e).max()) if e.size else float("nan"),
                       rms_m=float(np.sqrt(np.mean(e * e))) if e.size else float("nan"),
                       n_cells=int(valid.sum()), n_outside=int((~ok).sum()))
    return stats, err.reshape(dem.shape)
