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
    "CheckpointError",
    "OutputError",
    "check_range",
    "check_fields",
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


class CheckpointError(TinSwarmError, ValueError):
    """A training run's ``args.json`` or checkpoint file cannot be read, breaks its schema or does
    not match the run it would resume (names the file, the key, what was found and expected)."""


class OutputError(TinSwarmError, OSError):
    """An output file could not be written (full disk, encoder error, broken pipe...); names the
    file. The old file at that path, if any, is left as it was and no partial file is left."""


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


def check_range(where: str, key: str, value, lo: float = -float("inf"), hi: float = float("inf"), *,
                lo_open: bool = False, hi_open: bool = False, integer: bool = False, exc=None):
    """Return ``value`` if it is a finite number (an ``int`` when ``integer``) in the range
    ``lo .. hi`` (``lo_open``/``hi_open``: that end excluded); else raise ``exc`` (default
    :class:`ParameterError`) saying ``"{where}.{key} must be ... got value"``. The one range check
    behind every parameter and scenario number (NaN, inf, bool and strings are refused)."""
    import math
    import numbers

    exc = exc or ParameterError
    kind = "an integer" if integer else "a finite number"
    ok = isinstance(value, numbers.Integral if integer else numbers.Real) and not isinstance(value, bool)
    ok = ok and math.isfinite(value) and (value > lo if lo_open else value >= lo) and (
        value < hi if hi_open else value <= hi)
    if not ok:
        lo_s = "" if lo == -float("inf") else f"{'>' if lo_open else '>='} {lo:g}"
        hi_s = "" if hi == float("inf") else f"{'<' if hi_open else '<='} {hi:g}"
        bounds = " and ".join(s for s in (lo_s, hi_s) if s)
        raise exc(f"{where}.{key} must be {kind}{' ' + bounds if bounds else ''}, got {value!r}")
    return value


def check_fields(obj, limits: dict) -> None:
    """:func:`check_range` on each named field of dataclass ``obj``: ``limits`` maps a field name
    to the keyword arguments of :func:`check_range` (``{"lo": 0, "lo_open": True}``...)."""
    for key, kw in limits.items():
        check_range(type(obj).__name__, key, getattr(obj, key), **kw)
