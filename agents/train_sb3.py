"""PPO (Stable-Baselines3) on tin_swarm scenarios, one shared policy for all robots, optionally
warm-started by imitation of APF (behaviour cloning, then DAgger).

    python agents/train_sb3.py --scenario cliff_goal --total-timesteps 200000
    tin-swarm train cliff_goal --timesteps 200000                                  # the same
    python agents/train_sb3.py --scenario cliff_goal,ramp --net-arch 256,256 \\
        --bc-episodes 20 --dagger-rounds 2 --dagger-episodes 10 --total-timesteps 0   # BC + DAgger only
    python agents/train_sb3.py --scenario generated --bc-episodes 20 --dagger-rounds 2 \\
        --total-timesteps 5000000 --max-minutes 40                                   # then PPO fine-tuning
    python agents/train_sb3.py --scenario ramp --recurrent true                      # sb3-contrib RecurrentPPO

The arguments are the fields of :class:`tin_swarm_env.training.config.Args` (``--help`` lists them);
the training itself is :func:`tin_swarm_env.training.sb3.train` (environment or scenario mix,
imitation from :mod:`tin_swarm_env.training.imitation`, periodic evaluation on held-out seeds, PPO,
saving ``model.zip``, the pickle-free ``policy/``, ``model.json``, ``eval.csv``, ``curve.png``
into ``--out-dir``, default ``runs/<algo>_<scenarios>_s<seed>``).
"""

from tin_swarm_env.apps.args import parse_dataclass
from tin_swarm_env.training.config import Args
from tin_swarm_env.training.sb3 import train

if __name__ == "__main__":
    print(train(parse_dataclass(Args, description=__doc__.splitlines()[0])).parent)
