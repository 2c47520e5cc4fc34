"""The field explorer, driven headless (Agg), and episode video."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backend_bases import MouseEvent  # noqa: E402

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.apps.cli import main  # noqa: E402
from tin_swarm_env.apps.explorer import FieldExplorer  # noqa: E402


@pytest.fixture
def ex():
    e = FieldExplorer("ramp", robot=0, n_robots=6, grid=21)
    yield e
    e.close()


def test_toggling_a_field_changes_the_plotted_field(ex):
    u0 = ex.field_values.copy()
    labels = [t.get_text() for t in ex.checks.labels]
    ex.checks.set_active(labels.index("target"))  # the check box callback
    assert "target" not in ex.fields and "target" not in ex.policy.params.fields
    u1 = ex.field_values.copy()
    assert not np.allclose(u0, u1)
    ex.checks.set_active(labels.index("target"))
    np.testing.assert_allclose(ex.field_values, u0)


def test_next_step_button_moves_the_robots_and_reset_restores(ex):
    p0 = ex.env.world_state.positions.copy()
    ex.btn_next._observers.process("clicked", None)  # what a click on "next step" does
    assert ex.env.steps == 1
    assert np.all(np.hypot(*(ex.env.world_state.positions - p0).T) > 0)
    ex.btn_reset._observers.process("clicked", None)
    np.testing.assert_array_equal(ex.env.world_state.positions, p0)


def test_clicking_the_heatmap_moves_the_robot_and_adds_a_threat(ex):
    ax = ex.ax_heat
    x, y = ex.env.world_state.positions[0] + [10.0, 5.0]
    px, py = ax.transData.transform((x, y))
    ex.fig.canvas.callbacks.process("button_press_event", MouseEvent("button_press_event", ex.fig.canvas, px, py, 1))
    np.testing.assert_allclose(ex.env.world_state.positions[0], [x, y], atol=1.0)
    n = len(ex.env.world_state.targets)
    px, py = ax.transData.transform((x + 5, y))
    ex.fig.canvas.callbacks.process("button_press_event", MouseEvent("button_press_event", ex.fig.canvas, px, py, 3))
    assert len(ex.env.world_state.targets) == n + 1


def test_explore_cli_writes_a_png_that_is_not_blank(tmp_path):
    out = tmp_path / "ramp.png"
    assert main(["explore", "ramp", "--png", str(out), "--robots", "6", "--steps", "20"]) == 0
    from PIL import Image

    img = np.asarray(Image.open(out).convert("RGB")).astype(float)
    assert img.shape[0] > 400 and img.std() > 20
    assert main(["explore", "ramp", "--png", str(tmp_path / "all.png"), "--robot", "all", "--fields",
                 "robot,target"]) == 0
    assert main(["explore", "ramp", "--png", str(tmp_path / "x.png"), "--fields", "magnetism"]) == 2


def test_run_writes_an_mp4_and_record_video_parallel_works(tmp_path):
    pytest.importorskip("imageio_ffmpeg", reason="the video extra: pip install 'tin_swarm_env[video]'")
    out = tmp_path / "flat.mp4"
    assert main(["run", "flat", "--robots", "4", "--max-cycles", "40", "--mp4", str(out), "--quiet"]) == 0
    import imageio.v2 as iio

    frames = iio.mimread(out, memtest=False)
    assert len(frames) >= 8 and frames[0].ndim == 3
    from pettingzoo.utils.wrappers import RecordVideoParallel

    env = RecordVideoParallel(tse.parallel_env(scenario="flat", n_robots=3, max_cycles=15, render_mode="rgb_array"),
                              str(tmp_path / "vid"), episode_trigger=lambda e: True)
    env.reset(seed=0)
    while env.agents:
        env.step({a: env.action_space(a).sample() for a in env.agents})
    env.close()
    videos = list((tmp_path / "vid").glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000


def test_an_added_threat_is_assigned_and_changes_the_trajectories():
    runs = []
    for add in (False, True):
        e = FieldExplorer("ramp", robot=0, n_robots=6, grid=11)
        if add:
            n = len(e.env.world_state.targets)
            e.add_threat((60.0, 60.0))
            assert n + 1 == len(e.env.world_state.targets)
            assert n in e.env.target_assignment  # some robot now heads for the new threat
        for _ in range(15):
            e.next_step(draw=False)
        runs.append(e.env.world_state.positions.copy())
        e.close()
    moved_apart = np.hypot(*(runs[1] - runs[0]).T)
    assert moved_apart.max() > 1.0


# -- the thesis 4.1 controls, each by a synthesised event -------------------------------------------


def _mouse(ex, name, xy, button=1):
    px, py = ex.ax_heat.transData.transform(xy)
    ex.fig.canvas.callbacks.process(name, MouseEvent(name, ex.fig.canvas, px, py, button))


def _drag(ex, a, b):
    _mouse(ex, "button_press_event", a)
    _mouse(ex, "motion_notify_event", (np.asarray(a) + b) / 2)
    assert ex._ghost is not None  # the ghost follows the mouse
    _mouse(ex, "motion_notify_event", b)
    _mouse(ex, "button_release_event", b)


@pytest.fixture
def whole():
    e = FieldExplorer("ramp", robot=None, n_robots=6, grid=21)
    yield e
    e.close()


def test_clicking_a_robot_selects_it_and_its_field_is_shown(whole):
    ex = whole
    p = ex.env.world_state.positions.copy()
    _mouse(ex, "button_press_event", p[3])
    _mouse(ex, "button_release_event", p[3])
    assert ex.robot == 3 and "robot_3" in ex.ax_heat.get_title()
    np.testing.assert_array_equal(ex.env.world_state.positions, p)  # selecting moves nothing
    X, Y = ex.compute_field()[:2]
    assert X.min() >= p[3, 0] - 1.2 * ex.env.world.params.sensor.range_m - 1e-9  # the window is robot_3's


def test_dragging_a_threat_moves_it_and_the_robots_feel_it(whole):
    ex = whole
    tg = ex.env.world_state.targets.positions[0].copy()
    new = tg + [-40.0, 30.0]
    _drag(ex, tg, new)
    np.testing.assert_allclose(ex.env.world_state.targets.positions[0], new, atol=1.0)
    assert ex._ghost is None and "moved target 0" in ex.status
    ex.select(0)
    dist = ex.env.layout.target_distance_m(ex.obs["robot_0"][None], ex.env.world.params.sensor.range_m)[0]
    assert dist == pytest.approx(np.hypot(*(ex.env.world_state.positions[0] - new)), rel=1e-4)


def test_dragging_a_robot_moves_it_and_selects_it(whole):
    ex = whole
    p = ex.env.world_state.positions.copy()
    _drag(ex, p[2], p[2] + [6.0, -4.0])
    np.testing.assert_allclose(ex.env.world_state.positions[2], p[2] + [6.0, -4.0], atol=1.0)
    np.testing.assert_array_equal(np.delete(ex.env.world_state.positions, 2, 0), np.delete(p, 2, 0))
    assert ex.robot == 2


def test_add_robot_button_then_click_restarts_with_one_more_robot(ex):
    n = ex.env.n
    p = ex.env.world_state.positions.copy()
    xy = p[0] + [8.0, 8.0]
    ex.btn_add._observers.process("clicked", None)
    _mouse(ex, "button_press_event", xy)
    assert ex.env.n == n + 1 and len(ex.env.agents) == n + 1 and ex.robot == n
    np.testing.assert_allclose(ex.env.world_state.positions[:n], p)
    np.testing.assert_allclose(ex.env.world_state.positions[n], xy, atol=1.0)
    assert "new env with 7 robots" in ex.status and "agent set is fixed" in ex.status
    ex.next_step()
    assert ex.env.steps == 1 and f"robot_{n}" in ex.obs


def test_a_refused_placement_says_why_and_changes_nothing(whole):
    ex = whole
    p = ex.env.world_state.positions.copy()
    ex.add_robot((1e6, 1e6))
    assert "refused" in ex.status and "outside the terrain" in ex.status
    assert ex.env.n == 6
    np.testing.assert_array_equal(ex.env.world_state.positions, p)


def test_continuous_runs_on_the_timer_until_unchecked(ex):
    ex.run_check.set_active(0)  # "continuous" on
    assert ex.running and ex._timer is not None
    ex._timer._on_timer()  # what the GUI's event loop does every 100 ms
    ex._timer._on_timer()
    assert ex.env.steps == 2
    ex.run_check.set_active(0)  # off
    assert not ex.running
    ex._timer._on_timer()
    assert ex.env.steps == 2


def test_the_field_is_built_from_exactly_what_the_robot_senses():
    from tin_swarm_env.world.fields import fields_at

    e = FieldExplorer("cliff_goal", robot=0, n_robots=8, grid=15)
    for _ in range(40):
        e.next_step(draw=False)
    e.redraw()
    env, i = e.env, 0
    src = e.sensed_sources(i)
    lay, n = env.layout, env.n
    slots = env.sensed().breaks.nearest(n, lay.k_breaks)[0][i]
    assert len(src["breaks"]) == (slots >= 0).sum() <= lay.k_breaks
    np.testing.assert_array_equal(src["breaks"].segments, env.world.breaks.segments[slots[slots >= 0]])
    r_slots = env.sensed().robots.nearest(n, lay.k_robots)[0][i]
    np.testing.assert_array_equal(src["robots"], env.world_state.positions[r_slots[r_slots >= 0]])
    X, Y, U, _ = e.compute_field()
    pts = np.column_stack([X.ravel(), Y.ravel()])
    every = fields_at(pts, e.policy.params, breaks=env.world.breaks)["break"][1].reshape(X.shape)
    mine = fields_at(pts, e.policy.params, breaks=src["breaks"])["break"][1].reshape(X.shape)
    assert not np.allclose(every, mine)  # the window holds breaks the robot does not sense
    np.testing.assert_array_equal(U, e.field_values)
    e.close()


def test_cost_to_go_check_box_overlays_the_selected_robots_target(ex):
    assert ex.cost_values is None
    labels = [t.get_text() for t in ex.run_check.labels]
    ex.run_check.set_active(labels.index("cost-to-go"))
    C = ex.cost_values
    X, Y = ex.compute_field()[:2]
    g = ex.target_of_selected()
    ok = np.isfinite(C)
    assert ok.mean() > 0.5
    straight = np.hypot(X - g[0], Y - g[1])
    assert np.all(C[ok] >= straight[ok] - 1e-6)  # never below the straight line
    ctg = tse.terrain.cost_to_go(ex.env.tin, g, ~ex.env.world.steep)
    np.testing.assert_allclose(C, ctg.distance_at(np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape))
    # the overlay is the env's own field (the reward's metric), not a second build
    k = 0 if ex.robot is None else int(ex.env.target_assignment[ex.robot])
    env_field = ex.env.target_fields[k].distance_at(np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape)
    assert np.array_equal(C, env_field)
    assert "cost-to-go" in ex.ax_heat.get_title()
    ex.run_check.set_active(labels.index("cost-to-go"))
    assert ex.cost_values is None


def test_explore_cli_cost_to_go_png(tmp_path):
    out = tmp_path / "ctg.png"
    assert main(["explore", "cliff_goal", "--png", str(out), "--robots", "4", "--cost-to-go"]) == 0
    assert out.stat().st_size > 10_000


def test_selecting_a_robot_that_does_not_exist_names_it(ex):
    from tin_swarm_env.errors import ArgumentError

    with pytest.raises(ArgumentError, match=rf"robot {ex.env.n}: the episode has robots 0\.\.{ex.env.n - 1}"):
        ex.select(ex.env.n)


def test_the_png_has_no_controls_and_the_cost_to_go_over_the_whole_terrain_with_colour_bars(tmp_path):
    from PIL import Image

    ex = FieldExplorer("cliff_goal", robot=0, n_robots=4, grid=21, cost_to_go=True)
    controls = list(ex.widget_axes)
    assert len(controls) == 5
    out = tmp_path / "x.png"
    ex.save_png(out)
    assert not set(controls) & set(ex.fig.axes)  # no check boxes or buttons in the picture
    assert set(ex.fig.axes) == {ex.ax3d, ex.ax_surf, ex.ax_heat, ex.ax_heat_cbar, ex.ax_cost, ex.ax_cost_cbar}
    x0, y0, x1, y1 = ex.env.tin.bounds
    (im,) = ex.ax_cost.get_images()
    np.testing.assert_allclose(im.get_extent(), (x0, x1, y0, y1))  # the whole terrain, not the robot's window
    C = np.asarray(im.get_array().filled(np.nan))
    X, Y, C_ref = ex.cost_to_go_map()
    np.testing.assert_array_equal(np.isfinite(C), np.isfinite(C_ref))
    np.testing.assert_allclose(C[np.isfinite(C)], C_ref[np.isfinite(C_ref)])
    assert (X.min(), X.max(), Y.min(), Y.max()) == (x0, x1, y0, y1)
    cols = np.flatnonzero(np.isfinite(C).any(axis=0))
    assert cols[0] == 0 and cols[-1] == C.shape[1] - 1  # reachable ground from the left edge to the right
    g = ex.target_of_selected()
    j, i = np.unravel_index(np.nanargmin(C), C.shape)
    assert np.hypot(X[j, i] - g[0], Y[j, i] - g[1]) < 2 * (x1 - x0) / C.shape[1]  # lowest at the target
    assert im.colorbar is not None and im.colorbar.ax is ex.ax_cost_cbar and "m" in ex.ax_cost_cbar.get_ylabel()
    (heat,) = ex.ax_heat.get_images()
    assert heat.colorbar is not None and heat.colorbar.ax is ex.ax_heat_cbar  # the field's colour bar
    img = np.asarray(Image.open(out).convert("RGB")).astype(float)
    assert img.shape[0] > 400 and img.std() > 20
    ex.close()


def test_the_png_says_so_when_there_is_no_target(tmp_path):
    ex = FieldExplorer("containment", robot=0, n_robots=3, grid=11)  # (a goal task refuses an empty target list)
    ex.env.reset(seed=0, options={"target_positions": np.zeros((0, 2))})
    ex.save_png(tmp_path / "x.png")
    assert ex.cost_to_go_map() is None and not ex.ax_cost.get_images()
    assert "no target" in " ".join(t.get_text() for t in ex.ax_cost.texts)
    ex.close()
