"""CLI polish and the file-safety pieces behind it: help and defaults on every option,
--version, --debug, ``scenarios --copy``, eval's default output and up-front checks, policy
directories, atomic writes that keep permissions and clean up, GIF/MP4 frames streamed to disk,
the typed ``parallel_env`` signature and the no-display warning."""

from __future__ import annotations

import argparse
import inspect
import os
import stat

import numpy as np
import pytest

import tin_swarm_env as tse
from tin_swarm_env._atomic import atomic_path
from tin_swarm_env.apps.cli import build_parser, main


def _subparsers(p):
    act = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction))
    return act.choices


def test_every_option_of_every_subcommand_has_help_and_shows_its_default():
    p = build_parser()
    assert isinstance(p.formatter_class, type) and issubclass(p.formatter_class, argparse.ArgumentDefaultsHelpFormatter)
    for name, sp in _subparsers(p).items():
        assert issubclass(sp.formatter_class, argparse.ArgumentDefaultsHelpFormatter), name
        text = sp.format_help()
        for a in sp._actions:
            if isinstance(a, argparse._HelpAction):
                continue
            assert a.help and a.help != argparse.SUPPRESS, (name, a.dest)
            if a.default not in (None, False, []) and a.option_strings:
                assert f"(default: {a.default})" in " ".join(text.split()), (name, a.dest)


def test_version_and_debug(capsys, monkeypatch):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"tin-swarm {tse.__version__}"
    assert main(["run", "atlantis", "--quiet"]) == 2
    with pytest.raises(tse.errors.ScenarioError):
        main(["--debug", "run", "atlantis", "--quiet"])
    monkeypatch.setenv("TIN_SWARM_DEBUG", "1")
    with pytest.raises(tse.errors.ScenarioError):
        main(["run", "atlantis", "--quiet"])


def test_scenarios_copy_writes_the_builtin_and_refuses_to_overwrite(tmp_path, capsys):
    from tin_swarm_env.scenario.config import SCENARIO_DIR, load_scenario

    ramp = (SCENARIO_DIR / "ramp.toml").read_bytes()
    assert main(["scenarios", "--copy", "ramp", str(tmp_path)]) == 0  # into a directory: ramp.toml
    assert (tmp_path / "ramp.toml").read_bytes() == ramp
    dest = tmp_path / "mine.toml"
    dest.write_text("keep me")
    assert main(["scenarios", "--copy", "ramp", str(dest)]) == 2
    assert dest.read_text() == "keep me" and "--force" in capsys.readouterr().err
    assert main(["scenarios", "--copy", "ramp", str(dest), "--force"]) == 0
    assert dest.read_bytes() == ramp
    assert load_scenario(dest).name == "mine"  # the name comes from the file (no name key in the built-ins)


def test_eval_default_output_is_named_after_the_scenarios(tmp_path, monkeypatch, capsys):
    from tin_swarm_env.apps.evaluate import default_out

    assert default_out(["cliff_goal", "ramp"]) == os.path.join("runs", "eval_cliff_goal_ramp")
    assert default_out(["dir/my.toml"]) == os.path.join("runs", "eval_my")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "tiny.toml").write_text('max_cycles = 5\n[terrain]\nsource = "flat"\nsize_m = [60.0, 60.0]\n'
                                        '[robots]\ncount = 2\n[targets]\npositions = [[50.0, 30.0]]\n')
    assert main(["eval", "tiny.toml", "--seeds", "2", "--policies", "apf,RANDOM"]) == 0
    md = (tmp_path / "runs" / "eval_tiny.md").read_text()
    assert "| tiny.toml | apf |" in md and "| tiny.toml | random |" in md
    assert (tmp_path / "runs" / "eval_tiny.csv").exists() and (tmp_path / "runs" / "eval_tiny.png").exists()


