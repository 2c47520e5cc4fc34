"""research/apf_failures.py (run by hand): the rule firings read from the memory log, the loop test and
the classes, on hand-built logs with exact answers, and one tiny real episode end to end."""

import importlib.util
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from tin_swarm_env.world.state import Reason

ROOT = Path(__file__).resolve().parents[2]


def _study():
    spec = importlib.util.spec_from_file_location("research_apf_failures", ROOT / "research" / "apf_failures.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("research_apf_failures", mod)  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def _circle(laps, r=20.0, steps_per_lap=100):
    a = np.linspace(0.0, 2 * np.pi * laps, int(steps_per_lap * laps) + 1)
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)


def test_a_track_driven_twice_round_a_circle_is_a_loop_at_the_first_repeat():
    af = _study()
    p = _circle(2.0)  # 125.7 m a lap, 100 steps a lap
    step = 2 * 20 * np.sin(np.pi / 100)  # the chord of one step
    t, j, path = af.loop_in_search(p, 0)
    # within near_m (4 m) of step 0's place, going the same way: 3 steps (3.8 m of chord) short of a lap
    assert (t, j) == (97, 0) and abs(path - 97 * step) < 1e-6
    # the same circle, once: no loop; a straight line: no loop
    assert af.loop_in_search(_circle(0.9), 0) is None
    assert af.loop_in_search(np.stack([np.arange(300.0), np.zeros(300)], axis=-1), 0) is None


def test_a_turn_back_between_the_two_passes_is_no_loop():
    af = _study()
    out_ = np.stack([np.arange(0.0, 100.0), np.zeros(100)], axis=-1)
    back = out_[::-1]
    again = out_
    p = np.concatenate([out_, back, again])  # out, back past the start, out again the same way
    assert af.loop_in_search(p, 0) is not None  # passes its places again the same way ...
    assert af.loop_in_search(p, 0, breaks=[100, 200]) is None  # ... but it turned in between: a search, no loop
    # a loop after the last turn is still found (a circle 50 m off the line, from step 300 on)
    q = np.concatenate([p, _circle(2.0) + [50.0, 50.0]])
    assert af.loop_in_search(q, 0, breaks=[100, 200])[:2] == (397, 300)


def _log(af, rows: dict, pos, reasons, fields, stalled=None):
    n_t = len(pos)
    mem = {k: np.zeros((n_t, 1)) for k in af.FIELDS}
    for k, v in rows.items():
        mem[k][:, 0] = v
    out = SimpleNamespace(reasons=np.array(reasons, dtype=np.int8), n_robots=1,
                          stalled=np.array([False] if stalled is None else stalled),
                          looping=np.array([False]))
    return af.Log(np.asarray(pos, dtype=float)[:, None, :], mem, out, fields, np.array([0]))


class _Field:
    """A stand-in cost-to-go field: the straight-line distance to the origin, inf where x > limit."""

    def __init__(self, limit=np.inf):
        self.limit = limit

    def distance_at(self, xy):
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.where(xy[:, 0] > self.limit, np.inf, np.hypot(xy[:, 0], xy[:, 1]))


def test_events_read_each_rule_from_two_consecutive_memory_copies():
    af = _study()
    #         t: 0  1  2   3   4  5  6  7   8
    side = [0, 0, 1, 1, -1, -1, 0, 1, 0]
    rec = [np.inf, np.inf, 50, 50, 50, 50, 50, 50, 50]
    ended_first = [0, 0, 0, 0, 1, 1, 1, 1, 1]
    unreach = [0, 0, 0, 0, 0, 0, 0, 0, 1]
    gap = [0, 0, 0, 1, 2, 2, 0, 0, 0]
    pos = np.stack([np.arange(9.0), np.zeros(9)], axis=-1)
    lg = _log(af, {"side": side, "rec": rec, "ended_first": ended_first, "unreachable": unreach, "gap": gap},
              pos, [Reason.TIMEOUT], (_Field(),))
    ev = [(t, name) for t, name, _, _ in af.events(lg, 0, stall_steps=20)]
    assert ev == [(2, "fresh"), (3, "gap"), (4, "end-border"), (6, "leave"), (7, "resume"),
                  (8, "unreachable-circuit")]
    # a turn with no side newly ended is the budget's; one after a full stall count is a stall's end
    side = [0, 1, 1, -1]
    lg = _log(af, {"side": side, "rec": [np.inf, 9, 9, 9]}, pos[:4], [Reason.TIMEOUT], (_Field(),))
    assert [e[1] for e in af.events(lg, 0, 20)] == ["fresh", "budget"]
    lg = _log(af, {"side": side, "rec": [np.inf, 9, 9, 9], "ended_other": [0, 0, 0, 1], "stall": [0, 0, 19, 0]},
              pos[:4], [Reason.TIMEOUT], (_Field(),))
    assert [e[1] for e in af.events(lg, 0, 20)] == ["fresh", "end-stall"]


