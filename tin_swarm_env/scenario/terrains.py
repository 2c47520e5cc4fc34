"""Procedural terrains for the thesis's scenarios (DEM grids in metres).

Each recipe takes keyword parameters (the scenario's ``[terrain] params``) and returns a
:class:`~tin_swarm_env.terrain.Dem`; unknown parameters are an error naming the recipe.
"""

from __future__ import annotations

import inspect

import numpy as np

from ..errors import ArgumentError
from ..terrain import Dem

__all__ = ["RECIPES", "make_dem"]


def _grid(width, height, cell):
    x = np.arange(0.0, width + 1e-9, cell)
    y = np.arange(0.0, height + 1e-9, cell)
    return x, y, *np.meshgrid(x, y)


def ramp(width=300.0, height=240.0, cell=2.5, ramp_start_x=60.0, ramp_end_x=160.0, cliff_x=220.0,
         band_y0=80.0, band_y1=160.0, side_m=45.0, plateau_m=15.0) -> Dem:
    """Thesis figure 4.2: a ramp rising east to a plateau that ends in a cliff at ``cliff_x``.
    Ramp and plateau form a band between ``band_y0`` and ``band_y1`` whose sides slope gently
    down to the level ground over ``side_m``; the low ground east of the cliff is reachable
    around the band's ends, where the cliff runs out."""
    x, y, X, Y = _grid(width, height, cell)
    z = np.clip((X - ramp_start_x) / (ramp_end_x - ramp_start_x), 0, 1) * plateau_m
    outside = np.maximum(band_y0 - Y, Y - band_y1).clip(min=0)
    z = z * np.clip(1 - outside / side_m, 0, 1)
    z[X > cliff_x] = 0.0
    return Dem(z, x, y, source="procedural:ramp")


def cliff_goal(width=400.0, height=300.0, cell=2.5, plateau_m=20.0, cliff_x=150.0, pass_y=220.0,
               pass_len_m=100.0, hill_xy=(260.0, 120.0), hill_m=25.0, hill_sd_m=18.0) -> Dem:
    """Thesis figure 1.1: robots start on a plateau (x < ``cliff_x``) whose east edge is a cliff
    south of ``pass_y``; north of it the plateau descends gently (over ``pass_len_m``) to the low
    ground where the goal lies, hidden behind a steep hill."""
    x, y, X, Y = _grid(width, height, cell)
    z = np.where(X <= cliff_x, plateau_m, 0.0)
    north = Y >= pass_y
    z[north] = plateau_m * np.clip(1 - (X[north] - cliff_x) / pass_len_m, 0, 1)
    hx, hy = hill_xy
    z += hill_m * np.exp(-((X - hx) ** 2 + (Y - hy) ** 2) / (2 * hill_sd_m ** 2))
    return Dem(z, x, y, source="procedural:cliff_goal")


def hills(width=400.0, height=400.0, cell=4.0, n_hills=9, height_m=30.0, sd_m=30.0, seed=3) -> Dem:
    """Thesis figure 4.3: several hills and valleys (Gaussian bumps and dips from ``seed``) that
    block line of sight; the steepest flanks are not traversable."""
    x, y, X, Y = _grid(width, height, cell)
    rng = np.random.default_rng(seed)
    z = np.zeros_like(X)
    for _ in range(n_hills):
        cx, cy = rng.uniform(0.15, 0.85) * width, rng.uniform(0.15, 0.85) * height
        amp = height_m * rng.choice([-0.5, 1.0]) * rng.uniform(0.5, 1.0)
        sd = sd_m * rng.uniform(0.6, 1.2)
        z += amp * np.exp(-((X - cx) ** 2 + (Y - cy) ** 2) / (2 * sd ** 2))
    return Dem(z, x, y, source="procedural:hills")


def rolling(width=300.0, height=300.0, cell=5.0, amplitude_m=4.0, wavelength_m=120.0) -> Dem:
    """Gentle rolling ground (sine waves), all of it traversable."""
    x, y, X, Y = _grid(width, height, cell)
    k = 2 * np.pi / wavelength_m
    z = amplitude_m * (np.sin(k * X) * np.cos(0.7 * k * Y) + 0.5 * np.sin(0.5 * k * (X + Y)))
    return Dem(z, x, y, source="procedural:rolling")


def ridge(width=200.0, height=100.0, cell=2.0, ridge_m=10.0, half_width_m=20.0) -> Dem:
    """A straight north-south ridge of triangular profile across the middle of level ground."""
    x, y, X, Y = _grid(width, height, cell)
    z = ridge_m * np.clip(1 - np.abs(X - width / 2) / half_width_m, 0, 1)
    return Dem(z, x, y, source="procedural:ridge")


