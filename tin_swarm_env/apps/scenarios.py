"""``tin-swarm scenarios``: list the built-in scenarios, or copy one to a file to start from
(:class:`Args` holds the options, :func:`scenarios` does the command)."""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..errors import ArgumentError
from .args import check_args, opt

__all__ = ["Args", "scenarios"]


def _copy_problem(v) -> str | None:
    if v is None:
        return None
    if not isinstance(v, (list, tuple)) or len(v) != 2 or not all(isinstance(s, str) and s for s in v):
        return "give NAME DEST: a built-in scenario name and a file or directory"
    return None


@dataclass
class Args:
    """``tin-swarm scenarios``: every option, its help and what it accepts (checked when built)."""

    copy: list | None = opt(None, "write the built-in scenario NAME to the file (or into the directory) DEST",
                            check=_copy_problem, nargs=2, metavar=("NAME", "DEST"))
    force: bool = opt(False, "with --copy: overwrite DEST if it exists", flag=True)

    def __post_init__(self):
        check_args(self)
        if self.force and not self.copy:
            raise ArgumentError("--force applies to --copy only (it overwrites the copy's DEST)")


def scenarios(a: Args) -> int:
    """Print ``name  description`` per built-in scenario, or with ``--copy NAME DEST`` write the
    built-in scenario's TOML to ``DEST`` (refusing to overwrite a file without ``--force``)."""
    from .._atomic import atomic_path, check_outputs
    from ..scenario.config import list_scenarios, scenario_file

    if a.copy:
        name, dest = a.copy
        known = list_scenarios()
        if name not in known:  # (scenario_file's message also offers a .toml path, which --copy does not take)
            raise ArgumentError(f"--copy: unknown built-in scenario {name!r}; built-in: {', '.join(sorted(known))}")
        src = scenario_file(name)
        if os.path.isdir(dest):
            dest = os.path.join(dest, src.name)
        if os.path.exists(dest) and not a.force:
            raise ArgumentError(f"--copy: {dest} exists; pass --force to overwrite it")
        check_outputs({"--copy DEST": dest}, inputs=(src,))
        with atomic_path(dest) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(src.read_bytes())
        print(f"wrote {dest} (the built-in scenario {name!r}; edit it and run: tin-swarm run {dest})")
        return 0
    for name, desc in list_scenarios().items():
        print(f"{name:12s} {desc}")
    return 0
