"""Rendered frames: title strip (scenario, step, counts), legend of what the frame can show, scale bar,
height colour bar, markers by status, every pixel of the terrain in the fixed palette; off for training videos."""

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.env.viewer import COLORS, PALETTE, Viewer
from tin_swarm_env.world import Reason


def _env(scenario="ramp", n=3, **kw):
    return tse.parallel_env(scenario=scenario, n_robots=n, max_cycles=40, render_mode="rgb_array", **kw)


def _is(img, name):
    return (img == np.array(COLORS[name], np.uint8)).all(axis=-1)


def test_title_counts_the_step_the_fallen_and_the_timed_out():
    env = _env()
    # robot_0 drives east off the ramp's cliff; the other two wait
    env.reset(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 100.0], [30.0, 140.0]],
                               "headings": [0.0, 0.0, 0.0]})
    for _ in range(10):
        env.step({a: np.array([1.0, 0.0]) if a == "robot_0" else np.zeros(2) for a in env.agents})
    env.render()
    v = env._viewer
    t = v.title(env.world_state)
    assert t.startswith("ramp") and f"step {env.steps}" in t
    assert t.endswith("robots 3: arrived 0, fell 1, battery-empty 0, active 2")
    img = env.render()
    strip = img[: v._title.HEIGHT_PX]
    assert (strip < 100).all(axis=2).sum() > 100  # dark text on the white strip
    assert (strip == 255).all(axis=2).mean() > 0.7
    while env.agents:  # to max_cycles: the two still standing are cut off
        env.step({a: np.zeros(2) for a in env.agents})
    assert v.title(env.world_state, final=True).endswith("fell 1, battery-empty 0, timed out 2")
    last = env.render()  # the env knows its last frame
    np.testing.assert_array_equal(last[: v._title.HEIGHT_PX], v._title.render(v.title(env.world_state, True)))
    env.close()


def test_decorations_add_a_title_strip_colour_bar_legend_and_scale_bar_and_can_be_turned_off():
    on, off = _env(), _env(render_decorations=False)
    on.reset(seed=1)
    off.reset(seed=1)
    a, b = on.render(), off.render()
    from tin_swarm_env.env.viewer import COLORBAR_HEIGHT_PX

    h = on._viewer._title.HEIGHT_PX
    assert a.shape == (b.shape[0] + h + COLORBAR_HEIGHT_PX, b.shape[1], 3)
    terrain = a[h:h + b.shape[0]]
    H, W = b.shape[:2]
    top_right = (slice(0, H // 3), slice(2 * W // 3, W))
    bottom_left = (slice(H - H // 8, H), slice(0, W // 5))
    assert np.mean(terrain[top_right] != b[top_right]) > 0.1  # the legend
    assert np.mean(terrain[bottom_left] != b[bottom_left]) > 0.1  # the scale bar
    assert off._viewer._title is None
    rest = np.ones((H, W), bool)
    rest[top_right] = rest[bottom_left] = False
    np.testing.assert_array_equal(terrain[rest], b[rest])  # elsewhere the same picture
    on.close()
    off.close()


def test_the_colour_bar_shows_every_height_colour_and_the_terrain_uses_them():
    from tin_swarm_env.env.viewer import HEIGHT_BINS, _height_colors

    env = _env("hill")
    env.reset(seed=0)
    v_img = env.render()
    bar = v_img[-env._viewer._colorbar.shape[0]:]
    full = np.rint(255 * _height_colors()).astype(np.uint8)  # unshaded height colours: the bar's steps
    seen = [(bar == c).all(axis=-1).sum() for c in full]
    assert len(seen) == HEIGHT_BINS and min(seen) > 20  # every step is drawn, each a block of pixels
    lo, hi = env._viewer.z_range
    assert hi > lo + 1  # the hill has relief: the ticks span it


def test_a_bare_frame_holds_palette_colours_only():
    env = _env("ramp", n=30, render_decorations=False)
    env.reset(seed=0)
    for _ in range(30):
        env.step({a: np.array([1.0, 0.2]) for a in env.agents})
    img = env.render().reshape(-1, 3).astype(np.int64)
    key = (img[:, 0] << 16) | (img[:, 1] << 8) | img[:, 2]
    pal = PALETTE.astype(np.int64)
    assert np.isin(key, (pal[:, 0] << 16) | (pal[:, 1] << 8) | pal[:, 2]).all()
    assert len(PALETTE) <= 255 and len(np.unique(PALETTE, axis=0)) == len(PALETTE)
    env.close()


def test_markers_by_status_stay_drawn_where_the_robots_are():
    env = _env("flat", n=4)
    env.reset(seed=0)
    v = Viewer(env.world, width_px=400, decorations=False)
    s = env.world_state.copy()
    x0, y0, x1, y1 = v.bounds
    s.positions[:] = [[x0 + f * (x1 - x0), (y0 + y1) / 2] for f in (0.2, 0.4, 0.6, 0.8)]
    s.headings[:] = 0.0  # ticks point east
    s.status[:] = [Reason.NONE, Reason.ARRIVED, Reason.FELL, Reason.BATTERY]
    img = v.frame(s)
    r, c = v.to_px(s.positions)
    assert _is(img, "robot")[r[0], c[0] - 2]  # west of the centre (the heading tick points east)
    assert _is(img, "arrived")[r[1], c[1] + 3] and not _is(img, "arrived")[r[1], c[1]]  # a ring, still drawn
    assert _is(img, "fell")[r[2], c[2]] and _is(img, "fell")[r[2] + 3, c[2] + 3]  # a cross
    assert not _is(img, "fell")[r[2] + 3, c[2]]
    assert _is(img, "battery")[r[3], c[3] - 2]
    env.close()


def test_the_legend_lists_only_what_the_frame_can_show():
    flat = _env("flat", n=4)
    flat.reset(seed=0)
    flat.render()
    v = flat._viewer
    s = flat.world_state
    assert v.legend_entries(s) == ("robot", "target")  # no steep ground, breaks, assets or ended robots
    s2 = s.copy()
    s2.status[:2] = [Reason.FELL, Reason.ARRIVED]
    assert v.legend_entries(s2) == ("robot", "arrived", "fell", "target")
    assert not np.array_equal(v.background(v.legend_entries(s)), v.background(v.legend_entries(s2)))
    ramp = _env("ramp")
    ramp.reset(seed=0)
    ramp.render()
    got = ramp._viewer.legend_entries(ramp.world_state)
    assert "cliff" in got and "asset" not in got and "fell" not in got
    flat.close()
    ramp.close()
