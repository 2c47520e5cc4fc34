"""GIF, MP4 and WebP writing (apps/media.py): frames streamed to a hidden part file, decoded back exactly,
no file left behind by an error or an empty recording; the fixed GIF palette keeps the legend's colours
apart; the default stride and size keep a 200-robot, 900-step jacksboro GIF under 10 MB."""

from __future__ import annotations

import itertools
import os

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env.env.viewer import COLORS, PALETTE, Viewer
from tin_swarm_env.world import Reason

LEGEND_KEYS = ("robot", "arrived", "fell", "battery", "target", "cliff")  # must stay apart in a GIF
MIN_RGB_DISTANCE = 100.0  # pairwise Euclidean RGB distance of those colours as decoded from the GIF
MAX_GIF_BYTES = 10_000_000  # the bound for a 200-robot, 900-step jacksboro run with the defaults


def test_gif_frames_are_streamed_and_decode_exactly(tmp_path):
    from PIL import Image

    from tin_swarm_env.apps.media import FrameWriter, palette_indices

    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (30, 40, 3), dtype=np.uint8) for _ in range(4)]
    frames[2][:] = 200
    frames[3] = frames[2].copy()  # nothing changed: an empty (transparent) frame
    frames[3][5:9, 7:12] = PALETTE[3]  # ... but for this rectangle
    path = tmp_path / "a.gif"
    with FrameWriter(path, fps=20) as w:
        for f in frames:
            w.add(f)
            assert os.listdir(tmp_path)[0].endswith(".part.gif")  # written as they come, hidden
    im = Image.open(path)
    assert im.n_frames == 4 and im.size == (40, 30) and im.info["loop"] == 0
    for i, f in enumerate(frames):
        im.seek(i)
        ref = PALETTE[palette_indices(f)]  # each pixel's nearest palette colour
        assert np.array_equal(np.asarray(im.convert("RGB")), ref), i
        assert im.info["duration"] == 50
    d = ((frames[0][..., None, :].astype(int) - PALETTE.astype(int)) ** 2).sum(-1)
    np.testing.assert_array_equal(palette_indices(frames[0]), d.argmin(-1))  # nearest, by brute force
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


def test_the_suffix_picks_the_format_and_an_unknown_one_is_named(tmp_path):
    from PIL import Image

    from tin_swarm_env.apps.media import FrameWriter

    rng = np.random.default_rng(2)
    frames = [rng.integers(0, 256, (20, 30, 3), dtype=np.uint8) for _ in range(3)]
    with pytest.raises(tse.errors.ArgumentError, match=r"'\.avi'.*\.gif.*\.png.*\.mp4.*\.webp"):
        FrameWriter(tmp_path / "x.avi")
    with FrameWriter(tmp_path / "last.png") as w:
        for f in frames:
            w.add(f)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "last.png").convert("RGB")), frames[-1])
    pytest.importorskip("imageio_ffmpeg", reason="WebP is written by ffmpeg: the [video] extra")
    with FrameWriter(tmp_path / "x.webp") as w:
        for f in frames:
            w.add(f)
    im = Image.open(tmp_path / "x.webp")
    assert im.n_frames == 3
    for i, f in enumerate(frames):
        im.seek(i)
        assert np.array_equal(np.asarray(im.convert("RGB")), f), i  # lossless
    assert sorted(os.listdir(tmp_path)) == ["last.png", "x.webp"]


def test_webp_without_the_video_extra_names_the_file_and_the_extra(tmp_path, monkeypatch):
    import sys

    from tin_swarm_env.apps.media import FrameWriter

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if not installed
    with pytest.raises(tse.errors.MissingExtraError, match=r"x\.webp: writing a \.webp file.*tin_swarm_env\[video\]"):
        FrameWriter(tmp_path / "x.webp")


def _scene(scenario, n, width_px, seed=0):
    """A viewer and the state of a reset ``scenario`` with ``n`` robots."""
    env = tse.parallel_env(scenario=scenario, n_robots=n)
    env.reset(seed=seed)
    return env, Viewer(env.world, width_px=width_px, name=scenario)


