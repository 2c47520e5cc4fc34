"""The per-robot sensing reference itself (world/reference.py) on hand-built scenes with exact answers;
the batched sensing is compared against it in tests/world/test_sensing.py."""

from __future__ import annotations

import math

import numpy as np

from tin_swarm_env.terrain import Tin
from tin_swarm_env.world import Reason, World
from tin_swarm_env.world.reference import reference_sense


def test_the_reference_sees_by_range_field_of_view_and_status(world_params):
    w = World(None, world_params(sensor={"range_m": 30, "fov_deg": 180}))
    # 0 faces east: 1 is 20 m ahead, 2 is 40 m ahead (out of range); 1 faces west: sees 0 only;
    # 2 faces east: 1 is behind it
    s = w.reset(0, [[100, 100], [120, 100], [140, 100]], headings=[0.0, math.pi, 0.0],
                targets=[[110, 100], [90, 100]])
    robots, targets, assets, breaks = reference_sense(w, s)
    assert robots == {(0, 1), (1, 0)}
    assert targets == {(0, 0), (1, 0), (1, 1)} and assets == set() and breaks == set()
    s.status[1] = Reason.BATTERY  # present, seen, but blind
    assert reference_sense(w, s)[0] == {(0, 1)}
    s.status[1] = Reason.FELL  # gone
    assert reference_sense(w, s)[0] == set()


def test_only_the_max_candidates_nearest_are_candidates(world_params):
    w = World(None, world_params(sensor={"range_m": 30, "fov_deg": 180, "max_candidates": 1}))
    # robot 0 faces east; its nearest (5 m) is behind it, so the one ahead (10 m) is never checked
    s = w.reset(0, [[100, 100], [95, 100], [110, 100]], headings=[0.0, math.pi, math.pi])
    assert {p for p in reference_sense(w, s)[0] if p[0] == 0} == set()
    w = World(None, world_params(sensor={"range_m": 30, "fov_deg": 180, "max_candidates": 2}))
    assert {p for p in reference_sense(w, s)[0] if p[0] == 0} == {(0, 2)}


def test_a_ridge_hides_robots_and_entities_unless_sight_is_not_checked(world_params):
    xy = np.array([[0, 0], [0, 100], [50, 0], [50, 100], [100, 0], [100, 100]], float)
    ridge = Tin.from_points(np.column_stack([xy, [0, 0, 10, 10, 0, 0]]))
    pos, tgt = [[20, 50], [80, 50]], [[80, 40]]
    for los, seen in ((True, set()), (False, {(0, 1), (1, 0)})):
        w = World(ridge, world_params(sensor={"range_m": 100, "fov_deg": 360, "check_los": los}))
        robots, targets, _, _ = reference_sense(w, w.reset(0, pos, targets=tgt))
        assert robots == seen and targets == ({(1, 0)} if los else {(0, 0), (1, 0)})


def test_breaks_within_range_of_the_closest_point_of_their_segment(world_params, cliff_tin):
    w = World(cliff_tin(width=5.0), world_params(sensor={"range_m": 30}))
    assert len(w.breaks.segments) > 0
    s = w.reset(0, [[50.0, 50.0], [80.0, 50.0]])
    breaks = reference_sense(w, s)[3]
    # robot 0 is 50 m from the cliff edge (x = 100): none; robot 1 is 20 m from it: the breaks whose
    # segment comes within 30 m
    want = set()
    for j, seg in enumerate(w.breaks.segments):
        a, b = seg[0, :2], seg[1, :2]
        u = np.clip(np.dot(s.positions[1] - a, b - a) / np.dot(b - a, b - a), 0, 1)
        if np.hypot(*(s.positions[1] - (a + u * (b - a)))) <= 30.0:
            want.add((1, j))
    assert want and breaks == want
    assert all(w.breaks.segments[j][:, 0].min() >= 100.0 - 1e-9 for _, j in want)
