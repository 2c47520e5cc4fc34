"""Fuzzing the DEM and TIN readers: whatever the file holds, the only exceptions that come out are
TinSwarmError subclasses (naming the file), and no numpy warning (overflow, invalid value) passes
silently. Random bytes, random numbers, random shapes and dtypes, for every suffix the readers know.
The budget is kept small for CI (a few seconds in all); raise it with HYPOTHESIS_PROFILE=dev."""

from __future__ import annotations

import io
import itertools
import os
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tin_swarm_env.errors import TinSwarmError
from tin_swarm_env.terrain import Dem, build_tin, load_dem, load_tin

CI = os.environ.get("HYPOTHESIS_PROFILE", "ci") == "ci"
FUZZ = settings(max_examples=60 if CI else 1000, deadline=None, derandomize=CI,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
_names = itertools.count()

DEM_SUFFIXES = [".xyz", ".txt", ".csv", ".asc", ".npy", ".npz", ".tif"]
TIN_SUFFIXES = [".tin", ".txt", ".npz"]

numbers = st.one_of(
    st.integers(-5, 5), st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-1e4, 1e4), st.sampled_from([0.0, -0.0, 1e-320, 1e300, -1e300, 3.5e38, 1e15, 1e16]),
)


def _write(tmp: str, suffix: str, data: bytes) -> str:
    p = os.path.join(tmp, f"f{next(_names)}{suffix}")
    with open(p, "wb") as fh:
        fh.write(data)
    return p


def only_our_errors(fn, *args):
    """Run fn; a TinSwarmError is an answer, anything else (or a RuntimeWarning) a defect."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            return fn(*args)
        except TinSwarmError as exc:
            assert str(exc), "an error with no message"
            return None


def load_and_build_dem(path: str):
    dem = load_dem(path)
    if isinstance(dem, Dem):
        dem = dem.fill_nodata()
        build_tin(dem, method="delaunay")
        if min(dem.shape) >= 2 and dem.z.size <= 400:
            build_tin(dem, method="greedy", max_error_m=0.5)
            build_tin(dem, method="vip", max_vertices=max(4, dem.z.size // 2))
    else:
        build_tin(dem, method="delaunay")
    return dem


def load_and_query_tin(path: str):
    tin = load_tin(path)
    c = tin.vertices[:, :2].mean(axis=0)
    tin.locate(c[None, :])
    assert np.all(np.isfinite(tin.slope_deg)) and np.all(np.isfinite(tin.planes))
    return tin


@pytest.fixture(scope="module")
def tmp(tmp_path_factory):
    return str(tmp_path_factory.mktemp("fuzz"))


def _text(rows) -> bytes:
    return "\n".join(" ".join(repr(x) for x in r) for r in rows).encode()


@FUZZ
@given(data=st.binary(max_size=300), suffix=st.sampled_from(DEM_SUFFIXES + TIN_SUFFIXES))
def test_random_bytes(tmp, data, suffix):
    p = _write(tmp, suffix, data)
    only_our_errors(load_and_build_dem, p)
    only_our_errors(load_and_query_tin, p)


@FUZZ
@given(rows=st.lists(st.lists(numbers, min_size=0, max_size=10), max_size=12),
       suffix=st.sampled_from([".xyz", ".txt", ".csv", ".tin"]))
def test_random_numbers_as_text(tmp, rows, suffix):
    p = _write(tmp, suffix, _text(rows))
    only_our_errors(load_and_build_dem, p)
    only_our_errors(load_and_query_tin, p)


@FUZZ
@given(rows=st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4), numbers), min_size=1, max_size=25))
def test_random_grids_as_xyz(tmp, rows):
    """Points on a small lattice (so grids, near-grids and duplicates come up) with any z."""
    p = _write(tmp, ".xyz", _text(rows))
    only_our_errors(load_and_build_dem, p)


@FUZZ
@given(header=st.lists(st.tuples(st.sampled_from(["ncols", "nrows", "xllcorner", "yllcenter", "cellsize", "dx",
                                                  "dy", "NODATA_value", "bogus"]), numbers), max_size=8),
       values=st.lists(numbers, max_size=20))
def test_random_asc(tmp, header, values):
    text = "".join(f"{k} {v!r}\n" for k, v in header) + " ".join(repr(v) for v in values)
    only_our_errors(load_and_build_dem, _write(tmp, ".asc", text.encode()))


def arrays():
    dtypes = st.sampled_from(["float64", "float32", "int16", "uint16", "int64", "bool", "complex128", "U3"])
    shapes = st.lists(st.integers(0, 5), min_size=0, max_size=3).map(tuple)

    def make(args):
        dtype, shape, fill = args
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a fill beyond float32 is part of the test data
            a = np.full(shape, fill if np.dtype(dtype).kind in "fc" else 1, dtype=dtype) if dtype != "U3" \
                else np.full(shape, "ab")
        if a.size and np.dtype(dtype).kind in "f":
            a.flat[:: max(1, a.size // 3)] = np.arange(len(a.flat[:: max(1, a.size // 3)]))
        return a

    return st.tuples(dtypes, shapes, st.floats(allow_nan=True, allow_infinity=True)).map(make)


@FUZZ
@given(a=arrays())
def test_random_npy(tmp, a):
    buf = io.BytesIO()
    np.save(buf, a)
    only_our_errors(load_and_build_dem, _write(tmp, ".npy", buf.getvalue()))


@FUZZ
@given(d=st.dictionaries(st.sampled_from(["elevation", "z", "x", "y", "dx", "dy", "xmin", "xmax", "ymin", "ymax",
                                          "longitude", "latitude", "vertices", "triangles", "format"]),
                         arrays(), max_size=6))
def test_random_npz(tmp, d):
    buf = io.BytesIO()
    np.savez(buf, **d)
    p = _write(tmp, ".npz", buf.getvalue())
    only_our_errors(load_and_build_dem, p)
    only_our_errors(load_and_query_tin, p)


@FUZZ
@given(v=st.lists(st.tuples(numbers, numbers, numbers), min_size=0, max_size=8),
       t=st.lists(st.tuples(st.integers(-2, 9), st.integers(-2, 9), st.integers(-2, 9)), min_size=0, max_size=8),
       tdtype=st.sampled_from(["int64", "int32", "uint8", "float64"]))
def test_random_tin_npz(tmp, v, t, tdtype):
    buf = io.BytesIO()
    vert = np.asarray(v, dtype=np.float64).reshape(-1, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tri = np.asarray(t, dtype=np.int64).reshape(-1, 3).astype(tdtype)
    np.savez(buf, vertices=vert, triangles=tri)
    only_our_errors(load_and_query_tin, _write(tmp, ".npz", buf.getvalue()))


@FUZZ
@given(corners=st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3), st.integers(-2, 2)), min_size=3, max_size=18))
def test_random_tin_text_on_a_lattice(tmp, corners):
    """Triangles with corners on a 4x4 lattice: shared, duplicate, overlapping and T-junction cases."""
    k = len(corners) // 3 * 3
    rows = np.asarray(corners[:k], dtype=float).reshape(-1, 9)
    only_our_errors(load_and_query_tin, _write(tmp, ".tin", _text(rows.tolist())))


def test_the_oracle_flags_a_foreign_exception():
    """only_our_errors lets any other exception (and a RuntimeWarning) through."""
    with pytest.raises(ZeroDivisionError):
        only_our_errors(lambda: 1 / 0)
    with pytest.raises(RuntimeWarning):
        only_our_errors(lambda: np.float64(1e300) * np.float64(1e300))
