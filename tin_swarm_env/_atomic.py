"""Atomic file writing (a temporary file in the target's directory, then a rename) and the
checks every output path gets before a command starts its work.

While a file is being written it exists only as ``.NAME.<random>.part.EXT`` beside ``NAME``;
on success it is renamed over ``NAME``, on any error or Ctrl-C it is removed. A process killed
with SIGKILL (or a power cut) cannot clean up: such a file may then be left behind, hidden, and
is safe to delete.
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .errors import ArgumentError, OutputError

__all__ = ["atomic_path", "check_outputs", "check_suffix", "output_stem", "scenario_inputs", "stem_file"]

STEM_SUFFIXES = (".md", ".csv", ".png")  # what a command given an output stem (OUT) writes as OUT.md, ...


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m


def _naming(exc: OSError, p: Path, tmp) -> OSError:
    """``exc`` as an :class:`OutputError` naming the target ``p`` (an OSError of a write names no
    file, or the hidden temporary one); others pass through."""
    fn = exc.filename
    ours = fn is None or str(fn) == str(tmp) or (os.path.basename(str(fn)).startswith(f".{p.name}.") and
                                                 str(fn).endswith(".part" + p.suffix))
    if not ours or isinstance(exc, OutputError):
        return exc
    what = exc.strerror or str(exc) or type(exc).__name__
    return OutputError(exc.errno or errno.EIO, f"{what}; not written (an old file there is unchanged)", str(p))


@contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; on success it is renamed over ``path``, on any
    error (KeyboardInterrupt included) it is removed and ``path`` is left as it was. The result
    keeps the permission bits of the file it replaces (a new file: those a plain ``open`` would
    give). Raises FileNotFoundError when the directory does not exist; an OSError while writing
    (a full disk, a broken pipe) becomes an :class:`~tin_swarm_env.errors.OutputError` naming
    ``path``."""
    p = Path(os.fspath(path))
    if not p.parent.exists():
        raise FileNotFoundError(f"{p.parent}: directory does not exist")
    try:
        mode = stat.S_IMODE(os.stat(p).st_mode)
    except OSError:
        mode = 0o666 & ~_umask()
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".part" + p.suffix, dir=p.parent)
        os.close(fd)
    except OSError as exc:
        raise _naming(exc, p, None) from exc
    try:
        yield tmp
        os.chmod(tmp, mode)
        os.replace(tmp, p)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError):
            new = _naming(exc, p, tmp)
            if new is not exc:
                raise new from exc
        raise


def _identity(p: Path):
    """``(st_dev, st_ino)`` of an existing path (None: it does not exist or cannot be read)."""
    try:
        st = os.stat(p)
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


def _chain(p: Path) -> list[tuple[Path, object]]:
    """``p`` and each directory above it, with its resolved path and file identity."""
    out = []
    for q in (p, *p.parents):
        out.append((q.resolve(), _identity(q)))
    return out


def _is_or_inside(out: Path, src: Path) -> bool:
    """``out`` is the input ``src`` or lies inside it (``src`` a directory), by resolved path or by
    file identity (the same file or directory through a link, a bind mount or ``..``)."""
    rs, ids = src.resolve(), _identity(src)
    for q, qid in _chain(out):
        if q == rs or (ids is not None and qid == ids):
            return True
    return False


def scenario_inputs(scenario) -> list[Path]:
    """The files a scenario (a built-in name or a TOML path) reads: its TOML file and the DEM or TIN
    file its ``[terrain] path`` names. Empty for one that does not load (its own error comes when
    the command loads it)."""
    from .scenario.config import load_scenario

    try:
        cfg = load_scenario(scenario)
    except Exception:  # noqa: BLE001 (a bad scenario is refused by the command, with its file and key)
        p = Path(os.fspath(scenario))
        return [p] if p.exists() else []
    out = [Path(cfg.source)] if cfg.source and Path(cfg.source).exists() else []
    t = cfg.terrain
    if t.source in ("dem", "tin") and t.path:
        out.append(Path(cfg.base_dir) / t.path)
    return out


def check_outputs(outputs: dict, inputs=(), *, scenarios=(), dirs: dict | None = None) -> None:
    """The one check of a command's output paths against everything it reads, before any work.

    ``outputs`` maps an option name (``"--gif"``) to a file path (None: not asked for); ``dirs``
    the same for output directories a command fills or replaces (``train``'s ``policy/``). Each
    output file must lie in an existing, writable directory and not be a directory itself; no two
    outputs may share a path. No output may be an input or lie inside an input directory: the
    ``inputs`` (files and directories the command reads: a DEM, a ``--policy`` directory, a model)
    and the files of ``scenarios`` (:func:`scenario_inputs`: each TOML file and the terrain file it
    names), compared by resolved path and by file identity (``st_dev``/``st_ino``: the same file
    through a link or a bind mount); nor may an input lie inside an output directory. Raises
    :class:`ArgumentError` naming the option and the input."""
    srcs = [Path(os.fspath(s)) for s in inputs if s is not None and str(s) != ""]
    for sc in scenarios:
        srcs += scenario_inputs(sc)
    srcs = [s for s in srcs if s.exists()]
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
        for src in srcs:
            if _is_or_inside(p, src):
                what = "is the input" if not src.is_dir() or p.resolve() == src.resolve() else "lies inside the input"
                raise ArgumentError(f"{opt} {p}: {what} {src}; write the output elsewhere")
        key = os.path.normcase(str(p.resolve()))
        if key in seen:
            raise ArgumentError(f"{opt} and {seen[key]} are the same file {p}; give each output its own path")
        seen[key] = opt
    for opt, path in (dirs or {}).items():
        if path is None:
            continue
        p = Path(os.fspath(path))
        for src in srcs:
            if _is_or_inside(p, src) or _is_or_inside(src, p):
                raise ArgumentError(f"{opt} {p}: would write over the input {src}; write the output elsewhere")


def output_stem(out, option: str = "--out") -> Path:
    """The stem ``OUT`` of a command that writes ``OUT.md``, ``OUT.csv``, ...: ``out`` less one of
    :data:`STEM_SUFFIXES` (``run.md`` -> ``run``); any other dot stays in the name (``a.b`` ->
    ``a.b.md``, not ``a.md``). An existing directory is refused, naming ``option``."""
    p = Path(os.fspath(out))
    if p.is_dir():
        raise ArgumentError(f"{option} {p}: is a directory; give a file stem: OUT.md, OUT.csv, ... are written "
                            f"(e.g. {p / 'eval'})")
    return p.with_suffix("") if p.suffix.lower() in STEM_SUFFIXES else p


def stem_file(stem: Path, ext: str) -> Path:
    """``stem`` + ``ext`` (``ext`` appended, never replacing a dot in the stem's name)."""
    return stem.with_name(stem.name + ext)


def check_suffix(option: str, path, suffixes: tuple) -> None:
    """Refuse an output ``path`` (None: not asked for) whose suffix is not one of ``suffixes``,
    naming ``option``: a typo must not write a table over a file of another kind."""
    if path is None:
        return
    suffix = Path(os.fspath(path)).suffix.lower()
    if suffix not in suffixes:
        what = f"the suffix {suffix!r}" if suffix else "no suffix"
        raise ArgumentError(f"{option} {path}: {what}; this option writes {' or '.join(suffixes)}")
