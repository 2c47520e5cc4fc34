"""Atomic file writing: a temporary file in the target's directory, then a rename."""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path"]


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success it is renamed over ``path`` (with the
    permissions a plain ``open`` would give), on any error it is removed and ``path`` is left
    as it was. Raises FileNotFoundError when the directory does not exist."""
    p = Path(os.fspath(path))
    if not p.parent.exists():
        raise FileNotFoundError(f"{p.parent}: directory does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".part" + p.suffix, dir=p.parent)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
