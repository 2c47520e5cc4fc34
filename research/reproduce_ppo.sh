#!/usr/bin/env bash
# The two PPO runs of research/historical_ppo.md: 27 minutes each on the 2-core machine, one after the
# other (run by hand: bash research/reproduce_ppo.sh; outputs in runs/), then the table:
#   python agents/evaluate.py --scenarios cliff_goal,ramp --seeds 20 \
#     --models runs/ppo_cliff_goal/model.zip,runs/ppo_ramp/model.zip --out runs/eval
set -e
cd "$(dirname "$0")/.."
mkdir -p runs
for s in cliff_goal ramp; do
  python agents/train_sb3.py --scenario $s --n-robots 8 --n-envs 4 --n-steps 256 --batch-size 1024 \
    --n-epochs 5 --net-arch 128,128 --ent-coef 0.005 --gamma 0.995 --total-timesteps 50000000 --max-minutes 27 \
    --eval-every 100000 --eval-episodes 3 --checkpoint-every 500000 --out-dir runs/ppo_$s --progress-bar false \
    > runs/ppo_$s.log 2>&1
done
