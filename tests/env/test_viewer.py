"""Rendered frames: title strip (scenario, step, counts), legend and scale bar; off for training videos."""

import numpy as np

import tin_swarm_env as tse


def _env(**kw):
    return tse.parallel_env(scenario="ramp", n_robots=3, max_cycles=40, render_mode="rgb_array", **kw)


def test_title_counts_the_step_and_the_fallen():
    env = _env()
    # robot_0 drives east off the ramp's cliff; the other two wait
    env.reset(seed=0, options={"robot_positions": [[217.0, 120.0], [30.0, 100.0], [30.0, 140.0]],
                               "headings": [0.0, 0.0, 0.0]})
    for _ in range(10):
        env.step({a: np.array([1.0, 0.0]) if a == "robot_0" else np.zeros(2) for a in env.agents})
    env.render()
    v = env._viewer
    t = v.title(env.world_state)
    assert t.startswith("ramp") and f"step {env.steps}" in t and "fell 1" in t and "arrived 0" in t
    img = env.render()
    strip = img[: v._title.HEIGHT_PX]
    assert (strip < 100).all(axis=2).sum() > 100  # dark text on the white strip
    assert (strip == 255).all(axis=2).mean() > 0.7
    env.close()


def test_decorations_add_a_title_strip_legend_and_scale_bar_and_can_be_turned_off():
    on, off = _env(), _env(render_decorations=False)
    on.reset(seed=1)
    off.reset(seed=1)
    a, b = on.render(), off.render()
    h = on._viewer._title.HEIGHT_PX
    assert a.shape == (b.shape[0] + h, b.shape[1], 3)
    terrain = a[h:]
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
