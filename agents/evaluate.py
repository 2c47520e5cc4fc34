"""Evaluate policies on the same scenarios and held-out seeds: random, APF, GeodesicPolicy and
learned policies (pickle-free directories; SB3 .zip with --trust-pickle true).

    python agents/evaluate.py --scenarios cliff_goal,ramp,hill,generated,scenarios/valley.toml,jacksboro \\
        --seeds 20 --robots 20 --models "bc+dagger=runs/bc_cliff_goal+ramp_s0/policy,shared=agents/models/shared"
    tin-swarm eval cliff_goal ramp --seeds 20 --model runs/bc_ppo_cliff_goal_s0/policy   # the same kind
    python agents/evaluate.py --suite standard --models "shared=agents/models/shared"     # the standard suite

The arguments are the fields of :class:`tin_swarm_env.apps.evaluate.Args`; the evaluation (one
:func:`~tin_swarm_env.training.rollout.rollout` per seed from ``--seed-offset`` (default
:data:`~tin_swarm_env.training.evaluation.EVAL_SEED0`), above every
training seed; arrived, fell, timed out, steps to arrive, contacts per robot, return, each a mean
with a 95% confidence interval over robot-episodes; the Markdown table, CSV and bar plot written to
``--out``) is :func:`tin_swarm_env.apps.evaluate.evaluate`.
"""

from tin_swarm_env.apps.args import parse_dataclass
from tin_swarm_env.apps.evaluate import Args, evaluate
from tin_swarm_env.apps.suite import run_suite

if __name__ == "__main__":
    args = parse_dataclass(Args, description=__doc__.splitlines()[0])
    (run_suite if args.suite else evaluate)(args)
