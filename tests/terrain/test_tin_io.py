"""The thesis TIN text format and the binary form: round trips, bad files, atomic writes."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tin_swarm_env.errors import TinFormatError
from tin_swarm_env.terrain import load_tin, save_tin


@given(st.integers(0, 10_000), st.integers(3, 40), st.sampled_from([".tin", ".txt", ".npz"]))
def test_round_trip_is_exact(random_tin, tmp_path_factory, seed, n, suffix):
    tin = random_tin(seed, n, zscale=1e3 * (seed % 7 + 1) / 3.0)
    p = tmp_path_factory.mktemp("rt") / f"t{suffix}"
    save_tin(tin, p)
    back = load_tin(p)
    assert back == tin
    np.testing.assert_array_equal(np.sort(back.vertices, axis=0), np.sort(tin.vertices, axis=0))
    assert back.n_triangles == tin.n_triangles
    assert (back.neighbors >= 0).sum() == (tin.neighbors >= 0).sum()


def test_thesis_text_rebuilds_shared_vertices_and_adjacency(tmp_path):
    p = tmp_path / "two.tin"
    p.write_text("0 0 0 10 0 0 10 10 5\n# second\n0 0 0 10 10 5 0 10 5\n")
    tin = load_tin(p)
    assert tin.n_vertices == 4 and tin.n_triangles == 2
    assert (tin.neighbors >= 0).sum() == 2


def test_wrong_count_names_the_line(tmp_path):
    p = tmp_path / "bad.tin"
    p.write_text("0 0 0 10 0 0 10 10 5\n\n0 0 0 10 10 5 0 10\n")
    with pytest.raises(TinFormatError, match=r"bad\.tin:3: expected 9 numbers.*found 8"):
        load_tin(p)
    p.write_text("0 0 0 10 0 0 10 10 five\n")
    with pytest.raises(TinFormatError, match=r"bad\.tin:1: not a number"):
        load_tin(p)
    p.write_text("0 0 0 10 0 0 10 10 nan\n")
    with pytest.raises(TinFormatError, match=r"bad\.tin:1: NaN"):
        load_tin(p)


def test_empty_non_manifold_and_folded_files(tmp_path):
    p = tmp_path / "e.tin"
    p.write_text("\n# nothing\n")
    with pytest.raises(TinFormatError, match="empty"):
        load_tin(p)
    p = tmp_path / "nm.tin"
    p.write_text("0 0 0 1 0 0 0 1 0\n0 0 0 0 1 0 -1 1 0\n0 0 0 1 1 0 0 1 0\n")
    with pytest.raises(TinFormatError, match=r"nm\.tin: non-manifold"):
        load_tin(p)
    p = tmp_path / "two_z.tin"
    p.write_text("0 0 0 1 0 0 0 1 0\n1 0 0 1 1 0 0 1 3\n")
    with pytest.raises(TinFormatError, match="different z"):
        load_tin(p)
    p = tmp_path / "zip.npz"
    p.write_bytes(b"garbage")
    with pytest.raises(TinFormatError, match="not a readable"):
        load_tin(p)
    with pytest.raises(TinFormatError, match="no such"):
        load_tin(tmp_path / "missing.tin")


def test_failed_write_leaves_no_partial_file_and_keeps_the_old_one(random_tin, tmp_path, monkeypatch):
    tin = random_tin(1)
    p = tmp_path / "keep.tin"
    save_tin(tin, p)
    before = p.read_bytes()

    def boom(fh, rows, fmt):
        fh.write(b"1 2 3\n")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savetxt", boom)
    with pytest.raises(OSError, match="disk full"):
        save_tin(random_tin(2), p)
    assert p.read_bytes() == before
    assert [q.name for q in tmp_path.iterdir()] == ["keep.tin"]


def test_save_errors(random_tin, tmp_path):
    tin = random_tin(1)
    with pytest.raises(ValueError, match="unknown TIN suffix"):
        save_tin(tin, tmp_path / "t.obj")
    with pytest.raises(FileNotFoundError):
        save_tin(tin, tmp_path / "nodir" / "t.tin")
