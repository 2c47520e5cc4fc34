"""Options declared once: each field of an ``Args`` dataclass (a command's, or a training
recipe's configuration) is made by :func:`opt`, with its default, its help text and what it accepts
(a range ``lo``/``hi``, ``choices``, a ``check`` function); ``check_args(self)`` in the
dataclass's ``__post_init__`` refuses a value of the wrong type or out of range with an
:class:`~tin_swarm_env.errors.ArgumentError` naming ``--field-name``, so an ``Args`` built in code
is checked like the command line, before any work starts. The command line is made from the same
fields by :mod:`tin_swarm_env.apps.args`; this module knows nothing of argparse, so the training
library (:mod:`tin_swarm_env.training`) declares its options without importing the CLI.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing

from .errors import ArgumentError

__all__ = ["opt", "option_name", "accepts", "check_args", "base_type"]


def opt(default, help: str, *, lo: float | None = None, hi: float | None = None, lo_open: bool = False,
        hi_open: bool = False, choices: tuple | None = None, check=None, flag: bool = False, short: str | None = None,
        **cli):
    """A dataclass field with its help text and what it accepts, written once.

    ``lo``/``hi`` (``lo_open``/``hi_open``: that end excluded) bound a number; ``choices`` lists
    the accepted values (strings compare case-sensitively); ``check(value)`` returns an error
    message (or None) for anything else a value must satisfy; ``flag`` makes a bool a switch;
    ``short`` is a one-letter alias (``"-o"``); ``cli`` goes to ``argparse.add_argument``
    (``nargs``, ``metavar``, ``required``...)."""
    if not isinstance(help, str) or not help.strip():
        raise TypeError("opt(): every option needs a help text")
    md = {"help": help, "lo": lo, "hi": hi, "lo_open": lo_open, "hi_open": hi_open, "choices": choices,
          "check": check, "flag": flag, "short": short, "cli": cli}
    if isinstance(default, (list, dict, set)):
        return dataclasses.field(default_factory=lambda: type(default)(default), metadata=md)
    return dataclasses.field(default=default, metadata=md)


def option_name(name: str) -> str:
    return "--" + name.replace("_", "-")


def accepts(f: dataclasses.Field) -> str:
    """What a field accepts, in words (``> 0 and <= 1``, ``one of a, b``), from its metadata."""
    md = f.metadata
    parts = []
    if md.get("lo") is not None:
        parts.append(f"{'>' if md['lo_open'] else '>='} {md['lo']:g}")
    if md.get("hi") is not None:
        parts.append(f"{'<' if md['hi_open'] else '<='} {md['hi']:g}")
    if md.get("choices"):
        parts.append("one of " + ", ".join(map(str, md["choices"])))
    return " and ".join(parts)


def base_type(t):
    """``(type, optional)`` of an annotation: ``int | None`` -> ``(int, True)``."""
    origin, args = typing.get_origin(t), typing.get_args(t)
    if origin in (typing.Union, types.UnionType) and type(None) in args:
        inner = [a for a in args if a is not type(None)]
        return inner[0], True
    return t, False


def check_args(obj) -> None:
    """Type, range, choices and ``check`` of every field of ``obj`` (an ``Args`` dataclass made
    with :func:`opt`), normalising numbers (an ``int`` where a float is expected becomes a float).
    Raises :class:`ArgumentError` naming ``--field-name``, the accepted values and the value."""
    hints = typing.get_type_hints(type(obj))
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        t, optional = base_type(hints[f.name])
        md, name = f.metadata, option_name(f.name)
        if v is None and optional:
            continue
        kind = {int: "an integer", float: "a finite number", bool: "true or false", str: "a string"}.get(t)
        ok = True
        if t is bool:
            ok = isinstance(v, bool)
        elif t is int:
            ok = isinstance(v, numbers.Integral) and not isinstance(v, bool)
            v = int(v) if ok else v
        elif t is float:
            ok = isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
            v = float(v) if ok else v
        elif t is str:
            ok = isinstance(v, str)
        if kind is None:  # another type (a list...): only ``check`` applies
            ok = True
        rng = accepts(f)
        if ok and t in (int, float):
            lo, hi = md.get("lo"), md.get("hi")
            ok = (lo is None or (v > lo if md["lo_open"] else v >= lo)) and (
                hi is None or (v < hi if md["hi_open"] else v <= hi))
        if ok and md.get("choices") is not None:
            ok = v in md["choices"]
        if not ok:
            what = f"{kind} {rng}" if t in (int, float) and rng else (rng or kind)
            raise ArgumentError(f"{name} must be {what}, got {v!r}")
        if md.get("check") is not None:
            msg = md["check"](v)
            if msg:
                raise ArgumentError(f"{name} {v!r}: {msg}")
        if v is not getattr(obj, f.name):
            object.__setattr__(obj, f.name, v)
