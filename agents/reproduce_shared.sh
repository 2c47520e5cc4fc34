#!/usr/bin/env bash
# Reproduces the shared policy (agents/models/shared) on 2 cores, then its evaluation table.
#   bash agents/reproduce_shared.sh          # outputs in runs/shared (log: runs/shared.log)
# Recipe: behaviour cloning from APF on generated terrains (a new seeded terrain per reset, families
# canyon/mesa/hills; training seeds < 10**6, evaluation seeds from 10**6, so the table's "generated"
# rows are terrains never trained on) mixed with cliff_goal and ramp (hill, valley, jacksboro stay
# held out), two DAgger rounds with beta-mixing (APF drives each robot-step with probability 0.5,
# then 0.25: the learner's own stalls do not flood the data) and stalled robots' samples dropped
# after 60 steps without progress, then PPO fine-tuning with the geodesic progress reward (the goal
# task's default: [rewards] progress = "geodesic"), capped at 40 minutes in all.
#
# Measured (issue 12, learn2; 2 shared cores at load ~4.5, several times slower than an idle machine):
# a smaller run (--n-envs 1, 12 BC + 2x6 DAgger episodes, max 22 min: 16 min of imitation, then only
# 92k PPO timesteps) gave, on 5 held-out seeds x 20 robots: cliff_goal 100% arrived / 0% fell, ramp
# 100% / 0%, hill 95% / 5%, generated 31% / 1% (68% timed out), jacksboro 40% / 50%. Not yet the
# issue's numbers (hill falls, generated, jacksboro), so no policy is shipped; this is the full budget.
#
# Another mix: SCENARIOS=generated bash agents/reproduce_shared.sh
set -e
cd "$(dirname "$0")/.."
mkdir -p runs
SCENARIOS=${SCENARIOS:-generated,cliff_goal,ramp}
PY=${PY:-python}
$PY agents/train_sb3.py --scenario "$SCENARIOS" --n-robots 8 --n-envs 2 --net-arch 256,256 \
  --bc-episodes 24 --dagger-rounds 2 --dagger-episodes 12 --dagger-beta 0.5 --stall-steps 60 \
  --bc-epochs 30 --bc-std 0.3 --value-epochs 10 \
  --learning-rate 1e-4 --n-steps 256 --batch-size 1024 --n-epochs 5 --gamma 0.995 --ent-coef 0.0 \
  --total-timesteps 50000000 --max-minutes 40 --eval-every 200000 --eval-episodes 3 --checkpoint-every 1000000 \
  --seed 0 --out-dir runs/shared --progress-bar false > runs/shared.log 2>&1
# Ship it only if it meets the issue's numbers (see README): cp -r runs/shared/policy agents/models/shared
$PY agents/evaluate.py --scenarios cliff_goal,ramp,hill,generated,scenarios/valley.toml,jacksboro --seeds 20 \
  --robots 20 --models "shared=runs/shared/policy" --out runs/eval_shared
