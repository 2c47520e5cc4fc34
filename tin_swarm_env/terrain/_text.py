"""The one line tokenizer of the text terrain formats (``.xyz`` DEMs and ``.tin`` files)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path


def numeric_rows(p: Path, layout: str, exc: type[Exception]) -> Iterator[tuple[int, list[float], str]]:
    """Yield ``(line number, values, line)`` for every data line of text file ``p``: ``#`` starts
    a comment, commas count as whitespace, blank lines are skipped. Each data line must hold
    exactly as many numbers as ``layout`` names (``"x y z"``); otherwise ``exc`` is raised naming
    ``p:line``. Values may be NaN or infinite; the caller decides what it accepts."""
    width = len(layout.split())
    with open(p, encoding="utf-8", errors="replace") as fh:
        for i, line in enumerate(fh, start=1):
            s = line.split("#", 1)[0].replace(",", " ").split()
            if not s:
                continue
            if len(s) != width:
                raise exc(f"{p}:{i}: expected {width} numbers '{layout}', found {len(s)}: {line.strip()!r}")
            try:
                vals = [float(t) for t in s]
            except ValueError:
                raise exc(f"{p}:{i}: not a number in {line.strip()!r}") from None
            yield i, vals, line
