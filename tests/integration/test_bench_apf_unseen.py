"""bench/apf_unseen.py's shapes (run by hand; its --quick run is in test_bench_quick.py): each, as built
and mirrored, is a solvable detour. The target is reachable on the cost-to-go field from the spawn
region's centre and corners, and the straight line from the spawn to the target crosses ground the robots
cannot drive of the kind the bench says (hillside under 60 deg, cliff over it)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _bench():
    mod = sys.modules.get("bench_apf_unseen")
    if mod is None:
        spec = importlib.util.spec_from_file_location("bench_apf_unseen", ROOT / "bench" / "apf_unseen.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules["bench_apf_unseen"] = mod
        spec.loader.exec_module(mod)
    return mod


BENCH = _bench()


def test_at_least_eight_shapes_each_with_its_ground():
    assert len(BENCH.SHAPES) >= 8
    assert set(BENCH.GROUND) == set(BENCH.SHAPES)
    kinds = set(BENCH.GROUND.values())
    assert {"cliff", "hillside"} <= kinds  # cliffs and too-steep hillside both


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("apf_unseen")


@pytest.mark.parametrize("image", ["", "ns"])
@pytest.mark.parametrize("shape", list(BENCH.SHAPES))
def test_shape_is_solvable_and_its_straight_way_blocked(shape, image, folder):
    sol = BENCH.solvability(BENCH.shape_config(shape, folder, image))
    assert np.isfinite(sol["way_m"]) and np.all(np.isfinite(sol["corners_m"])), f"{shape}: target unreachable"
    assert sol["blocked"] > 0, f"{shape}: the straight line crosses no ground the robots cannot drive"
    assert sol["way_m"] > sol["straight_m"]
    ground = BENCH.GROUND[shape]
    if ground in ("hillside", "both"):
        assert sol["hillside"] > 0, f"{shape}: no too-steep hillside on the straight line"
    if ground == "hillside":
        assert sol["cliff"] == 0, f"{shape}: a cliff on the straight line of a hillside shape"
    if ground in ("cliff", "both"):
        assert sol["cliff"] > 0, f"{shape}: no cliff on the straight line"


def test_mirror_reflects_the_task(folder):
    """The mirror image's spawn region and target are the reflected ones (y -> 300 - y on the 2 m grid)."""
    a, b = BENCH.shape_config("ridge_saddle", folder), BENCH.shape_config("ridge_saddle", folder, "ns")
    x0, y0, x1, y1 = a.robots.spawn_region
    assert b.robots.spawn_region == pytest.approx((x0, BENCH.SIZE_M - y1, x1, BENCH.SIZE_M - y0))
    (tx, ty), = a.targets.positions
    assert b.targets.positions[0] == pytest.approx((tx, BENCH.SIZE_M - ty))
    assert b.terrain.mirror == "ns"


def test_another_tin_method_is_built_and_labelled(folder):
    """``--method`` / ``--only shape@method``: the shape's TIN is built by that method, and its rows say so;
    the default method's rows carry the bare shape name."""
    cfg = BENCH.shape_config("crater", folder, method="robot")
    assert cfg.terrain.method == "robot"
    assert BENCH.shape_config("crater", folder).terrain.method == BENCH.METHOD == "greedy"
    assert BENCH.label("crater", "robot") == "crater (robot TIN)"
    assert BENCH.label("crater") == "crater"


def test_an_unknown_method_after_at_is_refused_by_name(capsys):
    with pytest.raises(SystemExit):
        BENCH.main(["--only", "crater@nosuch", "--quick"])
    assert "nosuch" in capsys.readouterr().err
