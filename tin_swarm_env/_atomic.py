"""Atomic file writing (a temporary file in the target's directory, then a rename) and the
checks every output path gets before a command starts its work.

While a file is being written it exists only as ``.NAME.<random>.part.EXT`` beside ``NAME``;
on success it is renamed over ``NAME``, on any error or Ctrl-C it is removed. A process killed
with SIGKILL (or a power cut) cannot clean up: such a file may then be left behind, hidden, and
is safe to delete.
"""

from __future__ import annotations

import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import ArgumentError

__all__ = ["atomic_path", "check_outputs"]


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success it is renamed over ``path``, on any
    error (KeyboardInterrupt included) it is removed and ``path`` is left as it was. The result
    keeps the permission bits of the file it replaces (a new file: those a plain ``open`` would
    give). Raises FileNotFoundError when the directory does not exist."""
    p = Path(os.fspath(path))
    if not p.parent.exists():
        raise FileNotFoundError(f"{p.parent}: directory does not exist")
    try:
        mode = stat.S_IMODE(os.stat(p).st_mode)
    except OSError:
        mode = 0o666 & ~_umask()
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".part" + p.suffix, dir=p.parent)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, mode)
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def _same(a: Path, b: Path) -> bool:
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_outputs(outputs: dict, inputs=()) -> None:
    """Check output paths before any work starts: ``outputs`` maps an option name (``"--gif"``)
    to a path (None: not asked for). Each must lie in an existing, writable directory, must not
    be a directory itself, must not be one of ``inputs`` (files the command reads) and no two
    outputs may share a path. Raises :class:`ArgumentError` naming the option."""
    seen: dict[str, str] = {}
    for opt, path in outputs.items():
        if path is None:
            continue
        p = Path(os.fspath(path))
        if str(p) == "" or p.name in ("", ".", ".."):
            raise ArgumentError(f"{opt}: {str(path)!r} is not a file name")
        if p.is_dir():
            raise ArgumentError(f"{opt} {p}: is a directory; give a file name")
        d = p.parent
        if not d.is_dir():
            raise ArgumentError(f"{opt} {p}: directory {d} does not exist")
        if not os.access(d, os.W_OK | os.X_OK):
            raise ArgumentError(f"{opt} {p}: directory {d} is not writable")
        for src in inputs:  # inputs that exist: the same file (also through a link) or the same path
            s = Path(os.fspath(src)) if src is not None else None
            if s is not None and s.exists() and (_same(p, s) or p.resolve() == s.resolve()):
                raise ArgumentError(f"{opt} {p}: is the input {src}; write the output elsewhere")
        key = os.path.normcase(str(p.resolve()))
        if key in seen:
            raise ArgumentError(f"{opt} and {seen[key]} are the same file {p}; give each output its own path")
        seen[key] = opt
