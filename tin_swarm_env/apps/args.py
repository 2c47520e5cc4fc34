"""The one dataclass -> argparse helper behind every script and subcommand with an ``Args``.

Each option is declared once, as a dataclass field made by :func:`~tin_swarm_env.options.opt`: its
default, its help text and what it accepts (a range ``lo``/``hi``, ``choices``, a ``check``
function); :mod:`tin_swarm_env.options` holds that and the check (``check_args``), re-exported here.
From it, ``add_dataclass_args`` adds ``--field-name`` (type from the annotation, ``bool`` fields take
``true/false``, also 1/0, yes/no; ``flag=True`` makes a ``store_true`` switch) whose help is the
text, the accepted range and the default.
"""

from __future__ import annotations

import argparse
import dataclasses
import typing

from ..options import accepts, base_type, check_args, opt, option_name

__all__ = ["opt", "check_args", "add_dataclass_args", "parse_dataclass", "dataclass_from_namespace", "accepts",
           "option_name"]


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
        t, _ = base_type(hints[f.name])
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
            if isinstance(v, list) and base_type(hints[f.name])[0] is str:
                v = ",".join(v)
            kw[f.name] = v
    return cls(**{**kw, **override})


def parse_dataclass(cls, argv=None, description: str | None = None):
    """Parse ``argv`` (default ``sys.argv[1:]``) into an instance of dataclass ``cls``."""
    p = argparse.ArgumentParser(description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_dataclass_args(p, cls)
    return dataclass_from_namespace(cls, p.parse_args(argv))
