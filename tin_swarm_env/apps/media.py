"""Writing rendered frames as they come: an animated GIF (or the last frame as PNG) and an H.264
MP4. Memory stays at one frame whatever the episode's length: :class:`FrameWriter` encodes each
frame on arrival into a hidden ``.part`` file beside the output (renamed into place on success,
removed on any error or Ctrl-C; see :mod:`tin_swarm_env._atomic`).
"""

from __future__ import annotations

import io
import struct
from contextlib import ExitStack

import numpy as np

from .._atomic import atomic_path
from ..errors import ArgumentError, require

__all__ = ["FrameWriter", "save_gif", "save_mp4", "GIF_COLORS"]

GIF_COLORS = 128  # adaptive palette size per GIF frame


def _skip_blocks(b: bytes, i: int) -> int:
    """Index just after the data sub-blocks starting at ``b[i]`` (each a length byte + data, 0 ends)."""
    while b[i]:
        i += b[i] + 1
    return i + 1


def _gif_frame_parts(img) -> tuple[int, int, bytes, bytes]:
    """Encode one P-mode image with Pillow as a one-frame GIF and return ``(width, height,
    color table bytes, image descriptor + data)`` with the table moved into the descriptor
    (a local color table), so frames with their own palettes can be concatenated."""
    buf = io.BytesIO()
    img.save(buf, format="GIF")
    b = buf.getvalue()
    w, h, flags = struct.unpack("<HHB", b[6:11])
    i = 13
    table = b""
    if flags & 0x80:
        n = 3 * 2 ** ((flags & 7) + 1)
        table, i = b[i:i + n], i + n
    while b[i] == 0x21:  # extensions Pillow may write (graphic control, comment): dropped
        i = _skip_blocks(b, i + 2)
    if b[i] != 0x2C:
        raise RuntimeError("unexpected GIF layout from Pillow")  # pragma: no cover
    desc = bytearray(b[i:i + 10])
    i += 10
    if desc[9] & 0x80:  # the frame already has a local table
        n = 3 * 2 ** ((desc[9] & 7) + 1)
        table, i = b[i:i + n], i + n
    else:
        desc[9] = (desc[9] & 0x40) | 0x80 | (flags & 7)
    end = _skip_blocks(b, i + 1)  # LZW minimum code size, then the data sub-blocks
    return w, h, table, bytes(desc) + table + b[i:end]


class _GifStream:
    """An animated GIF written frame by frame (GIF89a, looping, a local palette per frame)."""

    def __init__(self, fh, fps: float):
        self.fh, self.delay_cs, self.size = fh, max(1, round(100 / fps)), None

    def add(self, frame):
        from PIL import Image

        img = Image.fromarray(frame).convert("P", palette=Image.Palette.ADAPTIVE, colors=GIF_COLORS)
        w, h, _, body = _gif_frame_parts(img)
        if self.size is None:
            self.size = (w, h)
            self.fh.write(b"GIF89a" + struct.pack("<HHBBB", w, h, 0, 0, 0))
            self.fh.write(b"!\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00")  # loop forever
        elif (w, h) != self.size:
            raise ArgumentError(f"GIF frames must all have one size: {self.size}, then {(w, h)}")
        self.fh.write(b"!\xf9\x04\x04" + struct.pack("<H", self.delay_cs) + b"\x00\x00")  # delay, keep
        self.fh.write(body)

    def close(self):
        self.fh.write(b";")


MAX_FRAMES = 10_000  # frames of one GIF/MP4: ~100 KB each at the default width, so at most ~1 GB of file
MAX_ROBOT_FRAMES = 20_000_000  # robots x frames drawn: each frame draws every robot (~1 us each), ~20 s at most


def check_animation(robots: int, steps: int, every: int, option: str = "--gif") -> int:
    """Refuse, before any work, an animation of more than :data:`MAX_FRAMES` frames or
    :data:`MAX_ROBOT_FRAMES` robots x frames (``steps`` steps, a frame every ``every``); returns
    the frame count. The message names ``option`` and what to lower."""
    frames = steps // max(every, 1) + 1
    if frames > MAX_FRAMES:
        raise ArgumentError(f"{option}: {steps} steps with a frame every {every} make {frames:,} frames; at most "
                            f"{MAX_FRAMES:,} (raise --frame-every or lower --max-cycles)")
    if robots * frames > MAX_ROBOT_FRAMES:
        raise ArgumentError(f"{option}: {robots:,} robots x {frames:,} frames = {robots * frames:,} robot-frames to "
                            f"draw; at most {MAX_ROBOT_FRAMES:,} (fewer robots, fewer steps or a larger --frame-every)")
    return frames


class FrameWriter:
    """``with FrameWriter(path) as w: w.add(frame (H, W, 3) uint8)...``: a GIF (any suffix but
    .png/.mp4), the last frame as PNG (``.png``) or an H.264 MP4 (``.mp4``, the [video] extra),
    written atomically, holding at most one frame in memory. ``n_frames`` counts the frames."""

    def __init__(self, path, fps: float = 10):
        self.path, self.fps, self.n_frames = path, fps, 0
        self.kind = next((k for k in ("png", "mp4") if str(path).lower().endswith("." + k)), "gif")
        if self.kind == "mp4":
            require("imageio", "video", "Writing MP4 video")
            self._iio = require("imageio.v2", "video", "Writing MP4 video")
            require("imageio_ffmpeg", "video", "Writing MP4 video")
        self._stack = ExitStack()
        self._sink = self._last = None

    def __enter__(self) -> FrameWriter:
        tmp = self._stack.enter_context(atomic_path(self.path))
        if self.kind == "gif":
            self._sink = _GifStream(self._stack.enter_context(open(tmp, "wb")), self.fps)
        elif self.kind == "mp4":
            self._sink = self._iio.get_writer(tmp, format="FFMPEG", fps=self.fps, codec="libx264",
                                              macro_block_size=1)
            self._stack.callback(self._sink.close)
        self._tmp = tmp
        self._stack.push(self._finish)
        return self

    def add(self, frame) -> None:
        frame = np.asarray(frame)
        if self.kind == "png":
            self._last = frame
        elif self.kind == "gif":
            self._sink.add(frame)
        else:
            h, w = frame.shape[:2]
            self._sink.append_data(frame[: h - h % 2, : w - w % 2])  # H.264 wants even sizes
        self.n_frames += 1

    def _finish(self, et, ev, tb):
        """On success: the GIF trailer or the PNG (an error here still removes the .part file)."""
        if et is None:
            if self.n_frames == 0:
                raise ArgumentError(f"{self.path}: no frames to write")
            if self.kind == "png":
                from PIL import Image

                Image.fromarray(self._last).save(self._tmp, format="PNG")
            elif self.kind == "gif":
                self._sink.close()
        return False

    def __exit__(self, et, ev, tb):
        return self._stack.__exit__(et, ev, tb)


def save_gif(frames, path, fps=10):
    """Write frames ``(H, W, 3) uint8`` as an animated GIF, or a single PNG when the path ends in
    .png (the last frame), atomically (a list or any iterable: frames are encoded one by one)."""
    with FrameWriter(path, fps) as w:
        for f in frames:
            w.add(f)


def save_mp4(frames, path, fps=10):
    """Write frames as an H.264 MP4 through imageio and the ffmpeg binary its imageio-ffmpeg
    package ships (``pip install 'tin_swarm_env[video]'``), atomically."""
    if not str(path).lower().endswith(".mp4"):
        raise ArgumentError(f"{path}: an MP4 file name must end in .mp4")
    save_gif(frames, path, fps)
