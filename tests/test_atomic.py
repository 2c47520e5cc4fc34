"""Atomic writes (_atomic.py): the file keeps its permissions, and an interrupted write leaves the
old file and no temporary file."""

from __future__ import annotations

import os
import stat

import pytest

from tin_swarm_env._atomic import atomic_path, check_suffix, output_stem, stem_file
from tin_swarm_env.errors import ArgumentError


def test_atomic_write_keeps_permissions_and_cleans_up_on_ctrl_c(tmp_path):
    p = tmp_path / "secret.md"
    p.write_text("old")
    os.chmod(p, 0o600)
    with atomic_path(p) as tmp:
        with open(tmp, "w") as fh:
            fh.write("new")
    assert p.read_text() == "new" and stat.S_IMODE(p.stat().st_mode) == 0o600
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(p) as tmp:
            with open(tmp, "w") as fh:
                fh.write("half")
            assert os.path.basename(tmp).startswith(".secret.md.") and ".part" in tmp
            raise KeyboardInterrupt
    assert sorted(os.listdir(tmp_path)) == ["secret.md"] and p.read_text() == "new"


def test_a_failed_write_names_the_target_and_keeps_the_old_file(tmp_path):
    """A write error says no file (ENOSPC, EPIPE): atomic_path names the target, the old bytes stay,
    the hidden .part file goes; an error naming its own file passes through unchanged."""
    import errno

    import pytest

    from tin_swarm_env.errors import OutputError

    target = tmp_path / "out.csv"
    target.write_bytes(b"old")
    with pytest.raises(OutputError) as ei:
        with atomic_path(target) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(b"partial")
                raise OSError(errno.ENOSPC, "No space left on device")
    assert ei.value.filename == str(target) and ei.value.errno == errno.ENOSPC
    assert target.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    with pytest.raises(FileNotFoundError) as ei:
        with atomic_path(target):
            open(tmp_path / "elsewhere" / "x")  # another file's error: its own name
    assert not isinstance(ei.value, OutputError) and "elsewhere" in ei.value.filename
    assert target.read_bytes() == b"old"


def test_an_output_stem_drops_only_a_suffix_it_writes_and_refuses_a_directory(tmp_path):
    assert output_stem(tmp_path / "run.md") == tmp_path / "run"
    assert output_stem(tmp_path / "run.CSV") == tmp_path / "run"
    assert output_stem(tmp_path / "a.b") == tmp_path / "a.b"
    assert stem_file(tmp_path / "a.b", ".md") == tmp_path / "a.b.md"
    with pytest.raises(ArgumentError, match=r"--out .*: is a directory"):
        output_stem(tmp_path)


def test_check_suffix_names_the_option_and_the_suffix():
    check_suffix("--summary", None, (".md",))
    check_suffix("--summary", "x.MD", (".md",))
    with pytest.raises(ArgumentError, match=r"--summary x\.npz: the suffix '\.npz'; this option writes \.md"):
        check_suffix("--summary", "x.npz", (".md",))
    with pytest.raises(ArgumentError, match="no suffix"):
        check_suffix("--summary", "x", (".md", ".txt"))
