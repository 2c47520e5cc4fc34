"""Every ```python block of README.md and docs/*.md runs as written.

The blocks of one Markdown file run in order, in one namespace, in a fresh Python process whose
working directory is an empty temporary directory (with links to the repository's ``agents/`` and
``scenarios/``, which snippets read), so a snippet writes nothing into the repository. A block that
would run long carries a marker on the line before its fence, literal replacements applied only here::

    <!-- snippet: learn(100_000) -> learn(64); n_robots=200 -> n_robots=4 -->

A replacement that does not match its block fails the test (a stale marker), and ``\\n`` in one is a
newline. See docs/contributing.md.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"<!--\s*snippet:\s*(.*?)\s*-->")
LINKED = ("agents", "scenarios")


def python_blocks(text: str, name: str = "<md>") -> list[tuple[int, str]]:
    """``(first code line number, code)`` of each ```python block of a Markdown text, with the
    replacements of its marker applied."""
    lines, out, i = text.splitlines(), [], 0
    while i < len(lines):
        if lines[i].strip() == "```python":
            j = i + 1
            while j < len(lines) and lines[j].strip() != "```":
                j += 1
            if j == len(lines):
                raise ValueError(f"{name}:{i + 1}: a ```python block is never closed")
            code = "\n".join(lines[i + 1:j]) + "\n"
            prev = next((line for line in reversed(lines[:i]) if line.strip()), "")
            m = MARKER.search(prev)
            out.append((i + 2, apply_marker(code, m.group(1), f"{name}:{i + 1}") if m else code))
            i = j
        i += 1
    return out


def apply_marker(code: str, marker: str, where: str) -> str:
    """Apply the ``A -> B; C -> D`` replacements of a snippet marker; each must match."""
    for pair in marker.split("; "):
        old, sep, new = pair.partition(" -> ")
        if not sep or old not in code:
            raise ValueError(f"{where}: snippet marker {pair!r} does not match its block")
        code = code.replace(old, new.replace("\\n", "\n"))
    return code


def markdown_files() -> list[Path]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    return [p for p in files if python_blocks(p.read_text(), str(p))]


# a page whose snippet needs an optional extra that is not installed is skipped, naming it
OPTIONAL = {"stable_baselines3", "sb3_contrib", "torch", "ray", "torchrl", "benchmarl", "tensordict", "imageio",
            "imageio_ffmpeg", "moviepy", "nbclient", "nbformat", "ipykernel", "rasterio", "pymartini"}
MISSING_EXTRA_RC = 3
RUNNER = """
import json, sys
ns = {"__name__": "__main__"}
optional = set(sys.argv[1].split(","))
blocks = json.loads(sys.stdin.read())
for name, line, code in blocks:
    try:
        exec(compile("\\n" * (line - 1) + code, name, "exec"), ns)
    except ImportError as exc:
        missing = (getattr(exc, "name", None) or "").split(".")[0]
        if missing in optional or type(exc).__name__ == "MissingExtraError":
            print(f"{name}:{line}: needs {missing or exc}")
            sys.exit(%d)
        raise
print("all", len(blocks), "blocks ran")
""" % MISSING_EXTRA_RC


