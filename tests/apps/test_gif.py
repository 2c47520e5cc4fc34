"""The GIF encoder (apps/gif.py): each pixel mapped to its nearest palette colour (checked by brute
force), frames written one by one decode back exactly, a frame that changed nothing is one
transparent pixel, only the changed rectangle is stored, and a frame of another size is refused."""

from __future__ import annotations

import io

import numpy as np
import pytest

from tin_swarm_env.apps.gif import TRANSPARENT, GifStream, gif_palette_image, palette_indices
from tin_swarm_env.env.viewer import PALETTE
from tin_swarm_env.errors import ArgumentError


def test_palette_indices_are_the_nearest_colours_and_the_palette_is_the_viewers():
    f = np.random.default_rng(0).integers(0, 256, (12, 9, 3), dtype=np.uint8)
    d = ((f[..., None, :].astype(int) - PALETTE.astype(int)) ** 2).sum(-1)
    np.testing.assert_array_equal(palette_indices(f), d.argmin(-1))
    np.testing.assert_array_equal(palette_indices(PALETTE[None, :, :]), np.arange(len(PALETTE))[None])
    pal = np.frombuffer(bytes(gif_palette_image().getpalette()[:768]), np.uint8).reshape(256, 3)
    np.testing.assert_array_equal(pal[:len(PALETTE)], PALETTE)
    assert TRANSPARENT >= len(PALETTE)  # never a frame colour
    with pytest.raises(ArgumentError, match=r"\(H, W, 3\) uint8"):
        palette_indices(np.zeros((4, 4), np.uint8))


def test_frames_decode_exactly_and_only_what_changed_is_stored():
    from PIL import Image

    a = np.full((20, 30, 3), PALETTE[1], np.uint8)
    b = a.copy()
    b[4:7, 10:15] = PALETTE[2]
    sizes = []
    buf = io.BytesIO()
    g = GifStream(buf, fps=10)
    for f in (a, a, b):
        before = buf.tell()
        g.add(f)
        sizes.append(buf.tell() - before)
    g.close()
    assert sizes[1] < sizes[2] < sizes[0]  # nothing changed: one transparent pixel; then a 3 x 5 rectangle
    im = Image.open(io.BytesIO(buf.getvalue()))
    assert im.n_frames == 3 and im.size == (30, 20) and im.info["loop"] == 0
    for i, f in enumerate((a, a, b)):
        im.seek(i)
        np.testing.assert_array_equal(np.asarray(im.convert("RGB")), f)
        assert im.info["duration"] == 100
    with pytest.raises(ArgumentError, match="one size"):
        g.add(np.zeros((5, 5, 3), np.uint8))
