#!/usr/bin/env bash
# Evaluates a run trained with the geodesic teacher (agents/train_sb3.py --teacher geodesic --symmetry mirror;
# RUN/policy_imitation: BC+DAgger, RUN/policy: after PPO) against APF, the geodesic reference and the shipped
# policy: held-out generated seeds per family (10 seeds x 20 robots; one TOML per family, written to
# runs/eval_cfg/), then the standard suite (its mirrored canyon_left/valley, fork/trap, thesis maps, jacksboro).
# research/teacher_geodesic.md quotes both tables.
#   flock /tmp/heavy.lock bash research/eval_teacher_geodesic.sh            # RUN=runs/geodesic
#   MODELS=geo_bc=runs/geodesic/policy_imitation POLICIES=apf,geodesic SUITE=0 bash research/eval_teacher_geodesic.sh
set -e
cd "$(dirname "$0")/.."
PY=${PY:-python}
RUN=${RUN:-runs/geodesic}
MODELS=${MODELS:-shared=agents/models/shared_sb3,geo_bc=$RUN/policy_imitation,geo_ppo=$RUN/policy}
POLICIES=${POLICIES-apf,geodesic}
OUT=${OUT:-runs/eval_teacher}
mkdir -p runs/eval_cfg
scen=""
for f in canyon mesa hills fork trap; do
  cat > runs/eval_cfg/gen_$f.toml <<TOML
description = "generated terrains of the $f family only"
task = "goal"
max_cycles = 1000

[terrain]
source = "generated"
resample = "reset"
families = ["$f"]
method = "greedy"
max_error_m = 0.5

[robots]
count = 20
max_slope_deg = 30.0

[targets]
arrival_radius_m = 8.0
TOML
  scen="$scen${scen:+,}runs/eval_cfg/gen_$f.toml"
done
$PY agents/evaluate.py --scenarios "$scen" --seeds 10 --robots 20 --policies "$POLICIES" --models "$MODELS" \
  --out "${OUT}_families"
if [ "${SUITE:-1}" = 1 ]; then
  suite_models=()
  IFS=, read -ra ms <<< "$MODELS"
  for m in "${ms[@]}"; do [ "${m%%=*}" = shared ] || suite_models+=(--model "$m"); done  # the suite has shared
  $PY bench/standard_suite.py "${suite_models[@]}" --out "${OUT}_suite"
fi
