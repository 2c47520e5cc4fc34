"""tests/ mirrors the package: the tests of module ``tin_swarm_env/x/y.py`` are in ``tests/x/test_y.py``
(``tin_swarm_env/y.py``: ``tests/test_y.py``; leading and trailing underscores dropped, so
``terrain/_kernels.py`` -> ``tests/terrain/test_kernels.py`` and ``__main__.py`` -> ``tests/test_main.py``);
cross-cutting tests are in ``tests/integration/``. Every module has its file, every test file outside
``tests/integration/`` names a module, the only other Python files are ``tests/conftest.py`` and the
helper modules under ``tests/helpers/`` (loaded by the conftest), and no test file imports another
test file, the conftest or a helper. Test docstrings say what is tested, never an issue number."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG, TESTS = ROOT / "tin_swarm_env", ROOT / "tests"


def expected_test_file(module: Path) -> Path:
    """``tin_swarm_env/x/_y.py`` -> ``tests/x/test_y.py``."""
    rel = module.relative_to(PKG)
    return TESTS.joinpath(*rel.parts[:-1], f"test_{rel.stem.strip('_')}.py")


def modules() -> list[Path]:
    return sorted(p for p in PKG.rglob("*.py") if p.name != "__init__.py")


def test_expected_test_file_strips_underscores_and_keeps_folders():
    assert expected_test_file(PKG / "terrain" / "_kernels.py") == TESTS / "terrain" / "test_kernels.py"
    assert expected_test_file(PKG / "__main__.py") == TESTS / "test_main.py"
    assert expected_test_file(PKG / "errors.py") == TESTS / "test_errors.py"
    assert expected_test_file(PKG / "apps" / "cli.py") == TESTS / "apps" / "test_cli.py"


def test_every_module_has_its_test_file():
    assert len(modules()) > 50
    missing = [f"{m.relative_to(ROOT)} -> {expected_test_file(m).relative_to(ROOT)}" for m in modules()
               if not expected_test_file(m).is_file()]
    assert missing == [], "modules without their test file:\n" + "\n".join(missing)


def test_every_test_file_outside_integration_names_a_module():
    wanted = {expected_test_file(m) for m in modules()}
    stray = []
    for p in sorted(TESTS.rglob("*.py")):
        rel = p.relative_to(TESTS)
        if rel.parts[0] in ("integration", "helpers") or rel == Path("conftest.py"):
            continue
        if p not in wanted:
            stray.append(str(p.relative_to(ROOT)))
    assert stray == [], ("test files that match no module (rename to tests/<sub>/test_<module>.py, move "
                         "cross-cutting ones to tests/integration/, helpers to tests/helpers/):\n" + "\n".join(stray))
    assert not [p for p in (TESTS / "integration").rglob("*.py") if not p.name.startswith("test_")]


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
        elif isinstance(node, ast.ImportFrom) and node.level > 0:
            out.add("." * node.level + (node.module or ""))
    return out


def test_test_files_import_no_test_file_conftest_or_helper():
    helpers = {p.stem for p in (TESTS / "helpers").glob("*.py")}
    bad = []
    for p in sorted(TESTS.rglob("test_*.py")):
        for name in _imports(p):
            first = name.split(".")[0]
            if name.startswith(".") or first.startswith("test_") or first in {"conftest", "tests", "helpers"} | helpers:
                bad.append(f"{p.relative_to(ROOT)} imports {name}")
    assert bad == [], "test files get shared code from tests/conftest.py fixtures:\n" + "\n".join(bad)


ISSUE = re.compile(r"#\d+\b|\bissues?\s+#?\d+", re.IGNORECASE)


def test_docstrings_say_what_is_tested_not_which_issue():
    bad = []
    for p in sorted(TESTS.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                doc = ast.get_docstring(node) or ""
                if ISSUE.search(doc):
                    bad.append(f"{p.relative_to(ROOT)}: {getattr(node, 'name', '<module>')}: {ISSUE.search(doc)[0]!r}")
    assert bad == [], "docstrings citing issue numbers:\n" + "\n".join(bad)