def test_classes_false_and_true_unreachable_and_the_first_side():
    af = _study()
    n_t = 60
    # robot walks from (100, 0) toward x = 160 (away from the target at the origin), says unreachable
    pos = np.stack([100.0 + np.arange(n_t), np.zeros(n_t)], axis=-1)
    side = np.r_[0, np.ones(n_t - 2), 0]
    rec = np.r_[np.inf, np.full(n_t - 1, 100.0)]
    unreach = np.r_[np.zeros(n_t - 1), 1]
    rows = {"side": side, "rec": rec, "unreachable": unreach}
    r = af.classify(_log(af, rows, pos, [Reason.TIMEOUT], (_Field(),)), 0, 20)
    assert r["cls"] == "c-false-unreachable" and r["H_step"] == 1 and r["first_right"] is False
    r = af.classify(_log(af, rows, pos, [Reason.TIMEOUT], (_Field(limit=150.0),)), 0, 20)
    assert r["cls"] == "f-true-unreachable"  # it ends at x = 159: the map does not reach it either
    # the same walk still following at the end, never turned: the long way, budget not spent
    rows = {"side": np.r_[0, np.ones(n_t - 1)], "rec": rec}
    r = af.classify(_log(af, rows, pos, [Reason.TIMEOUT], (_Field(),)), 0, 20)
    assert r["cls"] == "a-no-turn"
    # walking toward the target instead: the first side is the short way
    r = af.classify(_log(af, rows, pos[::-1] - [100.0, 0.0], [Reason.TIMEOUT], (_Field(),)), 0, 20)
    assert r["first_right"] is True and r["cls"] == "a-right-side"
    r = af.classify(_log(af, rows, pos, [Reason.FELL], (_Field(),)), 0, 20)
    assert r["cls"] == "fell"
    r = af.classify(_log(af, rows, pos, [Reason.TIMEOUT], (_Field(),), stalled=[True]), 0, 20)
    assert r["cls"] == "d-stalled"


def test_a_follower_circling_after_its_hit_point_is_a_loop():
    af = _study()
    c = _circle(3.0) + [200.0, 0.0]
    n_t = len(c)
    rows = {"side": np.r_[0, np.ones(n_t - 1)], "rec": np.r_[np.inf, np.full(n_t - 1, 150.0)]}
    r = af.classify(_log(af, rows, c, [Reason.TIMEOUT], (_Field(),)), 0, 20)
    assert r["cls"] == "b-loop" and r["loop"][0] - r["loop"][1] == 97


def test_one_tiny_episode_end_to_end(tmp_path):
    af = _study()
    out = tmp_path / "f.md"
    res = af.main(["--families", "trap", "--seeds", "1", "--robots", "3", "--out", str(out)])
    assert res["_n"] == {"trap": 3}
    text = out.read_text()
    assert "| robots | 3 |" in text and "did not arrive, all" in text
    for _, _, r in res["trap"]:  # every robot that did not arrive has a class
        assert r["cls"] in af.CLASSES


def test_a_lap_early_on_then_a_long_straight_drive_is_no_loop_at_the_end():
    af = _study()
    lap = _circle(1.5)  # one and a half laps, then 700 m straight on
    line = lap[-1] + np.stack([np.arange(1.0, 701.0), np.zeros(700)], axis=-1)
    p = np.concatenate([lap, line])
    n_t = len(p)
    rows = {"side": np.r_[0, np.ones(n_t - 1)], "rec": np.r_[np.inf, np.full(n_t - 1, 1000.0)]}
    r = af.classify(_log(af, rows, p, [Reason.TIMEOUT], (_Field(),)), 0, 20)
    assert r["loop"] is None and r["cls"] != "b-loop"
    assert af.loop_in_search(p, 0) is not None  # the lap is there, but not in the last LOOP_WINDOW steps
