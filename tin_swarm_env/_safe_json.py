"""Reading a JSON file that may be hostile: its size and nesting depth are checked before it is
parsed (a deeply nested file would otherwise end in a ``RecursionError``), ``NaN``/``Infinity``
literals are refused, and every error is one :class:`~tin_swarm_env.errors.TinSwarmError` naming
the file. Used by the training checkpoints (``args.json``, ``state.json``)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from .errors import TinSwarmError

__all__ = ["read_json", "json_depth", "MAX_DEPTH"]

MAX_DEPTH = 32  # nesting levels of arrays/objects a data file of this package may have


def json_depth(text: str) -> int:
    """The deepest nesting of ``[``/``{`` in JSON ``text`` (brackets inside strings not counted),
    found by one scan without parsing."""
    depth = deepest = 0
    in_str = esc = False
    for ch in text:
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def _refuse_constant(name):
    raise ValueError(f"{name} is not a JSON number")


def read_json(path, *, max_bytes: int, max_depth: int = MAX_DEPTH, exc=TinSwarmError):
    """The JSON value in file ``path``, or ``exc`` naming the file: not a regular file, larger than
    ``max_bytes``, nested deeper than ``max_depth``, not UTF-8, not JSON, or holding NaN/Infinity."""
    p = Path(os.fspath(path))
    try:
        if not p.is_file():
            raise exc(f"{p}: {'is a directory' if p.is_dir() else 'is missing' if not p.exists() else 'not a file'}")
        size = p.stat().st_size
        if size > max_bytes:
            raise exc(f"{p}: {size:,} bytes, more than the {max_bytes:,} such a file may have")
        text = p.read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise exc(f"{p}: cannot be read ({getattr(e, 'strerror', None) or e})") from None
    depth = json_depth(text)
    if depth > max_depth:
        raise exc(f"{p}: nested {depth} levels deep; at most {max_depth}")
    try:
        return json.loads(text, parse_constant=_refuse_constant)
    except (ValueError, RecursionError) as e:
        raise exc(f"{p}: not valid JSON ({e})") from None
