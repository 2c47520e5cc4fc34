"""Atomic writes (_atomic.py): the file keeps its permissions, and an interrupted write leaves the
old file and no temporary file."""

from __future__ import annotations

import os
import stat

import pytest

from tin_swarm_env._atomic import atomic_path


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
