"""What of the standard suite's held-out split a training scenario would use: the check behind an
honest held-out split (``tests/training/test_held_out.py`` runs it over every training
recipe's scenarios).

    from tin_swarm_env.training.held_out import held_out_use
    held_out_use("generated")                               # ['generated families fork, trap']
    held_out_use("agents/scenarios/train_generated.toml")   # []

A scenario uses the held-out split (:data:`~tin_swarm_env.training.suite.SPLITS`, key
``held_out``) when

* its terrain is generated and draws a family a held-out map draws (``[terrain] families``, every
  synthetic family when it names none: :data:`~tin_swarm_env.scenario.generators.ALL_FAMILIES`);
* its terrain is fixed and is the ground of a held-out map or of one of that map's mirror images
  (any axis of :data:`~tin_swarm_env.scenario.mirror.MIRRORS`): the same bounds (to 1 m) and the
  same height (to 0.5 m) at every point of a 21 x 21 grid over the inner 90% of them. The ground
  is compared, not the file, so a copy of a held-out file, or a recipe that rebuilds its terrain
  (the canyon of ``scenarios/canyon_right.toml`` is the mirror image of ``canyon_left``'s), counts.

The seeds are the other half of the split: training draws seeds below
:data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`, the suite plays from it.

The recipes are shell scripts; :func:`recipe_words` and :func:`recipe_command` read them as data
(never run them): continuation lines joined, comments dropped, ``NAME=value`` and
``NAME=${NAME:-value}`` assignments and ``for NAME in ...; do`` loop values resolved.
"""

from __future__ import annotations

import re
import shlex

import numpy as np

from ..errors import ArgumentError

__all__ = ["expand", "held_out_use", "held_out_families", "recipe_command", "recipe_words", "same_ground"]

HELD_OUT = "held_out"  # the key of the split in SPLITS
BOUNDS_TOL_M = 1.0
HEIGHT_TOL_M = 0.5
GRID = 21


def _held_out_maps():
    from .suite import SPLITS

    return [m for s in SPLITS if s.key == HELD_OUT for m in s.maps]


def held_out_families() -> set[str]:
    """The generated families the held-out split's maps draw."""
    return {f for m in _held_out_maps() for f in m.families}


def _families(cfg) -> list[str]:
    from ..scenario.generators import ALL_FAMILIES

    fam = cfg.terrain.families or ALL_FAMILIES
    if isinstance(fam, dict):
        return [k for k, w in fam.items() if w > 0]
    return list(fam)


def same_ground(a, b) -> bool:
    """Whether two fixed-terrain :class:`~tin_swarm_env.scenario.ScenarioConfig` have the same
    ground (module docstring: bounds to 1 m, heights to 0.5 m on a 21 x 21 grid)."""
    from ..scenario.build import build_tin_for

    ta, tb = build_tin_for(a), build_tin_for(b)
    if ta is None or tb is None:
        return ta is None and tb is None and tuple(a.world.flat_size_m) == tuple(b.world.flat_size_m)
    ba, bb = np.array(ta.bounds, dtype=np.float64), np.array(tb.bounds, dtype=np.float64)
    if np.abs(ba - bb).max() > BOUNDS_TOL_M:
        return False
    x0, y0, x1, y1 = bb
    mx, my = 0.05 * (x1 - x0), 0.05 * (y1 - y0)
    gx, gy = np.meshgrid(np.linspace(x0 + mx, x1 - mx, GRID), np.linspace(y0 + my, y1 - my, GRID))
    xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
    inside = (ta.locate(xy) >= 0) & (tb.locate(xy) >= 0)
    if not inside.all():
        return False
    return bool(np.abs(ta.height_at(xy) - tb.height_at(xy)).max() <= HEIGHT_TOL_M)


def held_out_use(scenario) -> list[str]:
    """What of the held-out split the scenario ``scenario`` (a built-in name, a TOML path or a
    :class:`~tin_swarm_env.scenario.ScenarioConfig`) uses, one line each; empty when nothing
    (module docstring)."""
    from ..scenario import load_scenario, mirror_scenario
    from ..scenario.mirror import MIRRORS
    from .suite import map_config

    cfg = scenario if hasattr(scenario, "terrain") else load_scenario(scenario)
    if cfg.terrain.source == "generated":
        bad = sorted(set(_families(cfg)) & held_out_families())
        return [f"generated families {', '.join(bad)}"] if bad else []
    out = []
    for m in _held_out_maps():
        if m.families:
            continue
        held = map_config(m)
        for axis in MIRRORS:
            if same_ground(cfg, mirror_scenario(held, axis) if axis else held):
                out.append(f"the ground of held-out map {m.label!r}" + (f" (its mirror image {axis})" if axis else ""))
                break
    return out


def recipe_words(text: str) -> list[tuple[str, dict]]:
    """``(word, variables)`` for each shell word of the recipe ``text`` (continuation lines joined,
    comments and redirections' targets kept as words), with the values of the plain ``NAME=value``
    and ``NAME=${NAME:-value}`` assignments and of the ``for NAME in ...; do`` loops seen before it:
    ``{NAME: [value, ...]}``."""
    text = text.replace("\\\n", " ")
    env: dict = {}
    out = []
    for line in text.splitlines():
        line = line.split(" #")[0].strip()
        if not line or line.startswith("#"):
            continue
        m = re.fullmatch(r"(\w+)=(\S+)", line)
        if m:
            d = re.fullmatch(r"\$\{%s:-([^}$]+)\}" % m.group(1), m.group(2))
            if d or "$" not in m.group(2):
                env[m.group(1)] = [d.group(1) if d else m.group(2)]
        m = re.match(r"for (\w+) in ([^;]+); do", line)
        if m:
            env[m.group(1)] = m.group(2).split()
        out.extend((w, dict(env)) for w in shlex.split(line))
    return out


def expand(word: str, env: dict) -> list[str]:
    """``word`` with every ``$NAME`` / ``${NAME}`` of ``env`` replaced, once per combination of the
    names' values (a loop variable gives one word per value)."""
    words = [word]
    for name in sorted(env, key=len, reverse=True):  # $TRAIN_B before $TRAIN
        words = [w.replace(f"${{{name}}}", v).replace(f"${name}", v) for w in words for v in env[name]]
    return words


def recipe_command(text: str, script: str, where: str = "recipe") -> list[str]:
    """The arguments of the first command of the recipe ``text`` that runs ``script`` (a path such
    as ``agents/train_puffer.py``), variables resolved (their first value), up to a redirection
    or the end of the command. :class:`~tin_swarm_env.errors.ArgumentError` naming ``where`` if
    no command runs it or a word stays unresolved."""
    words = recipe_words(text)
    at = next((i for i, (w, _) in enumerate(words) if w == script), None)
    if at is None:
        raise ArgumentError(f"{where}: no command runs {script}")
    argv = []
    for w, env in words[at + 1:]:
        if w in (">", ">>", "2>&1", "&&", "||", ";", "|") or w.startswith(">"):
            break
        v = expand(w, env)[0]
        if "$" in v:
            raise ArgumentError(f"{where}: {w!r} of the {script} command is not resolvable here")
        argv.append(v)
    return argv
