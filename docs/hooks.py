"""MkDocs hooks.

- The pictures the bench scripts draw (bench/figures/*.png) are served at the same relative path from
  the site, so a page links them as ``bench/figures/NAME.png`` (the path the README uses too) without
  a second copy under docs/.
- The package's docstrings cite names with reST roles (``:class:`~a.b.C```); in the rendered
  docstrings a role becomes plain code (``C``, or ``a.b.C`` without the ``~``)."""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]


def on_files(files, config):
    for png in sorted((ROOT / "bench" / "figures").glob("*.png")):
        files.append(File(png.relative_to(ROOT).as_posix(), str(ROOT), config["site_dir"],
                          config["use_directory_urls"]))
    return files


ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):<code>(~?)([^<]+)</code>")


def on_page_content(html, page, config, files):
    return ROLE.sub(lambda m: f"<code>{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}</code>", html)
