"""``tin-swarm train``: PPO (Stable-Baselines3) on tin_swarm scenarios, one shared policy for all
robots, with an optional warm start by imitation of a teacher; the command only.

    tin-swarm train cliff_goal --timesteps 200000
    tin-swarm train cliff_goal --resume runs/ppo_cliff_goal_s0     # continue a killed run
    python agents/train_sb3.py --scenario cliff_goal --total-timesteps 200000   # the same

The options are the fields of :class:`~tin_swarm_env.training.config.Args`; the training itself
(imitation, PPO, evaluation on held-out seeds, checkpoints, saving and export) is
:func:`tin_swarm_env.training.sb3.train`, importable without the CLI. This module parses nothing on
its own (:mod:`~tin_swarm_env.apps.cli` builds ``Args`` from the command line) and checks what only
the command has: a resumed run must be given the scenario it was started with.
"""

from __future__ import annotations

from pathlib import Path

from ..training.config import Args
from ..training.sb3 import train

__all__ = ["Args", "train", "train_command"]


def train_command(a: Args) -> int:
    """``tin-swarm train``: with ``--resume DIR``, refuse a scenario other than the run's (a
    :class:`~tin_swarm_env.errors.CheckpointError` naming ``DIR/args.json``), then train; 0."""
    if a.resume:
        from ..errors import CheckpointError
        from ..training.checkpoint import ARGS_FILE, read_args

        saved = read_args(Path(a.resume)).get("scenario")
        if saved != a.scenario:
            raise CheckpointError(f"{Path(a.resume) / ARGS_FILE}: key 'scenario': found {saved!r}, expected "
                                  f"{a.scenario!r} (the scenario given to tin-swarm train)")
    train(a)
    return 0
