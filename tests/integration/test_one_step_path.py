"""One step path: the single env (and its World) and the vector env step, sense and keep their books
through the same functions. Read with ``ast``: each per-robot piece of the step (the move, the battery
and status bookkeeping, the collision test, the sensing rows, the rewards, the distance to go) is
called from exactly the functions listed here, so a second copy of one (a loop of its own in
another module) fails this test. Run: both envs' steps go through those functions, once a step."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

import tin_swarm_env as tse
from tin_swarm_env.env import reward as reward_mod
from tin_swarm_env.env import tin_swarm as tin_swarm_mod
from tin_swarm_env.env import vector as vector_mod
from tin_swarm_env.world import sensing as sensing_mod
from tin_swarm_env.world import world as world_mod

PKG = Path(__file__).resolve().parents[2] / "tin_swarm_env"

# the test references (a plain loop to check the compiled one against) may call the pieces too
REFERENCES = {"world/reference.py", "env/reference.py"}

# piece -> the package functions ("path:function") that call it, and no others
CALLERS = {
    "move1": {"world/step_kernel.py:move_all"},
    "after_move": {"world/step_kernel.py:move_all"},
    "touches": {"world/step_kernel.py:collisions", "world/step_kernel.py:_pairs"},
    "move_all": {"world/step_kernel.py:step_copies"},
    "collisions": {"world/step_kernel.py:step_copies"},
    "step_copies": {"world/world.py:World._step", "env/vector.py:VectorEnv._step"},
    "near_row": {"world/batch_kernels.py:_sense1", "world/sense_kernels.py:entity_row"},
    "entity_row": {"world/batch_kernels.py:_sense1"},
    "mark_out_of_view": {"world/batch_kernels.py:_sense1"},
    "count_breaks": {"world/batch_kernels.py:_sense1"},
    "robot_sight": {"world/batch_kernels.py:_sense2"},
    "gather_breaks": {"world/batch_kernels.py:_sense2"},
    "break_row": {"world/batch_kernels.py:_sense2"},
    "scan_contact": {"world/scan_kernels.py:scan_wedges", "env/observation.py:scan_beams"},
    "scan_wedges": {"world/sense_kernels.py:break_row"},
    "break_scratch": {"world/batch_kernels.py:_sense2"},
    "_near_chunk": {"world/sense_kernels.py:break_row"},
    "_keep_chunk": {"world/sense_kernels.py:break_row"},
    "_sense1": {"world/batch_kernels.py:_sense_passes"},
    "_sense2": {"world/batch_kernels.py:_sense_passes"},
    "_sense_passes": {"world/batch_kernels.py:sense_copies"},
    "sense_copies": {"world/sensing.py:sense", "env/vector.py:VectorEnv._observe"},
    "rewards_kernel": {"env/reward.py:end_step", "env/reward.py:step_rewards"},
    "distance_copies": {"env/reward.py:measure"},
    "_distance_copies": {"env/field_pack.py:distance_copies"},
    "measure": {"env/reward.py:end_step", "env/tin_swarm.py:TinSwarmEnv._measure"},
    "end_step": {"env/tin_swarm.py:TinSwarmEnv._step_arrays", "env/vector.py:VectorEnv._step"},
    "step_scalars": {"world/world.py:World._step", "env/vector.py:VectorEnv.__init__"},
}


def calls() -> dict[str, set[str]]:
    """``{called name: {"path:function" that call it}}`` over the package (attribute calls by their
    attribute's name), the references left out."""
    out: dict[str, set[str]] = {}
    for path in PKG.rglob("*.py"):
        rel = path.relative_to(PKG).as_posix()
        if rel in REFERENCES:
            continue

        def visit(node, where, rel=rel):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    visit(child, f"{where}.{child.name}" if where else child.name)
                    continue
                if isinstance(child, ast.Call):
                    f = child.func
                    name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
                    if name in CALLERS:
                        out.setdefault(name, set()).add(f"{rel}:{where}")
                visit(child, where)

        visit(ast.parse(path.read_text(), str(path)), "")
    return out


def test_each_piece_of_the_step_has_its_one_set_of_callers():
    got = calls()
    for name, want in CALLERS.items():
        assert got.get(name, set()) == want, f"{name} is called from {sorted(got.get(name, ()))}, not {sorted(want)}"


def test_the_ast_reader_sees_a_second_caller(tmp_path, monkeypatch):
    """The check itself: a module of its own calling ``move1`` in a loop is reported."""
    pkg = tmp_path / "tin_swarm_env"
    (pkg / "world").mkdir(parents=True)
    (pkg / "world" / "step_kernel.py").write_text("def move_all():\n    move1()\n")
    (pkg / "world" / "twice.py").write_text("def my_loop():\n    for i in range(3):\n        x = move1(i)\n")
    monkeypatch.setitem(globals(), "PKG", pkg)
    assert calls()["move1"] == {"world/step_kernel.py:move_all", "world/twice.py:my_loop"}


def _spy(monkeypatch, module, name, seen):
    real = getattr(module, name)

    def spy(*a, **k):
        seen.append(f"{module.__name__.rsplit('.', 1)[-1]}.{name}")
        return real(*a, **k)

    monkeypatch.setattr(module, name, spy)


def test_both_envs_step_through_the_same_functions(monkeypatch):
    """One step of the parallel env and one of a two-copy vector env: each calls step_copies,
    sense_copies and end_step once (the parallel env through its World), and end_step measures the
    distance to go once."""
    seen: list[str] = []
    for module, name in ((world_mod, "step_copies"), (sensing_mod, "sense_copies"), (tin_swarm_mod, "end_step"),
                         (vector_mod, "step_copies"), (vector_mod, "sense_copies"), (vector_mod, "end_step"),
                         (reward_mod, "measure")):
        _spy(monkeypatch, module, name, seen)
    env = tse.parallel_env("cliff_goal", n_robots=3)
    env.reset_arrays(seed=0)
    seen.clear()
    env.step_arrays(np.zeros((3, 2)))
    assert sorted(seen) == ["reward.measure", "sensing.sense_copies", "tin_swarm.end_step", "world.step_copies"]
    vec = tse.vector_env("cliff_goal", n_envs=2, n_robots=3, seed=0)
    vec.reset()
    seen.clear()
    vec.step(np.zeros((2, 3, 2)))
    assert sorted(seen) == ["reward.measure", "vector.end_step", "vector.sense_copies", "vector.step_copies"]