@pytest.mark.parametrize("path", markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_python_blocks_run(path, tmp_path):
    rel = str(path.relative_to(ROOT))
    blocks = [(rel, line, code) for line, code in python_blocks(path.read_text(), rel)]
    for d in LINKED:
        (tmp_path / d).symlink_to(ROOT / d, target_is_directory=True)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    r = subprocess.run([sys.executable, "-c", RUNNER, ",".join(sorted(OPTIONAL))], input=json.dumps(blocks),
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)
    if r.returncode == MISSING_EXTRA_RC:
        pytest.skip(f"an optional extra is not installed: {r.stdout.strip().splitlines()[-1]}")
    assert r.returncode == 0, f"{rel}: a snippet failed\n{r.stdout[-2000:]}\n{r.stderr[-4000:]}"
    assert f"all {len(blocks)} blocks ran" in r.stdout, f"{rel}: a snippet left early\n{r.stdout[-2000:]}"


def test_blocks_markers_and_line_numbers():
    md = ("text\n```python\nx = 1\n```\n\n<!-- snippet: 100_000 -> 4; a -> b\\nc -->\n"
          "```python\nn = 100_000  # a\n```\n```bash\nls\n```\n")
    assert python_blocks(md) == [(3, "x = 1\n"), (8, "n = 4  # b\nc\n")]
    with pytest.raises(ValueError, match=r"<md>:7: snippet marker '200 -> 1' does not match"):
        python_blocks(md.replace("100_000 -> 4", "200 -> 1"))
    with pytest.raises(ValueError, match="never closed"):
        python_blocks("```python\nx = 1\n")


def test_every_page_with_code_is_collected():
    names = {str(p.relative_to(ROOT)) for p in markdown_files()}
    assert {"README.md", "docs/quickstart.md", "docs/terrain.md", "docs/learning.md"} <= names


def _readme_section(name: str) -> str:
    """The text between the README's ``--8<-- [start:NAME]`` and ``[end:NAME]`` lines (the section the
    quickstart page includes)."""
    text = (ROOT / "README.md").read_text()
    return text.split(f"--8<-- [start:{name}] -->\n", 1)[1].split(f"<!-- --8<-- [end:{name}]", 1)[0]


def test_ci_runs_the_readme_test_command_verbatim_then_builds_the_docs_strictly():
    block = _readme_section("tests")
    command = block.split("```bash\n", 1)[1].split("\n```", 1)[0]
    assert "\n" not in command and '".[' in command and "docs" in command and "pytest" in command
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert command in ci
    build = [line for line in ci if "mkdocs build" in line]
    assert ci.index(command) < ci.index(build[0]) and "--strict" in build[0] and "set -euo pipefail" in ci
    # mkdocs 1.6 with --quiet does not count warnings for --strict: the build would pass with broken links
    assert not {"-q", "--quiet"} & set(build[0].split())


def test_readme_is_short_and_its_main_job_is_the_run_command():
    assert len((ROOT / "README.md").read_bytes()) <= 15_000
    assert "tin-swarm run cliff_goal" in _readme_section("main-job")


def cli_commands(text: str) -> list[str]:
    """The ``tin-swarm`` commands written in a Markdown text: inline code spans and the lines of
    ```bash blocks (continuations joined; each ``&&`` part) that start with ``tin-swarm`` (after any
    ``.venv/bin/``), except a bare subcommand name, a placeholder (``tin-swarm COMMAND --help``), a
    quoted message (``tin-swarm run: error: ...``) and synopses with ``[optional]`` parts or ``...``."""
    spans = re.findall(r"`([^`\n]+)`", re.sub(r"```.*?```", "", text, flags=re.S))
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        spans += [part for line in block.replace("\\\n", " ").splitlines() for part in line.split("&&")]
    out = []
    for s in spans:
        words = re.sub(r"^\S*/(?=tin-swarm )", "", s.strip()).split(" #")[0].split()
        s = " ".join(words)
        if words[:1] == ["tin-swarm"] and len(words) > 2 and words[1].islower() and not words[1].endswith(":") \
                and "[" not in s and "..." not in s:
            out.append(s)
    return out


def test_cli_commands_finds_spans_and_bash_lines():
    md = ("run `tin-swarm run flat --robots 3`, not `tin-swarm run X [--gif G]` nor `tin-swarm eval`\n"
          "`tin-swarm run: error: bad` is a message\n"
          "```bash\npython3 -m venv .venv && .venv/bin/tin-swarm scenarios --copy a b   # copy\n"
          "tin-swarm run flat \\\n    --quiet\n```\n")
    assert cli_commands(md) == ["tin-swarm run flat --robots 3", "tin-swarm scenarios --copy a b",
                                "tin-swarm run flat --quiet"]


def test_every_cli_command_in_the_docs_parses():
    """Each ``tin-swarm`` command written in README.md and docs/ names a subcommand and only options it
    has, and one with arguments beyond a single option is accepted by the parser as written (files
    are not opened), so renaming or dropping an option fails here."""
    import argparse
    import contextlib
    import io
    import shlex

    from tin_swarm_env.apps.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices
    found = 0
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for cmd in cli_commands(page.read_text()):
            where = f"{page.relative_to(ROOT)}: {cmd}"
            argv = shlex.split(cmd)[1:]
            assert argv[0] in sub, where
            options = {s for a in sub[argv[0]]._actions for s in a.option_strings}
            assert {w.split("=")[0] for w in argv if w.startswith("-")} <= options, where
            if len(argv) > 2:
                err = io.StringIO()
                try:
                    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                        parser.parse_args(argv)
                except SystemExit as exc:
                    assert exc.code == 0 and "--help" in argv, f"{where}: {err.getvalue()}"
            found += 1
    assert found >= 10
