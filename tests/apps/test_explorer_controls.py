"""The field explorer's controls (apps/explorer_controls.py), driven headless (Agg): clicking picks and
selects a robot, dragging moves a robot or a threat, the "add robot" button then a click adds one,
a placement off traversable ground is refused with the reason, and "continuous" steps on the
timer until unchecked."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backend_bases import MouseEvent  # noqa: E402

from tin_swarm_env.apps.explorer import FieldExplorer  # noqa: E402


@pytest.fixture
def ex():
    e = FieldExplorer("ramp", robot=0, n_robots=6, grid=21)
    yield e
    e.close()


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


def test_a_refused_placement_says_why_and_changes_nothing(whole):
    ex = whole
    p = ex.env.world_state.positions.copy()
    ex.add_robot((1e6, 1e6))
    assert "refused" in ex.status and "outside the terrain" in ex.status
    assert ex.env.n == 6
    np.testing.assert_array_equal(ex.env.world_state.positions, p)
