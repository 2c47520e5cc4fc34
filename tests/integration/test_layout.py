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


# Beside the package: agents/ holds the shipped policies, their reproduce scripts and the recipes;
# studies live in research/ (listed in its README); docs/figures/ holds only the figures a page names.
INCLUDE_OR_LINK = re.compile(r"""(?:--8<--\s*["']|\]\()(?:docs/)?figures/([\w.-]+\.md)""")


def figures_named_by_pages(docs: Path) -> set[str]:
    """The ``docs/figures/*.md`` files a page under ``docs/`` (not a figure itself) includes or links."""
    return {m.group(1) for page in docs.glob("*.md") for m in INCLUDE_OR_LINK.finditer(page.read_text())}


def test_figures_named_by_pages_reads_includes_and_links(tmp_path):
    (tmp_path / "a.md").write_text('--8<-- "docs/figures/x.md"\nsee [y](figures/y.md) and figures/z.md\n'
                                   '[w](figures.md#w)\n')
    assert figures_named_by_pages(tmp_path) == {"x.md", "y.md"}


def test_every_figure_page_is_named_by_a_docs_page():
    figures = {p.name for p in (ROOT / "docs" / "figures").glob("*.md")}
    assert len(figures) > 10
    orphans = sorted(figures - figures_named_by_pages(ROOT / "docs"))
    assert orphans == [], ("docs/figures/ pages no docs/*.md page includes or links (a study note goes to "
                           "research/, a reference figure into the page that quotes it):\n" + "\n".join(orphans))


def test_agents_holds_no_diagnostic_or_one_off_script():
    agents = ROOT / "agents"
    assert (agents / "models").is_dir()
    stray = sorted(p.name for p in agents.iterdir() if p.name.startswith("diag_"))
    stray += sorted(p.name for p in agents.glob("*.sh") if not p.name.startswith("reproduce_"))
    assert stray == [], ("agents/ keeps shipped models, reproduce_*.sh and recipes; move these to research/: "
                         + str(stray))


def test_research_readme_names_every_file_in_research():
    research = ROOT / "research"
    readme = (research / "README.md").read_text()
    files = sorted(p.relative_to(research).as_posix() for p in research.rglob("*")
                   if p.is_file() and p.name != "README.md" and "__pycache__" not in p.parts)
    assert len(files) > 10
    unnamed = [f for f in files if f"`{f}`" not in readme]
    assert unnamed == [], "research/README.md does not name (as `path`) these files:\n" + "\n".join(unnamed)


def test_research_is_not_installed():
    pyproject = (ROOT / "pyproject.toml").read_text()
    find = re.search(r"\[tool\.setuptools\.packages\.find\]\s*\ninclude\s*=\s*\[([^\]]*)\]", pyproject)
    assert find is not None and re.findall(r'"([^"]+)"', find.group(1)) == ["tin_swarm_env*"]
    assert not (ROOT / "research" / "__init__.py").exists()
