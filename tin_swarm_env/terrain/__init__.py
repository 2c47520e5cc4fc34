"""Layer 0: DEM -> TIN and geometry queries. numpy/scipy/numba only; knows no robots.

>>> import tin_swarm_env as tse
>>> dem = tse.terrain.sample_dem("jacksboro")
>>> tin = tse.terrain.build_tin(dem, method="vip", max_vertices=5000)
>>> tin.locate([[1000.0, 1000.0]])            # doctest: +SKIP
"""

from ._kernels import exit_edge
from .breaks import ANGLE, BORDER, STEEP, Breaks, find_breaks
from .build import build_tin
from .cost_to_go import CostToGo, CostToGoStack, cost_to_go, pinch_vertices
from .dem import Dem, PointCloud, geographic_to_metres, metres_per_degree
from .dem_io import SAMPLES, load_dem, sample_dem
from .metrics import ErrorStats, vertical_error
from .tin import Tin
from .tin_io import load_tin, save_tin
from .vip import vip_select, vip_significance

__all__ = [
    "Dem", "PointCloud", "load_dem", "sample_dem", "SAMPLES", "geographic_to_metres", "metres_per_degree",
    "Tin", "build_tin", "vip_significance", "vip_select",
    "save_tin", "load_tin", "Breaks", "find_breaks", "BORDER", "STEEP", "ANGLE",
    "vertical_error", "ErrorStats", "exit_edge", "cost_to_go", "CostToGo", "CostToGoStack", "pinch_vertices",
]
