"""PPO (Stable-Baselines3) on a tin_swarm scenario, one shared policy for all robots.

    python agents/train_sb3.py --scenario cliff_goal --total-timesteps 200000
    tin-swarm train cliff_goal --timesteps 200000          # the same

The arguments are the fields of :class:`tin_swarm_env.apps.train.Args` (``--help`` lists them);
the training itself is :func:`tin_swarm_env.apps.train.train` (environment, periodic evaluation,
PPO, saving ``model.zip``, ``model.json``, ``eval.csv``, ``curve.png`` into ``--out-dir``).
"""

from tin_swarm_env.apps.args import parse_dataclass
from tin_swarm_env.apps.train import Args, train

if __name__ == "__main__":
    train(parse_dataclass(Args, description=__doc__.splitlines()[0]))
