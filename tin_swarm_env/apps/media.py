"""Writing rendered frames as they come: an animated GIF (or the last frame as PNG), an H.264
MP4 or an animated WebP. Memory stays at one frame whatever the episode's length:
:class:`FrameWriter` encodes each frame on arrival into a hidden ``.part`` file beside the
output (renamed into place on success, removed on any error or Ctrl-C; see
:mod:`tin_swarm_env._atomic`).

GIF (:mod:`~tin_swarm_env.apps.gif`): one fixed palette for every frame, the viewer's
:data:`~tin_swarm_env.env.viewer.PALETTE` (every colour a rendered frame holds: the legend's marker colours, a grey ramp and the terrain's
height x hillshade colours), each frame mapped to its nearest colour without dithering, so the
legend's colours stay exactly what the legend says. After the first frame each frame stores only
the rectangle that changed, its unchanged pixels transparent (they show the frame before): a
frame of a run costs about what its moving robots and title cover, not the whole picture.

Defaults (``tin-swarm run``): a frame every :data:`FRAME_EVERY` steps, :data:`GIF_WIDTH_PX`
pixels wide; a 200-robot, 900-step jacksboro run then writes a GIF under 10 MB (measured in
``docs/figures/media.md``; ``tests/apps/test_media.py`` bounds it).
"""

from __future__ import annotations

import os
import struct
from contextlib import ExitStack

import numpy as np

from .._atomic import atomic_path
from ..env.tin_swarm import DEFAULT_RENDER_WIDTH_PX
from ..errors import ArgumentError, require
from .gif import TRANSPARENT, GifStream, gif_palette_image, palette_indices

__all__ = ["FrameWriter", "save_gif", "save_mp4", "FRAME_EVERY", "GIF_WIDTH_PX", "SUFFIXES", "gif_palette_image",
           "TRANSPARENT", "palette_indices"]

FRAME_EVERY = 5  # steps between frames of `tin-swarm run --gif/--mp4` (--frame-every)
GIF_WIDTH_PX = DEFAULT_RENDER_WIDTH_PX  # frame width of `tin-swarm run --gif/--mp4` (--render-width)
SUFFIXES = {".gif": "an animated GIF", ".png": "the last frame as PNG", ".mp4": "H.264 video, the [video] extra",
            ".webp": "lossless animated WebP, the [video] extra"}


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


def frame_kind(path) -> str:
    """``"gif"``, ``"png"``, ``"mp4"`` or ``"webp"`` from ``path``'s suffix (:data:`SUFFIXES`);
    any other suffix is an ArgumentError naming it."""
    suffix = os.path.splitext(os.path.basename(os.fspath(path)))[1].lower()
    if suffix not in SUFFIXES:
        what = f"the suffix {suffix!r} is not a format written here" if suffix else "the file name has no suffix"
        raise ArgumentError(f"{path}: {what}; the suffix picks the format: "
                            + ", ".join(f"{k} ({v})" for k, v in SUFFIXES.items()))
    return suffix[1:]


class FrameWriter:
    """``with FrameWriter(path) as w: w.add(frame (H, W, 3) uint8)...``: by ``path``'s suffix a
    GIF (``.gif``), the last frame as PNG (``.png``), an H.264 MP4 (``.mp4``) or a lossless
    animated WebP (``.webp``; these two need imageio-ffmpeg, the [video] extra), written
    atomically, holding at most one frame in memory. ``n_frames`` counts the frames."""

    def __init__(self, path, fps: float = 10):
        self.path, self.fps, self.n_frames = path, fps, 0
        self.kind = frame_kind(path)
        if self.kind in ("mp4", "webp"):
            what = f"{path}: writing a .{self.kind} file"
            require("imageio", "video", what)
            self._iio = require("imageio.v2", "video", what)
            self._ffmpeg = require("imageio_ffmpeg", "video", what)
        self._stack = ExitStack()
        self._sink = self._last = None

    def __enter__(self) -> FrameWriter:
        tmp = self._stack.enter_context(atomic_path(self.path))
        if self.kind == "gif":
            self._sink = GifStream(self._stack.enter_context(open(tmp, "wb")), self.fps)
        elif self.kind == "mp4":
            self._sink = self._iio.get_writer(tmp, format="FFMPEG", fps=self.fps, codec="libx264",
                                              macro_block_size=1)
            self._stack.callback(self._sink.close)
        self._tmp = tmp
        return self

    def _webp(self, frame):
        """The WebP encoder (ffmpeg's libwebp_anim, lossless), started at the first frame's size."""
        if self._sink is None:
            h, w = frame.shape[:2]
            self._sink = self._ffmpeg.write_frames(self._tmp, (w, h), fps=self.fps, codec="libwebp_anim",
                                                   pix_fmt_out="bgra", output_params=["-f", "webp", "-loop", "0",
                                                                                      "-lossless", "1"],
                                                   macro_block_size=1)
            self._sink.send(None)
            self._stack.callback(self._sink.close)
        self._sink.send(np.ascontiguousarray(frame))

    def _add(self, frame) -> None:
        frame = np.asarray(frame)
        if self.kind == "png":
            self._last = frame
        elif self.kind == "gif":
            self._sink.add(frame)
        elif self.kind == "webp":
            self._webp(frame)
        else:
            h, w = frame.shape[:2]
            self._sink.append_data(frame[: h - h % 2, : w - w % 2])  # H.264 wants even sizes
        self.n_frames += 1

    def _finalize(self) -> None:
        """On success, in order: the GIF trailer or the PNG, the encoder closed (ffmpeg flushed and
        gone), the file closed, then the file checked whole (:func:`check_media_file`); only then
        does the stack rename it into place."""
        if self.n_frames == 0:
            raise ArgumentError(f"{self.path}: no frames to write")
        if self.kind == "png":
            from PIL import Image

            Image.fromarray(self._last).save(self._tmp, format="PNG")
        elif self.kind == "gif":
            self._sink.close()
            self._sink.fh.close()
        elif self._sink is not None:
            self._sink.close()
        check_media_file(self._tmp, self.kind, self.path)

    def __exit__(self, et, ev, tb):
        if et is None:
            try:
                self._finalize()
            except BaseException as exc:  # the .part file is removed; the error names the file
                new = _encoder_error(exc, self.path)
                if self._stack.__exit__(type(new), new, new.__traceback__):
                    return False  # pragma: no cover - nothing in the stack swallows errors
                if new is exc:
                    raise
                raise new from exc
            return self._stack.__exit__(None, None, None)
        return self._stack.__exit__(et, ev, tb)  # an error of the caller's: the .part file removed

    def add(self, frame) -> None:  # noqa: F811 (the encoders' errors name the file)
        try:
            self._add(frame)
        except (OSError, RuntimeError) as exc:
            new = _encoder_error(exc, self.path)
            if new is exc:
                raise
            raise new from exc


