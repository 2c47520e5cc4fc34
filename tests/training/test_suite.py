"""The standard evaluation suite's definition (tin_swarm_env/training/suite.py): its figures are
averaged as documented, its splits are the table the docs show, and they hold out what the shipped
policy did not train on."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from tin_swarm_env.training import suite as S
from tin_swarm_env.training.evaluation import EVAL_SEED0

ROOT = Path(__file__).resolve().parents[2]


def _ep(arrived, fell=0.0, stuck=0.0, steps=()):
    return {"arrived": arrived, "fell": fell, "stuck": stuck, "steps": np.asarray(steps, dtype=float)}


def test_leaderboard_figures_are_averaged_as_documented():
    splits = (S.Split("a", "A", "", ()), S.Split("b", "B", "", ()))
    by = {("a", ""): [_ep(1.0, steps=[10, 20]), _ep(0.5, fell=0.5, steps=[30])],  # split a: 0.75 arrived
          ("a", "ns"): [_ep(0.5, stuck=0.5, steps=[40])],                        # mirrored a: 0.5
          ("b", ""): [_ep(0.0, stuck=1.0)],                                      # split b: 0
          ("b", "ns"): [_ep(0.25, steps=[50]), _ep(0.25, fell=0.25, steps=[60])]}  # mirrored b: 0.25
    r = S.leaderboard("p", splits, by, 12.34)
    assert r["a"] == 0.75 and r["b"] == 0.0
    assert r["mirrored"] == pytest.approx((0.5 + 0.25) / 2)
    assert r["mirror_gap"] == pytest.approx(0.375 - 0.375)
    assert r["arrived"] == pytest.approx((0.75 + 0.5 + 0.0 + 0.25) / 4)
    assert r["fell"] == pytest.approx((0.25 + 0.0 + 0.0 + 0.125) / 4)
    assert r["stuck"] == pytest.approx((0.0 + 0.5 + 1.0 + 0.0) / 4)
    assert r["median_steps"] == 35.0  # over every arrived robot: 10 20 30 40 50 60
    assert r["seconds"] == 12.3
    md = S.leaderboard_markdown([r], splits)
    assert md.splitlines()[2] == "| p | 37.5 | 9.4 | 37.5 | 35 | 75.0 | 0.0 | 37.5 | +0.0 | 12 |"
    assert len(md.splitlines()[0].split("|")) == len(md.splitlines()[1].split("|"))


def test_the_split_table_is_the_one_the_docs_show():
    spec = importlib.util.spec_from_file_location("gen_tables", ROOT / "docs" / "gen_tables.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    shown = (ROOT / "docs" / "generated" / "suite_splits.md").read_text()
    assert shown == gen.HEADER + S.splits_markdown()
    page = (ROOT / "docs" / "baselines.md").read_text()
    for include in ('--8<-- "docs/generated/suite_splits.md"', '--8<-- "docs/figures/standard_suite.md"',
                    "::: tin_swarm_env.training.suite"):
        assert include in page
    for s in S.SPLITS:
        for m in s.maps:
            assert f"| {m.label} |" in shown
    n = sum(m.seeds for s in S.SPLITS for m in s.maps) * len(S.PLAYED)
    assert f"{n} episodes per policy" in shown and f"{n} episodes per policy" in S.__doc__


def test_the_splits_hold_out_what_the_shipped_policy_did_not_train_on():
    from tin_swarm_env.scenario.generators import ALL_FAMILIES, EXTRA_FAMILIES, PARAMS, REAL_FAMILIES
    from tin_swarm_env.scenario.mirror import reflect_region, reflect_xy, terrain_bounds

    recipe = (ROOT / "agents" / "reproduce_shared.sh").read_text()
    assert "--scenario $TRAIN,$TRAIN,cliff_goal,ramp" in recipe
    assert "TRAIN=agents/scenarios/train_generated_extra.toml" in recipe  # the training families (test_held_out.py)
    by_key = {s.key: s for s in S.SPLITS}
    train = {f for m in by_key["train_seeds"].maps for f in m.families}
    held = {f for m in by_key["held_out"].maps for f in m.families}
    assert train == {"canyon", "mesa", "hills"} and held == {"fork", "trap", "realdem"}
    # every family is trained on, held out, or one of the opt-in synthetic ones (drawn only where named)
    assert train | held | set(EXTRA_FAMILIES) == set(PARAMS) and not train & held
    assert set(ALL_FAMILIES) <= train | held and not held & set(EXTRA_FAMILIES)
    # the shipped recipe trains on the train split's families and the opt-in ones (bay, rough), none held out
    from tin_swarm_env.scenario import load_scenario

    trained = load_scenario(str(ROOT / "agents" / "scenarios" / "train_generated_extra.toml")).terrain.families
    assert set(trained) == train | set(EXTRA_FAMILIES)
    # no training recipe draws realdem: the recipes name no family, so they draw the default mix, which lacks it
    for recipe_file in sorted((ROOT / "agents").glob("*.sh")) + sorted((ROOT / "agents").glob("*.py")):
        assert "realdem" not in recipe_file.read_text(), recipe_file
    assert set(REAL_FAMILIES).isdisjoint(ALL_FAMILIES) and set(REAL_FAMILIES) <= held
    assert not {m.scenario for m in by_key["held_out"].maps} & {"cliff_goal", "ramp"}  # trained on
    assert [m.scenario for m in by_key["dem"].maps] == ["jacksboro"]
    assert {m.scenario for m in by_key["thesis"].maps} == {"cliff_goal", "ramp", "hill"}
    assert S.PLAYED == ("", "ns")
    for s in S.SPLITS:  # every map loads, both ways, and its mirror image is a mirror image
        for m in s.maps:
            cfg, mir = S.map_config(m), S.map_config(m, "ns")
            assert mir.terrain.mirror == "ns" and cfg.terrain.mirror == ""
            assert cfg.terrain.families == (tuple(m.families) if m.families else cfg.terrain.families)
            if cfg.terrain.source != "generated":
                b = terrain_bounds(cfg)
                assert np.array_equal(mir.targets.positions, reflect_xy(cfg.targets.positions, "ns", b))
                assert mir.robots.spawn_region == reflect_region(cfg.robots.spawn_region, "ns", b)
    assert EVAL_SEED0 == 1_000_000
