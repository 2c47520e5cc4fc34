"""GIF and MP4 writing (apps/media.py): frames streamed to a hidden part file, decoded back exactly,
and no file left behind by an error or an empty recording."""

from __future__ import annotations

import os

import numpy as np
import pytest

import tin_swarm_env as tse


def test_gif_frames_are_streamed_and_decode_exactly(tmp_path):
    from PIL import Image

    from tin_swarm_env.apps.media import GIF_COLORS, FrameWriter

    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (30, 40, 3), dtype=np.uint8) for _ in range(4)]
    frames[2][:] = 200
    path = tmp_path / "a.gif"
    with FrameWriter(path, fps=20) as w:
        for f in frames:
            w.add(f)
            assert os.listdir(tmp_path)[0].endswith(".part.gif")  # written as they come, hidden
    im = Image.open(path)
    assert im.n_frames == 4 and im.size == (40, 30) and im.info["loop"] == 0
    for i, f in enumerate(frames):
        im.seek(i)
        ref = Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=GIF_COLORS).convert("RGB")
        assert np.array_equal(np.asarray(im.convert("RGB")), np.asarray(ref)), i
        assert im.info["duration"] == 50
    with pytest.raises(RuntimeError):  # an error mid-way leaves the old file and no .part file
        with FrameWriter(path) as w:
            w.add(frames[0])
            raise RuntimeError
    assert os.listdir(tmp_path) == ["a.gif"] and Image.open(path).n_frames == 4
    with pytest.raises(tse.errors.ArgumentError, match="no frames"):
        with FrameWriter(tmp_path / "b.gif"):
            pass
    assert os.listdir(tmp_path) == ["a.gif"]


def test_mp4_frames_are_streamed(tmp_path):
    ffmpeg = pytest.importorskip("imageio_ffmpeg")

    from tin_swarm_env.apps.media import FrameWriter

    frames = [np.full((49, 65, 3), 40 * i, dtype=np.uint8) for i in range(5)]  # odd sizes: cropped to even
    with FrameWriter(tmp_path / "v.mp4") as w:
        for f in frames:
            w.add(f)
    assert os.listdir(tmp_path) == ["v.mp4"]
    reader = ffmpeg.read_frames(str(tmp_path / "v.mp4"))
    assert next(reader)["size"] == (64, 48)
    means = [np.frombuffer(b, np.uint8).mean() for b in reader]
    assert means == pytest.approx([0, 40, 80, 120, 160], abs=3)
