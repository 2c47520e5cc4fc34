"""tin_swarm_env: robot swarms on real terrain represented as a Triangulated Irregular Network.

Layers (imports flow downwards only): ``terrain`` (DEM -> TIN, geometry queries; numpy/scipy/numba)
is the foundation. See ``../shared/DESIGN.md`` for the full layout.
"""

from . import terrain
from .errors import (
    DemFormatError,
    MissingExtraError,
    TinFormatError,
    TinStructureError,
    TinSwarmError,
)

__version__ = "0.1.0"

__all__ = [
    "terrain",
    "TinSwarmError",
    "DemFormatError",
    "TinFormatError",
    "TinStructureError",
    "MissingExtraError",
    "__version__",
]
