"""Writing rendered frames: an animated GIF (or the last frame as PNG) and an H.264 MP4."""

from __future__ import annotations

from .._atomic import atomic_path
from ..errors import ArgumentError, require

__all__ = ["save_gif", "save_mp4"]


def save_gif(frames, path, fps=10):
    """Write frames ``(H, W, 3) uint8`` as an animated GIF (Pillow, which matplotlib ships
    with), or a single PNG when the path ends in .png (the last frame), atomically."""
    from PIL import Image

    if not frames:
        raise ArgumentError("no frames to write")
    png = str(path).lower().endswith(".png")
    with atomic_path(path) as tmp:  # never a half-written picture
        if png:
            Image.fromarray(frames[-1]).save(tmp, format="PNG")
        else:
            imgs = [Image.fromarray(f).convert("P", palette=Image.Palette.ADAPTIVE, colors=128) for f in frames]
            imgs[0].save(tmp, format="GIF", save_all=True, append_images=imgs[1:], duration=int(1000 / fps),
                         loop=0)


def save_mp4(frames, path, fps=10):
    """Write frames as an H.264 MP4 through imageio and the ffmpeg binary its imageio-ffmpeg
    package ships (``pip install 'tin_swarm_env[video]'``), atomically."""
    iio = require("imageio.v2", "video", "Writing MP4 video")
    require("imageio_ffmpeg", "video", "Writing MP4 video")
    if not frames:
        raise ArgumentError("no frames to write")
    h, w = frames[0].shape[:2]
    frames = [f[: h - h % 2, : w - w % 2] for f in frames]  # H.264 wants even sizes
    with atomic_path(path) as tmp:
        iio.mimwrite(tmp, frames, fps=fps, format="FFMPEG", codec="libx264", macro_block_size=1)
