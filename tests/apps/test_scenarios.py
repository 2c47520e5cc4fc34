"""``tin-swarm scenarios`` (apps/scenarios.py): the built-ins listed, ``--copy`` writes one and refuses to
overwrite without ``--force``."""

from __future__ import annotations

from tin_swarm_env.apps.cli import main
from tin_swarm_env.apps.scenarios import Args, scenarios
from tin_swarm_env.scenario.config import list_scenarios


def test_the_listing_is_one_line_per_builtin(capsys):
    assert scenarios(Args()) == 0
    lines = capsys.readouterr().out.splitlines()
    builtin = list_scenarios()
    assert [ln.split()[0] for ln in lines] == list(builtin)
    for ln, (name, desc) in zip(lines, builtin.items()):
        assert ln == f"{name:12s} {desc}"


def test_scenarios_lists_the_builtins(capsys):
    assert main(["scenarios"]) == 0
    out = capsys.readouterr().out
    for name in ("flat", "ramp", "hill", "cliff_goal", "jacksboro", "containment"):
        assert name in out


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
