"""The animated GIF encoder behind :class:`~tin_swarm_env.apps.media.FrameWriter`: one fixed
palette for every frame, the viewer's :data:`~tin_swarm_env.env.viewer.PALETTE`, each frame mapped
to its nearest colour without dithering (:func:`palette_indices`), and frames written one by one
(:class:`GifStream`): after the first, each stores only the rectangle that changed, its unchanged
pixels transparent (index :data:`TRANSPARENT`: they show the frame before).
"""

from __future__ import annotations

import io
import struct

import numpy as np

from ..errors import ArgumentError

__all__ = ["TRANSPARENT", "gif_palette_image", "palette_indices", "GifStream"]

TRANSPARENT = 255  # the GIF palette index of "unchanged since the last frame"


def gif_palette_image():
    """A P-mode Pillow image whose 256-entry palette is the viewer's :data:`PALETTE`, padded
    (index :data:`TRANSPARENT` is never a frame colour)."""
    from PIL import Image

    from ..env.viewer import PALETTE

    pal = np.zeros((256, 3), np.uint8)
    pal[:len(PALETTE)] = PALETTE
    pal[len(PALETTE):] = PALETTE[0]  # unused entries repeat a palette colour (never nearer than it)
    img = Image.new("P", (1, 1))
    img.putpalette(pal.ravel().tobytes())
    return img


def palette_indices(frame) -> np.ndarray:
    """``(H, W)`` uint8: the index of each pixel's nearest :data:`PALETTE` colour (RGB distance;
    exact for the palette's own colours, no dithering)."""
    from ..env.viewer import PALETTE

    f = np.asarray(frame)
    if f.ndim != 3 or f.shape[2] != 3 or f.dtype != np.uint8:
        raise ArgumentError(f"a frame is (H, W, 3) uint8, got {f.shape} {f.dtype}")
    key = (f[..., 0].astype(np.int32) << 16) | (f[..., 1].astype(np.int32) << 8) | f[..., 2]
    colors, inverse = np.unique(key.ravel(), return_inverse=True)
    rgb = np.column_stack([colors >> 16, (colors >> 8) & 255, colors & 255]).astype(np.int32)
    d = ((rgb[:, None, :] - PALETTE[None].astype(np.int32)) ** 2).sum(axis=2)
    return d.argmin(axis=1).astype(np.uint8)[inverse].reshape(f.shape[:2])


def _skip_blocks(b: bytes, i: int) -> int:
    """Index just after the data sub-blocks starting at ``b[i]`` (each a length byte + data, 0 ends)."""
    while b[i]:
        i += b[i] + 1
    return i + 1


def _gif_image_block(idx: np.ndarray, left: int, top: int, palette_img) -> bytes:
    """The image descriptor and LZW data of the ``(h, w)`` palette indices ``idx`` placed at
    ``(left, top)``, encoded by Pillow, with no local colour table (the global one applies)."""
    from PIL import Image

    img = Image.frombytes("P", (idx.shape[1], idx.shape[0]), np.ascontiguousarray(idx, np.uint8).tobytes())
    img.putpalette(palette_img.getpalette())
    buf = io.BytesIO()
    img.save(buf, format="GIF", optimize=False)
    b = buf.getvalue()
    i = 13
    flags = b[10]
    if flags & 0x80:
        i += 3 * 2 ** ((flags & 7) + 1)
    while b[i] == 0x21:  # extensions Pillow may write (graphic control, comment): dropped
        i = _skip_blocks(b, i + 2)
    if b[i] != 0x2C:
        raise RuntimeError("unexpected GIF layout from Pillow")  # pragma: no cover
    desc = bytearray(b[i:i + 10])
    i += 10
    if desc[9] & 0x80:  # a local table: skipped (the indices are the global palette's)
        i += 3 * 2 ** ((desc[9] & 7) + 1)
    desc[1:5] = struct.pack("<HH", left, top)
    desc[9] &= 0x40  # keep "interlaced" (never set by Pillow here), drop the local table
    if b[i] != 8:
        raise RuntimeError("unexpected GIF code size from Pillow")  # pragma: no cover
    end = _skip_blocks(b, i + 1)  # LZW minimum code size, then the data sub-blocks
    return bytes(desc) + b[i:end]


class GifStream:
    """An animated GIF written frame by frame (GIF89a, looping, one global palette; frames after
    the first store the changed rectangle, unchanged pixels transparent)."""

    def __init__(self, fh, fps: float):
        self.fh, self.delay_cs, self.size, self._prev = fh, max(1, round(100 / fps)), None, None
        self._pal = gif_palette_image()

    def add(self, frame):
        idx = palette_indices(frame)
        h, w = idx.shape
        if self.size is None:
            self.size = (w, h)
            self.fh.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0xF7, 0, 0))  # global table, 256 colours
            self.fh.write(bytes(self._pal.getpalette()[:768]))
            self.fh.write(b"!\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")  # loop forever
            block = _gif_image_block(idx, 0, 0, self._pal)
        elif (w, h) != self.size:
            raise ArgumentError(f"GIF frames must all have one size: {self.size}, then {(w, h)}")
        else:
            changed = idx != self._prev
            rows, cols = np.flatnonzero(changed.any(axis=1)), np.flatnonzero(changed.any(axis=0))
            if len(rows) == 0:
                block = _gif_image_block(np.full((1, 1), TRANSPARENT, np.uint8), 0, 0, self._pal)
            else:
                r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
                sub = np.where(changed[r0:r1, c0:c1], idx[r0:r1, c0:c1], TRANSPARENT).astype(np.uint8)
                block = _gif_image_block(sub, int(c0), int(r0), self._pal)
        self._prev = idx
        # graphic control: disposal 1 (keep), transparent index TRANSPARENT, the delay
        self.fh.write(b"!\xf9\x04\x05" + struct.pack("<HB", self.delay_cs, TRANSPARENT) + b"\x00")
        self.fh.write(block)

    def close(self):
        self.fh.write(b";")
