"""The one dataclass -> argparse helper behind every script and subcommand with an ``Args``.

Each field of a dataclass becomes ``--field-name`` with the field's type and default; ``bool``
fields take ``true/false`` (also 1/0, yes/no). The help text is the comment-free field type and
default, or a ``help`` entry in the field's metadata.
"""

from __future__ import annotations

import argparse
import dataclasses
import typing

__all__ = ["add_dataclass_args", "parse_dataclass", "dataclass_from_namespace"]


def _bool(s: str) -> bool:
    v = str(s).strip().lower()
    if v in ("1", "true", "yes", "on"):
        return True
    if v in ("0", "false", "no", "off"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got {s!r}")


def add_dataclass_args(parser: argparse.ArgumentParser, cls, skip=()) -> None:
    """Add one ``--option`` per field of dataclass ``cls`` (except the names in ``skip``)."""
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if f.name in skip:
            continue
        t = hints[f.name]
        conv = _bool if t is bool else t
        default = f.default if f.default is not dataclasses.MISSING else f.default_factory()
        parser.add_argument("--" + f.name.replace("_", "-"), dest=f.name, type=conv, default=default,
                            help=f.metadata.get("help", t.__name__))


def dataclass_from_namespace(cls, ns: argparse.Namespace, **override):
    """An instance of ``cls`` from the parsed fields in ``ns`` (and ``override``)."""
    kw = {f.name: getattr(ns, f.name) for f in dataclasses.fields(cls) if hasattr(ns, f.name)}
    return cls(**{**kw, **override})


def parse_dataclass(cls, argv=None, description: str | None = None):
    """Parse ``argv`` (default ``sys.argv[1:]``) into an instance of dataclass ``cls``."""
    p = argparse.ArgumentParser(description=description, formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_dataclass_args(p, cls)
    return dataclass_from_namespace(cls, p.parse_args(argv))
