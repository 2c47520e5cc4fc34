"""No import circle inside the package: the graph of which module imports which (every import
statement, module-level or inside a function, read with ``ast``; package ``__init__`` re-exports
left out) has no cycle. Before this test, scenario/config.py and scenario/generators.py imported
each other (one of them inside a function). Imports flow one way, down the layers of DESIGN.md
(:data:`LAYERS`): no subpackage imports one of a higher layer, and the training library imports no
``apps`` module (it is importable without the CLI)."""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[2] / "tin_swarm_env"


def _modules() -> dict[str, Path]:
    out = {}
    for p in PKG.rglob("*.py"):
        parts = p.relative_to(PKG.parent).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p
    return out


def import_graph() -> dict[str, set[str]]:
    """``{module: modules of the package it imports}`` over the non-``__init__`` modules."""
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        if path.name == "__init__.py":
            continue
        package = name.split(".")[:-1]
        deps = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom):
                base = ".".join(package[: len(package) - node.level + 1] + [node.module or ""]).rstrip(".") \
                    if node.level else node.module
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in mods else base for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            else:
                continue
            deps |= {t for t in targets if t in mods and t != name and mods[t].name != "__init__.py"}
        graph[name] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        x = stack.pop()
                        on.discard(x)
                        comp.append(x)
                        if x == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
            elif w not in index:
                index[w] = low[w] = counter[0]
                counter[0] += 1
                stack.append(w)
                on.add(w)
                work.append((w, iter(sorted(graph[w]))))
            elif w in on:
                low[v] = min(low[v], index[w])
    return out


def test_the_cycle_finder_finds_a_circle_and_a_longer_one():
    assert cycles({"a": {"b"}, "b": {"a"}, "c": set()}) == [["a", "b"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_the_graph_sees_relative_and_lazy_imports():
    g = import_graph()
    assert "tin_swarm_env.scenario.generators" in g["tin_swarm_env.scenario.config"]  # from .generators import
    assert "tin_swarm_env.scenario.generators" in g["tin_swarm_env.scenario.build"]  # inside a function
    assert "tin_swarm_env.terrain.dem" in g["tin_swarm_env.scenario.generators"] or \
        "tin_swarm_env.errors" in g["tin_swarm_env.scenario.generators"]


# Circles allowed for now, each with the reason (none: policies/learned.py <-> recurrent.py was
# broken up by policies/network.py).
KNOWN: list[list[str]] = []


def test_no_module_of_the_package_imports_itself_through_others():
    found = cycles(import_graph())
    assert [c for c in found if c not in KNOWN] == []
    scenario = [c for c in found if any(m.startswith("tin_swarm_env.scenario.") for m in c)]
    assert scenario == []
    assert "tin_swarm_env.scenario.config" not in import_graph()["tin_swarm_env.scenario.generators"]


def private_imports() -> list[str]:
    """``module: from X import _name`` for every private name (leading underscore) a module of the
    package imports from another module of it; a private *module* (``from . import _kernels``) is
    not a private name."""
    mods = _modules()
    out = []
    for name, path in mods.items():
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not isinstance(node, ast.ImportFrom) or node.module == "__future__":
                continue
            base = ".".join(package[: len(package) - node.level + 1] + [node.module or ""]).rstrip(".") \
                if node.level else node.module
            if not (base or "").startswith("tin_swarm_env"):
                continue
            for a in node.names:
                if a.name.startswith("_") and not a.name.startswith("__") and f"{base}.{a.name}" not in mods:
                    out.append(f"{name}: from {base} import {a.name}")
    return out


def test_no_module_imports_a_private_name_of_another():
    assert private_imports() == []


def test_the_private_import_finder_sees_one(tmp_path, monkeypatch):
    pkg = tmp_path / "tin_swarm_env"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "_kernels.py").write_text("def _k(): pass\n")
    (pkg / "sub" / "a.py").write_text("from __future__ import annotations\nfrom . import _kernels\nfrom ._kernels import _k\n")
    monkeypatch.setitem(globals(), "PKG", pkg)  # _modules() reads the module global PKG
    assert private_imports() == ["tin_swarm_env.sub.a: from tin_swarm_env.sub._kernels import _k"]


# The subpackages in layer order (DESIGN.md); a module may import its own layer and those below.
# The top-level helpers (errors, options, _atomic, _safe_json, _registration) are not in a layer.
LAYERS = (("terrain",), ("world",), ("scenario",), ("env", "adapters", "policies"), ("training",), ("apps",))


def layer_of(module: str) -> int | None:
    """The index in :data:`LAYERS` of ``tin_swarm_env.<sub>...``'s subpackage (None: a top-level module)."""
    parts = module.split(".")
    sub = parts[1] if len(parts) > 2 else None
    return next((i for i, names in enumerate(LAYERS) if sub in names), None)


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """``module -> imported`` for every import of a module of a higher layer than the importer's."""
    out = []
    for name, deps in sorted(graph.items()):
        a = layer_of(name)
        for d in sorted(deps):
            b = layer_of(d)
            if a is not None and b is not None and b > a:
                out.append(f"{name} -> {d}")
    return out


def test_the_layer_finder_sees_an_upward_import():
    graph = {"tin_swarm_env.training.x": {"tin_swarm_env.apps.cli", "tin_swarm_env.env.vector"},
             "tin_swarm_env.apps.cli": {"tin_swarm_env.training.x"}, "tin_swarm_env.errors": {"tin_swarm_env.apps.cli"}}
    assert upward_imports(graph) == ["tin_swarm_env.training.x -> tin_swarm_env.apps.cli"]
    assert layer_of("tin_swarm_env.training.sb3") == LAYERS.index(("training",))
    assert layer_of("tin_swarm_env.training") == layer_of("tin_swarm_env.options") is None


def test_imports_flow_down_the_layers_and_training_sits_between_env_and_apps():
    graph = import_graph()
    assert upward_imports(graph) == []
    subs = {m.split(".")[1] for m in graph if m.count(".") > 1}
    assert subs == {n for names in LAYERS for n in names}  # every subpackage has its layer
    order = [names for names in LAYERS]
    assert order.index(("env", "adapters", "policies")) < order.index(("training",)) < order.index(("apps",))


def test_training_imports_no_apps_module():
    graph = import_graph()
    training = {m: deps for m, deps in graph.items() if m.startswith("tin_swarm_env.training.")}
    assert {"tin_swarm_env.training.sb3", "tin_swarm_env.training.rollout", "tin_swarm_env.training.checkpoint",
            "tin_swarm_env.training.imitation", "tin_swarm_env.training.evaluation"} <= set(training)
    assert {m: sorted(d for d in deps if d.startswith("tin_swarm_env.apps")) for m, deps in training.items()
            if any(d.startswith("tin_swarm_env.apps") for d in deps)} == {}
    # and the commands do call it: apps/train.py is a command over training/sb3.py
    assert "tin_swarm_env.training.sb3" in graph["tin_swarm_env.apps.train"]
