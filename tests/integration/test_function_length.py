"""The rules read in small pieces: no function or method in ``tin_swarm_env/`` is over
:data:`MAX_LINES` lines (from its ``def`` line to its last line, docstring and nested definitions
included; a class body is not a function, its methods are). The few functions allowed over it are
listed by name in :data:`ALLOWED`, each with the reason; an entry that is back under the limit (or
gone) must be removed from the list."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "tin_swarm_env"
MAX_LINES = 100

# "path::qualified name" -> why it is still over MAX_LINES. Keep this short; shrink, then delete the entry.
ALLOWED: set[str] = set()


def function_lengths(source: str, filename: str = "<string>") -> dict[str, int]:
    """``qualified name -> lines`` of every function and method (nested ones too: ``outer.inner``,
    ``Class.method``) in ``source``."""
    out: dict[str, int] = {}

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + child.name
                out[name] = child.end_lineno - child.lineno + 1
                visit(child, name + ".")
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(source, filename), "")
    return out


def long_functions(limit: int = MAX_LINES) -> dict[str, int]:
    out = {}
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        for name, n in function_lengths(path.read_text(), rel).items():
            if n > limit:
                out[f"{rel}::{name}"] = n
    return out


def test_lengths_count_def_to_last_line_methods_and_nested_functions_but_not_class_bodies():
    src = "\n".join([
        "class A:",  # a class of 9 lines: not a function
        "    x = 1",
        "    def m(self):",  # 3 lines
        "        '''doc'''",
        "        return 1",
        "    @staticmethod",
        "    def s():",  # 3 lines: the decorator line is not counted
        "        y = 2",
        "        return y",
        "def f(a,",  # 6 lines, signature and nested function included
        "      b):",
        "    def g():",  # 2 lines
        "        return a",
        "    if a:",
        "        return g()",
    ])
    assert function_lengths(src) == {"A.m": 3, "A.s": 3, "f": 6, "f.g": 2}


def test_no_function_in_the_package_is_over_the_limit():
    found = long_functions()
    assert len(list(PKG.rglob("*.py"))) > 50  # the walk sees the package
    over = {k: n for k, n in found.items() if k not in ALLOWED}
    assert over == {}, (f"functions over {MAX_LINES} lines (split them into named helpers):\n"
                        + "\n".join(f"  {k}: {n} lines" for k, n in sorted(over.items())))


def test_every_allowed_long_function_is_still_over_the_limit():
    stale = sorted(ALLOWED - set(long_functions()))
    assert stale == [], ("no longer over the limit (or gone): remove from ALLOWED in "
                         "tests/integration/test_function_length.py:\n" + "\n".join(stale))