def test_eval_checks_models_before_the_first_episode(tmp_path, monkeypatch, capsys):
    import tin_swarm_env.apps.evaluate as ev

    def no_episodes(*a, **k):
        raise AssertionError("an episode ran before the options were checked")

    monkeypatch.setattr(ev, "rollout", no_episodes)
    assert main(["eval", "flat", "--model", str(tmp_path / "nope"), "--out", str(tmp_path / "e")]) == 2
    assert "--model" in capsys.readouterr().err
    (tmp_path / "m.zip").write_bytes(b"PK")
    assert main(["eval", "flat", "--model", str(tmp_path / "m.zip"), "--out", str(tmp_path / "e")]) == 2
    assert "--trust-pickle" in capsys.readouterr().err
    assert main(["eval", "flat", "--out", str(tmp_path / "no" / "e")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert not list(tmp_path.glob("e.*"))


def test_run_takes_a_pickle_free_policy_directory(tmp_path, capsys):
    from tin_swarm_env.policies import save_policy

    env = tse.parallel_env(scenario="flat", n_robots=2)
    d = env.layout.size
    rng = np.random.default_rng(0)
    save_policy(tmp_path / "pol", [(rng.normal(size=(8, d)), np.zeros(8)), (rng.normal(size=(2, 8)), np.zeros(2))],
                layout=env.layout, scenario="flat")
    assert main(["run", "flat", "--policy", str(tmp_path / "pol"), "--robots", "2", "--max-cycles", "4",
                 "--quiet"]) == 0
    assert "policy " + str(tmp_path / "pol") in capsys.readouterr().out
    from tin_swarm_env.apps.policy_factory import make_policy
    from tin_swarm_env.policies import MLPPolicy

    assert isinstance(make_policy(env, str(tmp_path / "pol" / "policy.json")), MLPPolicy)
    assert type(make_policy(env, "Random", seed=0)).__name__ == "RandomPolicy"


def test_atomic_write_keeps_permissions_and_cleans_up_on_ctrl_c(tmp_path):
    p = tmp_path / "secret.md"
    p.write_text("old")
    os.chmod(p, 0o600)
    with atomic_path(p) as tmp:
        with open(tmp, "w") as fh:
            fh.write("new")
    assert p.read_text() == "new" and stat.S_IMODE(p.stat().st_mode) == 0o600
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(p) as tmp:
            with open(tmp, "w") as fh:
                fh.write("half")
            assert os.path.basename(tmp).startswith(".secret.md.") and ".part" in tmp
            raise KeyboardInterrupt
    assert sorted(os.listdir(tmp_path)) == ["secret.md"] and p.read_text() == "new"


def test_run_hands_frames_to_the_writer_without_keeping_them(tmp_path):
    from tin_swarm_env.apps.run import run_episodes

    got = []
    stats, frames = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False,
                                 render_width=64, on_frame=lambda f: got.append(f.shape))
    assert frames == [] and len(got) == 4 and got[0][1] == 64  # steps 0, 2, 4 and the end
    _, kept = run_episodes("flat", robots=2, max_cycles=6, frames_every=2, progress=False, render_width=64)
    assert len(kept) == 4


def test_progress_bar_is_tqdm():
    import tqdm

    from tin_swarm_env.apps.run import progress_bar

    bar = progress_bar(10, "x")
    assert isinstance(bar, tqdm.tqdm)
    bar.close()
    assert progress_bar(10, "x", enabled=False) is None


def test_parallel_env_has_the_constructor_s_typed_signature():
    from tin_swarm_env.env.tin_swarm import TinSwarmEnv, parallel_env

    want = dict(inspect.signature(TinSwarmEnv.__init__).parameters)
    want.pop("self")
    got = dict(inspect.signature(parallel_env).parameters)
    assert list(got) == list(want)
    for k in want:
        assert (got[k].default, got[k].annotation, got[k].kind) == (want[k].default, want[k].annotation,
                                                                     want[k].kind), k


def test_human_render_without_a_display_warns(monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    env = tse.parallel_env(scenario="flat", n_robots=2, render_mode="human", render_width=64)
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="no display"):
        env.render()
    env.close()


def test_recipe_parameters_are_checked_by_type_and_range():
    from tin_swarm_env.errors import ScenarioError
    from tin_swarm_env.scenario.terrains import make_dem

    assert make_dem("ridge", {"width": 20, "height": 10.0, "cell": 2}).z.shape == (6, 11)
    bad = [("hills", {"n_hills": 2.5}, "n_hills must be an integer"), ("hills", {"seed": -1}, "seed must be"),
           ("cliff_goal", {"hill_xy": [1.0]}, "hill_xy must be a list of 2"),
           ("cliff_goal", {"hill_sd_m": 0}, "hill_sd_m must be a finite number > 0"),
           ("ridge", {"ridge_m": float("nan")}, "ridge_m must be a finite"), ("ridge", {"cell": True}, "cell"),
           ("canyon", {"travel": 3}, "travel must be a string"), ("canyon", {"travel": "north"}, "east' or 'west"),
           ("ramp", {"ramp_end_x": 10.0}, "ramp_end_x > ramp_start_x")]
    for recipe, params, msg in bad:
        with pytest.raises(ScenarioError, match=msg):
            make_dem(recipe, params, "f.toml [terrain]")
