"""Reading DEMs: thesis ``x y z`` text, ESRI ASCII grid, ``.npy``/``.npz``, GeoTIFF, and samples.

:func:`load_dem` picks the reader from the file suffix. Every reader returns a :class:`Dem`
in metres with increasing cell-centre coordinates (row 0 south), except a text file whose
points do not form a complete regular grid, which comes back as a :class:`PointCloud`.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from ..errors import ArgumentError, DemFormatError, require
from ._text import numeric_rows
from .dem import Dem, PointCloud, geographic_to_metres

__all__ = ["load_dem", "sample_dem", "SAMPLES"]


def load_dem(path, *, geographic: bool | None = None) -> Dem | PointCloud:
    """Read an elevation model from ``path``.

    ============  ===========================================================================
    suffix        format
    ============  ===========================================================================
    .xyz .txt     the thesis format: ``x y z`` per line (whitespace or comma separated; blank
    .csv          lines and ``#`` comments ignored). Points forming a complete regular grid, in
                  any line order, give a :class:`Dem`; anything else a :class:`PointCloud`.
                  Exact duplicate lines are dropped; the same x,y with two different z is an
                  error naming both line numbers.
    .asc          ESRI ASCII grid (``ncols nrows xllcorner|xllcenter yllcorner|yllcenter
                  cellsize|dx,dy [NODATA_value]``); NODATA cells become NaN.
    .npy          a 2-D elevation array, 1 m cells, origin (0, 0).
    .npz          ``elevation`` (or ``z``/``topo``) plus optional ``dx``, ``dy`` and the extents
                  ``xmin xmax ymin ymax`` (matplotlib's sample layout: rows north first), or
                  ``x``/``longitude`` and ``y``/``latitude`` cell-centre vectors.
    .tif .tiff    GeoTIFF through rasterio (``pip install 'tin_swarm_env[geo]'``).
    ============  ===========================================================================

    ``geographic``: whether x/y are longitude/latitude degrees, converted to metres with
    :func:`~tin_swarm_env.terrain.dem.geographic_to_metres`. ``None`` (default) decides for
    ``.npz``/``.tif`` files: coordinates named longitude/latitude, or coordinates (``x``/``y``
    or the extents) inside ±180/±90 with cells under 0.01°, are taken as degrees; a cell size
    alone (``dx``/``dy``, no coordinates) is metres. Text and ``.asc`` files are metres unless
    ``geographic=True``. Coordinates of one axis without the other's, or coordinates and a cell
    size together, are refused (which to trust would be a guess); so are latitudes beyond ±90.
    """
    p = Path(os.fspath(path))
    if not p.exists():
        raise DemFormatError(f"{p}: no such DEM file")
    if p.is_dir():
        raise DemFormatError(f"{p}: is a directory, not a DEM file")
    suffix = p.suffix.lower()
    if suffix in (".xyz", ".txt", ".csv"):
        return _read_xyz(p, geographic=bool(geographic))
    if suffix == ".asc":
        return _read_asc(p, geographic=bool(geographic))
    if suffix == ".npy":
        return _read_npy(p)
    if suffix == ".npz":
        return _read_npz(p, geographic)
    if suffix in (".tif", ".tiff"):
        return _read_geotiff(p, geographic)
    raise DemFormatError(
        f"{p}: unknown DEM suffix {suffix!r}; expected .xyz/.txt/.csv, .asc, .npy, .npz or .tif"
    )


# -- thesis x y z text ---------------------------------------------------------------------


def _read_xyz(p: Path, geographic: bool) -> Dem | PointCloud:
    rows: list[list[float]] = []
    line_no: list[int] = []
    for i, vals, line in numeric_rows(p, "x y z", DemFormatError):
        if not all(np.isfinite(vals[:2])):
            raise DemFormatError(f"{p}:{i}: x and y must be finite, got {line.strip()!r}")
        if np.isinf(vals[2]):
            raise DemFormatError(f"{p}:{i}: infinite elevation in {line.strip()!r}")
        rows.append(vals)
        line_no.append(i)
    if not rows:
        raise DemFormatError(f"{p}: empty DEM file (no 'x y z' lines)")
    pts = np.asarray(rows, dtype=np.float64)
    lines = np.asarray(line_no)
    pts, lines = _drop_duplicates(p, pts, lines)
    if geographic:
        x, y, _ = geographic_to_metres(pts[:, 0], pts[:, 1])
        pts = np.column_stack([x, y, pts[:, 2]])
    grid = _as_grid(pts)
    if grid is not None:
        xs, ys, z = grid
        return Dem(z, xs, ys, source=str(p))
    if np.isnan(pts[:, 2]).any():
        bad = lines[np.isnan(pts[:, 2])][0]
        raise DemFormatError(f"{p}:{bad}: NaN elevation in a scattered (non-grid) point file")
    if len(pts) < 3:
        raise DemFormatError(f"{p}: {len(pts)} distinct point(s); a TIN needs at least 3")
    return PointCloud(pts, source=str(p))


def _drop_duplicates(p: Path, pts: np.ndarray, lines: np.ndarray):
    """Drop exact duplicate points; the same (x, y) with different z is an error."""
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    s = pts[order]
    same_xy = np.all(s[1:, :2] == s[:-1, :2], axis=1)
    if not same_xy.any():
        return pts, lines
    zs = s[:, 2]
    same_z = (zs[1:] == zs[:-1]) | (np.isnan(zs[1:]) & np.isnan(zs[:-1]))
    clash = same_xy & ~same_z
    if clash.any():
        k = int(np.flatnonzero(clash)[0])
        a, b = sorted((int(lines[order[k]]), int(lines[order[k + 1]])))
        raise DemFormatError(
            f"{p}: lines {a} and {b} give the same point x={s[k, 0]!r} y={s[k, 1]!r} "
            f"with different elevations ({s[k, 2]!r} and {s[k + 1, 2]!r})"
        )
    keep = np.ones(len(pts), dtype=bool)
    keep[order[1:][same_xy]] = False
    return pts[keep], lines[keep]


def _as_grid(pts: np.ndarray):
    """(x, y, z) if the points are exactly a complete, evenly spaced grid, else None."""
    xs = np.unique(pts[:, 0])
    ys = np.unique(pts[:, 1])
    if xs.size < 2 or ys.size < 2 or xs.size * ys.size != len(pts):
        return None
    for c in (xs, ys):
        d = np.diff(c)
        if not np.allclose(d, d[0], rtol=1e-6, atol=0):
            return None
    ci = np.searchsorted(xs, pts[:, 0])
    ri = np.searchsorted(ys, pts[:, 1])
    z = np.full((ys.size, xs.size), np.nan)
    filled = np.zeros(z.shape, dtype=bool)
    filled[ri, ci] = True
    if not filled.all():  # pragma: no cover - impossible after de-duplication and the count check
        return None
    z[ri, ci] = pts[:, 2]
    return xs, ys, z


# -- ESRI ASCII grid -----------------------------------------------------------------------

_ASC_KEYS = {"ncols", "nrows", "xllcorner", "xllcenter", "yllcorner", "yllcenter", "cellsize",
             "dx", "dy", "nodata_value"}


def _read_asc(p: Path, geographic: bool) -> Dem:
    with open(p, encoding="utf-8", errors="replace") as fh:
        text_lines = fh.readlines()
    if not any(t.strip() for t in text_lines):
        raise DemFormatError(f"{p}: empty DEM file")
    header, header_line, first = _asc_header(p, text_lines)
    ncols, nrows, x0, y0, dx, dy = _asc_geometry(p, header, header_line)
    z = _asc_values(p, text_lines, first, nrows, ncols)
    if "nodata_value" in header:
        z[z == header["nodata_value"]] = np.nan
    z = z[::-1]  # ESRI rows run north to south; ours run south to north
    x = x0 + dx * np.arange(ncols)
    y = y0 + dy * np.arange(nrows)
    if geographic:
        x, y, _ = geographic_to_metres(x, y)
    return Dem(z, x, y, source=str(p))


def _asc_header(p: Path, text_lines: list[str]) -> tuple[dict[str, float], dict[str, int], int]:
    """The ``key value`` header: ``({key: value}, {key: 1-based line}, index of the first data line)``."""
    header: dict[str, float] = {}
    header_line: dict[str, int] = {}
    i = 0
    while i < len(text_lines):
        parts = text_lines[i].split()
        if not parts:
            i += 1
            continue
        key = parts[0].lower()
        if key[0].isdigit() or key[0] in "+-." or _is_number(parts[0]):  # the first data row (nan and inf too)
            break
        if key not in _ASC_KEYS:
            raise DemFormatError(f"{p}:{i + 1}: unknown ESRI ASCII header key {parts[0]!r}")
        if len(parts) != 2:
            raise DemFormatError(f"{p}:{i + 1}: header line must be 'key value', got {text_lines[i].strip()!r}")
        if key in header:
            raise DemFormatError(f"{p}:{i + 1}: header key {parts[0]} repeats line {header_line[key]}")
        try:
            header[key] = float(parts[1])
        except ValueError:
            raise DemFormatError(f"{p}:{i + 1}: header {parts[0]} has a non-numeric value {parts[1]!r}") from None
        header_line[key] = i + 1
        i += 1
    return header, header_line, i


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _asc_geometry(p: Path, header: dict, header_line: dict) -> tuple[int, int, float, float, float, float]:
    """``(ncols, nrows, x0, y0, dx, dy)`` from the header; x0, y0 (m or deg) are the centre of
    the south-west cell."""
    for k in ("ncols", "nrows"):
        if k not in header:
            raise DemFormatError(f"{p}: ESRI ASCII header lacks {k}")
        n = header[k]
        if not (np.isfinite(n) and n == int(n) and n >= 1):
            raise DemFormatError(f"{p}:{header_line[k]}: header {k} must be a positive whole number, got {n!r}")
    if "cellsize" in header:
        dx = dy = header["cellsize"]
    elif "dx" in header and "dy" in header:
        dx, dy = header["dx"], header["dy"]
    else:
        raise DemFormatError(f"{p}: ESRI ASCII header lacks cellsize (or dx and dy)")
    if not (dx > 0 and dy > 0):
        raise DemFormatError(f"{p}: cell size must be positive, got dx={dx}, dy={dy}")
    x0 = _asc_origin(p, header, "x", dx)
    y0 = _asc_origin(p, header, "y", dy)
    return int(header["ncols"]), int(header["nrows"]), x0, y0, dx, dy


def _asc_origin(p: Path, header: dict, axis: str, cell: float) -> float:
    """The centre of the first cell along ``axis`` ("x" or "y"): ``{axis}llcenter``, or
    ``{axis}llcorner`` plus half a cell."""
    if f"{axis}llcenter" in header:
        return header[f"{axis}llcenter"]
    if f"{axis}llcorner" in header:
        return header[f"{axis}llcorner"] + cell / 2
    raise DemFormatError(f"{p}: ESRI ASCII header lacks {axis}llcorner/{axis}llcenter")


def _asc_values(p: Path, text_lines: list[str], first: int, nrows: int, ncols: int) -> np.ndarray:
    """The ``(nrows, ncols)`` float64 grid read from ``text_lines[first:]``, in file order (north row first)."""
    values: list[float] = []
    for j in range(first, len(text_lines)):
        for tok in text_lines[j].split():
            try:
                v = float(tok)
            except ValueError:
                raise DemFormatError(f"{p}:{j + 1}: not a number: {tok!r}") from None
            if v in (np.inf, -np.inf):  # NaN is no data; an infinite height is an error, named where it is
                raise DemFormatError(f"{p}:{j + 1}: an infinite elevation {tok!r}")
            values.append(v)
    if len(values) != nrows * ncols:
        raise DemFormatError(
            f"{p}: header says {nrows} rows x {ncols} cols = {nrows * ncols} values, "
            f"found {len(values)} from line {first + 1} on"
        )
    return np.asarray(values, dtype=np.float64).reshape(nrows, ncols)


# -- numpy ---------------------------------------------------------------------------------


def _read_npy(p: Path) -> Dem:
    try:
        z = np.load(p, allow_pickle=False)
    except Exception as exc:
        raise DemFormatError(f"{p}: not a readable .npy array ({exc})") from None
    z = _as_real(z, "the array", str(p))
    if z.ndim != 2:
        raise DemFormatError(f"{p}: a .npy DEM must be a 2-D array, got shape {z.shape}")
    return Dem(z, np.arange(z.shape[1], dtype=float), np.arange(z.shape[0], dtype=float), str(p))


def _read_npz(p: Path, geographic: bool | None) -> Dem:
    if not zipfile.is_zipfile(p):  # numpy would say it holds pickled data (its guess for anything not a zip)
        raise DemFormatError(f"{p}: not an .npz archive (a zip of .npy arrays, as numpy.savez writes)")
    try:
        with np.load(p, allow_pickle=False) as f:
            d = {k: f[k] for k in f.files}
    except Exception as exc:
        raise DemFormatError(f"{p}: not a readable .npz archive ({exc})") from None
    return dem_from_arrays(d, source=str(p), geographic=geographic)


def dem_from_arrays(d: dict, source: str, geographic: bool | None = None) -> Dem:
    """Build a :class:`Dem` from a dict of arrays in the ``.npz`` layout of :func:`load_dem`."""
    zkey = next((k for k in ("elevation", "z", "topo") if k in d), None)
    if zkey is None:
        raise DemFormatError(
            f"{source}: no elevation array (expected a key 'elevation', 'z' or 'topo'; found {sorted(d)})")
    z = _as_real(d[zkey], f"'{zkey}'", source)
    if z.ndim != 2:
        raise DemFormatError(f"{source}: '{zkey}' must be 2-D, got shape {z.shape}")
    if min(z.shape) < 2:
        raise DemFormatError(f"{source}: a DEM needs at least 2x2 cells, '{zkey}' has shape {z.shape}")
    rows, cols = z.shape
    xkey = next((k for k in ("x", "longitude", "lon") if k in d), None)
    ykey = next((k for k in ("y", "latitude", "lat") if k in d), None)
    named_geo = xkey in ("longitude", "lon") or ykey in ("latitude", "lat")
    if bool(xkey) != bool(ykey):  # one axis's coordinates alone: the other's spacing would be a guess
        have, want = (xkey, "'y', 'latitude' or 'lat'") if xkey else (ykey, "'x', 'longitude' or 'lon'")
        raise DemFormatError(f"{source}: '{have}' given without the other axis's coordinates ({want})")
    spacing = [k for k in ("dx", "dy") if k in d]
    if xkey and spacing:
        raise DemFormatError(f"{source}: both coordinates ('{xkey}', '{ykey}') and a cell size ({', '.join(spacing)}) "
                             "given; keep one")
    extents = not xkey and all(k in d for k in ("xmin", "xmax", "ymin", "ymax"))
    if xkey:
        x = _as_real(d[xkey], f"'{xkey}'", source).reshape(-1)
        y = _as_real(d[ykey], f"'{ykey}'", source).reshape(-1)
        if x.size != cols or y.size != rows:
            raise DemFormatError(f"{source}: '{xkey}' ({x.size}) / '{ykey}' ({y.size}) do not match '{zkey}' {z.shape}")
        # coordinates stored in float32 (topobathy) wobble by ~1e-6: snap near-regular ones
        x, y = _snap_regular(x), _snap_regular(y)
    elif extents:
        # matplotlib's sample layout: extents are cell edges, rows are image rows (north first);
        # its jacksboro file stores the north edge in 'ymin'. We only need the extent.
        x_lo, x_hi = sorted((_scalar(d, "xmin", source), _scalar(d, "xmax", source)))
        y_lo, y_hi = sorted((_scalar(d, "ymin", source), _scalar(d, "ymax", source)))
        dx = (x_hi - x_lo) / cols
        dy = (y_hi - y_lo) / rows
        x = x_lo + dx * (np.arange(cols) + 0.5)
        y = y_lo + dy * (np.arange(rows) + 0.5)
        z = z[::-1]  # image rows (north first) -> ours (south first)
    else:
        if "dy" in d and "dx" not in d:  # a north-south cell size alone: the east-west one would be a guess
            raise DemFormatError(f"{source}: 'dy' given without 'dx' (give 'dx' alone for square cells, or both)")
        dx = _scalar(d, "dx", source) if "dx" in d else 1.0
        dy = _scalar(d, "dy", source) if "dy" in d else dx
        if not (dx > 0 and dy > 0):
            raise DemFormatError(f"{source}: dx and dy must be positive, got {dx}, {dy}")
        x = dx * np.arange(cols, dtype=float)
        y = dy * np.arange(rows, dtype=float)
    if x.size > 1 and x[1] < x[0]:
        x, z = x[::-1], z[:, ::-1]
    if y.size > 1 and y[1] < y[0]:
        y, z = y[::-1], z[::-1]
    if geographic is None:  # degrees: named so, or coordinates given (not a cell size alone) in degrees' range, tiny cells
        small_cells = x.size > 1 and y.size > 1 and (x[1] - x[0]) < 0.01 and (y[1] - y[0]) < 0.01
        in_range = np.all(np.abs(y) <= 90) and np.all(np.abs(x) <= 360)
        geographic = named_geo or ((bool(xkey) or extents) and small_cells and in_range)
    if geographic:
        if not np.all(np.abs(y) <= 90):
            raise DemFormatError(f"{source}: latitudes ('{ykey or 'y'}') must lie within -90..90 degrees, got "
                                 f"{y.min():g}..{y.max():g}")
        x, y, _ = geographic_to_metres(x, y)
    return Dem(z, x, y, source=source)


def _as_real(a, what: str, source: str) -> np.ndarray:
    """``a`` as float64, refusing arrays that do not hold real numbers (strings, complex, bool)."""
    a = np.asarray(a)
    if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise DemFormatError(f"{source}: {what} holds {a.dtype} values; expected real numbers")
    return a.astype(np.float64)


def _scalar(d: dict, key: str, source: str) -> float:
    a = _as_real(d[key], f"'{key}'", source)
    if a.size != 1:
        raise DemFormatError(f"{source}: '{key}' must be a single number, got shape {a.shape}")
    return float(a.reshape(-1)[0])


def _snap_regular(c: np.ndarray) -> np.ndarray:
    if c.size > 2:
        d = np.diff(c)
        if np.all(np.abs(d - d.mean()) <= 1e-3 * np.abs(d.mean())):
            return np.linspace(c[0], c[-1], c.size)
    return c


# -- GeoTIFF -------------------------------------------------------------------------------


def _read_geotiff(p: Path, geographic: bool | None) -> Dem:  # pragma: no cover - needs rasterio
    """Band 1 of a GeoTIFF. Integer rasters (SRTM's int16 with nodata -32768, uint16, int32)
    are cast to float64 before their NODATA cells become NaN."""
    rasterio = require("rasterio", "geo", "Reading GeoTIFF DEMs")
    try:
        with rasterio.open(p) as src:
            if src.count < 1:
                raise DemFormatError(f"{p}: the raster has no bands")
            band = src.read(1, masked=True)
            t = src.transform
            cols, rows = src.width, src.height
            is_geo = bool(src.crs is not None and src.crs.is_geographic)
    except DemFormatError:
        raise
    except Exception as exc:  # rasterio's own errors (not a TIFF, truncated, unsupported)
        raise DemFormatError(f"{p}: not a readable GeoTIFF ({type(exc).__name__}: {exc})") from None
    if not (np.issubdtype(band.dtype, np.integer) or np.issubdtype(band.dtype, np.floating)):
        raise DemFormatError(f"{p}: band 1 holds {band.dtype} values; a DEM needs integer or real elevations")
    z = np.ma.asarray(band).astype(np.float64).filled(np.nan)  # cast first: int16 cannot hold NaN
    if t.b != 0 or t.d != 0:
        raise DemFormatError(f"{p}: rotated rasters are not supported")
    x = t.c + t.a * (np.arange(cols) + 0.5)
    y = t.f + t.e * (np.arange(rows) + 0.5)
    if geographic is None:
        geographic = is_geo
    arrays = {"z": z, "x": x, "y": y}
    return dem_from_arrays(arrays, str(p), geographic=geographic)


# -- samples -------------------------------------------------------------------------------

SAMPLES = {
    "jacksboro": "jacksboro_fault_dem.npz",
    "topobathy": "topobathy.npz",
}


def sample_dem(name: str = "jacksboro") -> Dem:
    """A real DEM shipped with matplotlib, converted to metres.

    * ``"jacksboro"``: the Jacksboro fault, Tennessee (344x403 cells of 3 arc-seconds,
      236-1076 m). Longitudes/latitudes of the cell centres come from the file's extents
      (cell edges); rows are image rows (north first) and are flipped to south first.
    * ``"topobathy"``: topography and bathymetry around Vancouver Island (91x120 cells of
      2 arc-minutes of longitude, -1437..2205 m; sea floor included). Its rows are evenly
      spaced in Mercator y; they are placed evenly in latitude between the first and last
      row, which moves a row by at most 0.3 of a cell.

    Degrees become metres by a local equirectangular projection at the grid's mid latitude
    (:func:`~tin_swarm_env.terrain.dem.geographic_to_metres`): x = (lon - lon_min) *
    m_per_deg_lon(lat_mid), y = (lat - lat_min) * m_per_deg_lat(lat_mid), with WGS84's
    metres per degree; the origin is the south-west cell centre. Jacksboro's cells come out
    74.5 m east-west by 92.5 m north-south.
    """
    if name not in SAMPLES:
        raise ArgumentError(f"name: unknown sample DEM {name!r}; known: {sorted(SAMPLES)}")
    from matplotlib import cbook

    path = cbook.get_sample_data(SAMPLES[name], asfileobj=False)
    with np.load(path, allow_pickle=False) as f:
        d = {k: f[k] for k in f.files}
    if name == "topobathy":
        # float32 longitudes wobble by 0.3 %, and rows are evenly spaced in Mercator y, not
        # in latitude: place both evenly between the first and last centre (rows move by at
        # most 0.3 cell)
        for k in ("longitude", "latitude"):
            c = np.asarray(d[k], dtype=np.float64)
            d[k] = np.linspace(c[0], c[-1], c.size)
    return dem_from_arrays(d, source=f"sample:{name}", geographic=True)
