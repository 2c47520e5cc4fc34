"""An honest held-out split: no training recipe of the repository trains on a terrain family, map or
seed of the standard suite's held-out split (tin_swarm_env/training/held_out.py), and the check
itself catches each way a recipe could (a generated family, a held-out file, its mirror image, a
copy of its ground)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tin_swarm_env.training.config import Args
from tin_swarm_env.training.evaluation import EVAL_SEED0
from tin_swarm_env.errors import ArgumentError
from tin_swarm_env.training.held_out import (
    expand, held_out_families, held_out_use, recipe_command, recipe_words, same_ground)
from tin_swarm_env.training.suite import SPLITS

ROOT = Path(__file__).resolve().parents[2]
TRAINERS = sorted((ROOT / "agents").glob("train_*.py")) + sorted((ROOT / "research").glob("train_*.py"))
SCRIPTS = sorted((ROOT / "agents").glob("*.sh")) + sorted((ROOT / "research").glob("*.sh"))


def recipe_scenarios() -> dict[str, set[str]]:
    """Every training scenario a recipe names: ``--scenario`` of the shell recipes, the trainers'
    ``scenario`` defaults and fixed ``scenario=`` lists, and the training Args' default."""
    found: dict[str, set[str]] = {}
    for p in SCRIPTS:
        words = recipe_words(p.read_text())
        for i, (w, env) in enumerate(words[:-1]):
            if w == "--scenario":
                for v in expand(words[i + 1][0], env):
                    assert "$" not in v, f"{p.name}: --scenario {words[i + 1][0]!r} is not resolvable here"
                    found.setdefault(p.name, set()).update(v.split(","))
    for p in TRAINERS:
        text = p.read_text()
        consts = dict(re.findall(r'^(\w+) = "([^"]+)"', text, flags=re.M))
        values = re.findall(r'scenario: str = opt\("([^"]+)"', text)
        values += [re.sub(r"\{(\w+)\}", lambda m: consts[m.group(1)], v)
                   for v in re.findall(r'scenario=f?"([^"]+)"', text)]
        for v in values:
            found.setdefault(p.name, set()).update(v.split(","))
    found["training.config.Args"] = set(Args().scenario.split(","))
    return found


def _resolve(s: str) -> str:
    return str(ROOT / s) if "/" in s else s


def test_the_recipes_are_found():
    found = recipe_scenarios()
    for name in ("reproduce_shared.sh", "reproduce_shared_mirror.sh", "train_puffer.py", "train_benchmarl.py",
                 "train_rllib.py", "ablation.sh", "reproduce_ppo.sh", "train_multimodal.py"):
        assert found.get(name), f"no training scenario found for {name}: {found}"
    assert "cliff_goal" in found["reproduce_ppo.sh"] and "ramp" in found["reproduce_ppo.sh"]  # a for loop
    assert "agents/scenarios/train_generated_extra.toml" in found["reproduce_shared.sh"]  # a variable


def test_no_recipe_trains_on_the_held_out_split():
    uses = {(who, s): held_out_use(_resolve(s)) for who, ss in recipe_scenarios().items() for s in sorted(ss)}
    bad = {k: v for k, v in uses.items() if v}
    assert not bad, f"recipes that train on the held-out split: {bad}"


def test_the_recipes_seeds_are_training_seeds():
    seeds = []
    for p in SCRIPTS:
        words = recipe_words(p.read_text())
        seeds += [(p.name, int(v)) for i, (w, _) in enumerate(words[:-1]) if w == "--seed"
                  for v in expand(*words[i + 1])]  # a shell variable's default (SEED=${SEED:-0})
    assert seeds, "no --seed in the recipes"
    assert all(0 <= s < EVAL_SEED0 for _, s in seeds), seeds


