"""What the field explorer shows (apps/explorer_view.py), headless (Agg): the field is built from exactly
what the robot senses, the cost-to-go overlay is the selected robot's target's, and the PNG holds no
controls and the whole-terrain cost-to-go map, or says there is no target."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import tin_swarm_env as tse  # noqa: E402
from tin_swarm_env.apps.explorer import FieldExplorer  # noqa: E402


@pytest.fixture
def ex():
    e = FieldExplorer("ramp", robot=0, n_robots=6, grid=21)
    yield e
    e.close()


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
