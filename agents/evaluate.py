"""Evaluate policies on the same scenarios and seeds: random, APF and saved SB3 models.

    python agents/evaluate.py --scenarios cliff_goal,ramp --seeds 20 --models runs/ppo_cliff_goal/model.zip
    tin-swarm eval cliff_goal ramp --seeds 20 --model runs/ppo_cliff_goal/model.zip   # the same

The arguments are the fields of :class:`tin_swarm_env.apps.evaluate.Args`; the evaluation (one
:func:`~tin_swarm_env.apps.rollout.rollout` per seed, means with 95% confidence intervals, the
Markdown table, CSV and bar plot written to ``--out``) is :func:`tin_swarm_env.apps.evaluate.evaluate`.
"""

from tin_swarm_env.apps.args import parse_dataclass
from tin_swarm_env.apps.evaluate import Args, evaluate

if __name__ == "__main__":
    evaluate(parse_dataclass(Args, description=__doc__.splitlines()[0]))
