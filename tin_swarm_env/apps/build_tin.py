"""``tin-swarm build-tin``: reduce a DEM to a TIN and write it (:class:`Args` holds the options,
:func:`build_tin` does the command).

``DEM`` is a file :func:`~tin_swarm_env.terrain.load_dem` reads, or ``sample:jacksboro`` /
``sample:topobathy``; the command prints vertices, triangles, the max and RMS vertical error
against every DEM cell and the build time, and writes the TIN (``.tin`` thesis text or ``.npz``)
and, with ``--png``, a picture coloured by slope.
"""

from __future__ import annotations

import inspect
import re
import time
from dataclasses import dataclass, fields

from ..errors import ArgumentError
from ..terrain.build import METHODS
from ..terrain.dem_io import SAMPLES
from .args import check_args, opt, option_name

__all__ = ["Args", "build_tin", "VIP_DEFAULT_VERTICES"]

VIP_DEFAULT_VERTICES = 5000  # vip's vertex budget when no other limit is given


def _required(v: str) -> str | None:
    return None if v else "is required"


@dataclass
class Args:
    """``tin-swarm build-tin``: every option, its help and what it accepts (checked when built)."""

    dem: str = opt("sample:jacksboro", "DEM file (.xyz/.txt/.asc/.npy/.npz/.tif) or sample:jacksboro / "
                   "sample:topobathy")
    output: str = opt("", "output .tin or .txt (thesis text) or .npz", check=_required, short="-o", required=True)
    method: str | None = opt(None, "reduction (default: greedy with --max-error-m, else vip; delaunay for point "
                             "clouds; robot and trust need --max-slope-deg)", choices=METHODS)
    max_vertices: int | None = opt(None, f"vertex budget (vip default: {VIP_DEFAULT_VERTICES})", lo=4)
    max_error_m: float | None = opt(None, "greedy/robot/trust: largest vertical error kept (m)", lo=0)
    min_significance_m: float | None = opt(None, "vip: drop points less significant than this (m)", lo=0)
    max_slope_deg: float | None = opt(None, "robot/trust: the robots' steepest drivable slope, whose class the TIN "
                                      "keeps (deg)", lo=0, lo_open=True, hi=90, hi_open=True)
    png: str | None = opt(None, "also draw the TIN coloured by slope into this PNG file")

    def __post_init__(self):
        check_args(self)


def _as_options(msg: str) -> str:
    """A library message with the names of ``build_tin``'s parameters that are also this command's
    ``Args`` fields written as this command's options."""
    from ..terrain import build_tin as library_build_tin

    params = inspect.signature(library_build_tin).parameters
    for f in fields(Args):
        if f.name in params and f.name != "dem":  # (dem is the positional DEM argument, not an option)
            msg = re.sub(rf"(?<![\w-]){f.name}(?![\w])", option_name(f.name), msg)
    return msg.replace("--method=", "--method ")


def _load(spec: str):
    from .. import terrain

    if spec.startswith("sample:"):
        name = spec.split(":", 1)[1]
        if name not in SAMPLES:
            raise ArgumentError(f"DEM {spec!r}: unknown sample DEM; known: "
                                + ", ".join(f"sample:{k}" for k in SAMPLES))
        return terrain.sample_dem(name)
    return terrain.load_dem(spec)


def build_tin(a: Args) -> int:
    """Check the paths, load the DEM, build the TIN, print its figures and write it (and ``--png``)."""
    from .. import terrain
    from .._atomic import check_outputs

    check_outputs({"-o/--output": a.output, "--png": a.png}, inputs=() if a.dem.startswith("sample:") else (a.dem,))
    dem = _load(a.dem)
    method = a.method
    if method is None:
        method = "greedy" if a.max_error_m is not None else None
    kw = {k: v for k, v in (("max_vertices", a.max_vertices), ("max_error_m", a.max_error_m),
                            ("min_significance_m", a.min_significance_m), ("max_slope_deg", a.max_slope_deg))
          if v is not None}
    if method in (None, "vip") and not kw and isinstance(dem, terrain.Dem):
        kw["max_vertices"] = VIP_DEFAULT_VERTICES
    t0 = time.perf_counter()
    try:
        tin = terrain.build_tin(dem, method=method, **kw)
    except (ArgumentError, ValueError) as e:  # the library names its parameters: say the options instead
        raise type(e)(_as_options(str(e))) from None
    dt = time.perf_counter() - t0
    terrain.save_tin(tin, a.output)
    print(f"source     {dem!r}")
    print(f"method     {method or ('delaunay' if isinstance(dem, terrain.PointCloud) else 'vip')}")
    print(f"vertices   {tin.n_vertices}")
    print(f"triangles  {tin.n_triangles}")
    if isinstance(dem, terrain.Dem):
        st, _ = terrain.vertical_error(tin, dem)
        print(f"max error  {st.max_m:.2f} m")
        print(f"rms error  {st.rms_m:.2f} m   (over {st.n_cells} DEM cells)")
    print(f"build time {dt:.3f} s")
    print(f"wrote      {a.output}")
    if a.png:
        _plot_tin(tin, a.png)
        print(f"wrote      {a.png}")
    return 0


def _plot_tin(tin, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    from .._atomic import atomic_path

    tri = Triangulation(tin.vertices[:, 0], tin.vertices[:, 1], tin.triangles)
    fig, ax = plt.subplots(figsize=(8, 7), dpi=110)
    pc = ax.tripcolor(tri, facecolors=tin.slope_deg, cmap="viridis")
    ax.triplot(tri, lw=0.15, color="k", alpha=0.4)
    fig.colorbar(pc, ax=ax, label="slope (deg)")
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(f"{tin.n_vertices} vertices, {tin.n_triangles} triangles")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)