def test_a_200_robot_gif_keeps_every_legend_colour_apart_and_where_it_was_drawn(tmp_path):
    from PIL import Image

    from tin_swarm_env.apps.media import FrameWriter

    env, v = _scene("ramp", 200, 640)
    s = env.world_state.copy()
    x0, y0, x1, y1 = v.bounds
    gx, gy = np.meshgrid(np.linspace(x0 + 10, x1 - 10, 20), np.linspace(y0 + 10, y1 - 10, 10))
    s.positions[:] = np.column_stack([gx.ravel(), gy.ravel()])  # ~30 px apart: no marker covers another
    s.status[:] = np.resize([Reason.NONE, Reason.ARRIVED, Reason.FELL, Reason.BATTERY], 200)
    s.headings[:] = 0.0  # heading ticks point east
    frames = []
    for k in range(3):  # the robots move a little between frames
        s.positions[:, 0] += 2.0
        s.step = 5 * k
        frames.append(v.frame(s))
    path = tmp_path / "swarm.gif"
    with FrameWriter(path) as w:
        for f in frames:
            w.add(f)
    im = Image.open(path)
    decoded = []
    for i, f in enumerate(frames):
        im.seek(i)
        decoded.append(np.asarray(im.convert("RGB")))
    for f, g in zip(frames, decoded):
        for key in LEGEND_KEYS:
            drawn = (f == np.array(COLORS[key], np.uint8)).all(axis=-1)
            assert drawn.sum() > 20, key  # the colour is in the frame (markers, cliff lines, the legend)
            assert (g[drawn] == COLORS[key]).all(), key  # and decodes to exactly that colour
    got = {key: decoded[-1][(frames[-1] == np.array(COLORS[key], np.uint8)).all(axis=-1)][0].astype(float)
           for key in LEGEND_KEYS}
    for a, b in itertools.combinations(LEGEND_KEYS, 2):
        assert np.linalg.norm(got[a] - got[b]) > MIN_RGB_DISTANCE, (a, b)
    r, c = v.to_px(s.positions)
    r = r + v._title.HEIGHT_PX  # the title strip is above the terrain
    tr, tc = v.to_px(s.targets.positions)
    clear = np.hypot(r[:, None] - v._title.HEIGHT_PX - tr, c[:, None] - tc).min(axis=1) > 12  # no target on it
    g = decoded[-1]
    for i, key in enumerate(("robot", "arrived", "fell", "battery")):  # the markers where the robots are
        off = 3 if key == "arrived" else (0 if key == "fell" else -2)  # a ring / a cross / west of the tick
        m = clear[i::4]
        assert m.sum() > 40 and (g[r[i::4][m], c[i::4][m] + off] == COLORS[key]).all(), key


def test_default_stride_and_width_keep_a_200_robot_900_step_jacksboro_gif_under_10_mb(tmp_path):
    """A size model checked on real jacksboro frames: the first frame whole, then per frame the
    bytes of a worst case -- every one of the 200 robots moved a full stride at top speed, spread
    over the terrain, with all four statuses -- times the frames the defaults write in 900 steps.
    The measured run is in docs/figures/media.md; this fails if FRAME_EVERY or GIF_WIDTH_PX grow
    (or a frame's encoding does) past the bound."""
    from tin_swarm_env.apps.cli import build_parser
    from tin_swarm_env.apps.media import FRAME_EVERY, GIF_WIDTH_PX, FrameWriter, check_animation

    args = build_parser().parse_args(["run", "jacksboro", "--gif", "x.gif"])
    assert (args.frame_every, args.render_width) == (FRAME_EVERY, GIF_WIDTH_PX)  # the CLI uses the defaults
    env, v = _scene("jacksboro", 200, GIF_WIDTH_PX)
    assert env.max_cycles == 900 and env.n == 200
    frames_written = check_animation(200, 900, FRAME_EVERY)
    rng = np.random.default_rng(0)
    x0, y0, x1, y1 = v.bounds
    s = env.world_state.copy()
    s.positions[:] = rng.uniform([x0, y0], [x1, y1], (200, 2))
    s.status[:] = rng.choice([Reason.NONE, Reason.ARRIVED, Reason.FELL, Reason.BATTERY], 200)
    P = env.world.params
    stride_m = P.robot.max_speed_mps * P.dt_s * FRAME_EVERY
    states = [env.world_state, s]
    for k in range(3):
        s = s.copy()
        a = rng.uniform(-np.pi, np.pi, 200)
        s.positions += stride_m * np.column_stack([np.cos(a), np.sin(a)])
        s.headings += 1.0
        s.step += FRAME_EVERY
        states.append(s)
    sizes = []
    for k in (1, len(states)):
        with FrameWriter(tmp_path / "j.gif") as w:
            for st in states[:k]:
                w.add(v.frame(st))
        sizes.append((tmp_path / "j.gif").stat().st_size)
    first, per_frame = sizes[0], (sizes[1] - sizes[0]) / (len(states) - 1)
    model = first + per_frame * (frames_written - 1)
    print(f"model: first frame {first} B, {per_frame:.0f} B per frame, {frames_written} frames: {model / 1e6:.2f} MB")
    assert model <= MAX_GIF_BYTES, (first, per_frame, frames_written, model)
