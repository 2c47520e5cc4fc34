"""The one dataclass -> argparse helper behind every script and subcommand with an ``Args``.

Each option is declared once, as a dataclass field made by :func:`opt`: its default, its help
text and what it accepts (a range ``lo``/``hi``, ``choices``, a ``check`` function). From that:

* ``add_dataclass_args`` adds ``--field-name`` (type from the annotation, ``bool`` fields take
  ``true/false``, also 1/0, yes/no; ``flag=True`` makes a ``store_true`` switch) whose help is the
  text, the accepted range and the default;
* ``check_args(self)`` in the dataclass's ``__post_init__`` refuses a value of the wrong type or
  out of range with an :class:`~tin_swarm_env.errors.ArgumentError` naming ``--field-name``, so an
  ``Args`` built in code is checked like the command line, before any work starts.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import numbers
import types
import typing

from ..errors import ArgumentError

__all__ = ["opt", "check_args", "add_dataclass_args", "parse_dataclass", "dataclass_from_namespace", "accepts"]


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


def _base_type(t):
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
        t, optional = _base_type(hints[f.name])
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


def _bool(s: str) -> bool:
    v = str(s).strip().lower()
    if v in ("1", "true", "yes", "on"):
        return True
    if v in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {s!r}")


def _converter(t):
    """The argparse ``type`` for annotation ``t``: a parse with a one-line message (the range is
    checked by :func:`check_args`)."""
    if t is bool:
        return _bool

    def conv(s: str):
        try:
            return t(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {'an integer' if t is int else 'a number'}, got {s!r}") from None
    conv.__name__ = t.__name__
    return conv if t in (int, float) else t


def add_dataclass_args(parser: argparse.ArgumentParser, cls, skip=(), positional=(), rename: dict | None = None,
                       cli: dict | None = None) -> None:
    """Add one option per field of dataclass ``cls`` (except the names in ``skip``): ``--field-name``,
    or a positional argument for the names in ``positional``, ``rename`` maps a field to another
    option name, ``cli`` maps a field to more ``add_argument`` keywords for this parser alone
    (``{"models": {"action": "append"}}``: the caller joins the list). The help is the field's
    text, what it accepts and its default."""
    hints = typing.get_type_hints(cls)
    rename = rename or {}
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        t, _ = _base_type(hints[f.name])
        md = f.metadata
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        rng = accepts(f)
        text = md.get("help", t.__name__) + (f" [{rng}]" if rng and not md.get("choices") else "")
        if md.get("choices") and t is str:
            text += f" [{' | '.join(map(str, md['choices']))}]"
        extra = {**md.get("cli", {}), **(cli or {}).get(f.name, {})}
        if f.name in positional:
            parser.add_argument(f.name, help=text, **({"type": _converter(t)} if t in (int, float) else {}), **extra)
            continue
        names = ([md["short"]] if md.get("short") else []) + [option_name(rename.get(f.name, f.name))]
        if md.get("flag"):
            parser.add_argument(*names, dest=f.name, action="store_true", help=text, **extra)
            continue
        kw = {"type": _converter(t)} if t in (int, float, bool, str) and "action" not in extra else {}
        if t is bool and "action" not in extra:
            kw["metavar"] = "{true,false}"
        elif option_name(rename.get(f.name, f.name)) != option_name(f.name) and "metavar" not in extra:
            kw["metavar"] = option_name(rename[f.name])[2:].replace("-", "_").upper()
        if extra.get("action") == "append":  # repeated options collect into a list (the caller joins it)
            default = []
        parser.add_argument(*names, dest=f.name, default=default, help=text, **kw, **extra)


def dataclass_from_namespace(cls, ns: argparse.Namespace, **override):
    """An instance of ``cls`` from the parsed fields in ``ns`` (and ``override``). A ``str`` field
    given as several words (``nargs="+"``) or as a repeated option (``action="append"``) holds them
    joined with commas: ``eval a b --model x --model y`` -> ``scenarios="a,b"``, ``models="x,y"``."""
    hints = typing.get_type_hints(cls)
    kw = {}
    for f in dataclasses.fields(cls):
        if hasattr(ns, f.name):
            v = getattr(ns, f.name)
            if isinstance(v, list) and _base_type(hints[f.name])[0] is str:
                v = ",".join(v)
            kw[f.name] = v
    return cls(**{**kw, **override})


def parse_dataclass(cls, argv=None, description: str | None = None):
    """Parse ``argv`` (default ``sys.argv[1:]``) into an instance of dataclass ``cls``."""
    p = argparse.ArgumentParser(description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_dataclass_args(p, cls)
    return dataclass_from_namespace(cls, p.parse_args(argv))
