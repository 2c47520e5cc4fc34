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


def test_explore_steps_beyond_the_episode_are_refused_before_any_step(tmp_path, capsys):
    """``--steps 10**11`` ran on for ever: more steps than the scenario's max_cycles are refused by name."""
    from tin_swarm_env.scenario import load_scenario

    m = load_scenario("flat").max_cycles
    assert main(["explore", "flat", "--png", str(tmp_path / "e.png"), "--robots", "1", "--steps", str(m + 1)]) == 2
    err = capsys.readouterr().err
    assert f"--steps {m + 1}" in err and f"max_cycles = {m}" in err and not (tmp_path / "e.png").exists()
    assert main(["explore", "flat", "--png", str(tmp_path / "e.png"), "--robots", "1", "--steps", "100000000000"]) == 2
    assert "--steps" in capsys.readouterr().err


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


def test_explore_cli_cost_to_go_png(tmp_path):
    out = tmp_path / "ctg.png"
    assert main(["explore", "cliff_goal", "--png", str(out), "--robots", "4", "--cost-to-go"]) == 0
    assert out.stat().st_size > 10_000


def test_selecting_a_robot_that_does_not_exist_names_it(ex):
    from tin_swarm_env.errors import ArgumentError

    with pytest.raises(ArgumentError, match=rf"robot {ex.env.n}: the episode has robots 0\.\.{ex.env.n - 1}"):
        ex.select(ex.env.n)