def test_the_check_catches_every_way_in():
    assert held_out_families() == {"fork", "trap", "realdem"}
    assert held_out_use("generated") == ["generated families fork, trap"]  # every synthetic family
    assert held_out_use("agents/scenarios/train_generated.toml") == []
    assert held_out_use("agents/scenarios/train_generated_extra.toml") == []  # bay and rough are not held out
    assert held_out_use(str(ROOT / "scenarios/canyon_left.toml")) == ["the ground of held-out map 'canyon_left'"]
    assert held_out_use(str(ROOT / "scenarios/canyon_right.toml")) == [
        "the ground of held-out map 'canyon_left' (its mirror image ns)"]
    assert held_out_use(str(ROOT / "scenarios/valley.toml")) == ["the ground of held-out map 'valley'"]
    for fixed in ("cliff_goal", "ramp", "hill", "jacksboro"):  # other splits' maps: not held out
        assert held_out_use(fixed) == []


def test_a_copy_of_a_held_out_file_elsewhere_is_caught(tmp_path):
    """The ground is compared, not the path: the valley's DEM copied under another name, its
    scenario rewritten around it, and its east-west mirror image."""
    src = ROOT / "scenarios"
    (tmp_path / "ridge.asc").write_bytes((src / "valley.asc").read_bytes())
    text = (src / "valley.toml").read_text().replace('"valley.asc"', '"ridge.asc"')
    (tmp_path / "ridge.toml").write_text(text)
    (tmp_path / "ridge_ew.toml").write_text(text.replace("[terrain]\n", '[terrain]\nmirror = "ew"\n'))
    assert held_out_use(str(tmp_path / "ridge.toml")) == ["the ground of held-out map 'valley'"]
    assert held_out_use(str(tmp_path / "ridge_ew.toml")) == [
        "the ground of held-out map 'valley' (its mirror image ew)"]


@pytest.mark.parametrize("families,caught", [(["canyon", "fork"], ["generated families fork"]),
                                             (["hills"], []), ({"trap": 1.0, "mesa": 0.0}, ["generated families trap"]),
                                             ({"trap": 0.0, "mesa": 1.0}, [])])
def test_generated_families_by_name_and_weight(tmp_path, families, caught):
    from tin_swarm_env.scenario import load_scenario

    cfg = load_scenario(str(ROOT / "agents/scenarios/train_generated.toml")).with_families(families)
    assert held_out_use(cfg) == caught


def test_same_ground_tells_terrains_apart():
    from tin_swarm_env.scenario import load_scenario, mirror_scenario

    left = load_scenario(str(ROOT / "scenarios/canyon_left.toml"))
    right = load_scenario(str(ROOT / "scenarios/canyon_right.toml"))
    assert same_ground(left, left) and not same_ground(left, right)
    assert same_ground(mirror_scenario(left, "ns"), right)
    assert not same_ground(load_scenario("cliff_goal"), load_scenario("ramp"))
    assert [m.label for s in SPLITS if s.key == "held_out" for m in s.maps if not m.families] == ["canyon_left",
                                                                                                    "valley"]


def test_recipe_command_reads_a_hand_built_recipe():
    """Continuation lines, comments, NAME=value, NAME=${NAME:-default}, a for loop, a redirection."""
    text = """#!/usr/bin/env bash
# a comment naming agents/train_x.py --scenario held_out
T=a.toml  # the terrain
PY=${PY:-python}
MIN=${MIN:-7}
for S in cliff_goal ramp; do
  $PY agents/train_x.py --scenario $T,$S \\
    --max-minutes "$MIN" --seed 3 > runs/x.log 2>&1
done
"""
    assert recipe_command(text, "agents/train_x.py") == [
        "--scenario", "a.toml,cliff_goal", "--max-minutes", "7", "--seed", "3"]
    words = recipe_words(text)
    at = [w for w, _ in words].index("--scenario")
    assert expand(words[at + 1][0], words[at + 1][1]) == ["a.toml,cliff_goal", "a.toml,ramp"]
    with pytest.raises(ArgumentError, match="no command runs agents/train_y.py"):
        recipe_command(text, "agents/train_y.py", where="x.sh")
    with pytest.raises(ArgumentError, match="'\\$HOME'"):
        recipe_command("python t.py --out $HOME\n", "t.py")
