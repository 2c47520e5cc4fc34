"""Exceptions raised by tin_swarm_env.

Every error the package raises on bad input is a :class:`TinSwarmError` (and, where the
input's *value* is at fault, also a :class:`ValueError`), with a message that names the
file, line or argument at fault.
"""

from __future__ import annotations

__all__ = [
    "TinSwarmError",
    "DemFormatError",
    "TinFormatError",
    "TinStructureError",
    "MissingExtraError",
    "ScenarioError",
    "PlacementError",
    "ObservationLayoutError",
    "ParameterError",
    "ArgumentError",
    "PolicyFileError",
]


class TinSwarmError(Exception):
    """Base class of every error raised by tin_swarm_env."""


class DemFormatError(TinSwarmError, ValueError):
    """A DEM file or array could not be read or is not usable (names the file and line)."""


class TinFormatError(TinSwarmError, ValueError):
    """A TIN file is malformed (names the file and the line)."""


class TinStructureError(TinSwarmError, ValueError):
    """Vertices/triangles do not form a valid TIN (non-manifold edge, overlap, too few points...)."""


class PolicyFileError(TinSwarmError, ValueError):
    """A policy file (policy.json / weights.npz) is missing, malformed or made for other
    observations (names the file and the key)."""


class MissingExtraError(TinSwarmError, ImportError):
    """An optional dependency is missing; the message names the extra to install."""


class ScenarioError(TinSwarmError, ValueError):
    """A scenario file or setting is wrong (names the file and the key)."""


class PlacementError(TinSwarmError, ValueError):
    """A robot, target or asset position is not finite, lies outside the terrain or on a
    too-steep triangle (names the entity and its index)."""


class ObservationLayoutError(TinSwarmError, ValueError):
    """An observation layout is invalid, or a saved one does not match this version's."""


class ParameterError(TinSwarmError, ValueError):
    """A model parameter (robot, sensor, battery, world, field) is out of its range (names it)."""


class ArgumentError(TinSwarmError, ValueError):
    """A function, method or command-line argument is wrong (names the argument or the agent)."""


def require(module: str, extra: str, purpose: str):
    """Import an optional dependency lazily, or raise :class:`MissingExtraError` naming the extra."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise MissingExtraError(
            f"{purpose} needs the optional package '{module}', which is not installed; "
            f"install it with: pip install 'tin_swarm_env[{extra}]'"
        ) from exc
