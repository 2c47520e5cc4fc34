"""Seeded terrain generators: a new goal task (terrain, spawn region, target) from a random stream.

The jumanji "generator" idea: :func:`generate` draws a family and its parameters from ``ranges``
and returns a :class:`GeneratedTask`; the same generator state gives the same task bit for bit.
Each family is a function ``family(rng, **params) -> GeneratedTask`` (``FAMILIES``); parameters
left out take the middle of their default range (or the first choice).

Geometry is built in a *travel frame*: ``v`` forward from the spawn toward the target, ``u`` to
the robots' right, origin at the map centre; ``heading`` turns that frame onto the map (travel
north, east, south or west). "Left" and "right" are as seen from the spawn looking at the target.
Every cliff is a one-cell step at least ``cell_m * tan(cliff_min_deg)`` high, so steeper than
``cliff_min_deg = (90 + max_slope_deg) / 2`` (60 deg for the robots' default 30 deg limit);
every pass or ramp floor is at most ``max_slope_deg / 2`` steep (15 deg) including the noise,
which never adds more than ``max_slope_deg / 10`` (3 deg) of slope; a pass's flanks (``4 m + 2
cells`` wide, at most about 24 deg) join it to the ground over its full width near its ends, so a
greedy TIN never reduces that joint to one vertex; where it goes through the cliff (its *mouth*)
its walls are sheer and its floor one cell wider each side and level across the cliff line, so the
greedy TIN keeps its width there (``_cut_pass``). So the task stays unambiguous after TIN
reduction (measured: the target was reachable over passable triangles of the greedy 0.5 m TIN in
298 of 300 draws; the two misses, both mesas, had a steep sliver triangle across a ramp, which is
what the ``solvable`` check below catches; fork: 149 of 150, trap: 150 of 150; a sliver can also
seal a fork's dead end, about 1 in 60, which leaves the task solvable).

=========== ================ ================ ===================================================
family      parameter        default range    meaning
=========== ================ ================ ===================================================
(all)       size_m           [200, 400]       side of the square map, m
(all)       cell_m           [1, 4]           DEM cell size, m
(all)       noise_m          [0, 1.5]         amplitude of the smooth fractal noise, m
(all)       noise_scale_m    [20, 60]         largest wavelength of the noise, m
(all)       spawn_m          [22, 30]         side of the square spawn region, m (about 25-50
                                              robots at 2 m separation)
canyon      heading          n/e/s/w          direction of travel (the cliff runs across it)
canyon      spawn_on         top, bottom      robots start on the plateau or below the cliff
canyon      side             left/right/both  where the pass(es) lie; "both": mirror-image pair
canyon      cliff_m          [8, 16]          height of the escarpment, m
canyon      cliff_v_frac     [-0.1, 0.1]      cliff line's offset along travel, of half the size
canyon      pass_offset_frac [0.4, 0.75]      pass centre's lateral offset, of half the size
canyon      pass_width_m     [10, 20]         width of a pass, m
canyon      ramp_slope_deg   [9, 13]          slope of a pass (capped as above), deg
canyon      target_u_frac    [-0.15, 0.15]    target's lateral offset, of half the size
mesa        spawn_on         top, bottom      robots on the mesa (target below) or the reverse
mesa        side             left/right/both  where the ramp(s) lie; "both": mirror-image pair
mesa        bearing_deg      [0, 360]         bearing of the low end (spawn or target) from the
                                              mesa centre, deg counter-clockwise from east
mesa        mesa_m           [8, 11]          height of the mesa, m
mesa        radius_frac      [0.35, 0.5]      mesa radius, of half the size
mesa        ramp_angle_deg   [60, 120]        angle at the centre between that bearing and a ramp
mesa        ramp_width_m     [10, 18]         width of a ramp, m
mesa        ramp_slope_deg   [10, 13]         slope of a ramp (capped as above), deg
mesa        place_frac       [0.2, 0.8]       where the low end sits between its nearest and
                                              farthest allowed distance from the centre
hills       heading          n/e/s/w          direction of travel
hills       hill_m           [3, 10]          amplitude of the rolling hills, m (their slope is
                                              capped at max_slope_deg / 2)
hills       hill_scale_m     [60, 140]        largest wavelength of the hills, m
hills       n_blocks         [2, 6]           steep-walled raised blocks (rectangles)
hills       block_m          [8, 14]          height of a block, m
hills       block_size_m     [12, 36]         longest side of a block, m (each side is drawn
                                              in [0.5, 1] of it)
hills       n_pits           [1, 4]           steep-walled round pits
hills       pit_m            [6, 12]          depth of a pit, m
hills       pit_radius_m     [6, 16]          largest radius of a pit, m
hills       target_u_frac    [-0.3, 0.3]      target's lateral offset, of half the size
fork        heading          n/e/s/w          direction of travel (the cliff runs across it)
fork        spawn_on         top, bottom      robots start on the plateau or below the cliff
fork        side             left, right      where the way(s) through lie
fork        cliff_m          [6, 12]          height of the escarpment, m
fork        cliff_v_frac     [-0.1, 0.1]      cliff line's offset along travel, of half the size
fork        n_passes         [2, 4]           ramps or openings in the cliff, dead ends included
fork        n_dead           [0, 3]           how many of them are dead ends (at most
                                              n_passes - 1; 0: a canyon with several passes)
fork        dead_end         pocket, spur     a ramp into a walled pit, or a tongue of the
                                              plateau (spawn at the bottom: a ramp onto a
                                              walled block, or a blind canyon)
fork        pass_offset_frac [0.3, 0.7]       nearest way through's lateral offset, of half
                                              the size
fork        pass_width_m     [10, 16]         width of a ramp, m
fork        ramp_slope_deg   [9, 13]          slope of a ramp (capped as above), deg
fork        pocket_m         [15, 35]         length of a pocket past its ramp's foot, or of a
                                              spur, m
fork        pocket_depth_m   [3, 6]           depth of a pocket's pit below the floor, m (at
                                              least the cliff minimum)
fork        target_u_frac    [-0.15, 0.15]    target's lateral offset, of half the size
trap        heading          n/e/s/w          direction of travel
trap        side             left, right      where the barrier's opening lies
trap        barrier          wall, trench,    raised wall, sunk trench, or a basin walled by a
                                 cliff            cliff with a ramp out through the opening
trap        shape            round, square    a ring (C) or the sides of a square (U)
trap        trap_m           [6, 12]          height of the wall or depth of the trench, m
trap        radius_m         [28, 50]         inside radius (half side) of the barrier, m
trap        thickness_m      [4, 10]          thickness of the barrier, m (at least 3 cells)
trap        opening_deg      [100, 150]       the opening's centre, deg from the direction of
                                              travel toward ``side`` (180: straight back)
trap        gap_deg          [30, 40]         angular width of the opening, deg
trap        target_u_frac    [-0.15, 0.15]    target's lateral offset, of half the size
realdem     dem              jacksboro,       the bundled real DEM cropped (``sample_dem``)
                                 topobathy
realdem     crop_cells       [24, 48]         side of the crop, in the DEM's coarser cells
                                              (jacksboro ~92 m, topobathy ~2.4 km)
realdem     steep_frac       [0.1, 0.4]       share of the map's area too steep to drive: the
                                              robots' max_slope_deg is drawn to match it
realdem     detour_min       [1.3, 1.3]       the drivable way from the spawn centre to the
                                              target over the straight line, at least
realdem     orient           none, flip_x,    the crop's turn: mirror east-west or north-south,
                                 flip_y, ...      transpose, quarter turns (the 8 symmetries of
                                              the square, ``realdem.ORIENTS``)
bay         heading          n/e/s/w          direction of travel
bay         side             left/right/both  the way round the bay ("both": past either arm)
bay         barrier          wall, trench     raised wall or sunk trench (one-cell cliffs)
bay         bay_m            [6, 12]          height of the wall or depth of the trench, m
bay         thickness_m      [4, 10]          thickness of the barrier, m (at least 3 cells)
bay         width_frac       [0.3, 0.5]       the inside's half-width, of half the size
bay         depth_frac       [0.4, 0.9]       the arms' length, of the room between the spawn
                                              region and the back wall
bay         back_v_frac      [-0.1, 0.3]      the back wall's place along travel, of half
                                              the size
bay         target_u_frac    [-0.15, 0.15]    target's lateral offset, of half the size
rough       relief_m         [20, 60]         amplitude of the fractal relief, m (no cliff)
rough       relief_scale_m   [80, 200]        its longest wavelength, m
rough       steep_frac       [0.1, 0.4]       share of the map too steep to drive (as realdem)
rough       detour_min       [1.3, 1.3]       as realdem
=========== ================ ================ ===================================================

``bay`` and ``rough`` (in :data:`EXTRA_FAMILIES`) are drawn only where a scenario names them, so the
default mix (:data:`ALL_FAMILIES`) draws what it drew before they existed: ``bay`` is a dead end of
another shape than fork's and trap's (a U-shaped barrier across the way, open toward the spawn),
``rough`` ground too steep to drive with no cliff, built as ``realdem`` is but on fractal relief.

``realdem`` (held out: in :data:`REAL_FAMILIES`, not :data:`ALL_FAMILIES`, so a scenario draws it
only where its ``families`` name it) crops the real DEMs bundled with matplotlib; it has no noise,
keeps the crop's slope angles and draws the robots' ``max_slope_deg`` per task (the task's
``params["max_slope_deg"]``, which the scenario builder gives the robots); its spawn and target are
placed with ``terrain.cost_to_go`` on the crop's TIN (module :mod:`~tin_swarm_env.scenario.realdem`).

``detour_side``: canyon and mesa put the only way(s) down or up on the drawn ``side``; the
straight line from the spawn centre to the target always crosses a cliff. Fork puts every way
through on the drawn ``side`` (the nearest one first in ``passes``) and its dead ends on either
side (``dead_ends``); trap puts its opening on the drawn ``side``, so the shortest way round
goes that way. "Left" is the sign of the cross product of (spawn centre -> target) with (spawn
centre -> the middle of the first pass or opening), ``_side_of``; ``side`` is drawn uniformly,
so over many seeds the way round is on the left as often as on the right. Hills keep every block
and pit (their bounding circles) ``6 m + 2 cells`` apart and away from the map edge, the spawn
region and the target, so their tasks are solvable by construction; their label is "none". A
``solvable(task) -> bool`` check (the integrator passes one built on ``terrain.cost_to_go``)
makes :func:`generate` draw again from the same stream until it holds.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .. import terrain as T
from ..errors import ArgumentError, ScenarioError
from ..terrain import Dem
from ..terrain.breaks import MAX_SLOPE_DEG
from . import realdem as RD

__all__ = ["GeneratedTask", "PARAMS", "ALL_FAMILIES", "REAL_FAMILIES", "DEFAULT_RANGES", "FAMILIES", "HEADINGS", "generate",
           "validate_ranges", "family_weights", "draw_params", "replay", "canyon", "mesa", "hills", "fork", "trap",
           "realdem", "bay", "rough", "EXTRA_FAMILIES", "NoFitError"]

HEADINGS = {"north": (0.0, 1.0), "east": (1.0, 0.0), "south": (0.0, -1.0), "west": (-1.0, 0.0)}
SIDES = ("left", "right", "both")
MOUTH_CELLS = 2.0  # a pass's mouth (where it goes through the cliff): this many cells either side of the cliff line
MARGIN_M = 4.0  # clear ground kept between a spawn region / target and the map edge or a cliff


@dataclass(frozen=True)
class Param:
    """One drawn parameter: ``kind`` "float" | "int" | "choice"; ``default`` the default range
    ``(lo, hi)`` or the choices; ``bounds`` the allowed ``(lo, hi)`` (or the allowed choices)."""

    kind: str
    default: tuple
    bounds: tuple


def _f(lo, hi, blo, bhi):
    return Param("float", (float(lo), float(hi)), (float(blo), float(bhi)))


def _i(lo, hi, blo, bhi):
    return Param("int", (int(lo), int(hi)), (int(blo), int(bhi)))


def _c(*choices):
    return Param("choice", tuple(choices), tuple(choices))


_COMMON = {
    "size_m": _f(200, 400, 100, 2000), "cell_m": _f(1, 4, 0.25, 10), "noise_m": _f(0, 1.5, 0, 10),
    "noise_scale_m": _f(20, 60, 5, 500), "spawn_m": _f(22, 30, 5, 200),
}
PARAMS: dict[str, dict[str, Param]] = {
    "canyon": {**_COMMON, "heading": _c(*HEADINGS), "spawn_on": _c("top", "bottom"), "side": _c(*SIDES),
               "cliff_m": _f(8, 16, 1, 200), "cliff_v_frac": _f(-0.1, 0.1, -0.5, 0.5),
               "pass_offset_frac": _f(0.4, 0.75, 0.05, 0.95), "pass_width_m": _f(10, 20, 2, 200),
               "ramp_slope_deg": _f(9, 13, 1, 45), "target_u_frac": _f(-0.15, 0.15, -0.9, 0.9)},
    "mesa": {**_COMMON, "spawn_on": _c("top", "bottom"), "side": _c(*SIDES), "bearing_deg": _f(0, 360, -360, 720),
             "mesa_m": _f(8, 11, 1, 200), "radius_frac": _f(0.35, 0.5, 0.05, 0.9),
             "ramp_angle_deg": _f(60, 120, 20, 160), "ramp_width_m": _f(10, 18, 2, 200),
             "ramp_slope_deg": _f(10, 13, 1, 45), "place_frac": _f(0.2, 0.8, 0, 1)},
    "hills": {**_COMMON, "heading": _c(*HEADINGS), "hill_m": _f(3, 10, 0, 200), "hill_scale_m": _f(60, 140, 5, 2000),
              "n_blocks": _i(2, 6, 0, 50), "block_m": _f(8, 14, 1, 200), "block_size_m": _f(12, 36, 2, 500),
              "n_pits": _i(1, 4, 0, 50), "pit_m": _f(6, 12, 1, 200), "pit_radius_m": _f(6, 16, 1, 500),
              "target_u_frac": _f(-0.3, 0.3, -0.9, 0.9)},
    "fork": {**_COMMON, "heading": _c(*HEADINGS), "spawn_on": _c("top", "bottom"), "side": _c("left", "right"),
             "cliff_m": _f(6, 12, 1, 200), "cliff_v_frac": _f(-0.1, 0.1, -0.5, 0.5), "n_passes": _i(2, 4, 2, 8),
             "n_dead": _i(0, 3, 0, 7), "dead_end": _c("pocket", "spur"), "pass_offset_frac": _f(0.3, 0.7, 0.05, 0.95),
             "pass_width_m": _f(10, 16, 2, 200), "ramp_slope_deg": _f(9, 13, 1, 45),
             "pocket_m": _f(15, 35, 2, 500), "pocket_depth_m": _f(3, 6, 1, 100),
             "target_u_frac": _f(-0.15, 0.15, -0.9, 0.9)},
    "trap": {**_COMMON, "heading": _c(*HEADINGS), "side": _c("left", "right"),
             "barrier": _c("wall", "trench", "cliff"), "shape": _c("round", "square"), "trap_m": _f(6, 12, 1, 200),
             "radius_m": _f(28, 50, 5, 1000), "thickness_m": _f(4, 10, 1, 200), "opening_deg": _f(100, 150, 0, 180),
             "gap_deg": _f(30, 40, 10, 180),
             "target_u_frac": _f(-0.15, 0.15, -0.9, 0.9)},
    "realdem": {"size_m": _COMMON["size_m"], "cell_m": _COMMON["cell_m"], "spawn_m": _COMMON["spawn_m"],
                "dem": _c("jacksboro", "topobathy"), "crop_cells": _f(24, 48, 8, 80), "steep_frac": _f(0.1, 0.4, 0.02, 0.6),
                "detour_min": _f(1.3, 1.3, 1.0, 3.0),
                "orient": _c("none", "flip_x", "flip_y", "rot180", "transpose", "rot90", "rot270", "anti_transpose")},
    "bay": {**_COMMON, "heading": _c(*HEADINGS), "side": _c(*SIDES), "barrier": _c("wall", "trench"),
            "bay_m": _f(6, 12, 1, 200), "thickness_m": _f(4, 10, 1, 200), "width_frac": _f(0.3, 0.5, 0.1, 0.8),
            "depth_frac": _f(0.4, 0.9, 0.1, 1.0), "back_v_frac": _f(-0.1, 0.3, -0.5, 0.6),
            "target_u_frac": _f(-0.15, 0.15, -0.9, 0.9)},
    "rough": {"size_m": _COMMON["size_m"], "cell_m": _COMMON["cell_m"], "spawn_m": _COMMON["spawn_m"],
              "relief_m": _f(20, 60, 1, 500), "relief_scale_m": _f(80, 200, 10, 2000),
              "steep_frac": _f(0.1, 0.4, 0.02, 0.6), "detour_min": _f(1.3, 1.3, 1.0, 3.0)},
}
REAL_FAMILIES: tuple[str, ...] = ("realdem",)  # drawn only where a scenario names them (held out of every default mix)
EXTRA_FAMILIES: tuple[str, ...] = ("bay", "rough")  # synthetic, drawn only where a scenario names them (the default
# mix, and so every task drawn before they existed, stays as it was)
# the synthetic families, the default of every family list (a scenario naming none draws these)
ALL_FAMILIES: tuple[str, ...] = tuple(f for f in PARAMS if f not in REAL_FAMILIES + EXTRA_FAMILIES)
MAX_GRID_CELLS = 4_000_000  # a generated DEM's cells (size_m / cell_m + 1)^2: ~120 bytes each while it is built
# and meshed, so ~0.5 GB at the limit (2 km at 1 m); checked before any allocation
DEFAULT_RANGES: dict[str, dict[str, list]] = {
    fam: {k: list(p.default) for k, p in spec.items()} for fam, spec in PARAMS.items()}


@dataclass(frozen=True, eq=False)
class GeneratedTask:
    """One drawn goal task.

    dem            the terrain grid (source "generated:<family>")
    spawn_region   (x0, y0, x1, y1) m, traversable ground for the robots
    targets        (m, 2) m, target positions (read-only)
    family         the family's name
    params         every parameter the family was called with (drawn ones and ``max_slope_deg``)
    detour_side    "left", "right", "both" or "none": where the way round the cliff lies, as
                   seen from the spawn centre looking at the target
    passes         (k, 2, 2) m, the centre line of each pass or ramp, high end first (trap: of
                   the opening, inside first); fork: the way through first
    seed           the seed of the family's own generator (``replay`` rebuilds the task from it);
                   None when the family was called directly
    dead_ends      (j, 2, 2) m, fork: each dead end's entry (where a robot coming from the spawn
                   side enters it) and its far end (pocket floor, spur tip, blind canyon's end)
    detour_min     the drivable way from the spawn centre to each target is at least this many
                   times the straight line (realdem; 1.0: no such promise); the scenario builder
                   checks it on its TIN
    """

    dem: Dem
    spawn_region: tuple[float, float, float, float]
    targets: np.ndarray
    family: str
    params: dict
    detour_side: str
    passes: np.ndarray
    seed: int | None = None
    dead_ends: np.ndarray = dataclasses.field(default_factory=lambda: _frozen(np.zeros((0, 2, 2))))
    detour_min: float = 1.0

    @property
    def spawn_centre(self) -> np.ndarray:
        """(2,) m, the middle of the spawn region."""
        x0, y0, x1, y1 = self.spawn_region
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2])


# -- parameters -------------------------------------------------------------------------------


def _check_family(fam, where):
    if fam not in PARAMS:
        raise ScenarioError(f"{where}: unknown terrain family {fam!r}; known: {', '.join(PARAMS)}")


def _check_range(fam, key, value, where):
    """Normalise one range (a [lo, hi] pair, a single number, or a list of choices)."""
    if key not in PARAMS[fam]:
        raise ScenarioError(f"{where}: family {fam!r} has no parameter {key!r} (known: {', '.join(PARAMS[fam])})")
    p, name = PARAMS[fam][key], f"{where}: {fam}.{key}"
    if p.kind == "choice":
        vals = [value] if isinstance(value, str) else value
        if not isinstance(vals, (list, tuple)) or not vals or any(v not in p.bounds for v in vals):
            raise ScenarioError(f"{name} must be a non-empty list of {list(p.bounds)}, got {value!r}")
        return tuple(vals)
    pair = [value, value] if isinstance(value, (int, float)) else value
    ok = isinstance(pair, (list, tuple)) and len(pair) == 2 and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pair)
    if ok and p.kind == "int":
        ok = all(float(v).is_integer() for v in pair)
    if not ok:
        raise ScenarioError(f"{name} must be a [lo, hi] pair of {'integers' if p.kind == 'int' else 'numbers'}, "
                            f"got {value!r}")
    lo, hi = pair
    if lo > hi or lo < p.bounds[0] or hi > p.bounds[1]:
        raise ScenarioError(f"{name}: range {[lo, hi]} must have lo <= hi within {list(p.bounds)}")
    return (int(lo), int(hi)) if p.kind == "int" else (float(lo), float(hi))


def validate_ranges(ranges: Mapping | None, families: Sequence[str] = ALL_FAMILIES,
                    where: str = "generated terrain") -> dict[str, dict[str, tuple]]:
    """The default ranges of ``families`` with ``ranges`` (``{family: {param: [lo, hi] | value |
    [choices]}}``) laid over them, checked. An unknown family or parameter, or a bad range, is a
    :class:`ScenarioError` naming ``where``, the family and the key."""
    for fam in families:
        _check_family(fam, where)
    out = {fam: {k: p.default for k, p in PARAMS[fam].items()} for fam in families}
    for fam, over in (ranges or {}).items():
        _check_family(fam, where)
        if fam not in out:
            raise ScenarioError(f"{where}: ranges given for family {fam!r}, which is not among {list(families)}")
        if not isinstance(over, Mapping):
            raise ScenarioError(f"{where}: ranges for family {fam!r} must be a table, got {over!r}")
        for key, value in over.items():
            out[fam][key] = _check_range(fam, key, value, where)
    for fam, r in out.items():
        _check_cells(fam, r["size_m"][1], r["cell_m"][0], where)
    return out


def _check_cells(fam, size_m, cell_m, where):
    """Refuse a grid of more than :data:`MAX_GRID_CELLS` cells (the largest size over the smallest cell)."""
    cells = (size_m / cell_m + 1) ** 2
    if cells > MAX_GRID_CELLS:
        raise ScenarioError(f"{where}: {fam}.size_m up to {size_m:g} m with cell_m down to {cell_m:g} m makes "
                            f"{cells:.3g} grid cells; at most {MAX_GRID_CELLS:,} (raise cell_m or lower size_m)")


def draw_params(rng: np.random.Generator, family: str, ranges: Mapping[str, tuple]) -> dict:
    """One value per parameter of ``family``, uniform in its (checked) range, in table order."""
    out = {}
    for key, p in PARAMS[family].items():
        r = ranges[key]
        if p.kind == "float":
            out[key] = float(rng.uniform(r[0], r[1]))
        elif p.kind == "int":
            out[key] = int(rng.integers(r[0], r[1] + 1))
        else:
            out[key] = r[int(rng.integers(len(r)))]
    return out


def _resolve(family: str, params: dict) -> dict:
    """Fill missing parameters with the middle of their default range; check the given ones."""
    out = {"max_slope_deg": MAX_SLOPE_DEG}
    for key, p in PARAMS[family].items():
        out[key] = p.default[0] if p.kind == "choice" else (p.default[0] + p.default[1]) / 2
        if p.kind == "int":
            out[key] = int(out[key])
    for key, value in params.items():
        if key == "max_slope_deg":
            if not isinstance(value, (int, float)) or not 5.0 <= value <= 60.0:
                raise ScenarioError(f"{family}: max_slope_deg must be within [5, 60], got {value!r}")
        else:
            choice = key in PARAMS[family] and PARAMS[family][key].kind == "choice"
            _check_range(family, key, [value] if choice else value, family)
        out[key] = value
    _check_cells(family, out["size_m"], out["cell_m"], family)
    return out


# -- shared geometry --------------------------------------------------------------------------


def _grid(p):
    """Cell centres ``(n,)`` m (the same for x and y: maps are square) and the half size, m."""
    n = int(round(p["size_m"] / p["cell_m"])) + 1
    x = np.arange(n) * p["cell_m"]
    return x, x[-1] / 2


def _noise(rng, x, scale_m, octaves=3):
    """Smooth fractal value noise on the grid ``x`` x ``x``: random lattices ``scale_m / 2**o``
    apart, smoothstep-interpolated, amplitudes halving; max |value| scaled to 1. (n, n)."""
    out = np.zeros((x.size, x.size))
    for o in range(octaves):
        wl = scale_m / 2 ** o
        f = x / wl
        i = np.floor(f).astype(np.int64)
        t = f - i
        s = t * t * (3 - 2 * t)
        lat = rng.standard_normal((i[-1] + 2, i[-1] + 2))
        a, b = lat[i][:, i], lat[i][:, i + 1]
        c, d = lat[i + 1][:, i], lat[i + 1][:, i + 1]
        sy, sx = s[:, None], s[None, :]
        out += 0.5 ** o * ((1 - sy) * ((1 - sx) * a + sx * b) + sy * ((1 - sx) * c + sx * d))
    peak = np.abs(out).max()
    return out / peak if peak > 0 else out


def _capped(field, amplitude_m, max_tan, cell_m):
    """``amplitude_m * field``, scaled down where needed so its steepest slope is ``max_tan``."""
    z = amplitude_m * field
    gy, gx = np.gradient(z, cell_m)
    steepest = float(np.sqrt(gx * gx + gy * gy).max())
    return z * (max_tan / steepest) if steepest > max_tan else z


def _slopes(p):
    """(cliff height floor m, ramp tangent cap, noise tangent cap) from ``max_slope_deg``."""
    ms = math.radians(p["max_slope_deg"])
    noise_tan = math.tan(ms / 10)
    return p["cell_m"] * math.tan((math.pi / 2 + ms) / 2), math.tan(ms / 2) - noise_tan, noise_tan


def _frame(x, half, heading):
    """Travel-frame coordinates ``u`` (right) and ``v`` (forward) of every cell, (n, n) m, and the
    map from travel frame to world xy."""
    fx, fy = HEADINGS[heading]
    rx, ry = fy, -fx
    dx, dy = x[None, :] - half, x[:, None] - half

    def to_world(uv):
        uv = np.asarray(uv, dtype=np.float64)
        return np.stack([half + uv[..., 0] * rx + uv[..., 1] * fx, half + uv[..., 0] * ry + uv[..., 1] * fy], -1)

    return dx * rx + dy * ry, dx * fx + dy * fy, to_world


def _flare_m(p):
    """Width of a pass's gentle flanks, m (see :func:`_cut_pass`)."""
    return 4.0 + 2.0 * p["cell_m"]


def _run(h, tan, p):
    """Horizontal length of a pass ``h`` high at slope ``tan``, m: the slope's run and the mouth's
    landing (two cells, :func:`_cut_pass`)."""
    return h / tan + 2 * p["cell_m"]


def _cut_pass(z, along, across, start, run, h, width_m, p, cross=None):
    """``z`` (n, n) m with a pass cut into / built onto it: along the axis coordinate ``along``
    (n, n) m from ``start`` (height ``h``) to ``start + run`` (height 0), a floor ``width_m`` wide
    about ``across == 0``. Each side has a flank ``_flare_m`` wide rising or falling from the floor
    at ``tan(0.6 max_slope_deg)`` (18 deg) until it meets ``z``; beyond it ``z`` is kept, so the
    pass has steep walls where it is deep and gentle sides near its two ends (a TIN joins it to
    the ground over its full width there, never through one vertex).

    The *mouth*, where the pass goes through the cliff (``start + cross`` along the axis, default
    the middle), is built so that a TIN keeps its width. Within :data:`MOUTH_CELLS` cells of the
    cliff line the floor is ``width_m + 2 cell_m`` wide with no flank: the walls rise or fall
    sheer from the floor's edge (the extra cell each side pays for the last floor cell's
    triangle, which is steep). And the floor is level for one cell either side of the cliff line
    (the *landing*; :func:`_run` adds its two cells to the run, so the slope elsewhere is the
    drawn one), so the two cell rows either side of the cliff are at one height. Without these, a
    flank makes a step across the cliff line that grows from nothing at the floor's edge, and the
    slope's own step between the two rows leaves little margin on small cells; a greedy TIN,
    allowed its vertical error, then joins the two rows with slivers that cut across the floor
    (measured: mouths down to 1.5 m for an 11 m pass)."""
    cell = p["cell_m"]
    cross = run / 2 if cross is None else cross
    x = along - start
    x = x - np.clip(x - (cross - cell), 0.0, 2 * cell)  # the landing does not count
    ramp = h * np.clip(1.0 - x / (run - 2 * cell), 0.0, 1.0)
    mouth = np.abs(along - (start + cross)) <= MOUTH_CELLS * cell
    d = np.maximum(np.abs(across) - np.where(mouth, width_m / 2 + cell, width_m / 2), 0.0)
    flank = np.where((d <= _flare_m(p)) & ~mouth, math.tan(0.6 * math.radians(p["max_slope_deg"])) * d, np.inf)
    flank = np.where(mouth & (d == 0.0), 0.0, flank)
    on = (along >= start) & (along <= start + run)
    return np.where(on, np.clip(z, ramp - flank, ramp + flank), z)


def _lat_to_u(sg: float):
    """``(lat, v) -> (u, v)`` for points ``(..., 2)`` m: the families that draw a ``side`` build in a
    lateral coordinate ``lat = sg * u``, + toward the way round."""
    return lambda pts: np.asarray(pts, dtype=np.float64) * [sg, 1.0]


def _square(centre, side):
    cx, cy = (float(c) for c in centre)
    return (cx - side / 2, cy - side / 2, cx + side / 2, cy + side / 2)


def _side_of(spawn, target, points):
    """'left' / 'right' / 'both': the side of the line spawn -> target where ``points`` (k, 2) lie."""
    d = target - spawn
    cross = d[0] * (points[:, 1] - spawn[1]) - d[1] * (points[:, 0] - spawn[0])
    left, right = bool((cross > 0).any()), bool((cross < 0).any())
    return "both" if left and right else ("left" if left else "right")


def _frozen(a):
    a = np.asarray(a, dtype=np.float64)
    a.setflags(write=False)
    return a


def _task(family, p, x, z, spawn_centre, target, passes, rng_noise, dead_ends=()):
    """Add the common noise and wrap up. ``passes`` (k, 2, 2) m world; the rest as in GeneratedTask."""
    _, _, noise_tan = _slopes(p)
    z = z + _capped(_noise(rng_noise, x, p["noise_scale_m"]), p["noise_m"], noise_tan, p["cell_m"])
    targets = _frozen(np.asarray(target, dtype=np.float64).reshape(1, 2))
    passes = _frozen(np.asarray(passes, dtype=np.float64).reshape(-1, 2, 2))
    side = "none" if len(passes) == 0 else _side_of(np.asarray(spawn_centre), targets[0], passes.mean(axis=1))
    return GeneratedTask(Dem(z, x, x, source=f"generated:{family}"), _square(spawn_centre, p["spawn_m"]),
                         targets, family, p, side, passes,
                         dead_ends=_frozen(np.asarray(dead_ends, dtype=np.float64).reshape(-1, 2, 2)))


class NoFitError(ScenarioError):
    """A family's drawn parameters do not fit its map (:func:`generate` draws again)."""


def _fit(ok: bool, family: str, what: str, p: dict):
    if not ok:
        raise NoFitError(f"{family}: {what} does not fit a {p['size_m']:.0f} m map with these parameters: "
                            + ", ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in p.items()))


# -- families ---------------------------------------------------------------------------------


def canyon(rng: np.random.Generator, **params) -> GeneratedTask:
    """An escarpment across the way: a one-cell cliff ``cliff_m`` high spans the map between spawn
    and target; pass(es) ``pass_width_m`` wide ramp through it at ``ramp_slope_deg`` (half cut into
    the plateau, half built out below it) on the drawn ``side``, ``pass_offset_frac`` of the half
    size off the spawn-target line. ``rng`` draws only the noise."""
    p = _resolve("canyon", params)
    x, half = _grid(p)
    u, v, to_world = _frame(x, half, p["heading"])
    h_min, ramp_tan, _ = _slopes(p)
    h = max(p["cliff_m"], h_min)
    run = _run(h, min(math.tan(math.radians(p["ramp_slope_deg"])), ramp_tan), p)  # horizontal length of a pass, m
    vc, off, w, s = p["cliff_v_frac"] * half, p["pass_offset_frac"] * half, p["pass_width_m"], p["spawn_m"]
    spawn_uv = np.array([0.0, (vc - half) / 2])
    target_uv = np.array([p["target_u_frac"] * half, (vc + half) / 2])
    cross_u = spawn_uv[0] + (target_uv[0] - spawn_uv[0]) * (vc - spawn_uv[1]) / (target_uv[1] - spawn_uv[1])
    _fit(abs(vc) + run / 2 <= half - MARGIN_M, "canyon", f"a pass {run:.0f} m long", p)
    clear = off - w / 2 - _flare_m(p) - MARGIN_M  # from the spawn-target axis to the nearest pass flank, m
    _fit(s / 2 <= clear and abs(cross_u) <= clear and off + w / 2 <= half - MARGIN_M, "canyon",
         "the passes beside the spawn region and the straight way", p)
    _fit(spawn_uv[1] - s / 2 >= -half + MARGIN_M and spawn_uv[1] + s / 2 <= vc - MARGIN_M, "canyon",
         "the spawn region", p)
    z = np.where(v < vc, h, 0.0)  # (n, n) m, the plateau behind the cliff
    pass_u = {"left": [-off], "right": [off], "both": [-off, off]}[p["side"]]
    for uc in pass_u:
        z = _cut_pass(z, v, u - uc, vc - run / 2, run, h, w, p)
    ends = [[[uc, vc - run / 2], [uc, vc + run / 2]] for uc in pass_u]  # high end first
    if p["spawn_on"] == "bottom":
        z = h - z
        ends = [e[::-1] for e in ends]
    return _task("canyon", p, x, z, to_world(spawn_uv), to_world(target_uv), to_world(ends), rng)


def mesa(rng: np.random.Generator, **params) -> GeneratedTask:
    """A round mesa ``mesa_m`` high and ``radius_frac`` of the half size wide in the middle of the
    map, with one-cell cliffs all round except for radial ramp(s) ``ramp_width_m`` wide at
    ``ramp_slope_deg`` (cut into the rim as far as the spawn region or target allows, built out
    below it for the rest), ``ramp_angle_deg`` round from the low end's bearing on the drawn
    ``side``. Spawn on top: the spawn region is centred on the mesa and the target lies below at
    ``bearing_deg``; spawn at the bottom: the reverse. ``rng`` draws only the noise."""
    p = _resolve("mesa", params)
    x, half = _grid(p)
    dx, dy = x[None, :] - half, x[:, None] - half  # (1, n), (n, 1) m from the centre
    h_min, ramp_tan, _ = _slopes(p)
    h = max(p["mesa_m"], h_min)
    run = _run(h, min(math.tan(math.radians(p["ramp_slope_deg"])), ramp_tan), p)
    r, s, w, top = p["radius_frac"] * half, p["spawn_m"], p["ramp_width_m"], p["spawn_on"] == "top"
    room = r - (s / math.sqrt(2) + MARGIN_M if top else 2 * MARGIN_M)  # rim to spawn region / target, m
    _fit(room >= 0, "mesa", "the spawn region or target on top", p)
    inner = r - min(run / 2, room)  # the ramp's top end from the centre, m
    _fit(inner + run <= half - 1.5 * MARGIN_M, "mesa", f"a ramp {run:.0f} m long", p)
    beta = math.radians(p["bearing_deg"])
    bearing = np.array([math.cos(beta), math.sin(beta)])
    z = np.where(dx * dx + dy * dy <= r * r, h, 0.0)  # (n, n) m
    signs = {"left": [1.0], "right": [-1.0], "both": [1.0, -1.0]}[p["side"]]
    ends = []
    for sg in signs:  # seen from the centre, left is counter-clockwise; seen from outside, clockwise
        phi = beta + sg * (1.0 if top else -1.0) * math.radians(p["ramp_angle_deg"])
        c, sn = math.cos(phi), math.sin(phi)
        along, across = dx * c + dy * sn, dy * c - dx * sn
        z = _cut_pass(z, along, across, inner, run, h, w, p, cross=r - inner)
        ends.append([[half + inner * c, half + inner * sn], [half + (inner + run) * c, half + (inner + run) * sn]])
    reach = 1.0 / max(abs(bearing[0]), abs(bearing[1]))  # distance to the map edge per metre of half size
    if top:
        lo, hi = r + 2 * MARGIN_M, (half - 2 * MARGIN_M) * reach
    else:
        lo, hi = r + s / math.sqrt(2) + 2 * MARGIN_M, (half - s / 2 - MARGIN_M) * reach
    _fit(lo <= hi, "mesa", "the low end (spawn region or target) between the mesa and the map edge", p)
    low = half + (lo + p["place_frac"] * (hi - lo)) * bearing
    centre = np.array([half, half])
    spawn, target = (centre, low) if top else (low, centre)
    return _task("mesa", p, x, z, spawn, target, ends, rng)


def _place(rng, k, radii, half, keep_out, gap):
    """Up to ``k`` centres (travel frame, m) for features of bounding radii ``radii`` (k,), each at
    least ``gap`` from the map edge, the ``keep_out`` circles ``[(centre, radius), ...]`` and every
    feature placed before it. 32 candidates per feature, the first that fits wins (none: skipped)."""
    cands = rng.uniform(-half, half, (k, 32, 2))
    placed, rads = list(keep_out), []
    for i in range(k):
        c, ri = cands[i], radii[i]
        ok = np.all(np.abs(c) <= half - ri - gap, axis=1)
        for pc, pr in placed:
            ok &= np.hypot(c[:, 0] - pc[0], c[:, 1] - pc[1]) >= ri + pr + gap
        if ok.any():
            placed.append((c[np.argmax(ok)], ri))
            rads.append(i)
    return [placed[len(keep_out) + j][0] for j in range(len(rads))], rads


def hills(rng: np.random.Generator, **params) -> GeneratedTask:
    """Rolling hills (fractal noise ``hill_m`` high, slope capped at ``max_slope_deg / 2``) with
    ``n_blocks`` steep-walled blocks (rectangles at random angles, ``block_m`` high) and ``n_pits``
    steep-walled round pits (``pit_m`` deep) scattered over them. The spawn region sits at the
    rear edge, the target near the front edge. Every feature's bounding circle keeps ``6 m + 2
    cells`` from the others, the map edge, the spawn region and the target (fewer features when
    32 tries find no room), so the open ground stays connected. ``rng`` draws the hills, the
    features and the noise."""
    p = _resolve("hills", params)
    x, half = _grid(p)
    u, v, to_world = _frame(x, half, p["heading"])
    h_min, _, _ = _slopes(p)
    z = _capped(_noise(rng, x, p["hill_scale_m"]), p["hill_m"], math.tan(math.radians(p["max_slope_deg"]) / 2),
                p["cell_m"])
    s, gap = p["spawn_m"], 6.0 + 2 * p["cell_m"]
    spawn_uv = np.array([0.0, -half + MARGIN_M + s / 2])
    target_uv = np.array([p["target_u_frac"] * half, half - 3 * MARGIN_M])
    keep_out = [(spawn_uv, s / math.sqrt(2)), (target_uv, 0.0)]
    nb, npit = p["n_blocks"], p["n_pits"]
    sides = p["block_size_m"] * rng.uniform(0.5, 1.0, (nb, 2))  # (nb, 2) m
    angles = rng.uniform(0.0, math.pi, nb)
    pit_r = p["pit_radius_m"] * rng.uniform(0.6, 1.0, npit)
    radii = np.concatenate([np.hypot(sides[:, 0], sides[:, 1]) / 2, pit_r])
    centres, which = _place(rng, nb + npit, radii, half, keep_out, gap)
    for c, i in zip(centres, which, strict=True):
        du, dv = u - c[0], v - c[1]
        if i < nb:
            ca, sa = math.cos(angles[i]), math.sin(angles[i])
            inside = (np.abs(du * ca + dv * sa) <= sides[i, 0] / 2) & (np.abs(dv * ca - du * sa) <= sides[i, 1] / 2)
            z = z + np.where(inside, max(p["block_m"], h_min), 0.0)
        else:
            z = z - np.where(du * du + dv * dv <= pit_r[i - nb] ** 2, max(p["pit_m"], h_min), 0.0)
    return _task("hills", p, x, z, to_world(spawn_uv), to_world(target_uv), np.zeros((0, 2, 2)), rng)


def _lateral(rng, half_widths, taken, lo, hi, gap, both_sides=True, tries=32):
    """Lateral centres (m, signed; + toward the way through) for features of half-widths
    ``half_widths``, on a random side each (``both_sides``; else the + side), ``|lat|`` in ``[lo +
    hw, hi - hw]``, at least ``gap`` from every footprint in ``taken`` (``[(centre, half-width),
    ...]``, extended in place) and from each other. ``tries`` candidates per feature, the first that
    fits wins (none: skipped). Returns ``[(index, centre), ...]`` of the features placed."""
    placed = []
    for i, hw in enumerate(half_widths):
        if hi - hw < lo + hw:
            continue
        cands = rng.uniform(lo + hw, hi - hw, tries)
        if both_sides:
            cands = cands * np.where(rng.random(tries) < 0.5, -1.0, 1.0)
        ok = np.ones(tries, dtype=bool)
        for c, w in taken:
            ok &= np.abs(cands - c) >= hw + w + gap
        if ok.any():
            c = float(cands[np.argmax(ok)])
            taken.append((c, hw))
            placed.append((i, c))
    return placed


def fork(rng: np.random.Generator, **params) -> GeneratedTask:
    """An escarpment ``cliff_m`` high across the way (as in :func:`canyon`) with ``n_passes`` ramps
    or openings, ``n_dead`` of them (at most ``n_passes - 1``) dead ends, the rest ways through. The
    nearest way through lies ``pass_offset_frac`` of the half size off the spawn-target line (at
    least clear of the spawn region) on the drawn ``side``; further ones lie further out on that
    side, so the shortest way round is on ``side``. Dead ends take random places on either side
    (fewer when 32 tries find no room; at least one when ``n_dead >= 1``). A ``pocket`` dead end is
    a ramp down the cliff into a pit ``pocket_depth_m`` below the floor and ``pocket_m`` long past
    the ramp's foot, walled on its three other sides; a ``spur`` is a tongue of the plateau
    ``pocket_m`` long (at least 8 cells) reaching out over the floor. With ``spawn_on = "bottom"``
    the heights are turned upside down: a pocket becomes a ramp up onto a block ``pocket_depth_m``
    above the target's plateau, a spur a blind canyon cut into the plateau. ``rng`` draws the dead
    ends' places and the noise."""
    p = _resolve("fork", params)
    x, half = _grid(p)
    u, v, to_world = _frame(x, half, p["heading"])
    sg = -1.0 if p["side"] == "left" else 1.0
    lat = sg * u  # (n, n) m, lateral coordinate, + toward the way through
    h_min, ramp_tan, _ = _slopes(p)
    h, d = max(p["cliff_m"], h_min), max(p["pocket_depth_m"], h_min)
    tan = min(math.tan(math.radians(p["ramp_slope_deg"])), ramp_tan)
    run, run_d = _run(h, tan, p), _run(h + d, tan, p)  # horizontal length of a pass and of a pocket's ramp, m
    vc, w, s, fl, cell = p["cliff_v_frac"] * half, p["pass_width_m"], p["spawn_m"], _flare_m(p), p["cell_m"]
    spawn = np.array([0.0, (vc - half) / 2])
    target = np.array([p["target_u_frac"] * half, (vc + half) / 2])
    cross = target[0] * (vc - spawn[1]) / (target[1] - spawn[1])  # where the straight line meets the cliff
    c0 = max(s / 2, abs(cross), abs(target[0])) + MARGIN_M  # features stay clear of |lat| < c0
    gap = 2 * MARGIN_M + 2 * cell  # between two features' footprints, m
    hw_pass = w / 2 + fl
    pocket = p["dead_end"] == "pocket"
    hw_dead = hw_pass + (2 * cell + 2.0 if pocket else 0.0)  # a pocket keeps pit floor beside its ramp
    reach = (run_d / 2 + p["pocket_m"]) if pocket else max(p["pocket_m"], 8 * cell)  # past the cliff line, m
    _fit(vc - max(run, run_d if pocket else 0.0) / 2 >= -half + MARGIN_M
         and vc + max(run / 2, reach) <= half - MARGIN_M, "fork", f"a pass {run:.0f} m long and the dead ends", p)
    _fit(spawn[1] - s / 2 >= -half + MARGIN_M and spawn[1] + s / 2 <= vc - MARGIN_M, "fork", "the spawn region", p)
    off = max(p["pass_offset_frac"] * half, c0 + hw_pass)
    _fit(off + hw_pass <= half - MARGIN_M, "fork", "the way through beside the spawn region", p)
    n_dead = min(p["n_dead"], p["n_passes"] - 1)
    taken = [(off, hw_pass)]  # further ways through lie on the same side beyond the first (never shorter)
    _lateral(rng, [hw_pass] * (p["n_passes"] - 1 - n_dead), taken, off + hw_pass, half - MARGIN_M, gap, False)
    ways = [t for t, _ in taken]
    dead = [c for _, c in _lateral(rng, [hw_dead] * n_dead, taken, c0, half - MARGIN_M, gap)]
    _fit(n_dead == 0 or len(dead) > 0, "fork", "a dead end beside the ways through", p)
    z = np.where(v < vc, h, 0.0)  # (n, n) m, the plateau behind the cliff, the floor in front
    for c in ways:
        z = _cut_pass(z, v, lat - c, vc - run / 2, run, h, w, p)
    ends = []  # each dead end's entry (spawn side) and far end
    for c in dead:
        if pocket:  # the pit, then a ramp from the plateau (h) to its floor (-d)
            pit = (v >= vc) & (v <= vc + reach) & (np.abs(lat - c) <= hw_dead)
            z = _cut_pass(np.where(pit, -d, z) + d, v, lat - c, vc - run_d / 2, run_d, h + d, w, p) - d
            ends.append([[c, vc - run_d / 2], [c, vc + run_d / 2 + p["pocket_m"] / 2]])
        else:
            z = np.where((v >= vc) & (v <= vc + reach) & (np.abs(lat - c) <= hw_dead), h, z)
            ends.append([[c, vc], [c, vc + reach / 2]])
    passes = [[[c, vc - run / 2], [c, vc + run / 2]] for c in ways]  # high end first
    if p["spawn_on"] == "bottom":
        z = h - z
        passes = [e[::-1] for e in passes]
    uv = _lat_to_u(sg)
    return _task("fork", p, x, z, to_world(uv(spawn)), to_world(uv(target)), to_world(uv(passes)), rng,
                 dead_ends=to_world(uv(ends)).reshape(-1, 2, 2) if ends else ())


def trap(rng: np.random.Generator, **params) -> GeneratedTask:
    """A C- or U-shaped barrier round the spawn region, closed toward the target: a ``wall``
    ``trap_m`` high or a ``trench`` ``trap_m`` deep (one-cell cliffs on both sides), ``thickness_m``
    thick (at least three cells), its inside ``radius_m`` from the spawn centre (at least the spawn
    region's half diagonal plus a margin); ``round`` (a ring) or ``square`` (the sides of a square).
    An opening ``gap_deg`` wide is cut into it at ``opening_deg`` from the direction of travel, on
    the drawn ``side``: the robots must leave through it, away from the target, and go round that
    side. A ``cliff`` barrier is a basin ``trap_m`` deep out to the barrier's outer edge, walled by
    a one-cell cliff except where a ramp (12 deg or the ramp cap, as wide as the opening at the rim)
    climbs out through the opening. The spawn region sits behind the map centre with a corridor 16 m
    + 2 cells wide between the barrier and the map edge, the target near the front edge. ``rng``
    draws only the noise."""
    p = _resolve("trap", params)
    x, half = _grid(p)
    u, v, to_world = _frame(x, half, p["heading"])
    sg = -1.0 if p["side"] == "left" else 1.0
    lat = sg * u  # (n, n) m, + toward the opening's side
    h_min, ramp_tan, _ = _slopes(p)
    hb = max(p["trap_m"], h_min)
    thick = max(p["thickness_m"], 3 * p["cell_m"])
    s = p["spawn_m"]
    r_in = max(p["radius_m"], s / math.sqrt(2) + MARGIN_M + p["cell_m"])
    r_out, corridor = r_in + thick, 16.0 + 2 * p["cell_m"]
    _fit(r_out + corridor <= half, "trap", f"a barrier {r_out:.0f} m round the spawn", p)
    vs, vt = -half + corridor + r_out, half - 3 * MARGIN_M
    _fit(vt - vs >= r_out + 2 * MARGIN_M, "trap", "the target in front of the barrier", p)
    dl, dv = lat, v - vs
    r = np.hypot(dl, dv) if p["shape"] == "round" else np.maximum(np.abs(dl), np.abs(dv))
    off = (np.degrees(np.arctan2(dl, dv)) - p["opening_deg"] + 180.0) % 360.0 - 180.0
    a = math.radians(p["opening_deg"])
    dirn = np.array([math.sin(a), math.cos(a)])  # (lat, v) unit vector toward the opening
    scale = 1.0 if p["shape"] == "round" else 1.0 / max(abs(dirn[0]), abs(dirn[1]))
    spawn = np.array([0.0, vs])
    if p["barrier"] == "cliff":  # a basin inside the barrier's outer edge, a ramp up through the opening
        rim = r_out * scale  # from the spawn centre to the rim along the opening's axis, m
        run = _run(hb, min(math.tan(math.radians(12.0)), ramp_tan), p)
        width = 2.0 * rim * math.sin(math.radians(p["gap_deg"]) / 2)
        ends = [spawn + (rim - run / 2) * dirn, spawn + (rim + run / 2) * dirn]
        _fit(rim - run / 2 >= s / math.sqrt(2) and np.all(np.abs(ends[1]) <= half - MARGIN_M - width / 2), "trap",
             f"a ramp {run:.0f} m long out of the basin", p)
        along, across = dl * dirn[0] + dv * dirn[1], dv * dirn[0] - dl * dirn[1]
        z = _cut_pass(np.where(r <= r_out, 0.0, hb), -along, across, -(rim + run / 2), run, hb, width, p) - hb
        opening = ends
    else:
        band = (r >= r_in) & (r <= r_out) & (np.abs(off) >= p["gap_deg"] / 2)
        z = np.where(band, hb if p["barrier"] == "wall" else -hb, 0.0)
        opening = [spawn + (r_in - MARGIN_M) * scale * dirn, spawn + (r_out + MARGIN_M) * scale * dirn]
    uv = _lat_to_u(sg)
    target = np.array([p["target_u_frac"] * half, vt])
    return _task("trap", p, x, z, to_world(uv(spawn)), to_world(uv(target)), to_world(uv([opening])), rng)


def realdem(rng: np.random.Generator, **params) -> GeneratedTask:
    """A random crop of a bundled real DEM (:mod:`~tin_swarm_env.scenario.realdem` says how): slopes
    kept, the robots' slope limit drawn so that ``steep_frac`` of the map is too steep, spawn and
    target a detour apart on the crop's TIN. ``max_slope_deg`` among ``params`` is ignored (the task's
    ``params["max_slope_deg"]`` is the drawn limit), so :func:`replay` rebuilds the same task. ``rng``
    draws the crops' places and the candidate targets and spawn centres (bounded tries; a
    :class:`NoFitError` says why none fitted)."""
    p = _resolve("realdem", {k: v for k, v in params.items() if k != "max_slope_deg"})
    side_m = p["crop_cells"] * RD.source_cell_m(p["dem"])
    pad = RD.SPLINE_MARGIN * RD.source_cell_m(p["dem"])
    room = RD.source_extent_m(p["dem"]) - side_m
    if np.any(room < 2 * pad):
        raise NoFitError(f"realdem: a crop {p['crop_cells']:g} cells wide does not fit {p['dem']} "
                         f"({side_m / 1000:.1f} km; {RD.SPLINE_MARGIN:g} cells kept off its edges)")
    task, why = _hillside("realdem", p, rng, lambda: RD.crop_heights(
        p["dem"], rng.uniform(pad, room - pad), p["crop_cells"], p["size_m"], p["cell_m"], p["orient"]))
    if task is None:
        raise NoFitError(f"realdem: no crop of {p['dem']} ({p['crop_cells']:g} cells, steep_frac "
                         f"{p['steep_frac']:.2f}) fitted in {RD.CROP_TRIES} tries; the last: {why}")
    return task


def _hillside(family: str, p: dict, rng, heights) -> tuple[GeneratedTask | None, str]:
    """Up to ``RD.CROP_TRIES`` tries of ``heights() -> (x, z)``: mesh each, draw the robots' slope limit
    so that ``p["steep_frac"]`` of it is too steep and place spawn and target a detour apart
    (:mod:`~tin_swarm_env.scenario.realdem`); ``(task, "")``, or ``(None, why the last try failed)``.
    Sets ``p["max_slope_deg"]`` to the drawn limit."""
    why = "none drawn"
    for _ in range(RD.CROP_TRIES):
        x, z = heights()
        dem = Dem(z, x, x, source=f"generated:{family}")
        tin = T.build_tin(dem, **RD.MESH)
        limit = RD.steep_quantile_deg(tin, p["steep_frac"])
        if not RD.SLOPE_LIMITS_DEG[0] <= limit <= RD.SLOPE_LIMITS_DEG[1]:
            why = f"its slope limit {limit:.1f} deg lies outside {list(RD.SLOPE_LIMITS_DEG)}"
            continue
        placed = RD.place(rng, tin, tin.slope_deg <= limit, p["spawn_m"], p["detour_min"], MARGIN_M)
        if placed is None:
            why = f"no spawn and target {p['detour_min']:.2f}x apart by the drivable way"
            continue
        spawn, target, side = placed
        p["max_slope_deg"] = limit
        return GeneratedTask(dem, _square(spawn, p["spawn_m"]), _frozen(np.reshape(target, (1, 2))), family, p,
                             side, _frozen(np.zeros((0, 2, 2))), detour_min=float(p["detour_min"])), ""
    return None, why


def bay(rng: np.random.Generator, **params) -> GeneratedTask:
    """A U-shaped barrier across the way, open toward the spawn: a dead end that robots heading
    straight for the target drive into (the potential field's classic trap). A ``wall`` ``bay_m``
    high or a ``trench`` ``bay_m`` deep (one-cell cliffs both sides), ``thickness_m`` thick (at least
    three cells); its inside is ``2 width_frac`` of the half size wide (at least the spawn region
    and two margins) and reaches from its back, ``back_v_frac`` of the half size along the way, back
    toward the spawn for ``depth_frac`` of the room there. ``side`` "both": the way round is past
    either arm; "left" / "right": the back runs on to the map edge on the other side, so the way
    round is past the arm on ``side``. A corridor ``16 m + 2 cells`` wide is kept between each open
    arm and the map edge. ``rng`` draws only the noise."""
    p = _resolve("bay", params)
    x, half = _grid(p)
    u, v, to_world = _frame(x, half, p["heading"])
    sg = -1.0 if p["side"] == "left" else 1.0
    lat = sg * u  # (n, n) m, + toward the way round (either way for "both")
    h_min, _, _ = _slopes(p)
    hb = max(p["bay_m"], h_min)
    s, cell = p["spawn_m"], p["cell_m"]
    thick, corridor = max(p["thickness_m"], 3 * cell), 16.0 + 2 * cell
    a = max(p["width_frac"] * half, s / 2 + 2 * MARGIN_M)  # the inside's half-width, m
    _fit(a + thick + corridor <= half, "bay", f"a bay {2 * (a + thick):.0f} m wide with a corridor round it", p)
    vs, vt = -half + MARGIN_M + s / 2, half - 3 * MARGIN_M  # the spawn centre and the target along the way
    back = p["back_v_frac"] * half  # the back wall's inner face
    room = back - (vs + s / 2 + MARGIN_M)  # from the spawn region's front to the back wall, m
    _fit(room >= 8 * MARGIN_M and back + thick <= vt - 2 * MARGIN_M, "bay", "the bay between spawn and target", p)
    mouth = back - p["depth_frac"] * room  # the arms' open ends
    _fit(back - mouth >= 2 * MARGIN_M + 2 * cell, "bay", "arms long enough to make a dead end", p)
    tu = p["target_u_frac"] * half
    _fit(abs(tu) * (back - vs) / (vt - vs) + s / 2 <= a, "bay", "the straight way into the bay's mouth", p)
    inside = (np.abs(lat) < a) & (v >= mouth) & (v < back)
    shell = (np.abs(lat) <= a + thick) & (v >= mouth) & (v <= back + thick) & ~inside
    if p["side"] != "both":  # the back runs on to the map edge on the closed side
        shell |= (lat <= -a) & (v >= back) & (v <= back + thick)
    z = np.where(shell, hb if p["barrier"] == "wall" else -hb, 0.0)
    ways = [1.0] if p["side"] != "both" else [1.0, -1.0]
    passes = [[[w * (a + thick + corridor / 2), mouth], [w * (a + thick + corridor / 2), back + thick]] for w in ways]
    uv = _lat_to_u(sg)
    spawn, target = np.array([0.0, vs]), np.array([tu, vt])
    return _task("bay", p, x, z, to_world(uv(spawn)), to_world(uv(target)), to_world(uv(passes)), rng,
                 dead_ends=to_world(uv([[[0.0, mouth], [0.0, back - max(MARGIN_M, 2 * cell)]]])))


def rough(rng: np.random.Generator, **params) -> GeneratedTask:
    """Steep hillside with no cliff, the synthetic kin of ``realdem``: fractal relief (four octaves)
    ``relief_m`` high, ``relief_scale_m`` its longest wavelength, scaled down where needed so that no
    cell slope passes 45 deg (the robots' climb limit); the robots' slope limit drawn so
    that ``steep_frac`` of the map is too steep, spawn and target placed a detour apart on the TIN,
    both as ``realdem`` does (:mod:`~tin_swarm_env.scenario.realdem`). ``max_slope_deg`` among
    ``params`` is ignored (the task's ``params["max_slope_deg"]`` is the drawn limit). ``rng`` draws
    the relief and the places (bounded tries; a :class:`NoFitError` says why none fitted)."""
    p = _resolve("rough", {k: v for k, v in params.items() if k != "max_slope_deg"})
    x, _ = _grid(p)
    task, why = _hillside("rough", p, rng, lambda: (
        x, _capped(_noise(rng, x, p["relief_scale_m"], octaves=4), p["relief_m"], 1.0, p["cell_m"])))  # <= 45 deg
    if task is None:
        raise NoFitError(f"rough: no relief ({p['relief_m']:.0f} m, steep_frac {p['steep_frac']:.2f}) fitted in "
                         f"{RD.CROP_TRIES} tries; the last: {why}")
    return task


FAMILIES: dict[str, Callable[..., GeneratedTask]] = {"canyon": canyon, "mesa": mesa, "hills": hills, "fork": fork,
                                                     "trap": trap, "realdem": realdem, "bay": bay, "rough": rough}
assert tuple(FAMILIES) == tuple(PARAMS) == ALL_FAMILIES + REAL_FAMILIES + EXTRA_FAMILIES


# -- the dispatcher ---------------------------------------------------------------------------


def family_weights(families, where: str = "generated terrain") -> tuple[list[str], np.ndarray]:
    """``(names, probabilities)`` of a family list (uniform) or ``{family: weight}`` mapping; a
    ScenarioError naming ``where`` for an unknown family, no family, or bad weights."""
    if isinstance(families, str):
        families = (families,)
    if isinstance(families, Mapping):
        names, w = list(families), [families[k] for k in families]
    else:
        names, w = list(families), [1.0] * len(families)
    if not names:
        raise ScenarioError(f"{where}: no terrain families given")
    for fam in names:
        _check_family(fam, where)
    w = np.asarray(w, dtype=np.float64)
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ScenarioError(f"{where}: family weights must be finite, >= 0 and not all 0, got {dict(zip(names, w))}")
    return names, w / w.sum()


def generate(rng: np.random.Generator, families: Sequence[str] | Mapping[str, float] = ALL_FAMILIES,
             ranges: Mapping | None = None, *, max_slope_deg: float = MAX_SLOPE_DEG,
             solvable: Callable[[GeneratedTask], bool] | None = None, max_tries: int = 20,
             where: str = "generated terrain") -> GeneratedTask:
    """Draw a task: a family (uniformly, or by the weights of a ``{family: weight}`` mapping), its
    parameters uniformly from ``ranges`` laid over :data:`DEFAULT_RANGES` (see
    :func:`validate_ranges`), then the family's own generator seed; all from ``rng``, so the same
    state gives the same task bit for bit. A draw whose parameters do not fit the family's map
    (:class:`NoFitError`, possible for user ``ranges``) or, with ``solvable``, one for which
    ``solvable(task)`` is false is drawn again from the same stream, at most ``max_tries`` draws
    in all, then a ScenarioError names the last misfit.
    ``where`` (the scenario file) prefixes error messages."""
    names, weights = family_weights(families, where)
    checked = validate_ranges(ranges, names, where)
    if max_tries < 1:
        raise ScenarioError(f"{where}: max_tries must be >= 1, got {max_tries}")
    misfit = ""
    for _ in range(max_tries):
        fam = names[int(rng.choice(len(names), p=weights))]
        params = draw_params(rng, fam, checked[fam])
        seed = int(rng.integers(2 ** 63))
        try:
            task = FAMILIES[fam](np.random.default_rng(seed), max_slope_deg=max_slope_deg, **params)
        except NoFitError as exc:
            misfit = f" (last misfit: {exc})"
            continue
        task = dataclasses.replace(task, seed=seed)
        if solvable is None or solvable(task):
            return task
    raise ScenarioError(f"{where}: no solvable task in {max_tries} draws from families {names}{misfit}")


def replay(task: GeneratedTask) -> GeneratedTask:
    """Rebuild a task made by :func:`generate` from its family, parameters and seed (bit for bit)."""
    if task.seed is None:
        raise ArgumentError("replay needs a task made by generate() (its seed is None)")
    out = FAMILIES[task.family](np.random.default_rng(task.seed), **task.params)
    return dataclasses.replace(out, seed=task.seed)