def _encoder_error(exc: BaseException, path):
    """An encoder's failure (an OSError without a file, ffmpeg's IOError text, a RuntimeError) as
    an :class:`~tin_swarm_env.errors.OutputError` naming ``path``; other errors pass through."""
    import errno

    from ..errors import OutputError, TinSwarmError

    if isinstance(exc, (TinSwarmError, KeyboardInterrupt, SystemExit)) or not isinstance(exc, (OSError, RuntimeError)):
        return exc
    fn = getattr(exc, "filename", None)
    if isinstance(exc, OSError) and fn is not None and ".part" not in os.path.basename(str(fn)):
        return exc  # it names its own file
    first = (getattr(exc, "strerror", None) or str(exc).strip().splitlines()[0:1] or [type(exc).__name__])
    first = first if isinstance(first, str) else first[0]
    return OutputError(getattr(exc, "errno", None) or errno.EIO,
                       f"{first}; not written (an old file there is unchanged)", str(path))


def _mp4_complete(b: bytes) -> bool:
    """The top-level boxes of an MP4 cover the file exactly and include ``ftyp``, ``mdat`` and ``moov``."""
    i, seen = 0, set()
    while i + 8 <= len(b):
        size, kind = struct.unpack(">I4s", b[i:i + 8])
        if size == 1 and i + 16 <= len(b):
            size = struct.unpack(">Q", b[i + 8:i + 16])[0]
        if size < 8 or i + size > len(b):
            return False
        seen.add(kind)
        i += size
    return i == len(b) and {b"ftyp", b"mdat", b"moov"} <= seen


def check_media_file(tmp, kind: str, path) -> None:
    """Refuse (an :class:`~tin_swarm_env.errors.OutputError` naming ``path``) a written file that
    is not whole: a GIF without its trailer, a PNG without IEND, a WebP whose RIFF size is not the
    file's, an MP4 whose boxes do not cover the file or that lacks ``moov`` (an encoder such as
    ffmpeg that died on a full disk exits without a Python error: its file is checked instead)."""
    import errno

    from ..errors import OutputError

    with open(tmp, "rb") as fh:
        b = fh.read()
    ok = {"gif": lambda: b[:6] == b"GIF89a" and b[-1:] == b";",
          "png": lambda: b[:8] == b"\x89PNG\r\n\x1a\n" and b[-12:-8] == b"\x00\x00\x00\x00" and b[-8:-4] == b"IEND",
          "webp": lambda: b[:4] == b"RIFF" and b[8:12] == b"WEBP" and struct.unpack("<I", b[4:8])[0] + 8 == len(b),
          "mp4": lambda: _mp4_complete(b)}[kind]
    if len(b) < 12 or not ok():
        raise OutputError(errno.EIO, f"the {kind.upper()} encoder left an incomplete file ({len(b):,} bytes); not "
                          "written (an old file there is unchanged)", str(path))


def save_gif(frames, path, fps=10):
    """Write frames ``(H, W, 3) uint8`` as an animated GIF, or a single PNG when the path ends in
    .png (the last frame), or MP4/WebP by the suffix, atomically (a list or any iterable: frames
    are encoded one by one)."""
    with FrameWriter(path, fps) as w:
        for f in frames:
            w.add(f)


def save_mp4(frames, path, fps=10):
    """Write frames as an H.264 MP4 through imageio and the ffmpeg binary its imageio-ffmpeg
    package ships (``pip install 'tin_swarm_env[video]'``), atomically."""
    if not str(path).lower().endswith(".mp4"):
        raise ArgumentError(f"{path}: an MP4 file name must end in .mp4")
    save_gif(frames, path, fps)