def canyon(width=400.0, height=400.0, cell=2.0, plateau_m=50.0, cliff_x=200.0, pass_y=(330.0, 350.0),
           ramp_in_m=110.0, ramp_out_m=0.0, travel="east") -> Dem:
    """A plateau (``plateau_m`` high, west of ``cliff_x``) ending in a near-vertical north-south
    cliff across the whole terrain; the low floor lies east of it. The one way down is a pass
    across the band ``pass_y`` (y0, y1): a straight ramp from the plateau ``ramp_in_m`` west of the
    cliff down to the floor ``ramp_out_m`` east of it. With ``ramp_out_m = 0`` it is a cut in the
    plateau; otherwise a trench cut into the plateau that leads onto a causeway standing above the
    floor, cliffs on both sides. ``travel = "west"`` mirrors the terrain east-west."""
    if travel not in ("east", "west"):
        raise ArgumentError(f"canyon: travel must be 'east' or 'west', got {travel!r}")
    x, y, X, Y = _grid(width, height, cell)
    if travel == "west":
        X = width - X
    x0, x1 = cliff_x - ramp_in_m, cliff_x + ramp_out_m
    z = np.where(X <= cliff_x, plateau_m, 0.0)
    band = (Y >= pass_y[0]) & (Y <= pass_y[1]) & (X >= x0) & (X <= x1)
    z[band] = plateau_m * np.clip((x1 - X[band]) / (x1 - x0), 0, 1)
    return Dem(z, x, y, source="procedural:canyon")


RECIPES = {"ramp": ramp, "cliff_goal": cliff_goal, "hills": hills, "rolling": rolling, "ridge": ridge,
           "canyon": canyon}


# recipe parameters that must be > 0 (sizes, cell, widths, spreads), and the largest grid a recipe builds
_POSITIVE = {"width", "height", "cell", "hill_sd_m", "sd_m", "wavelength_m", "half_width_m", "pass_len_m", "side_m"}
MAX_CELLS = 25_000_000


def _check_param(where: str, recipe: str, key: str, value, default):
    """``value`` of recipe parameter ``key`` has the type of its ``default`` (a number, an integer,
    a string, a list of as many numbers) and is finite; sizes and spreads are > 0."""
    from ..errors import ScenarioError, check_range

    name = f"{where} params" if where else f"recipe {recipe!r}"
    if isinstance(default, tuple):
        if not isinstance(value, (list, tuple)) or len(value) != len(default):
            raise ScenarioError(f"{name}.{key} must be a list of {len(default)} numbers, got {value!r}")
        return tuple(float(check_range(name, f"{key}[{i}]", v, exc=ScenarioError)) for i, v in enumerate(value))
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ScenarioError(f"{name}.{key} must be a string, got {value!r}")
        return value
    lo = {"lo": 0, "lo_open": True} if key in _POSITIVE else ({"lo": 0} if isinstance(default, int) else {})
    return check_range(name, key, value, integer=isinstance(default, int), exc=ScenarioError, **lo)


def make_dem(recipe: str, params: dict, where: str = "") -> Dem:
    """Run a recipe with parameters; errors name the recipe and the parameter: an unknown one,
    one of the wrong type (each has its default's type), a non-finite number, a size, cell or
    spread <= 0, or a grid of more than :data:`MAX_CELLS` cells."""
    from ..errors import ScenarioError

    if recipe not in RECIPES:
        raise ScenarioError(f"{where}: unknown terrain recipe {recipe!r}; known: {', '.join(sorted(RECIPES))}")
    fn = RECIPES[recipe]
    sig = inspect.signature(fn)
    kw = {}
    for k, v in params.items():
        if k not in sig.parameters:
            raise ScenarioError(f"{where}: recipe {recipe!r} has no parameter '{k}' "
                                f"(known: {', '.join(sig.parameters)})")
        kw[k] = _check_param(where, recipe, k, v, sig.parameters[k].default)
    full = {k: p.default for k, p in sig.parameters.items()} | kw
    cells = (full["width"] / full["cell"] + 1) * (full["height"] / full["cell"] + 1)
    if cells > MAX_CELLS:
        raise ScenarioError(f"{where}: recipe {recipe!r} would build {cells:.3g} grid cells (width/cell x "
                            f"height/cell); at most {MAX_CELLS:,}: raise 'cell' or shrink the terrain")
    if recipe == "ramp" and not full["ramp_end_x"] > full["ramp_start_x"]:
        raise ScenarioError(f"{where}: recipe 'ramp' needs ramp_end_x > ramp_start_x")
    if recipe == "canyon" and not full["ramp_in_m"] + full["ramp_out_m"] > 0:
        raise ScenarioError(f"{where}: recipe 'canyon' needs ramp_in_m + ramp_out_m > 0")
    try:
        return fn(**kw)
    except ValueError as exc:  # a recipe's own check (canyon's travel): name the file and recipe
        raise ScenarioError(f"{where}: recipe {recipe!r}: {exc}") from None
