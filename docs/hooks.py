"""MkDocs hook: the pictures the bench scripts draw (bench/figures/*.png) are served at the same
relative path from the site, so a page links them as ``bench/figures/NAME.png`` (the path the README
uses too) without a second copy under docs/."""

from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]


def on_files(files, config):
    for png in sorted((ROOT / "bench" / "figures").glob("*.png")):
        files.append(File(png.relative_to(ROOT).as_posix(), str(ROOT), config["site_dir"],
                          config["use_directory_urls"]))
    return files
